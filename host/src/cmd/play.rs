//! `lmhost play`: play a committed slot.

use anyhow::Context as _;
use lm_proto::PlayAt;

use super::args::DeviceArgs;
use crate::cmd::upload::{UNTRACKED_WARNING, play_outcome};

/// Play a slot that holds a committed sequence.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    device: DeviceArgs,
    /// Slot to play (checked against the device's slot count).
    #[arg(long, default_value_t = 0)]
    slot: u8,
    /// Switch at once instead of at the end of the current cycle.
    #[arg(long)]
    immediate: bool,
    /// Play without tracking: the device sounds without a finger (no
    /// gating, no correction) until `lmhost stop`.
    #[arg(long)]
    untracked: bool,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let mut dev = self.device.open()?;
        let at = if self.immediate {
            PlayAt::Immediate
        } else {
            PlayAt::NextCycle
        };
        dev.play_at(self.slot, at, self.untracked)?;
        let st = dev.status().context("reading the device status")?;
        if self.untracked {
            lmhost::errln!("{UNTRACKED_WARNING}");
        }
        lmhost::outln!("{}", play_outcome(self.slot, &st))?;
        Ok(())
    }
}
