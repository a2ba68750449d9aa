//! Round 14: classes no earlier round had.
//!
//! - r14-1: the outputs of one run never share a path, a folder a run
//!   writes into among them. `track --record R.npy --plot R.npy` made the
//!   plot folder at the recording's path, tracked the whole run, then
//!   failed (exit 1, "cannot write R.npy: it is a directory") and left
//!   the recording's intrinsics and time stamps beside no recording;
//!   `session --events P --control P` made the event log, then refused
//!   its own log as a socket path that "exists and is not a socket" (and
//!   `--events` at the TCP token file's path was not checked at all).
//!   Every output of a run, the files beside a recording, the control
//!   socket and its token file included, is now checked against every
//!   other before any is made.
//! - r14-2: a port name of a form no port has is refused as such, not
//!   opened: `--port " /dev/ttyACM0"` or a name with its line end (and the
//!   same in `$LMHOST_PORT`, a stage's or a gauge's port) was opened as it
//!   was and failed as "no such file or directory" (exit 1, the space or
//!   line break unseen in the message); `stage --port "sim "` asked for a
//!   real stage's limits; `gauge --port ""` said ": no such file or
//!   directory"; a `$LMHOST_PORT` that is not UTF-8 was taken for an
//!   unset one, and discovery picked whatever board it found.
//! - r14-3: a JSON file holds one value: what follows it is refused. A
//!   foci file (`upload --foci-file`, a library's `foci_file`) read its
//!   first object and ignored the rest (a second object, a stray word),
//!   and so did a study's `session.json` (`study report`, `study run
//!   --resume`); a phases file refused it ("trailing characters").
//! - r14-4: a refusal states the range its check allows. A range with an
//!   open end was written closed: `--spacing 1e9` (and `--step`,
//!   `simulate --disk`, `--plane-step`, `--plane-size`, `--alpha`) said
//!   "allowed 0..=1000 mm" of a flag that refuses 0; now "allowed above 0
//!   and at most 1000 mm". The stage's and gauge's ranges were written
//!   `0..50`, as a range that leaves its end out reads, of checks that
//!   take the end; now `0..=50`, as every other message writes them.
//! - r14-5: a path a file gives is refused when empty, naming its field.
//!   A points file's `depth = ""` or `background = ""` named the points
//!   file's own folder, refused as "cannot read recording DIR/: it is a
//!   directory" with no word of the field; a protocol's `library = ""`
//!   said "cannot read stimulus library : no such file or directory". A
//!   library's `foci_file = ""` was already refused as empty; the three
//!   now are, by one rule (`files::in_folder`).
//! - r14-6: an output folder's path that is something else is named for
//!   what it is. `simulate --out FILE`, `demo --plots /dev/full` or a
//!   `--plot` at a link to nothing said "cannot create the --out directory
//!   FILE: it already exists", as though a folder that exists could not
//!   be written into; now "it is a regular file, not a directory" (a
//!   device node, a FIFO, a symbolic link to nothing).
//! - r14-7: a duration that rounds to no time is refused. Above 0 but
//!   below a nanosecond, the least a `Duration` holds, a value became
//!   none: `upload --hold 1e-300` held for 0 s ("holding for 0 s"), `sim
//!   --seconds` of it served for none, `stream --udp --seconds 1e-300`
//!   failed the socket (exit 1, "cannot set a 0 duration timeout"), a
//!   control line's `off_s` of it paused not at all, and so did a
//!   protocol's, which `study check` called valid. One rule in
//!   `limits::duration_s`, and the protocol's timeline checked by it
//!   before a run starts.
//!
//! Fixtures in `{dir}/r14`, those not whole on purpose in [`BROKEN`].

use super::*;

/// The folder of the fixtures that are not whole JSON on purpose, which
/// the check that every file is whole passes by.
pub(crate) const BROKEN: &str = "r14/broken";

pub(crate) fn round14_fixtures(dir: &Path) {
    let r = dir.join("r14");
    std::fs::create_dir_all(r.join("out")).unwrap();
    std::fs::create_dir_all(dir.join(BROKEN)).unwrap();
    let foci = r#"{"foci_mm": [[[0, 0, 200]]], "dwell_us": 1000}"#;
    std::fs::write(r.join("broken/foci_two.json"), format!("{foci}\n{foci}\n")).unwrap();
    std::fs::write(r.join("broken/foci_word.json"), format!("{foci} x")).unwrap();
    std::fs::write(r.join("broken/foci_blank.json"), format!("{foci}\n\n")).unwrap();
    // A finished participant (the study fixtures'), its session.json on
    // one line and then another object.
    let (from, to) = (dir.join("study/out/P1"), r.join("broken/tail/P1"));
    std::fs::create_dir_all(&to).unwrap();
    for f in ["trials.csv", "events.jsonl"] {
        std::fs::copy(from.join(f), to.join(f)).unwrap();
    }
    let text = std::fs::read_to_string(from.join("session.json")).unwrap();
    let session: serde_json::Value = serde_json::from_str(&text).unwrap();
    std::fs::write(to.join("session.json"), format!("{session}\n{{}}\n")).unwrap();
    let point = |i: usize, depth: &str| {
        format!(
            "[[point]]\nat_mm = [{}.0, {}.0, 30.0]\ndepth = \"{depth}\"\n",
            40 * (i % 2),
            30 + 40 * (i / 2)
        )
    };
    let points = |bg: &str, depth: &str| {
        format!(
            "ball_diameter_mm = 40.0\n{bg}{}{}{}",
            point(0, "p1.npy"),
            point(1, depth),
            point(2, "p3.npy")
        )
    };
    std::fs::write(r.join("points_depth.toml"), points("", "")).unwrap();
    std::fs::write(
        r.join("points_bg.toml"),
        points("background = \"\"\n", "p2.npy"),
    )
    .unwrap();
    let stair = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies/staircase-detection.toml"),
    )
    .unwrap();
    let empty = stair.replace("library = \"staircase-library.toml\"", "library = \"\"");
    assert_ne!(empty, stair, "the staircase protocol's library moved");
    std::fs::write(r.join("library_empty.toml"), empty).unwrap();
    let no_pause = stair.replace("off_s = 0.5", "off_s = 1e-300");
    assert_ne!(no_pause, stair, "the staircase protocol's off_s moved");
    std::fs::write(r.join("off_none.toml"), no_pause).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies/staircase-library.toml"),
        r.join("staircase-library.toml"),
    )
    .unwrap();
    std::fs::write(r.join("plain"), "a file\n").unwrap();
    std::os::unix::fs::symlink(r.join("missing"), r.join("dangling")).unwrap();
}

/// Nothing of the refused run is left in `{dir}/r14/out` (the folder was
/// made empty by the fixtures and every case writing there is refused).
fn nothing_made(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let left: Vec<String> = std::fs::read_dir(ctx.dir.join("r14/out"))
        .map_err(|e| e.to_string())?
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    match left.is_empty() {
        true => Ok(()),
        false => Err(format!("left in r14: {left:?}")),
    }
}

/// A `$LMHOST_PORT` that is not UTF-8 is refused, naming the variable.
fn env_not_utf8(_: &Ctx, _: &Run) -> Result<(), String> {
    use std::os::unix::ffi::OsStrExt as _;
    let out = Command::new(lmhost())
        .arg("status")
        .env("LMHOST_PORT", std::ffi::OsStr::from_bytes(b"/dev/tty\xff"))
        .output()
        .map_err(|e| e.to_string())?;
    let err = String::from_utf8_lossy(&out.stderr);
    let want = "error: $LMHOST_PORT `/dev/tty\u{fffd}` is not UTF-8: give a port name in UTF-8, or unset it\n";
    match (out.status.code(), err == want) {
        (Some(2), true) => Ok(()),
        (code, _) => Err(format!("non-UTF-8 $LMHOST_PORT: exit {code:?}, {err}")),
    }
}

/// `case(class, args)` with `more` appended as single arguments (values
/// with spaces or control characters).
fn with(class: &'static str, args: &str, more: &[&str]) -> Case {
    let mut c = case(class, args);
    c.args.extend(more.iter().map(|s| (*s).to_owned()));
    c
}

pub(crate) fn round14_cases() -> Vec<Case> {
    let session = "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --synthetic";
    let mut v = table! {
        R14_OUTPUTS "track --synthetic --fast --seconds 0.2 --record {dir}/r14/out/rec.npy --plot {dir}/r14/out/rec.npy"
            .err("error: --plot {dir}/r14/out/rec.npy and --record {dir}/r14/out/rec.npy are the same path; give each output its own")
            .check(nothing_made);
        R14_OUTPUTS "track --synthetic --fast --seconds 0.2 --record {dir}/r14/out/b.npy --plot {dir}/r14/out/./b.timestamps.npy"
            .err("error: --plot {dir}/r14/out/./b.timestamps.npy and --record's time stamps {dir}/r14/out/b.timestamps.npy are the same path; give each output its own")
            .check(nothing_made);
    };
    v.extend([
        case(
            R14_OUTPUTS,
            &format!("{session} --control {{dir}}/r14/out/ctl.sock --events {{dir}}/r14/out/ctl.sock"),
        )
        .err("error: --events {dir}/r14/out/ctl.sock and --control {dir}/r14/out/ctl.sock are the same path; give each output its own")
        .check(nothing_made),
        case(
            R14_OUTPUTS,
            &format!(
                "{session} --control {{dir}}/r14/out/c.sock --tcp {{tcp}} --events {{dir}}/r14/out/c.sock.token"
            ),
        )
        .err("error: --events {dir}/r14/out/c.sock.token and the TCP token file {dir}/r14/out/c.sock.token are the same path; give each output its own")
        .check(nothing_made),
    ]);
    let spaces = "has spaces at an end: give the port's name without them";
    let control = "holds a line break or control character: give the port's name alone";
    v.extend([
        with(R14_PORT_FORM, "status --port", &[" {port}"])
            .err(&format!("error: --port ` {{port}}` {spaces}"))
            .check(env_not_utf8),
        with(R14_PORT_FORM, "upload --hold 0.1 --port", &["{port}\n"])
            .err(&format!("error: --port `{{port}}\\n` {control}")),
        with(R14_PORT_FORM, "info --port", &["autd3:emulator "])
            .err(&format!("error: --port `autd3:emulator ` {spaces}")),
        case(R14_PORT_FORM, "status")
            .env("LMHOST_PORT", "{port} ")
            .err(&format!("error: $LMHOST_PORT `{{port}} ` {spaces}")),
        with(R14_PORT_FORM, "stage position --port", &["sim "])
            .err(&format!("error: stage `sim ` {spaces}")),
        with(R14_PORT_FORM, "gauge read --port", &[" sim"])
            .err(&format!("error: gauge ` sim` {spaces}")),
        with(R14_PORT_FORM, "gauge read --port", &[""])
            .err("error: gauge: give sim or a serial port, not an empty name"),
        with(
            R14_PORT_FORM,
            "study run {scenes}/../studies/paper-exp3.toml --port autd3:emulator \
             --out {dir}/r14/out/study --participant P1 --finger synthetic --stage sim --gauge",
            &["sim\t"],
        )
        .err(&format!("error: gauge `sim\\t` {control}"))
        .check(nothing_made),
    ]);
    let upload = "upload --port {port} --no-play --foci-file {dir}/r14/broken";
    v.extend(table! {
        R14_JSON_TAIL "upload --port {port} --no-play --foci-file {dir}/r14/broken/foci_two.json"
            .err("error: --foci-file {dir}/r14/broken/foci_two.json: not a foci JSON object (trailing characters at line 2 column 1)");
        R14_JSON_TAIL "upload --port {port} --no-play --foci-file {dir}/r14/broken/foci_word.json"
            .err("error: --foci-file {dir}/r14/broken/foci_word.json: not a foci JSON object (trailing characters at line 1 column 48)");
        R14_JSON_TAIL "study report {dir}/r14/broken/tail/P1"
            .err("error: {dir}/r14/broken/tail/P1/session.json: trailing characters at line 2 column 1");
    });
    // White space after the value is no value.
    v.push(case(R14_JSON_TAIL, &format!("{upload}/foci_blank.json")).ok());
    v.extend(table! {
        R14_RANGES "plan --foci 2 --spacing 1e9"
            .err("error: spacing 1e9 mm is out of range: allowed above 0 and at most 1000 mm");
        R14_RANGES "plan --step 5000"
            .err("error: step 5000 mm is out of range: allowed above 0 and at most 1000 mm");
        R14_RANGES "simulate --disk 1e9 --out {dir}/r14/out/sim"
            .err("error: --disk 1e9 mm is out of range: allowed above 0 and at most 1000 mm")
            .check(nothing_made);
        R14_RANGES "simulate --alpha 3 --out {dir}/r14/out/sim"
            .err("error: --alpha 3 is out of range: allowed above 0 and at most 2");
        R14_RANGES "stage move --port sim --to 60"
            .err("error: sim-stage: position 60 mm is outside the stage's soft limits 0..=50 mm");
        R14_RANGES "stage move --port sim --to 1 --speed 100"
            .err("error: sim-stage: stage speed 100 mm/s is outside 0.01..=50 mm/s");
        R14_RANGES "gauge read --port sim --sim-depth 30"
            .err("error: simulated depth 30 mm is outside 0..=7 mm (the simulated pad reaches the gauge's 50 N capacity at 7.5 mm)");
        R14_RANGES "stage move --port /dev/null --min 0 --max 20 --to 1 --step-um 0"
            .err("error: /dev/null: stage step 0 µm/pulse is outside 0.001..=1000 µm/pulse");
        // The ends a range says it takes are taken.
        R14_RANGES "stage move --port sim --to 50 --speed 50" .ok();
        R14_EMPTY_PATH "calibrate camera {dir}/r14/points_depth.toml --scene {scenes}/paper.toml"
            .err("error: points file {dir}/r14/points_depth.toml: `point[1].depth` is empty: give a file");
        R14_EMPTY_PATH "calibrate camera {dir}/r14/points_bg.toml --scene {scenes}/paper.toml"
            .err("error: points file {dir}/r14/points_bg.toml: `background` is empty: give a file");
        R14_EMPTY_PATH "study check {dir}/r14/library_empty.toml"
            .err("error: study protocol {dir}/r14/library_empty.toml: line 17, field `library`: the path is empty: give the stimulus library's file, relative to the protocol");
        R14_NOT_A_FOLDER "simulate --out {dir}/r14/plain" .code(1)
            .err("error: cannot create the --out directory {dir}/r14/plain: it is a regular file, not a directory");
        R14_NOT_A_FOLDER "demo --plots /dev/full --seconds 1" .code(1)
            .err("error: cannot create the --plots directory /dev/full: it is a device node, not a directory");
        R14_NOT_A_FOLDER "track --synthetic --fast --seconds 0.2 --plot {dir}/r14/dangling" .code(1)
            .err("error: cannot create the --plot directory {dir}/r14/dangling: it is a symbolic link to nothing (its target is missing)");
        R14_NO_TIME "upload --port {port} --hold 1e-300"
            .err("error: --hold 1e-300 s rounds to no time (a duration holds whole nanoseconds): give at least 1e-9 s");
        R14_NO_TIME "stream --port {port} --udp {tcp} --seconds 1e-300"
            .err("error: --seconds 1e-300 s rounds to no time (a duration holds whole nanoseconds): give at least 1e-9 s");
        R14_NO_TIME "sim --seconds 4e-10"
            .err("error: --seconds 4e-10 s rounds to no time (a duration holds whole nanoseconds): give at least 1e-9 s");
        R14_NO_TIME "study check {dir}/r14/off_none.toml"
            .err("error: study protocol {dir}/r14/off_none.toml: the timeline's off_s 1e-300 s rounds to no time (a duration holds whole nanoseconds): give an off_s of 0 or at least 1e-9 s (as `study run` plans it for the LM firmware)");
        R14_NO_TIME "study run {dir}/r14/off_none.toml --port autd3:emulator --participant P1 --out {dir}/r14/out/study --observer logistic:threshold=0.4,slope=15,seed=1 --time-scale 0.5"
            .err("error: study protocol {dir}/r14/off_none.toml: the timeline's off_s 1e-300 s × --time-scale 0.5 = 5e-301 s rounds to no time (a duration holds whole nanoseconds): give an off_s of 0 or at least 2e-9 s")
            .check(nothing_made);
        // The least a duration holds is one.
        R14_NO_TIME "upload --port {port} --hold 1e-9" .ok();
    });
    v.push(
        case(
            R14_NO_TIME,
            "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control -",
        )
        .stdin(
            "{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a2\",\"gate\":\"untracked\",\"on_s\":0.5,\"off_s\":1e-300,\"repeat\":2}\n",
        )
        .ok()
        .out("{\"cmd\":\"present\",\"error\":\"off_s 1e-300 s rounds to no time (a duration holds whole nanoseconds): give 0 (no pause) or at least 1e-9 s\",\"ok\":false}"),
    );
    v
}
