//! Paths and the `cargo` every task runs.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The thumb target every firmware crate builds for.
pub const THUMB: &str = "thumbv7em-none-eabihf";
/// Package name of the QEMU board crate.
pub const QEMU_PKG: &str = "lm-fw-qemu";
/// Package (and binary) name of the Nucleo-H743 board crate.
pub const NUCLEO_PKG: &str = "lm-fw-nucleo-h743";
/// Binary that runs the on-target tests under QEMU.
pub const SELFTEST_BIN: &str = "lm-fw-qemu-selftest";

/// Lints every host and firmware crate is built with in CI: clippy's
/// default set, undocumented `unsafe`, and every warning an error.
const CLIPPY_DENY: [&str; 4] = ["-D", "warnings", "-D", "clippy::undocumented_unsafe_blocks"];

/// Paths shared by the tasks.
pub struct Ctx {
    /// The workspace root.
    pub root: PathBuf,
    /// The one target dir every step builds into.
    pub target_dir: PathBuf,
    /// Build the workspace's crates through clippy (the CI does: one
    /// compilation both builds and lints them, see [`Ctx::cargo`]).
    pub lint: bool,
}

impl Ctx {
    pub fn new() -> Ctx {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("xtask lives one level below the workspace root")
            .to_path_buf();
        let target_dir = match std::env::var_os("CARGO_TARGET_DIR") {
            Some(d) if Path::new(&d).is_absolute() => PathBuf::from(d),
            Some(d) => root.join(d),
            None => root.join("target"),
        };
        Ctx {
            root,
            target_dir,
            lint: false,
        }
    }

    /// `cargo` as invoked by the user (the alias sets `CARGO`). With
    /// [`Ctx::lint`], the workspace's own crates are compiled by
    /// clippy-driver (`RUSTC_WORKSPACE_WRAPPER`, as `cargo clippy` does
    /// internally) with warnings denied, so one build both compiles and
    /// lints them; dependencies are compiled by rustc as always and are
    /// shared with a plain build. Every cargo call of a CI run carries the
    /// same wrapper, so none of them rebuilds another's work.
    pub fn cargo(&self, args: &[&str]) -> Command {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(&self.root).args(args);
        if let Some(driver) = self.lint.then(clippy_driver).flatten() {
            cmd.env("RUSTC_WORKSPACE_WRAPPER", driver)
                // clippy-driver's own argument channel (cargo-clippy joins
                // its `-- ARGS` this way).
                .env(
                    "CLIPPY_ARGS",
                    CLIPPY_DENY.join("__CLIPPY_HACKERY__") + "__CLIPPY_HACKERY__",
                );
        }
        cmd
    }

    pub fn thumb_release_dir(&self) -> PathBuf {
        self.target_dir.join(THUMB).join("release")
    }

    pub fn firmware_elf(&self) -> PathBuf {
        self.thumb_release_dir().join(QEMU_PKG)
    }

    pub fn selftest_elf(&self) -> PathBuf {
        self.thumb_release_dir().join(SELFTEST_BIN)
    }

    pub fn nucleo_elf(&self) -> PathBuf {
        self.thumb_release_dir().join(NUCLEO_PKG)
    }

    /// The `lmhost` binary the debug build leaves.
    pub fn lmhost(&self) -> PathBuf {
        self.target_dir.join("debug").join("lmhost")
    }

    /// A copy of [`Ctx::lmhost`] taken right after the host build, which the
    /// tests run: a later build with other features (the EtherCAT step)
    /// replaces `target/debug/lmhost` while tests still use it.
    pub fn lmhost_for_tests(&self) -> PathBuf {
        self.target_dir.join("ci").join("lmhost")
    }

    /// Where the CI keeps its logs and lists.
    pub fn ci_dir(&self) -> PathBuf {
        self.target_dir.join("ci")
    }
}

/// The toolchain's clippy-driver, next to its rustc.
pub fn clippy_driver() -> Option<PathBuf> {
    let out = Command::new("rustup")
        .args(["which", "clippy-driver"])
        .output()
        .ok()?;
    let p = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    (out.status.success() && p.is_file()).then_some(p)
}
