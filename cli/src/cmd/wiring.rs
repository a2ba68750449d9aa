//! `lmhost wiring`: which driver-board header pin drives which transducer.

use std::path::PathBuf;

use lmhost::device::wiring::{self, MAX_CHANNELS_PER_BOARD};
use lmhost::plan::scene::Scene;

/// Print (or write) the channel → board → header pin → transducer map of a
/// scene: one CSV line per frame channel, the rig builder's wiring list
/// (firmware/DRIVER.md).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file (TOML) [default: four AUTD3 in a flat 2×2 facing +z].
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Channels per iCE40-HX8K driver board; the last board takes the
    /// remainder, as `cargo xtask bitstream --all` builds them.
    #[arg(long, value_name = "N", default_value_t = MAX_CHANNELS_PER_BOARD, value_parser = super::whole::whole::<usize>(1, MAX_CHANNELS_PER_BOARD as u64))]
    pub channels_per_board: usize,
    /// Print JSON (one object per channel) instead of CSV.
    #[arg(long)]
    pub json: bool,
    /// Write to FILE (whole or not at all) instead of stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

impl Args {
    /// Maps and prints.
    pub fn run(self) -> anyhow::Result<()> {
        let scene = Scene::load_or_default(self.scene.as_deref())?;
        if let Some(out) = &self.out {
            lmhost::files::not_an_input("--out", out)?;
        }
        let map = wiring::map(&scene, self.channels_per_board)?;
        let text = if self.json {
            let mut s = serde_json::to_string(&map)?;
            s.push('\n');
            s
        } else {
            wiring::to_csv(&map)
        };
        match &self.out {
            Some(path) => lmhost::files::write_whole(path, text.as_bytes()),
            None => lmhost::out!("{text}"),
        }
    }
}
