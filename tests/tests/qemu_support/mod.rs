//! Shared by the QEMU end-to-end tests: find (or build) the firmware ELF and
//! launch `qemu-system-arm` (`mps2-an500`, the Cortex-M7 the STM32H743
//! has) with UART0 on a TCP port.
//!
//! The ELF comes from `LM_FW_QEMU_ELF` (set by `cargo xtask ci`, which builds
//! it first); without it it is built with
//! `cargo build --release -p lm-fw-qemu --target thumbv7em-none-eabihf` into
//! the test's own target dir.
#![allow(dead_code)]

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The firmware's target.
pub const THUMB: &str = "thumbv7em-none-eabihf";

/// Whether `qemu-system-arm` runs (tests skip, with a message, without it).
pub fn qemu_installed() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The firmware ELF: from xtask, or built here into our own target dir.
pub fn firmware_elf() -> PathBuf {
    if let Some(p) = std::env::var_os("LM_FW_QEMU_ELF") {
        let p = PathBuf::from(p);
        assert!(p.exists(), "LM_FW_QEMU_ELF={} does not exist", p.display());
        return p;
    }
    let target_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("lm-fw-qemu");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(root)
        .args([
            "build",
            "--release",
            "-p",
            "lm-fw-qemu",
            "--bin",
            "lm-fw-qemu",
            "--target",
            THUMB,
        ])
        .arg("--target-dir")
        .arg(&target_dir)
        .status()
        .expect("run cargo to build the QEMU firmware");
    assert!(
        status.success(),
        "building the QEMU firmware failed (is the {THUMB} target installed? `rustup target add {THUMB}`)"
    );
    target_dir.join(THUMB).join("release/lm-fw-qemu")
}

/// A free TCP port on 127.0.0.1: bind, read it, release it for QEMU.
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// `qemu-system-arm` running `elf` with UART0 as a TCP server on `port`.
/// With `wait`, the guest starts only once a client has connected.
/// `-icount shift=0`: virtual time is 1 ns per guest instruction, so the
/// firmware's timer follows its own work, not the host's load, and a
/// deadline is missed only if the firmware itself is too slow.
pub fn qemu_command(elf: &Path, port: u16, wait: bool) -> Command {
    qemu_command_icount(elf, port, wait, "shift=0")
}

/// [`qemu_command`] with another `-icount` setting (`shift=auto,sleep=on`:
/// the guest's clock follows the host's, for comparing device counts with
/// host times).
pub fn qemu_command_icount(elf: &Path, port: u16, wait: bool, icount: &str) -> Command {
    let wait = if wait { "on" } else { "off" };
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-M", "mps2-an500", "-display", "none", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-icount", icount])
        .arg("-serial")
        .arg(format!("tcp:127.0.0.1:{port},server=on,wait={wait}"))
        .arg("-kernel")
        .arg(elf);
    cmd
}
