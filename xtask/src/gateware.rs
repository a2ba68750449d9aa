//! The transducer-driver gateware: the exact SPI frames `lm-fw-core` sends
//! for a planned LM-M sequence (its `spi_frames` test writes them to
//! `target/gateware/frames.bin`), the Amaranth simulation tests in a
//! virtual environment of their own (pure Python), then the full-width
//! chain under Verilator.

use std::path::Path;
use std::process::Command;

use crate::ctx::Ctx;
use crate::proc::{Log, run};
use crate::setup;

/// Transducers of the paper's rig (`scenes/paper.toml`) and the channels
/// of one driver board in the full-width run (the HX8K breakout board's
/// 64: 15 boards of 64 and one of 36, as `cargo xtask bitstream --all`).
const FULL_WIDTH: (&str, &str) = ("996", "64");

/// The venv the gateware steps (and `cargo xtask bitstream`) use.
pub fn venv(c: &Ctx, log: &Log) -> Result<std::path::PathBuf, String> {
    setup::venv(c, log, "gw-venv", &["amaranth>=0.5,<0.6"])
}

/// How the step is run.
#[derive(Debug, Clone, Copy)]
pub struct Mode {
    /// The CI's host build is done: run its `spi_frames` executable (a
    /// cargo call of its own would select other packages, unify other
    /// features and compile the core again).
    pub host_built: bool,
    /// The full-width chain under Verilator too.
    pub full_width: bool,
}

pub fn step(c: &Ctx, log: &Log, mode: Mode) -> Result<(), String> {
    let out = c.target_dir.join("gateware");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let frames = out.join("frames.bin");
    let _ = std::fs::remove_file(&frames);
    let mut frames_test = spi_frames(c, mode)?;
    run(log, frames_test.env("LM_GW_FRAMES_OUT", &frames))?;
    let python = venv(c, log)?;
    run(
        log,
        Command::new(&python)
            .current_dir(c.root.join("gateware"))
            .arg("sim_lmdriver.py")
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .env("LM_GW_OUT", &out),
    )?;
    if mode.full_width {
        full_width(c, log, &python, &out)
    } else {
        log.line(
            "full width under Verilator: with `cargo xtask gateware` or `cargo xtask ci --full`",
        );
        Ok(())
    }
}

/// The core's `spi_frames` test: the CI build's executable, or through
/// cargo.
fn spi_frames(c: &Ctx, mode: Mode) -> Result<Command, String> {
    if mode.host_built {
        crate::host::test_command(c, "lm-fw-core/spi_frames")
    } else {
        Ok(c.cargo(&[
            "test",
            "-q",
            "-p",
            "lm-fw-core",
            "--test",
            "spi_frames",
            "--",
        ]))
    }
}

/// The whole chain at full width: `lmhost plan` (the paper's LM-M on the
/// paper's scene) → lm-fw-core (`spi_frames`' full-width test) → the SPI
/// bytes → the driver as Verilog (Yosys) on the 16 boards of the array
/// under Verilator (one module per distinct channel count, instantiated
/// per board with its slice) → every edge of every channel against the
/// plan (`gateware/full_width.py`).
fn full_width(c: &Ctx, log: &Log, python: &Path, out: &Path) -> Result<(), String> {
    setup::ensure_apt(
        log,
        &[
            ("yosys", "/usr/bin/yosys"),
            ("verilator", "/usr/bin/verilator"),
        ],
    )?;
    let lmhost = if c.lmhost_for_tests().exists() {
        c.lmhost_for_tests()
    } else {
        run(log, c.cargo(&["build", "-q", "-p", "lmhost-cli"]))?;
        c.lmhost()
    };
    let phases = out.join("lmm-paper.bin");
    run(
        log,
        Command::new(lmhost)
            .current_dir(&c.root)
            .args([
                "plan",
                "--scene",
                "scenes/paper.toml",
                "--radius",
                "3",
                "--foci",
                "4",
                "--out",
            ])
            .arg(&phases),
    )?;
    let frames = out.join("frames-full.bin");
    let _ = std::fs::remove_file(&frames);
    run(
        log,
        spi_frames(
            c,
            Mode {
                host_built: false,
                full_width: true,
            },
        )?
        .args(["--ignored", "full_width"])
        .env("LM_GW_PHASES", &phases)
        .env("LM_GW_CHANNELS", FULL_WIDTH.0)
        .env("LM_GW_FRAMES_OUT", &frames),
    )?;
    run(
        log,
        Command::new(python)
            .current_dir(c.root.join("gateware"))
            .arg("full_width.py")
            .arg(&frames)
            .args(["--total", FULL_WIDTH.0, "--board", FULL_WIDTH.1, "--work"])
            .arg(out.join("verilator"))
            .env("PYTHONDONTWRITEBYTECODE", "1"),
    )
}
