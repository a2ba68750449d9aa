//! `lmhost stop`: stop playing and mute the output.

use super::args::DeviceArgs;

/// Stop playing (the output mutes at once).
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    device: DeviceArgs,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        self.device.plays_nothing("stop")?;
        let mut dev = self.device.open()?;
        dev.stop()?;
        lmhost::outln!("stopped")?;
        Ok(())
    }
}
