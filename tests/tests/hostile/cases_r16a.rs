//! Round 16a: a sweep of the command line and its files for what earlier
//! rounds missed.
//!
//! - r16a-1: a refusal's advice is one its flag can take: a FIFO given to
//!   any input said "pipe into standard input instead", `--scene`,
//!   `--library` and `--phases` too, which read no standard input; now only
//!   a flag that takes `-` says so, naming itself (`give `--input -``).
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
    v
}
