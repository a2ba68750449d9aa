//! The Python package (and the statistics' scipy reference): a virtual environment of its own under the target
//! dir (nothing global), maturin, numpy and pytest from the package index,
//! the binding built in the workspace's target dir and dev profile (pyo3
//! and lmhost compiled once, shared with the other steps), then pytest
//! against the real `lmhost`.

use std::process::Command;

use crate::ctx::Ctx;
use crate::proc::{Log, run};
use crate::setup;

/// What the Python step installs into its venv. scipy is pinned: it wrote
/// `host/tests/stats/reference.json`, and a new one means regenerating it
/// (`scipy_reference.py write`) and reading the diff.
pub const PACKAGES: &[&str] = &["maturin>=1.5,<2", "numpy", "pytest", "scipy==1.17.1"];

pub fn step(c: &Ctx, log: &Log) -> Result<(), String> {
    let python = setup::venv(c, log, "py-venv", PACKAGES)?;
    // The statistics' reference: scipy recomputes it, and it must not differ
    // from the committed one, so the values `stats_scipy.rs` checks really
    // are scipy's.
    run(
        log,
        Command::new(&python).current_dir(&c.root).args([
            "host/tests/stats/scipy_reference.py",
            "check",
            "host/tests/stats/reference.json",
        ]),
    )?;
    let bin = python
        .parent()
        .ok_or("the venv's python has no directory")?
        .to_path_buf();
    let lmhost = if c.lmhost_for_tests().exists() {
        c.lmhost_for_tests()
    } else {
        run(log, c.cargo(&["build", "-p", "lmhost-cli"]))?;
        c.lmhost()
    };
    let path = match std::env::var_os("PATH") {
        Some(p) => {
            let mut all = vec![bin.clone()];
            all.extend(std::env::split_paths(&p));
            std::env::join_paths(all).map_err(|e| format!("PATH: {e}"))?
        }
        None => bin.clone().into_os_string(),
    };
    // maturin runs cargo: the same wrapper and variables as every other
    // build of the run, so lmhost is not compiled twice.
    let cargo_env = c.cargo(&[]);
    let mut develop = Command::new(bin.join("maturin"));
    for (k, v) in cargo_env.get_envs() {
        if let Some(v) = v {
            develop.env(k, v);
        }
    }
    run(
        log,
        develop
            .current_dir(c.root.join("python"))
            .args(["develop", "--quiet"])
            .env(
                "VIRTUAL_ENV",
                python.parent().and_then(|b| b.parent()).unwrap_or(&bin),
            )
            .env("PATH", &path)
            .env("CARGO_TARGET_DIR", &c.target_dir),
    )?;
    run(
        log,
        Command::new(&python)
            .current_dir(&c.root)
            .args([
                "-m",
                "pytest",
                "python/tests",
                "-q",
                "-p",
                "no:cacheprovider",
            ])
            .env("LMHOST_BIN", lmhost)
            .env("CARGO_TARGET_DIR", &c.target_dir),
    )
}
