//! The lints that need no build, and rustdoc's.

use std::process::Command;

use crate::ctx::Ctx;
use crate::proc::{Log, run};

/// Formatting, the module graph and the wing order of every crate, and
/// clap only in the CLI: cheap, so they run first.
pub fn source(c: &Ctx, log: &Log) -> Result<(), String> {
    run(log, c.cargo(&["fmt", "--all", "--", "--check"]))?;
    run(
        log,
        Command::new("python3")
            .current_dir(&c.root)
            .arg("xtask/module_cycles.py"),
    )?;
    // The library and the Python package never parse a command line.
    for pkg in ["lmhost", "lmhost-py"] {
        let tree = c
            .cargo(&["tree", "-p", pkg, "-e", "normal,build", "--prefix", "none"])
            .output()
            .map_err(|e| format!("cannot run cargo tree: {e}"))?;
        if !tree.status.success() {
            return Err(format!("cargo tree -p {pkg} failed"));
        }
        if String::from_utf8_lossy(&tree.stdout)
            .lines()
            .any(|l| l.starts_with("clap "))
        {
            return Err(format!("{pkg} depends on clap: only lmhost-cli may"));
        }
    }
    log.line("clap: only in lmhost-cli");
    Ok(())
}

/// rustdoc with warnings denied (broken and private links) on the
/// libraries. Clippy needs no step of its own: the CI's builds compile the
/// workspace's crates through clippy-driver ([`Ctx::cargo`]).
pub fn doc(c: &Ctx, log: &Log) -> Result<(), String> {
    run(
        log,
        c.cargo(&[
            "doc",
            "--no-deps",
            "-p",
            "lmhost",
            "-p",
            "lm-proto",
            "-p",
            "lm-fw-core",
        ])
        .env("RUSTDOCFLAGS", "-D warnings"),
    )
}
