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
//!
//! Fixtures in `{dir}/r11`.

use super::*;

pub(crate) fn round11_fixtures(dir: &Path) {
    let r11 = dir.join("r11");
    for i in 1..=300 {
        std::fs::create_dir_all(r11.join(format!("many/d{i}"))).unwrap();
    }
    let mini = std::fs::read_to_string(dir.join("study/mini.toml"))
        .unwrap()
        .replace("sets = 2", "sets = 1");
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
    table![
        // 1. A whole-number flag names its own range.
        R11_WHOLE "track --synthetic --fast --enter-frames -1" .err("-1 is not in 1..=90");
        R11_WHOLE "track --synthetic --fast --leave-frames 4294967296"
            .err("4294967296 is not in 1..=90");
        R11_WHOLE "info --port {port} --timeout-ms -1" .err("-1 is not in 1..=60000");
        R11_WHOLE "info --port {port} --tries 99999999999999999999" .err("is not in 1..=100")
            .check(short_numbers);
        R11_WHOLE "sim --slot-steps 4294967296" .err("4294967296 is not in 1..=65535");
        R11_WHOLE "sim --centroid-timeout-ms -1" .err("-1 is not in 0..=3600000");
        R11_WHOLE "plan --steps 1.5" .err("1.5 is not a whole number in 1..=65535");
        R11_WHOLE "plan --foci -1" .err("-1 is not in 1..=32");
        R11_WHOLE "wiring --channels-per-board 1e3"
            .err("1e3 is not a whole number in 1..=64");
        R11_WHOLE "study check {dir}/study/mini.toml --seed -1" .err("-1 is not in 0..=2^64-1");
        R11_WHOLE "status --port {port}" .env("LMHOST_TIMEOUT_MS", "-5")
            .err("-5 is not in 1..=60000 (the value of $LMHOST_TIMEOUT_MS");
        // 2. A message lists a few of many and counts the rest.
        R11_LISTS "study report {dir}/r11/many" .err("no participant folder")
            .err("skipped d1, d10, d100, d101, d102, d103, d104, d105, … and 292 more (the first: ")
            .check(short_line);
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
    ]
}
