//! Round 8: what rounds 6 and 7 noticed and left, fixed as classes, and a
//! sweep of the run-time inputs they covered least: centroid streams
//! (stdin, `--input` files, `--udp` datagrams) and the session's control
//! lines, each field given huge, negative, NaN, inf and wrongly typed
//! values, keys twice, truncations, CRLF, BOMs, 100 000-character and a
//! million lines; depth frames for `track --depth` of 0 × 0 to 100 000 × 1,
//! every dtype, Fortran order, truncated, every header byte flipped. One
//! row per class and per input kind it hit.
//!
//! - A spacing for one focus, refused on the flags since round 6, is
//!   refused in a library entry too (`Cycle::given`, one rule).
//! - A centroid's time stamp lies in 0 to 1e10 s (a tracker's Unix
//!   seconds fit): one of 1e300 was taken and every sample after it
//!   dropped as out of order; one a year ahead is now dropped alone
//!   (counted as a time jump, not out of order: it came in order).
//!   Depth time stamps meet the same bounds where their file is named.
//! - `--resume` refuses a row without its time or with a
//!   `present_fraction` beyond 1 (the view's `/drawn` cap is a unit test:
//!   memory is not seen from here).
//! - An error about a file's content names the file: the points file's
//!   geometry, a library entry the AUTD3 cannot play, time stamps that do
//!   not fit the recording.
//! - A number the toml crate or serde quotes is tidied as any other (a
//!   300-digit `1e300`), and one beyond `f64` is cut, not called `inf`.
//! - A value that changes nothing is refused: `--index` without a
//!   latin-square order, a control line's `off_s` with one on-phase.
//! - A stream line is refused for what it is (a stray byte-order mark,
//!   a JSON array were read as CSV), and only the exact CSV header is
//!   skipped (`T,whatever` was).
//! - An `.npy` header value with a tail (`'<u2'*2`) is not the value it
//!   starts with.
//!
//! Fixtures in `{dir}/r8`.

use super::cases_r7_files::{npy, resumed_copy};
use super::*;

/// A session on the AUTD3 emulator over stdin (closed at once).
const SESSION: &str = "session --port autd3:emulator --control - --library";

pub(crate) fn round8_fixtures(dir: &Path) {
    let r8 = dir.join("r8");
    std::fs::create_dir_all(&r8).unwrap();
    let w = |name: &str, body: &[u8]| std::fs::write(r8.join(name), body).unwrap();
    w(
        "lib_spacing.toml",
        b"[[stimulus]]\nid = \"a\"\nfoci = 1\nspacing = 3.0\n",
    );
    w(
        "lib_dwell.toml",
        b"[[stimulus]]\nid = \"ok\"\n\n[[stimulus]]\nid = \"fast\"\nfreq = 400\nsteps = 100\n",
    );
    w(
        "lib_steps.toml",
        b"[[stimulus]]\nid = \"a\"\nsteps = 1e300\n",
    );
    w(
        "cam_w.toml",
        b"width = 1e300\nheight = 4\nfx = 2.0\nfy = 2.0\nppx = 1.5\nppy = 1.5\ndepth_scale = 0.001\n",
    );
    w(
        "points_line.toml",
        b"ball_diameter_mm = 40.0\n\n[[point]]\nat_mm = [0.0, 30.0, 30.0]\ndepth = \"p1.npy\"\n\n\
          [[point]]\nat_mm = [20.0, 30.0, 30.0]\ndepth = \"p2.npy\"\n\n\
          [[point]]\nat_mm = [40.0, 30.0, 30.0]\ndepth = \"p3.npy\"\n",
    );
    w(
        "t1e300.csv",
        csv(&["0,0,0,200,1", "1e300,0,0,200,1"]).as_bytes(),
    );
    // Time stamps for the two frames of `ok.npy`, and three for them.
    for (name, t) in [
        ("ts_neg.npy", &[-1.0, 0.0][..]),
        ("ts_three.npy", &[0.0, 0.1, 0.2]),
    ] {
        let mut b = npy(&format!(
            "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
            t.len()
        ));
        b.truncate(b.len() - 64);
        b.extend(t.iter().flat_map(|v: &f64| v.to_le_bytes()));
        w(name, &b);
    }
    w(
        "tail.depth",
        &npy("{'descr': '<u2'*2, 'fortran_order': False, 'shape': (2, 4, 4), }"),
    );
    // Plan reports (`plan --out F.json`): one for an AUTD3, one with a
    // phase changed after plan wrote it; raw phases short of a step.
    for (name, target) in [("plan_autd3.json", "autd3"), ("plan_edit.json", "lm")] {
        let out = r8.join(name);
        ok(&[
            "plan",
            "--target",
            target,
            "--steps",
            "4",
            "--freq",
            "20",
            "--out",
            out.to_str().unwrap(),
        ]);
    }
    let text = std::fs::read_to_string(r8.join("plan_edit.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let p = v["phases"][0][0].as_u64().unwrap();
    v["phases"][0][0] = ((p + 1) % 256).into();
    w("plan_edit.json", v.to_string().as_bytes());
    w("short.bin", &[0u8; 997]);
    resumed_copy(dir, "r8_time", 1, "time_utc", "");
    resumed_copy(dir, "r8_fraction", 1, "present_fraction", "1.5");
}

/// A message of at most 300 bytes: no value echoed whole.
fn short(_: &Ctx, r: &Run) -> Result<(), String> {
    match r.stderr.len() {
        n if n <= 300 => Ok(()),
        n => Err(format!("stderr is {n} bytes")),
    }
}

/// Datagrams `t,0,0,200,1` for each time stamp.
fn at(times: &[f64]) -> Vec<Vec<u8>> {
    times
        .iter()
        .map(|t| format!("{t},0,0,200,1").into_bytes())
        .collect()
}

pub(crate) fn round8_cases() -> Vec<Case> {
    let resume = |id: &str| {
        format!(
            "study run {{dir}}/study/mini.toml --port autd3:emulator --out {{dir}}/study/out \
             --time-scale 0.02 --responses {{dir}}/study/ans.txt --participant {id} --resume"
        )
    };
    let nines = format!("0,0,0,200,{}\n", "9".repeat(400));
    let mut v = table! {
        // 1. A spacing for one focus, in a library entry as on the flags.
        NOTICED_CANNOT_APPLY "session --port autd3:emulator --control - --library {dir}/r8/lib_spacing.toml"
            .err("stimulus library {dir}/r8/lib_spacing.toml: stimulus 1 (`a`): spacing applies to LM-M only: give foci 2 or more");
        // 2. Time stamps: a stream's line, a file's, a datagram, a depth
        //    recording's, each in 0 to 1e10 s.
        STREAM_TIME "stream --port {port}" .stdin(csv(&["0,0,0,200,1", "-1,0,0,200,1"]))
            .err("line 2: time stamp -1 s is out of range: give 0 to 1e10 s");
        STREAM_TIME "stream --port {port} --input {dir}/r8/t1e300.csv"
            .err("--input file {dir}/r8/t1e300.csv: line 2: time stamp 1e300 s is out of range");
        STREAM_TIME "track --depth {dir}/ok.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml --fast --timestamps {dir}/r8/ts_neg.npy"
            .err("{dir}/r8/ts_neg.npy: frame 0: time stamp -1 s is out of range");
        // 4. Rows a run cannot have written.
        NOTICED_RESUME "" .args(&resume("r8_time"))
            .err("line 2: column `time_utc`: ``: give a time").err("nothing was changed");
        NOTICED_RESUME "" .args(&resume("r8_fraction"))
            .err("line 2: column `present_fraction`: `1.5`: give a fraction from 0 to 1");
        // 5. The file named with its content's error.
        NOTICED_FILE_NAMED "calibrate camera {dir}/r8/points_line.toml --scene {scenes}/paper.toml"
            .err("points file {dir}/r8/points_line.toml: the ball positions are (nearly) on one line");
        NOTICED_FILE_NAMED "session --port autd3:emulator --control - --library {dir}/r8/lib_dwell.toml"
            .err("stimulus library {dir}/r8/lib_dwell.toml: stimulus 2 (`fast`): LM at 400 Hz with 100 steps needs a 25.0 µs dwell");
        NOTICED_FILE_NAMED "track --depth {dir}/ok.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml --fast --timestamps {dir}/r8/ts_three.npy"
            .err("{dir}/r8/ts_three.npy: 3 time stamps for 2 frames in {dir}/ok.npy");
        // 6. Quoted numbers tidied: the toml crate's and a stream's.
        NOTICED_TIDY "track --depth {dir}/ok.npy --intrinsics {dir}/r8/cam_w.toml --scene {scenes}/paper.toml --fast"
            .err("line 1, field `width`: 1e300 is out of range: allowed 1..=8192").check(short);
        NOTICED_TIDY "session --port autd3:emulator --control - --library {dir}/r8/lib_steps.toml"
            .err("field `stimulus[0].steps`: 1e300 is out of range: allowed 1..=65535").check(short);
        NOTICED_TIDY "stream --port {port}" .stdin(&nines)
            .err("line 1: `999999…(400 digits)` is not a `present` value").check(short);
        // 7. Values that change nothing.
        NOTICED_CHANGES_NOTHING "study run {dir}/study/mini.toml --port autd3:emulator --out {dir}/study/out --time-scale 0.02 --responses {dir}/study/ans.txt --participant r8_index --index 2"
            .err("--index 2 picks a row of a latin-square order, and this protocol has none");
        // 8. Lines refused for what they are.
        STREAM_TROUBLE "stream --port {port}" .stdin("0,0,0,200,1\n\u{feff}0.01,0,0,200,1\n")
            .err("line 2 starts with a byte-order mark (U+FEFF), which only the first line may");
        STREAM_TROUBLE "stream --port {port}" .stdin("0,0,0,200,1\n[0.01,0,0,200,1]\n")
            .err("line 2: not a centroid JSON object (a JSON array");
        STREAM_TROUBLE "stream --port {port}" .stdin("0,0,0,200,1\nT,whatever\n")
            .err("line 2: expected 5 CSV fields t,x,y,z,present, found 2");
        // 10. What plan --out writes, upload --phases reads: whole, for
        //     its target, unchanged.
        FILES_EXACT "upload --port {port} --phases {dir}/r8/short.bin --freq 5"
            .err("--phases file {dir}/r8/short.bin: 997 bytes is not 1..=65535 steps of 996 phases");
        FILES_ONE_RULE "upload --port {port} --phases {dir}/r8/plan_autd3.json"
            .err("--phases file {dir}/r8/plan_autd3.json: was planned for target autd3");
        FILES_ONE_RULE "upload --port {port} --phases {dir}/r8/plan_edit.json"
            .err("--phases file {dir}/r8/plan_edit.json: its crc32").err("the file changed after plan wrote it");
        // 9. A header value with a tail.
        STREAM_NPY_TAIL "track" .depth("r8/tail.depth", "cam.toml")
            .err(".npy header's 'descr' must be a quoted type such as '<u2', got `'<u2'*2`");
    };
    // 2. Datagrams: one absurd stamp is counted bad, one a year ahead
    //    dropped alone; the samples after each are taken.
    v.push(
        case(
            STREAM_TIME,
            "stream --port {port} --udp 47081 --seconds 1 --json",
        )
        .udp(47081, at(&[0.0, 1e300, 0.02, 0.03, 0.04]))
        .ok()
        .out("\"bad_datagrams\":1")
        .out("\"out_of_order\":0")
        .out("\"samples\":4"),
    );
    v.push(
        case(
            STREAM_TIME,
            "stream --port {port} --udp 47082 --seconds 1 --json",
        )
        .udp(47082, at(&[0.0, 3.2e7, 0.02, 0.03, 0.04]))
        .ok()
        .out("\"out_of_order\":0")
        .out("\"time_jumps\":1")
        .out("\"present\":4"),
    );
    // 7. A control line's off_s with one on-phase.
    v.push(
        case(
            NOTICED_CHANGES_NOTHING,
            &format!("{SESSION} {{scenes}}/../studies/paper-library.toml"),
        )
        .stdin(
            "{\"cmd\":\"present\",\"stimulus\":\"lms-5hz-a3\",\"gate\":\"untracked\",\"on_s\":1,\"off_s\":2}\n\
             {\"cmd\":\"status\"}\n",
        )
        .ok()
        .out("`off_s` is the silence between on-phases: give `repeat` 2 or more")
        .out("\"state\":\"idle\""),
    );
    v
}
