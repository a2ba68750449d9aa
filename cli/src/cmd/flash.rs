//! `lmhost flash --board <name> [--elf FILE]`: write the firmware to a
//! board through a debug probe, with probe-rs (built-in targets, ELF
//! loader).
//!
//! probe-rs is heavy to build, so it sits behind the `flash` cargo feature
//! (`cargo install --path cli --features flash`); without it this command
//! explains how to get it. probe-rs is built without its HID (libudev)
//! backend, so no system libraries are needed either way.

use std::path::PathBuf;

/// A board `lmhost flash` knows: its probe-rs chip name and where its
/// firmware crate builds the ELF.
#[derive(Debug, Clone, Copy)]
pub struct Board {
    /// `--board` name.
    pub name: &'static str,
    /// probe-rs chip name.
    pub chip: &'static str,
    /// Default ELF, relative to the repository root.
    pub elf: &'static str,
    /// How to build that ELF.
    pub build: &'static str,
}

/// Boards with firmware in this repository.
pub const BOARDS: &[Board] = &[Board {
    name: "nucleo-h743",
    chip: "STM32H743ZITx",
    elf: "target/thumbv7em-none-eabihf/release/lm-fw-nucleo-h743",
    build: "cargo build -p lm-fw-nucleo-h743 --target thumbv7em-none-eabihf --release",
}];

/// Flash the firmware onto a board with a debug probe.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Board name (known: nucleo-h743).
    #[arg(long)]
    board: String,
    /// Firmware ELF [default: the board crate's release build].
    #[arg(long, value_name = "FILE")]
    elf: Option<PathBuf>,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let Some(board) = BOARDS.iter().find(|b| b.name == self.board) else {
            let known: Vec<_> = BOARDS.iter().map(|b| b.name).collect();
            lmhost::bad_input!(
                "unknown board `{}` (known: {})",
                self.board,
                known.join(", ")
            );
        };
        let elf = self.elf.clone().unwrap_or_else(|| PathBuf::from(board.elf));
        if !elf.is_file() {
            lmhost::bad_input!(
                "firmware ELF {} not found; build it with `{}` or pass --elf FILE",
                elf.display(),
                board.build
            );
        }
        flash(board, &elf)
    }
}

#[cfg(feature = "flash")]
fn flash(board: &Board, elf: &std::path::Path) -> anyhow::Result<()> {
    use anyhow::Context as _;
    use probe_rs::Permissions;
    use probe_rs::flashing::{ElfLoader, ElfOptions, download_file};
    use probe_rs::probe::list::Lister;

    let probes = Lister::new().list_all();
    let Some(info) = probes.first() else {
        anyhow::bail!(
            "no debug probe found: connect the board's ST-LINK by USB (and check udev permissions)"
        );
    };
    let probe = info
        .open()
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("opening probe {}", info.identifier))?;
    let mut session = probe
        .attach(board.chip, Permissions::default())
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("attaching to {} through {}", board.chip, info.identifier))?;
    download_file(&mut session, elf, ElfLoader(ElfOptions::default()))
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("flashing {}", elf.display()))?;
    session
        .core(0)
        .and_then(|mut c| c.reset())
        .map_err(|e| anyhow::anyhow!("{e}"))
        .context("resetting the board")?;
    lmhost::outln!(
        "flashed {} onto {} ({}) and reset it",
        elf.display(),
        board.name,
        board.chip
    )?;
    Ok(())
}

#[cfg(not(feature = "flash"))]
fn flash(board: &Board, _elf: &std::path::Path) -> anyhow::Result<()> {
    anyhow::bail!(
        "this lmhost was built without probe-rs; to flash {} rebuild with `cargo install --path cli --features flash` \
         (or use probe-rs's own `probe-rs download --chip {}`)",
        board.name,
        board.chip
    )
}
