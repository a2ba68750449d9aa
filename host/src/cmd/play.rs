//! `lmhost play`: play a committed slot.

use anyhow::Context as _;
use lm_proto::PlayAt;

use crate::link::PortArgs;

/// Play a slot that holds a committed sequence.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    port: PortArgs,
    /// Slot to play.
    #[arg(long, default_value_t = 0)]
    slot: u8,
    /// Switch at once instead of at the end of the current cycle.
    #[arg(long)]
    immediate: bool,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let mut client = self.port.connect()?;
        let at = if self.immediate {
            PlayAt::Immediate
        } else {
            PlayAt::NextCycle
        };
        client
            .play(self.slot, at)
            .with_context(|| format!("playing slot {}", self.slot))?;
        println!("playing slot {}", self.slot);
        Ok(())
    }
}
