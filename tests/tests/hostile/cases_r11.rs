//! Round 11: a fresh look at what earlier rounds left, by class.
//!
//! - A whole-number flag names its own range, whatever is wrong with the
//!   value: `--timeout-ms -1` said "invalid digit found in string",
//!   `--tries 99999999999999999999` "number too large to fit in target
//!   type", and `--enter-frames -1` (1 to 90) "-1 is not in
//!   0..=4294967295", its type's range.
//! - A message lists a few of many and counts the rest: `study report` of
//!   a folder of 300 folders without a participant named every one with
//!   its reason (26 kB on one line); a level not of a 200-level factor
//!   listed all 200.
//! - A report line prints a number as a person reads it: `stream`'s last
//!   line said `dwell 2439.0243902439024 µs`.
//! - A study's timeline is checked, as the run plays it, against every
//!   stimulus it presents before the device opens: an on-phase that rounds
//!   to no step of one stimulus (by the protocol or by `--time-scale`) ran
//!   the trials before it, then ended the run naming `on_s` with the
//!   folder half written; one that `--time-scale` makes longer than a
//!   presentation plays was refused at the first trial.
//! - A session refused or failed in its set-up leaves its `--events` log
//!   as it was: an earlier session's log was emptied at once, before the
//!   port, the control socket or the device was tried, and a new one was
//!   left empty behind.
//! - An output folder a run made is removed again while empty when the
//!   run is refused, fails or is stopped (`simulate --out DIR --radius
//!   1e9`, `track --plot DIR --plot-frame 9999`, Ctrl-C in `simulate`):
//!   an empty folder stayed behind.
//! - The session's default control socket is named by what gave it: an
//!   unusable `$XDG_RUNTIME_DIR` was refused as `--control PATH`, a flag
//!   never typed; a relative one was taken as a folder of the working
//!   directory, and a `$USER` holding `/` or `..` placed the socket
//!   outside `/tmp` (the uid names it then).
//! - A session whose standard output (`--control -`) is closed ends
//!   quietly: a reply queued after its writer had failed was taken for a
//!   reader that fell 1024 lines behind (exit 1, "nothing reads it").
//! - An output is a file where a file is meant: `--out -` (standard
//!   output, as `-` is standard input for `--stream -`) made a file named
//!   `-`, and `--record /dev/null` wrote its time stamps and intrinsics
//!   beside it, as `/dev/null.timestamps.npy`, into `/dev`.
//! - A number inside a flag's list is read as exactly as a lone number
//!   flag: `--center 1e-400,0,200`, `--z`, `--weights`, `--away`,
//!   `--plane-size`, `--z-profile`, `--faults ber=` and `--observer`
//!   took a literal that underflows as 0 without a word.
//!
//! Fixtures in `{dir}/r11`.

use super::*;

pub(crate) fn round11_fixtures(dir: &Path) {
    let r11 = dir.join("r11");
    for i in 1..=300 {
        std::fs::create_dir_all(r11.join(format!("many/d{i}"))).unwrap();
    }
    let full = std::fs::read_to_string(dir.join("study/mini.toml")).unwrap();
    let mini = full.replace("sets = 2", "sets = 1");
    let levels: Vec<String> = (1..=200).map(|i| format!("\"l{i}\"")).collect();
    std::fs::write(
        r11.join("levels.toml"),
        format!(
            "{mini}\n[[factor]]\nname = \"x\"\nlevels = [{}]\n\n\
             [[report.pairs]]\nfactor = \"x\"\npairs = [[\"l1\", \"zz\"]]\n",
            levels.join(", ")
        ),
    )
    .unwrap();
    std::fs::write(r11.join("prev.jsonl"), PREV_LOG).unwrap();
    for (name, on_s) in [("short", "0.0015"), ("long", "3600")] {
        let text = full.replace("on_s = 0.5", &format!("on_s = {on_s}"));
        std::fs::write(r11.join(format!("{name}.toml")), text).unwrap();
    }
}

/// The earlier session's log a refused session must leave as it was.
const PREV_LOG: &str = "{\"t_host_us\":1,\"event\":\"closed\",\"reason\":\"quit\"}\n";

/// `{dir}/r11/prev.jsonl` is the earlier session's log still, and no
/// `{dir}/r11/new.jsonl` was left.
fn logs_as_they_were(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let prev =
        std::fs::read_to_string(ctx.dir.join("r11/prev.jsonl")).map_err(|e| e.to_string())?;
    if prev != PREV_LOG {
        return Err(format!("prev.jsonl was changed: {prev:?}"));
    }
    if ctx.dir.join("r11/new.jsonl").exists() {
        return Err("new.jsonl was left behind".into());
    }
    Ok(())
}

/// No file named `-` was made in the working directory.
fn no_dash_file(_: &Ctx, _: &Run) -> Result<(), String> {
    match Path::new("-").exists() {
        true => Err("a file named - was made".into()),
        false => Ok(()),
    }
}

/// Nothing was written beside `/dev/null`.
fn nothing_beside_dev_null(_: &Ctx, _: &Run) -> Result<(), String> {
    for f in ["/dev/null.timestamps.npy", "/dev/null.intrinsics.toml"] {
        if Path::new(f).exists() {
            let _ = std::fs::remove_file(f);
            return Err(format!("{f} was written"));
        }
    }
    Ok(())
}

/// No `{dir}/r11/made` was left: the folders a refused run made are gone.
fn no_folder_made(ctx: &Ctx, _: &Run) -> Result<(), String> {
    match ctx.dir.join("r11/made").exists() {
        true => Err(format!(
            "{} was left behind",
            ctx.dir.join("r11/made").display()
        )),
        false => Ok(()),
    }
}

/// `study run` of protocol `{dir}/PROTOCOL` as participant `ID` into
/// `{dir}/r11/out`.
fn study(protocol: &str, id: &str) -> String {
    format!(
        "study run {{dir}}/{protocol} --port autd3:emulator --out {{dir}}/r11/out \
         --responses {{dir}}/study/ans.txt --participant {id}"
    )
}

/// No participant's folder was made: the run was refused before it
/// started.
fn no_participant_folder(ctx: &Ctx, _: &Run) -> Result<(), String> {
    match std::fs::read_dir(ctx.dir.join("r11/out")) {
        Ok(mut d) => match d.next() {
            Some(e) => Err(format!(
                "{} was written",
                e.map_err(|e| e.to_string())?.path().display()
            )),
            None => Ok(()),
        },
        Err(_) => Ok(()),
    }
}

/// The one error line is short, whatever the input held.
fn short_line(_: &Ctx, r: &Run) -> Result<(), String> {
    match r.stderr.lines().map(|l| l.chars().count()).max() {
        Some(n) if n > 1000 => Err(format!("a {n}-character error line")),
        _ => Ok(()),
    }
}

/// No number on a text line of stdout or stderr carries more than 10
/// significant digits (a float printed with `{}` has up to 17). JSON
/// keeps every digit, for a program to read.
pub(crate) fn readable_numbers(_: &Ctx, r: &Run) -> Result<(), String> {
    let text = r.stdout.lines().chain(r.stderr.lines());
    for line in text.filter(|l| serde_json::from_str::<serde_json::Value>(l).is_err()) {
        let words = line.split(|c: char| !(c.is_ascii_digit() || c == '.'));
        for w in words.filter(|w| w.contains('.')) {
            let digits = w.trim_start_matches(['0', '.']).chars();
            let n = digits.filter(char::is_ascii_digit).count();
            if n > 10 {
                return Err(format!("{w} has {n} digits: {line}"));
            }
        }
    }
    Ok(())
}

pub(crate) fn round11_cases() -> Vec<Case> {
    let c = |class: &'static str, args: String| case(class, &args);
    let mut v = vec![
        // 4. A study's timeline is checked as played before the device opens.
        c(R11_TIMING, study("study/mini.toml", "r11_scale") + " --time-scale 0.003")
            .err("study protocol {dir}/study/mini.toml: the timeline's on_s 0.5 s × --time-scale 0.003 = 0.0015 s is shorter than half a step of `lms-5hz-a2`")
            .err("give a --time-scale of at least 0.003625")
            .check(no_participant_folder),
        c(R11_TIMING, study("r11/short.toml", "r11_short"))
            .err("the timeline's on_s 0.0015 s is shorter than half a step of `lms-5hz-a2`")
            .err("give an on_s of at least 0.0018125 s")
            .check(no_participant_folder),
        c(R11_TIMING, study("r11/long.toml", "r11_long") + " --time-scale 2")
            .err("the timeline's on_s 3600 s × --time-scale 2 = 7200 s is longer than a presentation plays (at most 3600 s): give a --time-scale of at most 1")
            .check(no_participant_folder),
        c(R11_TIMING, study("study/mini.toml", "r11_ok") + " --time-scale 0.004")
            .ok()
            .err("4 of 4 trials done"),
    ];
    let session = "session --library {scenes}/../studies/paper-library.toml";
    v.push(
        c(PIPE, format!("{session} --port autd3:emulator --control -"))
            .stdin("{\"cmd\":\"status\"}\n".repeat(200))
            .closed_stdout(),
    );
    v.extend([
        // 5. A session refused or failed in its set-up leaves its log.
        c(R11_SETUP, format!("{session} --port {{dir}}/r11/no-port --control - --events {{dir}}/r11/prev.jsonl"))
            .code(1)
            .err("opening serial port {dir}/r11/no-port: no such file or directory")
            .check(logs_as_they_were),
        c(R11_SETUP, format!("{session} --port autd3:emulator --control {{dir}}/r11/levels.toml --events {{dir}}/r11/prev.jsonl"))
            .err("exists and is not a socket")
            .check(logs_as_they_were),
        c(R11_SETUP, format!("{session} --port tcp:127.0.0.1:0 --control - --events {{dir}}/r11/new.jsonl"))
            .err("--port tcp:127.0.0.1:0: port `0` is not a number in 1..=65535")
            .check(logs_as_they_were),
        c(R11_SETUP, format!("{session} --port {{dir}}/r11/no-port --control - --events {{dir}}/r11/new.jsonl"))
            .code(1)
            .check(logs_as_they_were),
    ]);
    // 8. An output given as `-` is a file, never standard output: refused
    //    naming the flag, and no file `-` is written.
    for (args, flag) in [
        ("wiring --out -", "--out"),
        ("plan --out -", "--out"),
        ("simulate --out -", "--out"),
        (
            "track --synthetic --fast --seconds 0.2 --record -",
            "--record",
        ),
        (
            "study run {dir}/study/mini.toml --port autd3:emulator --out - \
             --responses {dir}/study/ans.txt --participant r11_dash",
            "--out",
        ),
        (
            "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator \
             --control - --events -",
            "--events",
        ),
    ] {
        let said = format!(
            "error: {flag} -: this output is a file, not standard output; give its path \
             (./- for a file named -)"
        );
        v.push(case(R11_OUTPUTS, args).err(&said).check(no_dash_file));
    }
    // 9. A number inside a flag's list is read exactly: refused naming the
    //    flag (and its list, where the message quotes it) and the literal.
    let tiny = "is too small to represent";
    for (args, said) in [
        (
            "plan --center 1e-400,0,200",
            format!("--center: 1e-400 {tiny} (it would be read as 0)"),
        ),
        ("plan --z 0,1e-400", format!("--z: 1e-400 {tiny}")),
        (
            "plan --foci 2 --weights 1,1e-400",
            format!("--weights: 1e-400 {tiny}"),
        ),
        (
            "simulate --plane-size 1e-400 --out {dir}/r11/made",
            format!("--plane-size: 1e-400 {tiny}"),
        ),
        (
            "simulate --plane-axes 1,0,0,0,1e-320,0 --out {dir}/r11/made",
            format!("--plane-axes: 1e-320 {tiny}: below"),
        ),
        (
            "stream --port autd3:emulator --synthetic --fast --seconds 0.3 --away 1e-400,1",
            format!("--away `1e-400,1`: START 1e-400 {tiny}"),
        ),
        (
            "track --synthetic --fast --z-profile 1e-400,5",
            format!("--z-profile `1e-400,5`: the radius 1e-400 {tiny}"),
        ),
        (
            "sim --faults ber=1e-400 --seconds 0.1",
            format!("--faults: ber: 1e-400 {tiny}"),
        ),
        (
            "calibrate force --measured 0.02 --center 1e-400,30,30",
            format!("--center: 1e-400 {tiny}"),
        ),
    ] {
        let c = case(R11_LIST_NUMBERS, args).err(&format!("error: {said}"));
        v.push(match args.contains("--out") {
            true => c.check(no_folder_made),
            false => c,
        });
    }
    v.extend(table![
        // 8. An output is a file where a file is meant (`-` below).
        R11_OUTPUTS "track --synthetic --fast --seconds 0.2 --record /dev/null"
            .err("error: --record /dev/null: it is a device node, and files are written beside it under its name: give a file path")
            .check(nothing_beside_dev_null);
        R11_OUTPUTS "track --synthetic --fast --seconds 0.2 --record /dev/full"
            .err("error: --record /dev/full: it is a device node");
        // 7. The default control socket is named by what gave it.
        R11_ENV "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator"
            .env("XDG_RUNTIME_DIR", "{dir}/r11/no-such-dir").code(1)
            .err("error: the default control socket ($XDG_RUNTIME_DIR/lmhost.sock; give --control PATH) {dir}/r11/no-such-dir/lmhost.sock: no such file or directory");
        R11_ENV "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator"
            .env("XDG_RUNTIME_DIR", "run/user")
            .err("error: $XDG_RUNTIME_DIR `run/user` is not an absolute path, so it holds no default control socket: give --control PATH");
        R11_ENV "session --library {scenes}/../studies/paper-library.toml --port autd3:emulator --control {dir}/r11/levels.toml"
            .env("XDG_RUNTIME_DIR", "run/user")
            .err("error: --control {dir}/r11/levels.toml: exists and is not a socket");
        // 6. An output folder a run made and left empty is removed.
        R11_DIRS "simulate --out {dir}/r11/made/sim --radius 1e9" .err("radius 1e9 mm is out of range")
            .check(no_folder_made);
        R11_DIRS "track --synthetic --fast --seconds 0.2 --plot {dir}/r11/made --plot-frame 9999"
            .err("--plot-frame 9999 is beyond the 18 frames").check(no_folder_made);
        R11_DIRS "demo --seconds 1 --plots {dir}/r11/made/p --port /dev/null"
            .err("demo --port takes an AUTD3 port").check(no_folder_made);
        R11_DIRS "simulate --out {dir}/r11/made/a/b" .signal("INT", 1500).code(130)
            .err("lmhost: interrupted by SIGINT").check(no_folder_made);
    ]);
    v.extend(table![
        // 1. A whole-number flag names its own range.
        R11_WHOLE "track --synthetic --fast --enter-frames -1" .err("-1 is out of range: allowed 1..=90");
        R11_WHOLE "track --synthetic --fast --leave-frames 4294967296"
            .err("4294967296 is out of range: allowed 1..=90");
        R11_WHOLE "info --port {port} --timeout-ms -1" .err("-1 is out of range: allowed 1..=60000");
        R11_WHOLE "info --port {port} --tries 99999999999999999999" .err("is out of range: allowed 1..=100")
            .check(short_numbers);
        R11_WHOLE "sim --slot-steps 4294967296" .err("4294967296 is out of range: allowed 1..=65535");
        R11_WHOLE "sim --centroid-timeout-ms -1" .err("-1 is out of range: allowed 0..=3600000");
        R11_WHOLE "plan --steps 1.5" .err("1.5 is not a whole number: allowed 1..=65535");
        R11_WHOLE "plan --foci -1" .err("-1 is out of range: allowed 1..=32");
        R11_WHOLE "wiring --channels-per-board 1e3"
            .err("1e3 is not a whole number: allowed 1..=64");
        R11_WHOLE "study check {dir}/study/mini.toml --seed -1" .err("-1 is out of range: allowed 0..=2^64-1");
        R11_WHOLE "status --port {port}" .env("LMHOST_TIMEOUT_MS", "-5")
            .err("-5 is out of range: allowed 1..=60000 (the value of $LMHOST_TIMEOUT_MS");
        // 2. A message lists a few of many and counts the rest.
        R11_LISTS "study report {dir}/r11/many" .err("no participant folder")
            .err("skipped d1, d10, d100, d101, d102, d103, d104, d105, … and 292 more (the first: ")
            .check(short_line);
        // A file given for the folder is named as one.
        PATH_MESSAGES "study report {dir}/r11/levels.toml"
            .err("error: {dir}/r11/levels.toml is not a folder: give a participant folder");
        PATH_MESSAGES "study report /dev/null" .err("error: /dev/null is not a folder");
        R11_LISTS "study check {dir}/r11/levels.toml"
            .err("`zz` is not a level of factor `x` (l1, l2, l3, l4, l5, l6, l7, l8, … and 192 more)");
        // 3. A report line prints a number as a person reads it.
        R11_DIGITS "stream --port {port} --synthetic --seconds 0.3 --fast --freq 7" .ok()
            .out("corrections applied").out("dwell 1742.2 µs").check(readable_numbers);
        R11_DIGITS "stream --port {port} --synthetic --seconds 0.3 --fast --freq 3 --json" .ok()
            .err("dwell 4065.0 µs").check(readable_numbers);
        R11_DIGITS "upload --port {port} --freq 7 --no-play" .ok().check(readable_numbers);
        R11_DIGITS "demo --seconds 1" .ok().check(readable_numbers);
        R11_DIGITS "track --synthetic --seconds 0.3 --fast --port {port} --freq 7" .ok()
            .check(readable_numbers);
    ]);
    v
}
