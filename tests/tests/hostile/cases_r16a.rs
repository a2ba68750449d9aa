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
//!   flags too).
//! - r16a-3: flags that together ask less than each says, without a word:
//!   `simulate --plane-step 50` over the default 20 mm plane simulated
//!   and plotted one point (a step wider than the plane leaves one point
//!   across it), `--plane-size 20,10 --plane-step 15` a row; refused
//!   where the plane is checked (`field::plane`), so Python's
//!   `simulate()` meets it too.
//!
//! Fixtures in `{dir}/r16a`.

use super::*;

pub(crate) fn round16a_fixtures(dir: &Path) {
    let r = dir.join("r16a");
    std::fs::create_dir_all(&r).unwrap();
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
    // 3. A step wider than the plane it steps over.
    let plane = "error: bad observation plane: a step of";
    v.extend(table! {
        R16A_LESS "simulate --plane-step 50 --out {dir}/r16a/sim_wide"
            .err(&format!("{plane} 50 mm is wider than the plane's width of 20 mm, which it would leave one point across; give a step of at most 20 mm\n"));
        R16A_LESS "simulate --plane-size 20,10 --plane-step 15 --out {dir}/r16a/sim_row"
            .err(&format!("{plane} 15 mm is wider than the plane's height of 10 mm, which it would leave one point across; give a step of at most 10 mm\n"));
        R16A_LESS "simulate --plane-size 2,1 --plane-step 1 --out {dir}/r16a/sim_ok" .ok();
    });
    v
}

/// `case(class, args)` with `more` appended as single arguments (values
/// with spaces or commas).
fn with(class: &'static str, args: &str, more: &[&str]) -> Case {
    let mut c = case(class, args);
    c.args.extend(more.iter().map(|s| (*s).to_owned()));
    c
}
