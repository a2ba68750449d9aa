//! Round 13: what earlier rounds knew of and left, each as a class.
//!
//! - A whole-number field of a file names the field's own range whatever
//!   number came: `width = -1` in intrinsics, `sets = 2.5` or `repeat =
//!   -1` in a protocol, `foci = -1` or `ratio = [-1, 2]` in a library,
//!   `min_points = -5` in a scene said "expected a whole number from 0 to
//!   4294967295" (or "≥ 0", or "invalid type: floating point"): the Rust
//!   type's range, the field's own rule named only for a value the type
//!   held.
//! - A missing field is named plainly, with where it was wanted:
//!   intrinsics without `fx` said "line 1, field `width`: missing field
//!   `fx`", the file's first key taken for the place.
//! - A recording of nothing is refused, naming it: `track --depth` of a
//!   0-frame `.npy`, `track --stream` of a stream that ends after its
//!   header, `stream` of empty input (or of comments only) and a
//!   session's `--stream` file of no samples exited 0 reporting 0 frames
//!   or samples, as if a finger had been tracked and nothing seen; `study
//!   report` of participants whose trials.csv holds no row wrote a
//!   summary of nothing and said "0 trials summarised".
//! - A number whose derived quantity overflows is refused by its own
//!   value and range: `plan --freq 1e-300` said "period 1e300 s exceeds
//!   the wire's u32 microseconds" (Python's `freq=1e-320` "period inf s"),
//!   `--step 1e-300` "gives 1.9e301 steps", `simulate --plane-step 1e-300`
//!   "inf × inf = inf points", a phases file's `dwell_us = 1e-300` "is inf
//!   Hz"; `--radius 1e-300` named a circumference of "0.000 mm", a dwell
//!   below the device's "0.0000 ms", and `simulate --density 1e-300`
//!   computed a force near 1e300 N without a word. An AUTD3 dwell too long
//!   was told to "lower the frequency" (which lengthens it).
//! - `study check` applies the timeline rule `study run` applies before
//!   the device opens: it planned no library, so it called "valid" a
//!   protocol whose on-phase `run` then refused as shorter than half a
//!   step of a stimulus (as written or by `--time-scale`, which `check`
//!   now takes with `--scene`, as `run` does).
//! - A number flag's value that is no number says so and what to give:
//!   `--radius x` said "invalid float literal", `--radius ""` "cannot
//!   parse float from empty string", `--steps ""` " is not a whole
//!   number" (an empty echo), and `--steps " 5"` "5 is not a whole
//!   number", naming a value that would have been taken; a value of
//!   20 000 characters with spaces was echoed whole, twice.
//! - A number literal beyond what a float holds is refused as itself:
//!   `--freq 1e309` said "must be a finite number > 0 Hz, got inf", a
//!   value never typed (a file's or a line's literal was refused, a
//!   flag's read as infinity); `--radius 1e-320` "would be read as
//!   1e-320", the literal itself, for the value held.
//! - An intensity above 0 that rounds to level 0 of 255 is refused, not
//!   played as silence: `--intensity 0.001` (or a library entry's, or
//!   Python's) planned and uploaded level 0, a stimulus nobody feels,
//!   said only in a report line.
//! - A file's text is bounded and free of control characters: a scene's
//!   `name` of 200 000 characters was printed whole at the head of every
//!   report, one holding `\n` or an escape sequence broke the report's
//!   line or drove the terminal; a protocol's question or adjustment
//!   `text` (what the participant reads) took any length and `\u001b[2J`,
//!   which cleared the participant's screen.
//! - An empty `--port` is refused, not taken for no `--port`: `--port
//!   "$PORT"` with PORT unset used `$LMHOST_PORT` or whatever board
//!   discovery found.
//! - A flag's value `-inf` or `-nan` is its value: clap took it for a
//!   cluster of short flags (`--radius -inf` said "unexpected argument
//!   '-i' found") where `-1` was a value.
//!
//! The Python cases (r13-4 and r13-8 through `plan()` and `simulate()`,
//! and r13-11, Python's own: every argument of the wrong kind said as what
//! it must be, not pyo3's `TypeError`) are in
//! `python/tests/test_hostile_r13.py`.
//!
//! Fixtures in `{dir}/r13`.

use super::*;

/// The repository's `studies/NAME` with its library named by its whole
/// path, so a copy in `{dir}/r13` finds it.
pub(crate) fn study(name: &str) -> String {
    let studies = Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies");
    let text = std::fs::read_to_string(studies.join(name)).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        match line.strip_prefix("library = \"") {
            Some(rest) => out.push_str(&format!(
                "library = \"{}\"",
                studies.join(rest.trim_end_matches('"')).display()
            )),
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

const CAM: &str =
    "width = 4\nheight = 4\nfx = 2.0\nfy = 2.0\nppx = 1.5\nppy = 1.5\ndepth_scale = 0.001\n";

/// Whole numbers no field takes, as a file may write them.
const NOT_WHOLE: [(&str, &str); 5] = [
    ("neg", "-1"),
    ("frac", "2.5"),
    ("float", "3.0"),
    ("huge", "1e30"),
    ("big", "99999999999"),
];

pub(crate) fn round13_fixtures(dir: &Path) {
    let r13 = dir.join("r13");
    std::fs::create_dir_all(&r13).unwrap();
    let w = |name: &str, body: &str| std::fs::write(r13.join(name), body).unwrap();
    let exp1 = study("exp1-with-practice.toml");
    let stair = study("staircase-detection.toml");
    let scene =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml"))
            .unwrap();
    for (tag, v) in NOT_WHOLE {
        w(
            &format!("cam_w_{tag}.toml"),
            &CAM.replace("width = 4", &format!("width = {v}")),
        );
        w(
            &format!("sets_{tag}.toml"),
            &exp1.replacen("sets = 2", &format!("sets = {v}"), 1),
        );
        w(
            &format!("points_{tag}.toml"),
            &exp1.replacen("points = 7", &format!("points = {v}"), 1),
        );
        w(
            &format!("stair_{tag}.toml"),
            &stair.replacen(
                "threshold_reversals = 8",
                &format!("threshold_reversals = {v}"),
                1,
            ),
        );
        w(
            &format!("steps_{tag}.toml"),
            &stair.replacen("steps = [4, 2, 1]", &format!("steps = [4, {v}, 1]"), 1),
        );
        w(
            &format!("repeat_{tag}.toml"),
            &exp1.replacen("iti_s = 1.0", &format!("iti_s = 1.0\nrepeat = {v}"), 1),
        );
        w(
            &format!("lib_foci_{tag}.toml"),
            &format!("[[stimulus]]\nid = \"a\"\nradius = 2.0\nfoci = {v}\n"),
        );
        w(
            &format!("lib_ratio_{tag}.toml"),
            &format!(
                "[[stimulus]]\nid = \"a\"\n\
                 path = {{ shape = \"lissajous\", a = 2.0, b = 2.0, ratio = [{v}, 2] }}\n"
            ),
        );
        w(
            &format!("scene_pts_{tag}.toml"),
            &scene.replacen("min_points = 20", &format!("min_points = {v}"), 1),
        );
    }
    std::fs::write(r13.join("header_only.lmdepth"), header_only()).unwrap();
    w("no_samples.csv", "# t,x,y,z,present\n\n");
    w("empty.csv", "");
    let rows = vec![vec![0u8; 996]; 4];
    for (name, dwell) in [("dwell_tiny.json", 1e-300), ("dwell_huge.json", 1e300)] {
        let body = serde_json::json!({"phases": rows, "dwell_us": dwell});
        w(name, &body.to_string());
    }
    let library = Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies/paper-library.toml");
    let short = |on_s: &str| {
        format!(
            "name = \"short\"\nlibrary = \"{}\"\nsets = 1\nstimulus = \"lms-5hz-a{{radius}}\"\n\n\
             [timeline]\non_s = {on_s}\niti_s = 0.0\ngate = \"untracked\"\n\n\
             [[factor]]\nname = \"radius\"\nlevels = [\"2\", \"3\"]\n\n\
             [[question]]\nid = \"guess\"\nkind = \"number\"\n",
            library.display()
        )
    };
    w("short_on.toml", &short("0.001"));
    w("long_on.toml", &short("0.5"));
    w("answers.txt", "1\n2\n");
    // A participant whose trials.csv holds its header alone.
    let p1 = dir.join("study/out/P1");
    let none = r13.join("no_trials/P1");
    std::fs::create_dir_all(&none).unwrap();
    for f in ["session.json", "events.jsonl"] {
        std::fs::copy(p1.join(f), none.join(f)).unwrap();
    }
    let trials = std::fs::read_to_string(p1.join("trials.csv")).unwrap();
    let header = trials.lines().next().unwrap();
    std::fs::write(none.join("trials.csv"), format!("{header}\n")).unwrap();
    w(
        "lib_faint.toml",
        "[[stimulus]]\nid = \"faint\"\nintensity = 0.0015\n",
    );
    for (file, name) in [
        ("scene_long_name.toml", "a b ".repeat(50_000)),
        ("scene_nl_name.toml", "paper\\nrig".to_owned()),
        ("scene_esc_name.toml", "paper\\u001b[2J".to_owned()),
    ] {
        let named = scene.replacen(
            "name = \"paper: four AUTD3 over a reflective display\"",
            &format!("name = \"{name}\""),
            1,
        );
        assert_ne!(named, scene, "the paper scene's name line moved");
        w(file, &named);
    }
    let exp3 = study("paper-exp3.toml");
    let q1 = "text = \"Q1.";
    for (file, text) in [
        ("q_escape.toml", "\\u001b[2J".to_owned()),
        ("q_bell.toml", "\\u0007".to_owned()),
        ("q_long.toml", "x".repeat(3000)),
    ] {
        w(file, &exp1.replacen(q1, &format!("text = \"{text}Q1."), 1));
    }
    let adjust = exp3.replacen(
        "text = \"Compared with",
        "text = \"\\u009b2JCompared with",
        1,
    );
    assert_ne!(adjust, exp3, "paper-exp3.toml's [adjustment] text moved");
    w("adjust_escape.toml", &adjust);
    w("cam_no_fx.toml", &CAM.replace("fx = 2.0\n", ""));
    w(
        "cam_no_width.toml",
        &format!("# a D435\n{}", CAM.replace("width = 4\n", "")),
    );
}

/// An LMDEPTH1 header of a 4 × 4 stream, and no frame after it.
fn header_only() -> Vec<u8> {
    let mut hdr = b"LMDEPTH1".to_vec();
    hdr.extend(4u32.to_le_bytes());
    hdr.extend(4u32.to_le_bytes());
    for v in [2.0f64, 2.0, 1.5, 1.5, 0.001] {
        hdr.extend(v.to_le_bytes());
    }
    hdr
}

/// What `v` (a [`NOT_WHOLE`] value) is said to be, against `range`.
fn said(v: &str, range: &str) -> String {
    match v {
        "2.5" | "3.0" => format!("{v} is not a whole number: allowed {range}"),
        _ => format!("{v} is out of range: allowed {range}"),
    }
}

pub(crate) fn round13_cases() -> Vec<Case> {
    let mut v = Vec::new();
    let session = "session --port autd3:emulator --control - --library";
    for (tag, n) in NOT_WHOLE {
        let c = |args: String| case(R13_FILE_WHOLE, &args);
        v.push(
            c("track".into())
                .depth("ok.npy", &format!("r13/cam_w_{tag}.toml"))
                .err(&format!("line 1, field `width`: {}", said(n, "1..=8192"))),
        );
        for (file, field, range) in [
            ("sets", "line 14, field `sets`", "1..=100"),
            (
                "points",
                "field `question[0].points`: question `vibration`",
                "2..=9",
            ),
            ("repeat", "field `timeline.repeat`", "1..=10000"),
            ("stair", "field `staircase.threshold_reversals`", "1..=12"),
        ] {
            v.push(
                c(format!("study check {{dir}}/r13/{file}_{tag}.toml"))
                    .err(&format!("{field}: {}", said(n, range))),
            );
        }
        v.push(
            c(format!("study check {{dir}}/r13/steps_{tag}.toml"))
                .err("field `staircase.steps`: give 1 or more steps, each 1 to 19 grid places"),
        );
        v.push(
            c(format!("{session} {{dir}}/r13/lib_foci_{tag}.toml")).err(&format!(
                "line 4, field `stimulus[0].foci`: {}",
                said(n, "1..=32")
            )),
        );
        v.push(
            c(format!("{session} {{dir}}/r13/lib_ratio_{tag}.toml")).err(&format!(
                "field `stimulus[0].path.ratio`: {}",
                said(n, "1..=32")
            )),
        );
        v.push(
            c(format!("plan --scene {{dir}}/r13/scene_pts_{tag}.toml")).err(&format!(
                "field `tracking.min_points`: {}",
                said(n, "1..=67108864")
            )),
        );
    }
    v.push(
        case(R13_MISSING, "track")
            .depth("ok.npy", "r13/cam_no_fx.toml")
            .err("intrinsics")
            .err(": missing field `fx` at the top level"),
    );
    v.push(
        case(R13_MISSING, "track")
            .depth("ok.npy", "r13/cam_no_width.toml")
            .err(": missing field `width` at the top level"),
    );
    v.extend(empty_recordings());
    let half = "is shorter than half a step of `lms-5hz-a2`";
    let run = "study run --port autd3:emulator --out {dir}/r13/out --participant P1 \
               --responses {dir}/r13/answers.txt";
    v.extend(vec![
        case(R13_CHECK_RUN, "study check {dir}/r13/short_on.toml")
            .err("the timeline's on_s 0.001 s")
            .err(half),
        case(R13_CHECK_RUN, &format!("{run} {{dir}}/r13/short_on.toml"))
            .err("the timeline's on_s 0.001 s")
            .err(half),
        case(
            R13_CHECK_RUN,
            "study check {dir}/r13/long_on.toml --time-scale 0.003",
        )
        .err("on_s 0.5 s × --time-scale 0.003 = 0.0015 s")
        .err(half),
        case(
            R13_CHECK_RUN,
            &format!("{run} {{dir}}/r13/long_on.toml --time-scale 0.003"),
        )
        .err("on_s 0.5 s × --time-scale 0.003 = 0.0015 s")
        .err(half),
        // The flags `run` takes, taken: what plays is valid.
        case(
            R13_CHECK_RUN,
            "study check {dir}/r13/long_on.toml --time-scale 1",
        )
        .ok()
        .out("protocol `short`: valid"),
        // A step of `lms-5hz-a2` is 3636.36 µs on the LM firmware, 3625 µs
        // on AUTD3's 25 µs grid: an on-phase of 1.815 ms plays on an AUTD3
        // only, and `--target` says which device the check is for.
        case(
            R13_CHECK_RUN,
            "study check {dir}/r13/long_on.toml --time-scale 0.00363 --target autd3",
        )
        .ok()
        .out("protocol `short`: valid"),
        case(
            R13_CHECK_RUN,
            "study check {dir}/r13/long_on.toml --time-scale 0.00363 --target lm",
        )
        .err("(3636.36 µs)")
        .err("(as `study run` plans it for the LM firmware)"),
        case(
            R13_CHECK_RUN,
            "study check {dir}/r13/long_on.toml --time-scale 0.00363",
        )
        .err("(as `study run` plans it for the LM firmware)"),
        case(
            R13_CHECK_RUN,
            "study check {dir}/r13/long_on.toml --time-scale 1e-300",
        )
        .err("on_s 0.5 s × --time-scale 1e-300 = 5e-301 s"),
        case(
            R13_CHECK_RUN,
            "study check {dir}/r13/long_on.toml --time-scale 101",
        )
        .err("--time-scale 101: give a factor above 0 and at most 100"),
    ]);
    v.extend(flag_values());
    let too_large = "is too large to represent (it would be read as";
    v.extend(table! {
        R13_TOO_LARGE "plan --freq 1e309" .err(&format!("1e309 {too_large} inf)"));
        R13_TOO_LARGE "plan --radius=-1e400" .err(&format!("-1e400 {too_large} -inf)"));
        R13_TOO_LARGE "plan --center 1e309,0,200" .err(&format!("--center: 1e309 {too_large}"));
        R13_TOO_LARGE "simulate --plane-size 1e999 --out {dir}/r13/sim_huge"
            .err(&format!("1e999 {too_large} inf): give a magnitude of at most 1.79769e308"));
        R13_TOO_LARGE "upload --port {port} --hold 1e400" .err(&format!("1e400 {too_large}"));
        R13_TOO_LARGE "plan --radius 1e-320" .err("(it would be read as 9.9998887e-321)");
        R13_TOO_LARGE "plan --center 5e-324,0,200" .err("(it would be read as 4.9406565e-324)");
    });
    let silence = "rounds to level 0 of 255, silence: give 0 for silence or at least 0.00197";
    v.extend(table! {
        R13_SILENCE "plan --intensity 0.001" .err(&format!("intensity 0.001 {silence}"));
        R13_SILENCE "plan --intensity 1e-300" .err(&format!("intensity 1e-300 {silence}"));
        R13_SILENCE "upload --port {port} --intensity 0.0019"
            .err(&format!("intensity 0.0019 {silence}"));
        R13_SILENCE "session --port autd3:emulator --control - --library {dir}/r13/lib_faint.toml"
            .err(&format!("stimulus 1 (`faint`): intensity 0.0015 {silence}"));
        R13_SILENCE "simulate --intensity 0.001 --plane-size 2 --plane-step 1 --out {dir}/r13/sim_faint"
            .err(&format!("intensity 0.001 {silence}"));
    });
    v.extend(table! {
        R13_FILE_TEXT "plan --scene {dir}/r13/scene_long_name.toml"
            .err("field `name` has 200000 characters, more than 200").check(short_refusal);
        R13_FILE_TEXT "plan --scene {dir}/r13/scene_nl_name.toml"
            .err("field `name` `paper\\nrig` holds a line break or control character");
        R13_FILE_TEXT "scene --scene {dir}/r13/scene_esc_name.toml"
            .err("field `name` `paper\\u{1b}[2J` holds a line break or control character");
        R13_FILE_TEXT "study check {dir}/r13/q_escape.toml"
            .err("field `question[0].text`: holds the control character \\u{1b}");
        R13_FILE_TEXT "study check {dir}/r13/q_bell.toml"
            .err("field `question[0].text`: holds the control character \\u{7}");
        R13_FILE_TEXT "study check {dir}/r13/q_long.toml"
            .err("field `question[0].text`: 3083 characters, more than 2000");
        R13_FILE_TEXT "study check {dir}/r13/adjust_escape.toml"
            .err("field `adjustment.text`: holds the control character \\u{9b}");
    });
    let empty = "--port is empty: give a serial port path, tcp:HOST:PORT or autd3:…";
    for args in [
        "status",
        "upload --hold 0.1",
        "track --synthetic --seconds 0.2 --fast",
    ] {
        let mut c = case(R13_EMPTY_PORT, args).err(empty);
        c.args.extend(["--port".to_owned(), String::new()]);
        // Not the device `$LMHOST_PORT` names.
        v.push(c.env("LMHOST_PORT", "{port}"));
    }
    v.extend(table! {
        R13_NEGATIVE_WORDS "plan --radius -inf"
            .err("radius (--radius) must be a finite number ≥ 0 mm, got -inf");
        R13_NEGATIVE_WORDS "plan --freq -NaN"
            .err("frequency (--freq) must be a finite number > 0 Hz, got NaN");
        R13_NEGATIVE_WORDS "upload --port {port} --hold -Infinity"
            .err("--hold -inf s is out of range: give a number above 0");
        R13_NEGATIVE_WORDS "track --synthetic --seconds -nan" .err("--seconds NaN must be in (0, 3600]");
    });
    v.extend(table! {
        R13_DERIVED "plan --freq 1e-300"
            .err("frequency 1e-300 Hz is out of range: allowed 0.000232831..=1000 Hz");
        R13_DERIVED "plan --freq 0.0002328 --steps 1"
            .err("frequency 0.0002328 Hz is out of range: allowed 0.000232831..=1000 Hz");
        R13_DERIVED "plan --step 1e-300"
            .err("step 1e-300 mm is out of range: allowed 0.000287626..=18.8496 mm (a finer one takes more than 65535 steps");
        R13_DERIVED "plan --radius 1e-300" .err("the circumference 2πA = 6.283e-300 mm");
        R13_DERIVED "plan --steps 65535 --freq 1000" .err("dwell 1/(N·f) = 1.5259e-5 ms is below");
        R13_DERIVED "plan --target autd3 --freq 0.00024"
            .err("needs a 50813008.1 µs dwell").err("raise the frequency or the step count");
        R13_DERIVED "simulate --plane-step 1e-300 --out {dir}/r13/sim_fine"
            .err("a step of 1e-300 mm over 20 × 20 mm gives too many points to count")
            .err("give a step of at least 0.010005 mm");
        R13_DERIVED "simulate --density 1e-300 --plane-size 2 --plane-step 1 --out {dir}/r13/sim_thin"
            .err("--density 1e-300 kg/m³ is out of range: allowed 0.001..=100 kg/m³");
        R13_DERIVED "upload --port {port} --phases {dir}/r13/dwell_tiny.json"
            .err("dwell_us 1e-300 over 4 steps is out of range: allowed 250..=1.07374e9 µs");
        R13_DERIVED "upload --port {port} --phases {dir}/r13/dwell_huge.json"
            .err("dwell_us 1e300 over 4 steps is out of range: allowed 250..=1.07374e9 µs");
    });
    v
}

/// `R13_EMPTY`: every reader of a recording refuses one of nothing.
fn empty_recordings() -> Vec<Case> {
    let scene = "--scene {scenes}/paper.toml";
    let lib = "--library {scenes}/../studies/paper-library.toml";
    vec![
        case(R13_EMPTY, "track")
            .depth("empty.npy", "cam.toml")
            .err("empty.npy: the recording holds no frames (shape (0, 4, 4))"),
        case(R13_EMPTY, "track")
            .depth("empty.npy", "cam.toml")
            .args("--record {dir}/r13/rec_of_none.npy")
            .err("the recording holds no frames")
            .check(no_recording_of_none),
        case(
            R13_EMPTY,
            &format!("track --stream {{dir}}/r13/header_only.lmdepth {scene}"),
        )
        .err("header_only.lmdepth: the stream holds no frames (it ended after its header)"),
        case(R13_EMPTY, &format!("track --stream - {scene}"))
            .stdin(header_only())
            .err("stdin: the stream holds no frames"),
        case(R13_EMPTY, "stream --port {port}")
            .err("no centroids on input: standard input ended before its first sample line"),
        case(R13_EMPTY, "stream --port {port}")
            .stdin("# t,x,y,z,present\n")
            .err("no centroids on input: standard input ended"),
        case(
            R13_EMPTY,
            "stream --port {port} --json --input {dir}/r13/no_samples.csv",
        )
        .err("no centroids on input: --input file {dir}/r13/no_samples.csv ended"),
        case(
            R13_EMPTY,
            "stream --port {port} --input {dir}/r13/empty.csv",
        )
        .err("no centroids on input: --input file {dir}/r13/empty.csv ended"),
        case(
            R13_EMPTY,
            &format!(
                "session {lib} --port autd3:emulator --control - --stream {{dir}}/r13/empty.csv"
            ),
        )
        .stdin("")
        .hold_stdin()
        .err("no centroids on input: --stream file {dir}/r13/empty.csv ended"),
        case(R13_EMPTY, "study report {dir}/r13/no_trials")
            .err("no_trials: no trial to report: every trials.csv holds no row")
            .check(no_summary),
        case(R13_EMPTY, "study report {dir}/r13/no_trials/P1").err("no trial to report"),
    ]
}

/// `R13_NOT_A_NUMBER`: `lmhost args FLAG VALUE`, the value whole.
fn flag_values() -> Vec<Case> {
    let with = |args: &str, value: String| {
        let mut c = case(R13_NOT_A_NUMBER, args);
        c.args.push(value);
        c
    };
    let give = "is not a number: give one such as 2.5, -1 or 1e-3";
    let long = "a b ".repeat(5000);
    vec![
        with("plan --radius", "x".into()).err(&format!("x {give}")),
        with("plan --radius", String::new()).err(&format!("an empty value {give}")),
        with("simulate --out {dir}/r13/nan --plane-step", "1,5".into()).err(
            "1,5 is not a number (a decimal comma? write `1.5`): give one such as 2.5, -1 or 1e-3",
        ),
        with("plan --freq", " 5".into())
            .err("` 5` is not a number (white space around it): give one such as"),
        with("plan --steps", String::new())
            .err("an empty value is not a whole number: allowed 1..=65535"),
        with("plan --steps", " 5".into()).err("` 5` is not a whole number: allowed 1..=65535"),
        with("plan --radius", long.clone())
            .err("…(20000 characters)…")
            .check(short_refusal),
        with("plan --steps", long)
            .err("…(20000 characters)…")
            .err("is not a whole number: allowed 1..=65535")
            .check(short_refusal),
        with("plan --radius", "1\n".repeat(500))
            .err("1\\n1\\n")
            .err("is not a number (white space around it): give one such as 2.5, -1 or 1e-3")
            .check(short_refusal),
    ]
}

/// The refusal is a line of a few hundred characters: the value was cut.
fn short_refusal(_: &Ctx, r: &Run) -> Result<(), String> {
    match r.stderr.chars().count() {
        n if n < 600 => Ok(()),
        n => Err(format!("stderr has {n} characters")),
    }
}

/// The refused report wrote nothing.
fn no_summary(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let p = ctx.dir.join("r13/no_trials/summary.csv");
    match p.exists() {
        true => Err(format!("{} was written", p.display())),
        false => Ok(()),
    }
}

/// The refused run left no recording behind.
fn no_recording_of_none(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let p = ctx.dir.join("r13/rec_of_none.npy");
    match p.exists() {
        true => Err(format!("{} was left", p.display())),
        false => Ok(()),
    }
}
