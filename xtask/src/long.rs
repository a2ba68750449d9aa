//! The long randomised runs (`#[ignore]`d tests): on the everyday CI the
//! debug build's test executables at a tenth of their size or less
//! (`LM_LONG_SCALE`), proportionate to a run a developer waits for; with
//! `--full` in release at their whole size, as a scheduled run would.

use crate::ctx::Ctx;
use crate::proc::{Log, run};

/// (package, cargo test target args, test filter, name of the executable
/// in `tests.json`, the share of its full size the everyday CI runs).
/// `lmhost`'s `long_random` tests are the planner's accuracy run and the
/// fuzz run over every reader of user input (`host/src/lab/tests/`).
/// The planner's accuracy run is the slowest per case in a debug build
/// (the f64 reference beside every fast frame): a smaller share of it
/// keeps the step about as long as the others.
const RUNS: &[(&str, &[&str], &str, &str, &str)] = &[
    ("lm-proto", &["--test", "fuzz"], "", "lm-proto/fuzz", "0.1"),
    (
        "lm-fw-core",
        &["--test", "robustness"],
        "",
        "lm-fw-core/robustness",
        "0.1",
    ),
    ("lmhost", &["--lib"], "long_random", "lmhost/lmhost", "0.03"),
    (
        "lm-e2e",
        &["--test", "fault_upload"],
        "",
        "lm-e2e/fault_upload",
        "0.1",
    ),
    (
        "lm-e2e",
        &["--test", "stream_soak"],
        "",
        "lm-e2e/stream_soak",
        "0.1",
    ),
];
/// The proto fuzzer's full size (`LM_PROTO_FUZZ_CASES`).
const FUZZ_CASES: u64 = 1_000_000;

pub fn step(c: &Ctx, log: &Log, full: bool) -> Result<(), String> {
    for (pkg, target, filter, name, scale) in RUNS {
        if full {
            let mut args = vec!["test", "--release", "-p", pkg];
            args.extend_from_slice(target);
            args.extend_from_slice(&["--", "--ignored", filter]);
            run(log, c.cargo(&args))?;
            continue;
        }
        let cases = (FUZZ_CASES as f64 * scale.parse::<f64>().unwrap_or(1.0)) as u64;
        let mut cmd = crate::host::test_command(c, name)?;
        cmd.args(["--ignored", "--nocapture"])
            .env("LM_LONG_SCALE", scale)
            .env("LM_PROTO_FUZZ_CASES", cases.to_string());
        if !filter.is_empty() {
            cmd.arg(filter);
        }
        run(log, &mut cmd)?;
    }
    Ok(())
}
