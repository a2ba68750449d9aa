//! Round 16a: a sweep of the command line and its files for what earlier
//! rounds missed.
//!
//! - r16a-1: a refusal's advice is one its flag can take: a FIFO given to
//!   any input said "pipe into standard input instead", `--scene`,
//!   `--library` and `--phases` too, which read no standard input; now only
//!   a flag that takes `-` says so, naming itself (`give `--input -``).
//! - r16a-2: a value that is no number is refused in one wording wherever
//!   it is read, saying what it looks like: a lone number flag said `0x10
//!   is not a number: give one such as …`, a number in a flag's list ``
//!   `0x10` is not a number (got `0,0x10,150`)`` (an empty item `` `` ``),
//!   `--away` `` `x` is not a number of seconds``, `--z-profile` its own
//!   words again, a CSV centroid field `` x `0x10` is not a number``, and
//!   none said that `2,5` has a decimal comma (a CSV field did), `3mm` a
//!   unit, `١٢` or `５` digits other than 0-9, `0x10` hexadecimal or
//!   `1_000` digit separators. Now `limits::no_number` says it for every
//!   reader, `files::text::number_hint` what it looks like (whole-number
//!   flags too). A TOML file's number in quotes said `invalid type:
//!   string "2,5", expected a number` in every TOML file: now `"2,5" is
//!   text, not a number (a decimal comma? write `2.5`)`, and `"5"` what
//!   to write.
//! - r16a-3: flags that together ask less than each says, without a word:
//!   `simulate --plane-step 50` over the default 20 mm plane simulated
//!   and plotted one point (a step wider than the plane leaves one point
//!   across it), `--plane-size 20,10 --plane-step 15` a row; refused
//!   where the plane is checked (`field::plane`), so Python's
//!   `simulate()` meets it too. `stream --synthetic --away 0,100
//!   --seconds 1` (a window larger than the run) streamed 90 samples and
//!   no finger: an away window that holds every frame is refused where
//!   r15a-1 refuses one that holds none.
//! - r16a-4: every `LMHOST_*` variable is taken as set or refused naming
//!   it: `$LMHOST_PYTHON` not UTF-8 ran `python3` instead, empty "cannot
//!   run ``"; `$LMHOST_CAMERA_COLOUR` other than `0` (`no`, `off`, empty)
//!   asked the bridge for colour; `$LMHOST_PORT` set empty was taken for
//!   unset (whatever board was found) where an empty `--port` and an empty
//!   `$LMHOST_TIMEOUT_MS` are refused, and its upper-case prefix was
//!   called `--port`; `lmhost doctor` left `$LMHOST_PORT` unchecked and
//!   `$LMHOST_TIMEOUT_MS` unread, the device and timeout every other
//!   command uses (a flag still wins over either).
//! - r16a-5: every signal whose default action ends the process leaves
//!   outputs whole or absent, as SIGINT, SIGTERM and SIGHUP do: SIGUSR2
//!   and SIGALRM (a `timeout -s ALRM`, a job scheduler's limit, SIGXCPU
//!   from `ulimit -t`) killed lmhost with its output's temporary file
//!   beside the name and, in `track --record`, no recording; now each ends
//!   a command as the others do (`stop::SIGNALS`).
//! - r16a-6: a JSON file that is no object is named as what it is:
//!   serde reads a struct from an array too, so `--phases` given `[[]]`
//!   or `[1,2,3]` said it "is a plan summary without its phases" (the
//!   first item taken for `crc32`), `--foci-file` that it was a plan
//!   report, and `"x"` or `5` "expected struct Keys", a Rust type's name.
//! - r16a-7: an output that cannot be written because of its folder names
//!   the part of the path that is wrong: "a part of the path is not a
//!   directory" (`--out FILE/x.json`, `--record`, `--events`, an `--out`
//!   folder) and "no such file or directory" (a missing folder, or a
//!   symbolic link whose target's folder is missing) named none.
//! - r16a-8: a TOML table written as an array is refused, not read by
//!   position: serde reads a struct from an array too, so `reflector =
//!   [[0, 0, 0], [0, 0, 1]]` was a reflector whose point and normal came
//!   from the order of the struct's fields, and a library's `am =
//!   ["sine", 100.0]` an AM, in every TOML file (`scene::tables`).
//! - and r3-3 (an output that is an input) again: `calibrate force
//!   --scene S --out L`, L a link to S, was refused only by the writer, as
//!   `output L`, after the work: the scene is now read before `--out` is
//!   checked, so it is refused by its flag first.
//!
//! Fixtures in `{dir}/r16a`.

use super::*;

pub(crate) fn round16a_fixtures(dir: &Path) {
    let r = dir.join("r16a");
    std::fs::create_dir_all(r.join("sig")).unwrap();
    std::fs::create_dir_all(r.join("rec")).unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml");
    std::fs::copy(scene, r.join("scene.toml")).unwrap();
    std::os::unix::fs::symlink("scene.toml", r.join("link.toml")).unwrap();
    std::fs::write(r.join("plain"), "a file, not a folder\n").unwrap();
    let scene_text = std::fs::read_to_string(r.join("scene.toml")).unwrap();
    let studies = Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies");
    let protocol = std::fs::read_to_string(studies.join("paper-exp1.toml")).unwrap();
    for (name, body) in [
        (
            "dwell_comma.toml",
            scene_text.replacen("min_dwell_ms = 1.0", "min_dwell_ms = \"2,5\"", 1),
        ),
        (
            "lib_steps.toml",
            "[[stimulus]]\nid = \"a\"\nradius = 2.0\nsteps = \"10\"\n".to_owned(),
        ),
        (
            "reflector_array.toml",
            format!(
                "reflector = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]\n{}",
                scene_text.replacen(
                    "[reflector]\npoint_mm = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n",
                    "",
                    1
                )
            ),
        ),
        (
            "lib_am_array.toml",
            "[[stimulus]]\nid = \"a\"\nradius = 2.0\nam = [\"sine\", 100.0]\n".to_owned(),
        ),
        (
            "touch_unit.toml",
            protocol.replacen("touch_s = 3.0", "touch_s = \"3 s\"", 1),
        ),
    ] {
        assert!(body.contains('"'), "{name}");
        std::fs::write(r.join(name), body).unwrap();
    }
    std::os::unix::fs::symlink(r.join("gone/x.json"), r.join("dangling.json")).unwrap();
    for (name, body) in [
        ("array.json", "[[]]\n"),
        ("numbers.json", "[1,2,3]\n"),
        ("string.json", "\"x\"\n"),
        ("number.json", "5\n"),
        ("null.json", "null\n"),
        ("false.json", "false\n"),
        ("toml.JSON", "name = \"x\"\n"),
    ] {
        std::fs::write(r.join(name), body).unwrap();
    }
}

/// The refusal of `{dir}/fifo` as `what`, and a flag's own advice.
fn fifo(what: &str, advice: &str) -> String {
    format!(
        "error: cannot read {what} {{dir}}/fifo: it is a FIFO (named pipe), not a regular file{advice}\n"
    )
}

/// The advice of a flag that takes `-`.
fn pipe(flag: &str) -> String {
    format!("; give `{flag} -` and pipe into standard input instead")
}

/// A session on the AUTD3 emulator, its control on stdin.
const SESSION: &str =
    "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control -";

pub(crate) fn round16a_cases() -> Vec<Case> {
    let mut v = table! {
        // 1. A FIFO's advice only where the flag takes `-`.
        R16A_ADVICE "scene --scene {dir}/fifo" .err(&fifo("scene file", ""));
        R16A_ADVICE "plan --scene {dir}/fifo" .err(&fifo("scene file", ""));
        R16A_ADVICE "upload --port {port} --phases {dir}/fifo" .err(&fifo("--phases file", ""));
        R16A_ADVICE "study check {dir}/fifo" .err(&fifo("study protocol", ""));
        R16A_ADVICE "stream --port {port} --input {dir}/fifo"
            .err(&fifo("--input file", &pipe("--input")));
        R16A_ADVICE "track --scene {scenes}/paper.toml --stream {dir}/fifo"
            .err(&fifo("--stream file", &pipe("--stream")));
    };
    v.extend([
        case(R16A_ADVICE, &format!("{SESSION} --stream {{dir}}/fifo"))
            .err(&fifo("--stream file", &pipe("--stream"))),
        case(
            R16A_ADVICE,
            "session --library {dir}/fifo --port autd3:emulator --control -",
        )
        .err(&fifo("stimulus library", "")),
        case(
            R16A_ADVICE,
            &format!("{SESSION} --scene {{scenes}}/paper.toml --depth-stream {{dir}}/fifo"),
        )
        .err(&fifo("--depth-stream file", &pipe("--depth-stream"))),
        case(
            R16A_ADVICE,
            "study run {scenes}/../studies/paper-exp1.toml --port autd3:emulator --finger synthetic --participant p1 --out {dir}/r16a/out --responses {dir}/fifo",
        )
        .err(&fifo("--responses file", &pipe("--responses"))),
    ]);
    // 2. One wording for a value that is no number, and what it looks like.
    let give = "give one such as 2.5, -1 or 1e-3";
    let lone = |v: &str, why: &str| {
        with(R16A_NO_NUMBER, "plan --radius", &[v]).err(&format!(
            "error: invalid value '{v}' for '--radius <MM>': {v} is not a number{why}: {give} (see --help)\n"
        ))
    };
    let digits = " (digits other than 0-9: write it with 0-9)";
    v.extend([
        lone("0x10", " (a hexadecimal number? write it in decimal)"),
        lone("1_000", " (digit separators? write `1000`)"),
        lone("١٢", digits),
        lone("５", digits),
        lone("3mm", " (a unit after it? give the number alone: `3`)"),
        lone("2,5", " (a decimal comma? write `2.5`)"),
        lone("1e", ""),
    ]);
    let v16 = table! {
        R16A_NO_NUMBER "plan --foci 0x2"
            .err("error: invalid value '0x2' for '--foci <N>': 0x2 is not a whole number (a hexadecimal number? write it in decimal): allowed 1..=32 (see --help)\n");
        R16A_NO_NUMBER "status --port {port} --timeout-ms 30ms"
            .err("error: invalid value '30ms' for '--timeout-ms <MS>': 30ms is not a whole number (a unit after it? give the number alone: `30`): allowed 1..=60000 (see --help)\n");
        R16A_NO_NUMBER "plan --steps 1,000"
            .err("error: invalid value '1,000' for '--steps <N>': 1,000 is not a whole number: allowed 1..=65535 (see --help)\n");
        R16A_NO_NUMBER "plan --center 0,,150"
            .err("error: --center: an empty value is not a number: give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "plan --center 0,0x10,150"
            .err("error: --center: 0x10 is not a number (a hexadecimal number? write it in decimal): give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "plan --foci 2 --weights 1,１"
            .err("error: --weights: １ is not a number (digits other than 0-9: write it with 0-9): give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "simulate --plane-size 5mm"
            .err("error: --plane-size: 5mm is not a number (a unit after it? give the number alone: `5`): give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "simulate --plane-axes 1,0,0,0,x,0"
            .err("error: --plane-axes: x is not a number: give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "stream --synthetic --away x,1"
            .err("error: --away `x,1`: START x is not a number: give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "track --synthetic --z-profile 3mm,8"
            .err("error: --z-profile `3mm,8`: the radius 3mm is not a number (a unit after it? give the number alone: `3`): give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "sim --faults ber=1_0"
            .err("error: --faults: ber: 1_0 is not a number (digit separators? write `10`): give one such as 2.5, -1 or 1e-3\n");
        R16A_NO_NUMBER "stream --port {port} --input -"
            .stdin("0,3mm,0,200,1\n")
            .err("error: line 1: `x`: 3mm is not a number (a unit after it? give the number alone: `3`)\n");
        R16A_NO_NUMBER "stream --port {port} --input -"
            .stdin("0,0,0,,1\n")
            .err("error: line 1: `z`: an empty value is not a number\n");
    };
    v.extend(v16);
    v.extend(table! {
        R16A_NO_NUMBER "scene --scene {dir}/r16a/dwell_comma.toml"
            .err("error: scene file {dir}/r16a/dwell_comma.toml: line 9, field `min_dwell_ms`: \"2,5\" is text, not a number (a decimal comma? write `2.5`)\n");
        R16A_NO_NUMBER "simulate --library {dir}/r16a/lib_steps.toml --stimulus a --out {dir}/r16a/lib_sim"
            .err("error: stimulus library {dir}/r16a/lib_steps.toml: line 4, field `stimulus[0].steps`: \"10\" is text, not a whole number in 1..=65535: write `10` without quotes\n");
        R16A_NO_NUMBER "study check {dir}/r16a/touch_unit.toml"
            .err("error: study protocol {dir}/r16a/touch_unit.toml: line 28, field `timeline.touch_s`: \"3 s\" is text, not a number (a unit after it? give the number alone: `3`)\n");
    });
    // 3. A step wider than the plane it steps over.
    let plane = "error: bad observation plane: a step of";
    v.extend(table! {
        R16A_LESS "simulate --plane-step 50 --out {dir}/r16a/sim_wide"
            .err(&format!("{plane} 50 mm is wider than the plane's width of 20 mm, which it would leave one point across; give a step of at most 20 mm\n"));
        R16A_LESS "simulate --plane-size 20,10 --plane-step 15 --out {dir}/r16a/sim_row"
            .err(&format!("{plane} 15 mm is wider than the plane's height of 10 mm, which it would leave one point across; give a step of at most 10 mm\n"));
        R16A_LESS "simulate --plane-size 2,1 --plane-step 1 --out {dir}/r16a/sim_ok" .ok();
        R16A_LESS "stream --synthetic --fast --port {port} --away 0,100 --seconds 1"
            .err("error: --away 0,100 holds every frame of the stream (--seconds 1): the finger would never show; give a window that leaves it at least one frame\n");
        R16A_LESS "stream --synthetic --fast --port {port} --away 0,10"
            .err("error: --away 0,10 holds every frame of the stream (--seconds 10): the finger would never show; give a window that leaves it at least one frame\n");
        R16A_LESS "stream --synthetic --fast --port {port} --away 0,0.98 --seconds 1" .ok()
            .out("streamed 90 samples (1 with a finger)");
    });
    // 4. Each LMHOST_* variable as set, or refused naming it.
    let camera = "track --camera --scene {scenes}/paper.toml";
    let colour = |v: &str| {
        case(R16A_ENV, camera).env("LMHOST_CAMERA_COLOUR", v).err(&format!(
            "error: $LMHOST_CAMERA_COLOUR `{v}` is neither 0 (depth only) nor 1 (depth and colour, the default): give one of them, or unset it\n"
        ))
    };
    let empty_port = "error: $LMHOST_PORT is empty: give a serial port path, tcp:HOST:PORT or autd3:…, or unset it for the one LM board found\n";
    v.extend([
        colour("no"),
        colour(""),
        colour(" 0"),
        case(R16A_ENV, camera)
            .env("LMHOST_PYTHON", "")
            .err("error: $LMHOST_PYTHON is empty: give the Python that runs the RealSense bridge, or unset it for python3\n"),
        case(R16A_ENV, camera)
            .env("LMHOST_PYTHON", "python3 ")
            .err("error: $LMHOST_PYTHON `python3 ` has spaces at an end: give the Python's name without them\n"),
        case(R16A_ENV, camera)
            .code(1)
            .env("LMHOST_CAMERA_COLOUR", "0")
            .env("LMHOST_PYTHON", "{dir}/r16a/no_python")
            .err("error: no camera: cannot run `{dir}/r16a/no_python` (the RealSense bridge needs python3 with pyrealsense2)\n"),
        case(R16A_ENV, "status").env("LMHOST_PORT", "").err(empty_port),
        case(R16A_ENV, "stream --synthetic").env("LMHOST_PORT", "").err(empty_port),
        case(R16A_ENV, "doctor").env("LMHOST_PORT", "").err(empty_port),
        case(R16A_ENV, "status --port {port}").env("LMHOST_PORT", "").ok(),
        case(R16A_ENV, "status").env("LMHOST_PORT", "TCP:localhost:1").err(
            "error: $LMHOST_PORT TCP:localhost:1: port prefixes are lowercase: tcp:HOST:PORT, autd3:emulator, autd3:soem[:IF], autd3:ethercrab[:IF], autd3:remote:HOST:PORT, or a serial port path\n",
        ),
        case(R16A_ENV, "doctor").env("LMHOST_PORT", "{port}").ok().out("ok      lm board: "),
        case(R16A_ENV, "doctor").env("LMHOST_TIMEOUT_MS", "0").err(
            "error: invalid value '0' for '--timeout-ms <MS>': 0 is out of range: allowed 1..=60000 (the value of $LMHOST_TIMEOUT_MS; see --help)\n",
        ),
        case(R16A_ENV, "doctor --timeout-ms 300").env("LMHOST_TIMEOUT_MS", "0").ok(),
        case(R16A_ENV, "plan").ok().check(python_not_utf8),
    ]);
    // 6. A JSON file that is no object, named as what it is.
    let phases = r#"{"phases": [[P, ...], ...], "dwell_us": D}"#;
    let foci = r#"{"foci_mm": [[[x, y, z], ...], ...], "dwell_us": D}"#;
    for (file, it) in [
        ("array", "an array"),
        ("numbers", "an array"),
        ("string", "a string"),
        ("number", "a number"),
        ("null", "`null`"),
        ("false", "`false`"),
    ] {
        v.push(
            case(R16A_NOT_OBJECT, &format!("upload --port {{port}} --phases {{dir}}/r16a/{file}.json"))
                .err(&format!("error: --phases file {{dir}}/r16a/{file}.json: is {it}, not a JSON object: give {phases}\n")),
        );
        v.push(
            case(R16A_NOT_OBJECT, &format!("upload --port {{port}} --foci-file {{dir}}/r16a/{file}.json"))
                .err(&format!("error: --foci-file {{dir}}/r16a/{file}.json: is {it}, not a JSON object: give {foci}\n")),
        );
    }
    // Not JSON at all (upper-case extension: not one of the files the
    // wholeness check reads as JSON): its parse's place, not a kind.
    v.push(
        case(R16A_NOT_OBJECT, "upload --port {port} --phases {dir}/r16a/toml.JSON")
            .err("error: --phases file {dir}/r16a/toml.JSON: not a phases JSON object (expected ident at line 1 column 2)\n"),
    );
    // 8. A TOML table written as an array.
    let array = "an array where a table goes: write it as a table, each value under its key";
    v.extend(table! {
        R16A_TOML_ARRAY "scene --scene {dir}/r16a/reflector_array.toml"
            .err(&format!("error: scene file {{dir}}/r16a/reflector_array.toml: line 1, field `reflector`: {array}\n"));
        R16A_TOML_ARRAY "simulate --library {dir}/r16a/lib_am_array.toml --stimulus a --out {dir}/r16a/lib_am"
            .err(&format!("error: stimulus library {{dir}}/r16a/lib_am_array.toml: line 4, field `stimulus[0].am`: {array}\n"));
    });
    // 7. The part of an output's path that is wrong.
    let plain = "{dir}/r16a/plain is a regular file, not a folder";
    v.extend(table! {
        R16A_WHICH_PART "plan --out {dir}/r16a/plain/x.json" .code(1)
            .err(&format!("error: cannot write {{dir}}/r16a/plain/x.json: {plain}\n"));
        R16A_WHICH_PART "wiring --out {dir}/r16a/plain/deeper/w.csv" .code(1)
            .err(&format!("error: cannot write {{dir}}/r16a/plain/deeper/w.csv: {plain}\n"));
        R16A_WHICH_PART "track --synthetic --fast --seconds 0.1 --record {dir}/r16a/plain/r.npy" .code(1)
            .err(&format!("error: cannot write {{dir}}/r16a/plain/r.npy: {plain}\n"));
        R16A_WHICH_PART "simulate --plane-size 2 --plane-step 1 --out {dir}/r16a/plain/sim" .code(1)
            .err(&format!("error: cannot create the --out directory {{dir}}/r16a/plain/sim: {plain}\n"));
        R16A_WHICH_PART "plan --out {dir}/r16a/missing/x.json" .code(1)
            .err("error: cannot write {dir}/r16a/missing/x.json: its folder {dir}/r16a/missing does not exist\n");
        R16A_WHICH_PART "plan --out {dir}/r16a/dangling.json" .code(1)
            .err("error: cannot write {dir}/r16a/dangling.json: it is a symbolic link to {dir}/r16a/gone/x.json, and its folder {dir}/r16a/gone does not exist\n");
    });
    v.push(
        case(
            R16A_WHICH_PART,
            &format!("{SESSION} --events {{dir}}/r16a/plain/e.jsonl"),
        )
        .code(1)
        .err(&format!(
            "error: cannot write {{dir}}/r16a/plain/e.jsonl: {plain}\n"
        )),
    );
    // r3-3: an --out that is the scene, through a link, by its flag.
    v.push(
        case(
            SAME_FILE,
            "calibrate force --measured 0.02 --scene {dir}/r16a/scene.toml --out {dir}/r16a/link.toml",
        )
        .err("error: --out {dir}/r16a/link.toml is the input {dir}/r16a/scene.toml: refusing to overwrite it; choose another output path\n"),
    );
    // 5. Every ending signal: outputs whole or absent.
    v.extend(table! {
        R16A_SIGNALS "simulate --plane-step 0.03 --out {dir}/r16a/sig/usr2"
            .signal("USR2", 1500).code(140).err("lmhost: interrupted by SIGUSR2").check(sig_left_nothing);
        R16A_SIGNALS "simulate --plane-step 0.03 --out {dir}/r16a/sig/xcpu"
            .signal("XCPU", 1500).code(152).err("lmhost: interrupted by SIGXCPU").check(sig_left_nothing);
        R16A_SIGNALS "track --synthetic --seconds 60 --record {dir}/r16a/rec/alrm.npy"
            .signal("ALRM", 1500).ok().out("stopped by SIGALRM").check(alrm_recorded);
    });
    v
}

/// Nothing under `{dir}/r16a/sig`: neither an output folder nor a
/// temporary file.
fn sig_left_nothing(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let d = ctx.dir.join("r16a/sig");
    let left: Vec<_> = std::fs::read_dir(&d)
        .map_err(|e| e.to_string())?
        .map(|e| e.map(|e| e.file_name()))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    match left.is_empty() {
        true => Ok(()),
        false => Err(format!("left in {}: {left:?}", d.display())),
    }
}

/// The recording stopped by SIGALRM is whole (with its files beside it),
/// and no temporary file is left.
fn alrm_recorded(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let d = ctx.dir.join("r16a/rec");
    let mut names: Vec<String> = std::fs::read_dir(&d)
        .map_err(|e| e.to_string())?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let want = ["alrm.intrinsics.toml", "alrm.npy", "alrm.timestamps.npy"];
    match names == want {
        true => Ok(()),
        false => Err(format!("{} holds {names:?}, want {want:?}", d.display())),
    }
}

/// `$LMHOST_PYTHON` not UTF-8 is run as named (a path need not be UTF-8),
/// not replaced by `python3`.
fn python_not_utf8(ctx: &Ctx, _: &Run) -> Result<(), String> {
    use std::os::unix::ffi::OsStrExt as _;
    let mut python = ctx.dir.join("r16a").into_os_string();
    python.push(std::ffi::OsStr::from_bytes(b"/py\xff"));
    let scene = ctx.scenes.join("paper.toml");
    let out = Command::new(lmhost())
        .args(["track", "--camera", "--scene"])
        .arg(&scene)
        .env("LMHOST_PYTHON", &python)
        .env("LMHOST_CAMERA_COLOUR", "1")
        .output()
        .map_err(|e| e.to_string())?;
    let err = String::from_utf8_lossy(&out.stderr);
    let want = format!(
        "error: no camera: cannot run `{}/r16a/py\u{fffd}` (the RealSense bridge needs python3 with pyrealsense2)\n",
        ctx.dir.display()
    );
    match (out.status.code(), err == want) {
        (Some(1), true) => Ok(()),
        (code, _) => Err(format!("non-UTF-8 $LMHOST_PYTHON: exit {code:?}, {err}")),
    }
}

/// `case(class, args)` with `more` appended as single arguments (values
/// with spaces or commas).
fn with(class: &'static str, args: &str, more: &[&str]) -> Case {
    let mut c = case(class, args);
    c.args.extend(more.iter().map(|s| (*s).to_owned()));
    c
}
