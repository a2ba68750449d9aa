//! Round 15a: values that change nothing, and refusals that disagree.
//!
//! - r15a-1: an away window that changes nothing is refused, naming the
//!   window and the stream's length: `stream --synthetic --away 2,3
//!   --seconds 1` streamed a finger that never left, and a window between
//!   two frames (`0.001,0.002`) did the same. (`track --synthetic` has no
//!   `--away`; its finger's timeline is fixed.)
//! - r15a-2: a staircase's `steps` longer than it can use is refused, in
//!   the protocol's words with its line: the step after reversal `k` first
//!   moves the level at that reversal, so at most `reversals` steps (fewer
//!   when `trials` ends it sooner) are ever used; the rest were taken.
//! - r15a-3: a gauge's sampling rate whose period is longer than the read
//!   (`gauge read --for 2 --rate 1e-300`) took one reading whatever was
//!   asked; refused, stating the rates that give at least one reading.
//! - r15a-4: `track --replan-mm` had no upper bound (`1e9` never
//!   re-planned, without a word): now at most 100 mm, the largest per-step
//!   depth a plan holds.
//! - r15a-5: a repeatable flag's value given twice is refused, naming it:
//!   `bench --section X --section X` ran X once, `doctor --port P --port
//!   P` checked P once (an AUTD3 link twice).
//! - r15a-6: a number in a flag's list with spaces at its ends is refused
//!   as a lone number flag refuses ` 5`, in the same words: `--center
//!   "0, 0,150"`, `--weights`, `--plane-size`, `--away`, `--z-profile`
//!   trimmed their items. The help of each list flag says "no spaces" (the
//!   docs show none).
//! - r15a-7: a control line's `off_s` refusal states its real range: 0 (no
//!   pause) is allowed, which "give at least 1e-9 s" and "give a number
//!   above 0" hid.
//! - r15a-8: a flag's environment variable that is not UTF-8
//!   (`$LMHOST_TIMEOUT_MS`) is named, as `$LMHOST_PORT` is: clap said
//!   "invalid UTF-8 was detected in one or more arguments".
//! - r15a-9 (Python's own, `python/tests/test_hostile_r15a.py`):
//!   `Session.command(..., field=None)` leaves the field out, as a None of
//!   `present()` and `plan()` is their default; now said in its docs.
//!
//! Fixtures in `{dir}/r15a`.

use super::cases_r13::study;
use super::*;

pub(crate) fn round15a_fixtures(dir: &Path) {
    let r = dir.join("r15a");
    std::fs::create_dir_all(&r).unwrap();
    let stair = study("staircase-detection.toml");
    let w = |name: &str, body: String| std::fs::write(r.join(name), body).unwrap();
    w(
        "stair_reversals.toml",
        stair.replacen("reversals = 12", "reversals = 2", 1),
    );
    w(
        "stair_trials.toml",
        stair.replacen("trials = 80", "trials = 3", 1),
    );
    w(
        "stair_used.toml",
        stair.replacen(
            "reversals = 12\nthreshold_reversals = 8",
            "reversals = 3\nthreshold_reversals = 3",
            1,
        ),
    );
}

/// `case(class, args)` with `more` appended as single arguments (values
/// with spaces).
fn with(class: &'static str, args: &str, more: &[&str]) -> Case {
    let mut c = case(class, args);
    c.args.extend(more.iter().map(|s| (*s).to_owned()));
    c
}

/// A session on the AUTD3 emulator over stdin.
const STDIN_SESSION: &str =
    "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control -";

pub(crate) fn round15a_cases() -> Vec<Case> {
    let steps = "{dir}/r15a/stair";
    let space = "is not a number (white space around it): give one such as 2.5, -1 or 1e-3";
    let mut v = table! {
        // 1. Away windows.
        R15A_AWAY "stream --synthetic --away 2,3 --seconds 1"
            .err("error: --away 2,3 starts at or after the stream's end (--seconds 1): give a START below 1 s");
        R15A_AWAY "stream --synthetic --away 10,11"
            .err("error: --away 10,11 starts at or after the stream's end (--seconds 10): give a START below 10 s");
        R15A_AWAY "stream --synthetic --away 0.001,0.002 --seconds 1"
            .err("error: --away 0.001,0.002 holds no frame of the stream (90 frames a second, before --seconds 1): give a window holding at least one");
        R15A_AWAY "stream --synthetic --fast --port {port} --away 0.5,3 --seconds 1" .ok();
        // 2. Steps a staircase never uses.
        R15A_STEPS "study check {dir}/r15a/stair_reversals.toml"
            .err(&format!("error: study protocol {steps}_reversals.toml: line 50, field `staircase.steps`: 3 steps, but only the first 2 can ever be used: a step follows each reversal and the staircase ends at reversal 2 (`reversals`); give at most 2"));
        R15A_STEPS "study check {dir}/r15a/stair_trials.toml"
            .err(&format!("error: study protocol {steps}_trials.toml: line 50, field `staircase.steps`: 3 steps, but only the first can ever be used: with up 1 and down 2, 3 presentations (`trials`) reach at most 0 reversals before the last; give at most 1"));
        R15A_STEPS "study check {dir}/r15a/stair_used.toml" .ok();
        // 3. A gauge rate below one reading.
        R15A_RATE "gauge read --port sim --for 2 --rate 1e-300"
            .err("error: sim-gauge: sampling rate 1e-300 Hz is less than one reading in 2 s: allowed 0.5..=1000 Hz");
        R15A_RATE "gauge read --port sim --for 0.0001"
            .err("error: sim-gauge: sampling duration 0.0001 s is shorter than one reading at 1000 Hz: give at least 0.001 s");
        R15A_RATE "gauge read --port sim --for 2 --rate 0.5" .ok();
        // 4. --replan-mm bounded.
        R15A_REPLAN "track --synthetic --z-profile 3,8 --replan-mm 1e9"
            .err("error: --replan-mm 1e9 mm is out of range: allowed 0..=100 mm");
        R15A_REPLAN "track --synthetic --z-profile 3,8 --replan-mm 100.5"
            .err("error: --replan-mm 100.5 mm is out of range: allowed 0..=100 mm");
        // 5. A repeated value of a repeatable flag.
        R15A_REPEATED "bench --section planner --section planner"
            .err("error: --section `planner` is given twice: give each section once");
        R15A_REPEATED "doctor --port /dev/null --port autd3:emulator --port /dev/null"
            .err("error: --port `/dev/null` is given twice: give each port once");
        // 8. A flag's environment variable not UTF-8 (checked by its own
        //    run: a case's environment is text).
        R15A_ENV "plan" .ok().check(timeout_env_not_utf8);
    };
    // 6. Spaces at a list item's ends, as a lone number's.
    v.extend([
        with(R15A_SPACES, "plan --center", &["0, 0,150"])
            .err(&format!("error: --center: ` 0` {space}")),
        with(R15A_SPACES, "plan --foci 2 --weights", &["1 ,1"])
            .err(&format!("error: --weights: `1 ` {space}")),
        with(R15A_SPACES, "plan --radius", &[" 5"]).err(&format!(
            "error: invalid value ' 5' for '--radius <MM>': ` 5` {space} (see --help)"
        )),
        with(R15A_SPACES, "simulate --plane-size", &["10, 10"])
            .err(&format!("error: --plane-size: ` 10` {space}")),
        with(R15A_SPACES, "stream --synthetic --away", &["0.5, 1"])
            .err(&format!("error: --away `0.5, 1`: END ` 1` {space}")),
        with(R15A_SPACES, "track --synthetic --z-profile", &["3, 8"]).err(
            "error: --z-profile `3, 8`: the steps ` 8` are not a whole number: allowed 1..=1000",
        ),
        with(R15A_SPACES, "track --synthetic --z-profile", &[" 3,8"]).err(&format!(
            "error: --z-profile ` 3,8`: the radius ` 3` {space}"
        )),
    ]);
    // 7. off_s's range, 0 in it.
    for (value, want) in [
        (
            "-1",
            "off_s -1 s is out of range: give 0 (no pause) or a number from 1e-9 to 3600 s",
        ),
        (
            "1e-300",
            "off_s 1e-300 s rounds to no time (a duration holds whole nanoseconds): give 0 (no pause) or at least 1e-9 s",
        ),
    ] {
        v.push(
            case(R15A_OFF, STDIN_SESSION)
                .stdin(format!(
                    "{{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a2\",\"gate\":\"untracked\",\"on_s\":0.5,\"off_s\":{value},\"repeat\":2}}\n{{\"cmd\":\"status\"}}\n"
                ))
                .ok()
                .out(&format!(
                    "{{\"cmd\":\"present\",\"error\":\"{want}\",\"ok\":false}}"
                ))
                .out("\"state\":\"idle\""),
        );
    }
    v.push(
        case(R15A_OFF, STDIN_SESSION)
            .stdin("{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a2\",\"gate\":\"untracked\",\"on_s\":0.05,\"off_s\":0,\"repeat\":2}\n")
            .ok()
            .out("{\"cmd\":\"present\",\"ok\":true"),
    );
    v
}

/// A `$LMHOST_TIMEOUT_MS` that is not UTF-8 is refused naming it, and an
/// argument that is not UTF-8 still gets clap's words.
fn timeout_env_not_utf8(_: &Ctx, _: &Run) -> Result<(), String> {
    use std::os::unix::ffi::OsStrExt as _;
    let run = |args: &[&std::ffi::OsStr]| {
        Command::new(lmhost())
            .args(args)
            .env("LMHOST_TIMEOUT_MS", std::ffi::OsStr::from_bytes(b"30\xff"))
            .env_remove("LMHOST_PORT")
            .output()
            .map_err(|e| e.to_string())
    };
    let out = run(&["status".as_ref(), "--port".as_ref(), "/dev/null".as_ref()])?;
    let err = String::from_utf8_lossy(&out.stderr);
    let want = "error: $LMHOST_TIMEOUT_MS `30\u{fffd}` is not UTF-8: give the --timeout-ms value in UTF-8, or unset it\n";
    if (out.status.code(), err.as_ref()) != (Some(2), want) {
        return Err(format!(
            "non-UTF-8 $LMHOST_TIMEOUT_MS: exit {:?}, {err}",
            out.status.code()
        ));
    }
    // Given on the command line, the variable is not read.
    let out = run(&[
        "status".as_ref(),
        "--timeout-ms".as_ref(),
        "0".as_ref(),
        "--port".as_ref(),
        "/dev/null".as_ref(),
    ])?;
    let err = String::from_utf8_lossy(&out.stderr);
    match (
        out.status.code(),
        err.contains("0 is out of range: allowed 1..=60000"),
    ) {
        (Some(2), true) => Ok(()),
        (code, _) => Err(format!(
            "--timeout-ms beside the variable: exit {code:?}, {err}"
        )),
    }
}
