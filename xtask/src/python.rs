//! The Python package (and the statistics' scipy reference): a virtual
//! environment of its own under the target dir (nothing global), maturin,
//! numpy, pytest and scipy from the package index, then pytest against the
//! real `lmhost`. The extension is the one the host build compiled beside
//! every test (one feature set, lmhost compiled once), put where `maturin
//! develop` puts it; `--full` builds it through `maturin develop` as a user
//! does.

use std::process::Command;

use crate::ctx::Ctx;
use crate::proc::{Log, run};
use crate::setup;

/// What the Python step installs into its venv. scipy is pinned: it wrote
/// `host/tests/stats/reference.json`, and a new one means regenerating it
/// (`scipy_reference.py write`) and reading the diff.
pub const PACKAGES: &[&str] = &[
    "maturin>=1.5,<2",
    "numpy",
    "pytest",
    "scipy==1.17.1",
    // python/tests/test_schema.py: the committed JSON Schemas checked by an
    // implementation that is not the one that generated them.
    "jsonschema",
];

pub fn step(c: &Ctx, log: &Log, with_maturin: bool) -> Result<(), String> {
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
    if with_maturin {
        maturin_develop(c, log, &python, &bin, &path)?;
    } else {
        install_built(c, log)?;
    }
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
            .env("PYTHONPATH", c.root.join("python"))
            .env("CARGO_TARGET_DIR", &c.target_dir),
    )
}

/// The host build's extension into the package's source folder, as
/// `maturin develop` places it (`python/lmhost/_lmhost.abi3.so`), through
/// a new file and a rename.
fn install_built(c: &Ctx, log: &Log) -> Result<(), String> {
    let built = crate::host::python_extension(c)?;
    let dest = c.root.join("python/lmhost/_lmhost.abi3.so");
    let tmp = dest.with_extension("new");
    std::fs::copy(&built, &tmp)
        .and_then(|_| std::fs::rename(&tmp, &dest))
        .map_err(|e| {
            format!(
                "cannot install {} as {}: {e}",
                built.display(),
                dest.display()
            )
        })?;
    log.line(format!(
        "installed the host build's extension as {}",
        dest.display()
    ));
    Ok(())
}

/// `maturin develop` into the venv, with the same wrapper and variables as
/// every other cargo call of the run.
fn maturin_develop(
    c: &Ctx,
    log: &Log,
    python: &std::path::Path,
    bin: &std::path::Path,
    path: &std::ffi::OsStr,
) -> Result<(), String> {
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
                python.parent().and_then(|b| b.parent()).unwrap_or(bin),
            )
            .env("PATH", path)
            .env("CARGO_TARGET_DIR", &c.target_dir),
    )
}
