//! `lmhost play`: play a committed slot.

use anyhow::Context as _;
use lm_proto::PlayAt;

use crate::cmd::upload::{UNTRACKED_WARNING, check_slot, play_outcome};
use crate::link::PortArgs;

/// Play a slot that holds a committed sequence.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    port: PortArgs,
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
        let mut client = self.port.connect()?;
        let where_ = client.transport_mut().describe();
        let info = client
            .info()
            .with_context(|| format!("asking {where_} for its info"))?;
        check_slot(self.slot, &info)?;
        let at = if self.immediate {
            PlayAt::Immediate
        } else {
            PlayAt::NextCycle
        };
        client
            .play(self.slot, at, self.untracked)
            .with_context(|| format!("playing slot {}", self.slot))?;
        let st = client.status().context("reading the device status")?;
        if self.untracked {
            eprintln!("{UNTRACKED_WARNING}");
        }
        println!("{}", play_outcome(self.slot, &st));
        Ok(())
    }
}
