//! The long randomised runs (`#[ignore]`d tests): on the everyday CI the
//! debug build's test executables at a tenth of their size
//! (`LM_LONG_SCALE`), proportionate to a run a developer waits for; with
//! `--full` in release at their whole size, as a scheduled run would.

use std::process::Command;

use crate::ctx::Ctx;
use crate::proc::{Log, run};

/// (package, cargo test target args, test filter, name of the executable
/// in `tests.json`, the size knob's variable and full size).
const RUNS: &[(&str, &[&str], &str, &str)] = &[
    ("lm-proto", &["--test", "fuzz"], "", "lm-proto/fuzz"),
    (
        "lm-fw-core",
        &["--test", "robustness"],
        "",
        "lm-fw-core/robustness",
    ),
    ("lmhost", &["--lib"], "long_random", "lmhost/lmhost"),
    (
        "lm-e2e",
        &["--test", "fault_upload"],
        "",
        "lm-e2e/fault_upload",
    ),
    (
        "lm-e2e",
        &["--test", "stream_soak"],
        "",
        "lm-e2e/stream_soak",
    ),
];

/// Share of the full size the everyday CI runs.
const EVERYDAY_SCALE: &str = "0.1";
/// The proto fuzzer's full size (`LM_PROTO_FUZZ_CASES`).
const FUZZ_CASES: u64 = 1_000_000;

pub fn step(c: &Ctx, log: &Log, full: bool) -> Result<(), String> {
    let bins = crate::host::test_executables(c)?;
    for (pkg, target, filter, name) in RUNS {
        if full {
            let mut args = vec!["test", "--release", "-p", pkg];
            args.extend_from_slice(target);
            args.extend_from_slice(&["--", "--ignored", filter]);
            run(log, c.cargo(&args))?;
            continue;
        }
        let (exe, dir) = bins
            .iter()
            .find(|(n, _, _)| n == name)
            .map(|(_, e, d)| (e.clone(), d.clone()))
            .ok_or_else(|| format!("no test executable {name} was built"))?;
        let cases = (FUZZ_CASES as f64 * EVERYDAY_SCALE.parse::<f64>().unwrap_or(1.0)) as u64;
        let mut cmd = Command::new(exe);
        cmd.current_dir(dir)
            .args(["--ignored", "--nocapture"])
            .env("LM_LONG_SCALE", EVERYDAY_SCALE)
            .env("LM_PROTO_FUZZ_CASES", cases.to_string())
            .env("LMHOST_BIN", c.lmhost_for_tests())
            .env("CARGO_TARGET_DIR", &c.target_dir);
        if !filter.is_empty() {
            cmd.arg(filter);
        }
        run(log, cmd)?;
    }
    Ok(())
}
