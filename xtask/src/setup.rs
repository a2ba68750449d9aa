//! What the tests need installed: the thumb target, clippy and rustfmt,
//! Debian packages (as root, all in one apt-get run), and the Python
//! virtual environments under the target dir.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::ctx::{Ctx, THUMB};
use crate::proc::{Log, has_program, is_root, run};

/// Debian packages the CI uses, with a file that shows each is there.
pub const APT: &[(&str, &str)] = &[
    ("qemu-system-arm", "/usr/bin/qemu-system-arm"),
    ("verilator", "/usr/bin/verilator"),
    ("yosys", "/usr/bin/yosys"),
    ("libpcap-dev", "/usr/include/pcap/pcap.h"),
    // The live view's browser test (tests/tests/browser.rs).
    ("chromium", "/usr/bin/chromium"),
    ("chromium-driver", "/usr/bin/chromedriver"),
];

fn thumb_target_installed() -> bool {
    let out = Command::new("rustc")
        .args(["--print", "target-libdir", "--target", THUMB])
        .output();
    match out {
        Ok(o) if o.status.success() => {
            let dir = String::from_utf8_lossy(&o.stdout).trim().to_string();
            std::fs::read_dir(&dir).is_ok_and(|mut d| d.next().is_some())
        }
        _ => false,
    }
}

pub fn ensure_thumb_target(log: &Log) -> Result<(), String> {
    if thumb_target_installed() {
        log.line(format!("thumb target {THUMB}: installed"));
        return Ok(());
    }
    run(log, Command::new("rustup").args(["target", "add", THUMB])).map_err(|e| {
        format!("{e}\nthe {THUMB} target is missing; install it with `rustup target add {THUMB}`")
    })
}

/// clippy and rustfmt, which the lints run.
pub fn ensure_components(log: &Log) -> Result<(), String> {
    for (sub, component) in [("clippy", "clippy"), ("fmt", "rustfmt")] {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let have = Command::new(cargo)
            .args([sub, "--version"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if have {
            log.line(format!("{component}: installed"));
            continue;
        }
        run(
            log,
            Command::new("rustup").args(["component", "add", component]),
        )
        .map_err(|e| {
            format!(
                "{e}\n{component} is missing; install it with `rustup component add {component}`"
            )
        })?;
    }
    Ok(())
}

/// The Debian packages of `wanted` that are missing, installed in one
/// apt-get run when root; otherwise an error naming them.
pub fn ensure_apt(log: &Log, wanted: &[(&str, &str)]) -> Result<(), String> {
    let missing: Vec<&str> = wanted
        .iter()
        .filter(|(_, file)| !Path::new(file).exists())
        .map(|(pkg, _)| *pkg)
        .collect();
    if missing.is_empty() {
        log.line(format!(
            "apt: {} installed",
            wanted.iter().map(|w| w.0).collect::<Vec<_>>().join(", ")
        ));
        return Ok(());
    }
    if !is_root() || !has_program("apt-get") {
        return Err(format!(
            "missing Debian packages: {}; this is not a root shell with apt-get: install them \
             (`sudo apt-get install -y {}`) and rerun",
            missing.join(", "),
            missing.join(" ")
        ));
    }
    let install = |log: &Log| {
        run(
            log,
            Command::new("apt-get")
                .args(["install", "-y", "--no-install-recommends"])
                .args(&missing)
                .env("DEBIAN_FRONTEND", "noninteractive"),
        )
    };
    install(log).or_else(|_| {
        run(log, Command::new("apt-get").arg("update"))?;
        install(log)
    })
}

/// A virtual environment at `target/<name>` with `packages` from the
/// package index (nothing global); returns its python.
pub fn venv(c: &Ctx, log: &Log, name: &str, packages: &[&str]) -> Result<PathBuf, String> {
    let venv = c.target_dir.join(name);
    let python = venv.join("bin").join("python");
    if !python.exists() {
        run(
            log,
            Command::new("python3").arg("-m").arg("venv").arg(&venv),
        )
        .map_err(|e| format!("{e}\nthis step needs python3 with its venv module"))?;
    }
    run(
        log,
        Command::new(&python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
            ])
            .args(packages),
    )?;
    Ok(python)
}
