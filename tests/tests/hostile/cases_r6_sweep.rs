//! Round 6, a sweep of every subcommand's every value flag with hostile
//! values (NaN, ±inf, -1, 0, 1e300, 2^64, 2^32, empty, 100 000 chars,
//! wrong tuples, missing paths, directories, device nodes, random bytes):
//! one row per class of what it found and per command the class hit.
//!
//! - A flag given is used or refused, never ignored: clap waives
//!   `requires` when the flag required conflicts with one given, and a
//!   flag that only applies beside another was dropped without a word.
//! - A value is checked on every path: a stage twin refuses the step its
//!   controller would, `--udp 0` is refused wherever a UDP source is,
//!   `--baud 0` whether or not a serial link opens.
//! - A negative number is a flag's value (`--hold -1` was an unknown
//!   flag `-1`), refused by the flag's range, and `--weights` takes the
//!   range the synthesis does.
//! - A replayed centroid file names itself in its errors, which come long
//!   after the command started; a port or a timeout from the environment
//!   (`LMHOST_PORT`, `LMHOST_TIMEOUT_MS`) is named as the variable, not as
//!   a flag the user never typed; a path that is no serial port says so.
//! - A 100 000-character value is cut in its message (its start, its
//!   length, its end), on every command: one readable line.
//! - An output that cannot be written is refused before the work: the
//!   demo's `--plots` folder was made after the demo had run, the
//!   session's `--events` log opened after it said it had started.
//!
//! Fixtures in `{dir}/r6`: a centroid file whose second line is garbage.

use super::*;

pub(crate) fn sweep_fixtures(dir: &Path) {
    let dir = dir.join("r6");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("garbage.csv"), b"0,0,0,200,1\n\x01\xffgarbage\n").unwrap();
}

/// The study run's stderr (progress, then the error) names the file.
fn study_names_the_stream_file(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let err = std::fs::read_to_string(ctx.dir.join("r6/study-stream.err")).unwrap_or_default();
    let want = format!(
        "--stream file {}: line 2 ",
        ctx.dir.join("r6/garbage.csv").display()
    );
    match err.lines().last() {
        Some(l) if l.starts_with("error: ") && l.contains(&want) => Ok(()),
        _ => Err(format!("the last line of stderr lacks `{want}`: {err}")),
    }
}

pub(crate) fn sweep_cases() -> Vec<Case> {
    let mut cases = table! {
        // 1. No flag silently ignored. `--timestamps` needs `--depth`; the
        //    synthetic finger's flags conflict with `--depth`, which waived it.
        SWEEP_IGNORED "track --synthetic --seconds 0.3 --fast --timestamps {dir}/r6/ts.npy"
                      .err("cannot be used with");
        SWEEP_IGNORED "track --synthetic --noise-mm 0.5 --fast --timestamps {dir}/r6/ts.npy"
                      .err("cannot be used with");
        SWEEP_IGNORED "track --synthetic --holes 0.1 --fast --timestamps {dir}/r6/ts.npy"
                      .err("cannot be used with");
        // One focus has no neighbour: `--spacing` changed nothing in LM-S.
        SWEEP_IGNORED "plan --spacing 4" .err("--spacing applies to LM-M only");
        SWEEP_IGNORED "upload --port {port} --foci 1 --spacing 4" .err("--spacing applies to LM-M only");
        SWEEP_IGNORED "plan --foci 2 --spacing 4" .ok();
        // An AUTD3 has no serial link: its settings were dropped.
        SWEEP_IGNORED "upload --port autd3:emulator --baud 9600" .err("--baud applies to the LM firmware's serial link");
        SWEEP_IGNORED "status --port autd3:emulator --tries 3" .err("--tries applies to the LM firmware's serial link");
        SWEEP_IGNORED "upload --port autd3:emulator --encoding raw" .err("--encoding applies to the LM firmware's serial link");
        SWEEP_IGNORED "stream --port autd3:emulator --synthetic --seconds 0.3 --fast --lease 5"
                      .err("--lease applies to the LM firmware's serial link");
        SWEEP_IGNORED "upload --port {port} --baud 9600 --tries 3 --encoding raw --no-play" .ok();
        SWEEP_IGNORED "upload --port {port} --lease 5 --no-play" .err("cannot be used with");
        // A rig's scene names an AUTD3's devices; the LM firmware has its
        // array from the upload.
        SWEEP_IGNORED "status --port {port} --scene {scenes}/paper.toml" .err("--scene applies to an AUTD3 port");
        SWEEP_IGNORED "status --port autd3:emulator --scene {scenes}/paper.toml" .ok();
        // The gauge twin's noise seed means nothing to a real gauge.
        SWEEP_IGNORED "gauge read --port /dev/null --seed 3" .err("a noise seed (--seed) needs port sim");
        // A filter smooths samples: the synthetic finger and no finger
        // have none; its lead is the Kalman filter's.
        SWEEP_IGNORED "session --port autd3:emulator --library {scenes}/../studies/paper-library.toml --control - --filter none"
                      .err("--filter applies to a finger tracked or streamed");
        SWEEP_IGNORED "stream --port {port} --synthetic --seconds 0.3 --fast --filter none --lead-ms 20"
                      .err("--lead-ms applies to --filter kalman only");
        SWEEP_IGNORED "stream --port {port} --synthetic --seconds 0.3 --fast --lead-ms 20" .ok();
        // With commands on stdin no client disconnects.
        SWEEP_IGNORED "session --port autd3:emulator --library {scenes}/../studies/paper-library.toml --control - --on-disconnect quit"
                      .err("--on-disconnect needs a socket --control");
        // `--stimulus` needs `--library`, which conflicts with the plan flags.
        SWEEP_IGNORED "simulate --stimulus lms-5hz-a2 --radius 3 --out {dir}/r6/sim"
                      .err("'--stimulus <ID>' cannot be used with '--radius <MM>'");
        SWEEP_IGNORED "simulate --stimulus lms-5hz-a2 --freq 5 --out {dir}/r6/sim"
                      .err("cannot be used with");
        // `--rate` applies to a `--for` series only.
        SWEEP_IGNORED "gauge read --port sim --rate 5" .err("--for");
        SWEEP_IGNORED "gauge read --port sim --rate nan" .err("--for");
        // ... and with --for it is used (the rate in the output).
        SWEEP_IGNORED "gauge read --port sim --rate 5 --for 0.2" .ok().out("at 5 Hz");
        // `--baud 0` where no serial link opens.
        SWEEP_IGNORED "track --synthetic --seconds 0.3 --fast --baud 0" .err("--baud");
        SWEEP_IGNORED "study run {dir}/study/mini.toml --port autd3:emulator --out {dir}/r6/out \
                       --responses {dir}/study/ans.txt --participant baud0 --baud 0" .err("--baud");
        // What the output says it used is what was given (0.05 s was said
        // as 0.1 s).
        SWEEP_IGNORED "upload --port {port} --hold 0.05" .ok().err("for 0.05 s");
        // 2. One check on every path: the stage twin, a port that does not
        //    open (the step said before the I/O error), the controller.
        SWEEP_EVERY_PATH "stage move --port sim --to 1 --step-um nan" .err("µm/pulse is outside");
        SWEEP_EVERY_PATH "stage move --port sim --to 1 --step-um 1e300" .err("µm/pulse is outside");
        SWEEP_EVERY_PATH "stage position --port sim --step-um 0" .err("µm/pulse is outside");
        SWEEP_EVERY_PATH "stage home --port sim --step-um inf" .err("µm/pulse is outside");
        SWEEP_EVERY_PATH "stage move --port sim:fail-after=3 --min 0 --max 10 --to 1 --step-um nan"
                         .err("µm/pulse is outside");
        SWEEP_EVERY_PATH "stage move --port {dir}/r6/no-stage --min 0 --max 10 --to 1 --step-um nan"
                         .err("µm/pulse is outside");
        // A step in range is still refused by the twin, which has no
        // pulses: it would be ignored.
        SWEEP_EVERY_PATH "stage move --port sim --to 1 --step-um 0.5"
                         .err("--step-um does not apply to the simulated stage");
        SWEEP_EVERY_PATH "study run {scenes}/../studies/paper-exp3.toml --port autd3:emulator \
                          --out {dir}/r6/out --time-scale 0.02 --responses {dir}/exp3/same.txt \
                          --participant step --finger synthetic --stage sim --gauge sim \
                          --stage-step-um nan" .err("sim: stage step NaN µm/pulse");
        // `--udp 0` binds a port no tracker is told: refused as `stream` does.
        SWEEP_EVERY_PATH "session --library {scenes}/../studies/paper-library.toml \
                          --port autd3:emulator --control - --udp 0" .err("0 is out of range: allowed 1..=65535");
        SWEEP_EVERY_PATH "study run {dir}/study/mini.toml --port autd3:emulator --out {dir}/r6/out \
                          --responses {dir}/study/ans.txt --participant udp0 --udp 0"
                         .err("0 is out of range: allowed 1..=65535");
        // The message they now share with stream.
        SWEEP_EVERY_PATH "stream --port {port} --udp 0" .err("0 is out of range: allowed 1..=65535");
        // 3. A negative value is the flag's value, refused by its range (it
        //    was an unknown flag `-1`) or taken where the range allows it.
        SWEEP_NEGATIVE "sim --slot-steps -1" .err("-1 is out of range: allowed 1..=65535");
        SWEEP_NEGATIVE "doctor --timeout-ms -1" .err("invalid value '-1' for '--timeout-ms <MS>'");
        SWEEP_NEGATIVE "upload --port {port} --tries -1" .err("-1 is out of range: allowed 1..=100");
        SWEEP_NEGATIVE "track --synthetic --seconds 0.3 --fast --plot {dir}/r6/plot --plot-frame -1"
                       .err("invalid value '-1' for '--plot-frame <N>'");
        SWEEP_NEGATIVE "plan --steps -5" .err("invalid value '-5' for '--steps <N>'");
        SWEEP_NEGATIVE "wiring --channels-per-board -1"
                       .err("invalid value '-1' for '--channels-per-board <N>'");
        SWEEP_NEGATIVE "stream --port {port} --synthetic --seconds 0.3 --lead-ms -1001"
                       .err("--lead-ms -1001 must be within ±1000");
        SWEEP_NEGATIVE "stream --port {port} --synthetic --seconds 0.3 --lead-ms -1" .ok()
                       .out("streamed");
        // --weights: the range the synthesis takes (the help said ±1e6,
        // the synthesis refused below 0; `-1,1` could not be typed).
        SWEEP_NEGATIVE "plan --foci 2 --weights -1,1"
                       .err("--weights value -1 is out of range: allowed 0..=1000000");
        SWEEP_NEGATIVE "upload --port {port} --foci 2 --weights -1,1"
                       .err("--weights value -1 is out of range");
        // 4. A replayed centroid file names itself (the session's control
        //    held open, so it is the stream that ends it).
        PATH_MESSAGES "stream --port {port} --input {dir}/r6/garbage.csv"
                      .err("--input file {dir}/r6/garbage.csv: line 2 ");
        // A value from the environment is named as such (the user may not
        // remember a shell profile's variable); the flag typed wins.
        PATH_MESSAGES "status" .env("LMHOST_PORT", "{dir}/no_such_port").code(1)
                      .err("$LMHOST_PORT: opening serial port {dir}/no_such_port");
        PATH_MESSAGES "status --port {dir}/no_such_port" .env("LMHOST_PORT", "{port}").code(1)
                      .err("error: opening serial port {dir}/no_such_port");
        PATH_MESSAGES "status --port {port}" .env("LMHOST_TIMEOUT_MS", "0")
                      .err("(the value of $LMHOST_TIMEOUT_MS; see --help)");
        PATH_MESSAGES "status --port {port} --timeout-ms 0" .env("LMHOST_TIMEOUT_MS", "50")
                      .err("0 is out of range: allowed 1..=60000 (see --help)");
        // A path that opens but is no serial port, in words (not the OS's
        // "Not a typewriter").
        PATH_MESSAGES "status --port /dev/null" .code(1).err("/dev/null: not a serial port");
        PATH_MESSAGES "gauge read --port {dir}/a_file" .code(1).err("not a serial port");
        PATH_MESSAGES "session --library {scenes}/../studies/paper-library.toml \
                       --port autd3:emulator --control - --stream {dir}/r6/garbage.csv"
                      .hold_stdin().err("--stream file {dir}/r6/garbage.csv: line 2 ");
    };
    cases.extend(table! {
        // 5. Outputs first (exit 1 as every unwritable output): nothing
        //    ran, so nothing was printed before the one error line.
        SWEEP_OUTPUT_FIRST "demo --plots {dir}/a_file" .code(1).err("a_file")
                           .check(nothing_on_stdout);
        SWEEP_OUTPUT_FIRST "demo --plots {dir}/a_file/maps" .code(1).err("a_file")
                           .check(nothing_on_stdout);
        SWEEP_OUTPUT_FIRST "session --library {scenes}/../studies/paper-library.toml \
                            --port autd3:emulator --control {dir}/r6/events.sock \
                            --events {dir}/a_directory" .code(1).err("a_directory");
        SWEEP_OUTPUT_FIRST "session --library {scenes}/../studies/paper-library.toml \
                            --port autd3:emulator --control {dir}/r6/events.sock \
                            --events {dir}/r6/no_such_dir/events.jsonl" .code(1)
                           .err("no_such_dir");
    });
    cases.push(
        case(
            PATH_MESSAGES,
            "study run {dir}/study/mini.toml --port autd3:emulator --out {dir}/r6/out \
             --responses {dir}/study/ans.txt --participant stream --stream {dir}/r6/garbage.csv",
        )
        .stderr_file("{dir}/r6/study-stream.err")
        .check(study_names_the_stream_file),
    );
    cases
}

/// The command stopped before its work: it printed nothing.
fn nothing_on_stdout(_: &Ctx, r: &Run) -> Result<(), String> {
    if r.stdout.is_empty() {
        Ok(())
    } else {
        Err(format!("it printed before failing: {}", r.stdout.trim()))
    }
}

/// The one error line holds the 100 000-character value cut around its
/// length, not whole.
fn long_value_cut(_: &Ctx, r: &Run) -> Result<(), String> {
    if r.stderr.len() < 1000 && r.stderr.contains(" characters)…") {
        Ok(())
    } else {
        Err(format!(
            "stderr is {} bytes, want the value cut: {}",
            r.stderr.len(),
            r.stderr.chars().take(300).collect::<String>()
        ))
    }
}

/// Every command given a 100 000-character value (`{long}`), with the
/// exit code its message goes with.
pub(crate) fn long_value_cases() -> Vec<Case> {
    let long = "x".repeat(100_000);
    let lib = "--library {scenes}/../studies/paper-library.toml";
    let study = "{dir}/study/mini.toml --port autd3:emulator --out {dir}/r6/out \
                 --responses {dir}/study/ans.txt --participant long";
    let rows: Vec<(String, i32)> = [
        ("plan --scene {long}", 2),
        ("scene --scene {long}", 2),
        ("wiring --scene {long}", 2),
        ("doctor --port {port} --timeout-ms {long}", 2),
        ("simulate --out {dir}/r6/sim --scene {long}", 2),
        ("bench --quick --section {long}", 2),
        ("sim --seconds {long}", 2),
        ("info --port {port} --scene {long}", 2),
        ("status --port {port} --scene {long}", 2),
        ("upload --port {port} --scene {long}", 2),
        ("play --port {port} --scene {long}", 2),
        ("stop --port {port} --scene {long}", 2),
        ("selftest --port {port} --scene {long}", 2),
        ("demo --seconds {long}", 2),
        (
            "stream --port {port} --synthetic --seconds 0.3 --scene {long}",
            2,
        ),
        ("flash --board {long}", 2),
        ("track --synthetic --seconds 0.3 --fast --scene {long}", 2),
        ("study report {dir}/study/out --width-mm {long}", 2),
        ("study check {dir}/study/mini.toml --participant {long}", 2),
        ("calibrate force --measured 0.01 --scene {long}", 2),
        (
            "calibrate camera {dir}/r6/garbage.csv --max-residual {long}",
            2,
        ),
        ("gauge read --port {long}", 1),
        ("stage move --port sim --to 1 --min {long}", 2),
        ("stage position --port sim --min {long}", 2),
        ("stage home --port sim --min {long}", 2),
    ]
    .into_iter()
    .map(|(a, c)| (a.to_owned(), c))
    .chain([
        (
            format!("session {lib} --port autd3:emulator --control - --scene {{long}}"),
            2,
        ),
        (format!("study run {study} --scene {{long}}"), 2),
        // Longer than any device path: refused as input (round 12).
        ("upload --port {long}".to_owned(), 2),
    ])
    .collect();
    rows.into_iter()
        .map(|(a, code)| {
            case(SWEEP_LONG, &a.replace("{long}", &long))
                .code(code)
                .check(long_value_cut)
        })
        .collect()
}
