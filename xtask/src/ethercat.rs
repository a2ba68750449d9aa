//! The opt-in backends: the EtherCAT links (as root: libpcap-dev from apt,
//! CMake ≥ 3.28 for SOEM) built together with lmhost and checked without
//! an adapter and without privileges; with `--full`, `flash` (probe-rs)
//! too.

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use crate::ctx::Ctx;
use crate::proc::{Log, has_program, is_root, output_within, run};
use crate::setup;

/// Builds `lmhost-cli` with both EtherCAT links (and `flash` when `full`)
/// and runs the missing-adapter smoke test; without root, says why it
/// cannot and builds `flash` only when `full`.
pub fn step(c: &Ctx, log: &Log, full: bool) -> Result<(), String> {
    if !is_root() {
        log.line(
            "ethercat: skipped (not root: the EtherCAT build needs libpcap-dev from apt and the smoke test raw sockets)",
        );
        return if full {
            run(
                log,
                c.cargo(&["build", "-p", "lmhost-cli", "--features", "flash"]),
            )
        } else {
            Ok(())
        };
    }
    let path = ensure_ethercat_tools(c, log)?;
    let features = if full {
        "flash,autd3-soem,autd3-ethercrab"
    } else {
        "autd3-soem,autd3-ethercrab"
    };
    run(
        log,
        c.cargo(&["build", "-p", "lmhost-cli", "--features", features])
            .env("PATH", path),
    )?;
    smoke(log, &c.lmhost())?;
    // The binary with the links built in checks the machine as a rig
    // builder's would: each missing piece in one line.
    run(log, Command::new(c.lmhost()).arg("doctor"))
}

/// libpcap-dev (apt) and CMake ≥ 3.28 (Debian's or, when older, from the
/// package index into a venv under the target dir); returns the PATH for
/// the build.
fn ensure_ethercat_tools(c: &Ctx, log: &Log) -> Result<std::ffi::OsString, String> {
    setup::ensure_apt(log, &[("libpcap-dev", "/usr/include/pcap/pcap.h")])?;
    let path = std::env::var_os("PATH").unwrap_or_default();
    if cmake_at_least(Path::new("cmake"), (3, 28)) {
        log.line("cmake ≥ 3.28: installed");
        return Ok(path);
    }
    let venv = c.target_dir.join("tools-venv");
    let bin = venv.join("bin");
    if !cmake_at_least(&bin.join("cmake"), (3, 28)) {
        if !venv.join("bin").join("python").exists() {
            run(
                log,
                Command::new("python3").arg("-m").arg("venv").arg(&venv),
            )
            .map_err(|e| {
                format!(
                    "{e}\nthe EtherCAT build needs python3 with its venv module for CMake ≥ 3.28"
                )
            })?;
        }
        // SOEM's CMakeLists predate CMake 4's removal of old policies.
        run(
            log,
            Command::new(bin.join("python")).args([
                "-m",
                "pip",
                "install",
                "--disable-pip-version-check",
                "-q",
                "cmake>=3.28,<4",
            ]),
        )?;
    }
    let mut p = std::ffi::OsString::from(bin.as_os_str());
    p.push(":");
    p.push(path);
    Ok(p)
}

/// Whether `cmake --version` says at least `min`.
fn cmake_at_least(cmake: &Path, min: (u32, u32)) -> bool {
    let Ok(out) = Command::new(cmake).arg("--version").output() else {
        return false;
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let v: Vec<u32> = text
        .split_whitespace()
        .nth(2)
        .unwrap_or("")
        .split('.')
        .take(2)
        .filter_map(|x| x.parse().ok())
        .collect();
    v.len() == 2 && (v[0], v[1]) >= min
}

/// Opening each EtherCAT link without an adapter (a missing interface,
/// no AUTD3 on any) and without privileges (as `nobody`, via setpriv)
/// must fail in one line with exit 1, within a bound.
fn smoke(log: &Log, lmhost: &Path) -> Result<(), String> {
    let mut cases: Vec<(Vec<String>, &str, &str)> = Vec::new();
    for link in ["soem", "ethercrab"] {
        cases.push((
            vec![format!("autd3:{link}:lm-no-such-if0")],
            "no network interface",
            "",
        ));
        cases.push((vec![format!("autd3:{link}")], "no AUTD", ""));
    }
    let privileged = cases.len();
    if has_program("setpriv") {
        for link in ["soem", "ethercrab"] {
            cases.push((
                vec![format!("autd3:{link}")],
                "raw-socket privileges",
                "nobody",
            ));
        }
    } else {
        log.line("ethercat: setpriv missing, the unprivileged cases are skipped");
    }
    let (mut passed, mut failed) = (0, 0);
    for (i, (port, want, _)) in cases.iter().enumerate() {
        let mut cmd = if i >= privileged {
            let mut c = Command::new("setpriv");
            c.args(["--reuid=65534", "--regid=65534", "--clear-groups"])
                .arg(lmhost)
                .current_dir("/tmp");
            c
        } else {
            Command::new(lmhost)
        };
        cmd.args(["info", "--port", &port[0]])
            .env_remove("RUST_BACKTRACE");
        let who = if i >= privileged { " (as nobody)" } else { "" };
        let verdict = match output_within(cmd, Duration::from_secs(60))? {
            None => Err("did not end within 60 s".to_string()),
            Some(o) => {
                let err = String::from_utf8_lossy(&o.stderr).to_string();
                let lines = err.trim_end().lines().count();
                if o.status.code() != Some(1) {
                    Err(format!("exit {:?}, want 1: {err}", o.status.code()))
                } else if lines != 1 || !err.starts_with("error: ") {
                    Err(format!(
                        "{lines} lines on stderr, want one `error: ` line: {err}"
                    ))
                } else if !err.to_lowercase().contains(&want.to_lowercase()) {
                    Err(format!("`{}` does not say `{want}`", err.trim_end()))
                } else {
                    Ok(err.trim_end().to_string())
                }
            }
        };
        match verdict {
            Ok(line) => {
                passed += 1;
                log.line(format!("ok   {}{who}: {line}", port[0]));
            }
            Err(e) => {
                failed += 1;
                log.line(format!("FAIL {}{who}: {e}", port[0]));
            }
        }
    }
    log.line(format!("ethercat smoke: {passed} passed, {failed} failed"));
    if failed == 0 {
        Ok(())
    } else {
        Err(format!("{failed} EtherCAT smoke cases failed"))
    }
}
