//! `lmhost stop`: stop playing and mute the output.

use anyhow::Context as _;

use crate::link::PortArgs;

/// Stop playing (the output mutes at once).
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    port: PortArgs,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let mut client = self.port.connect()?;
        client.stop().context("stopping the device")?;
        println!("stopped");
        Ok(())
    }
}
