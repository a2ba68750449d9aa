//! `lmhost stop`: stop playing and mute the output.

use std::path::PathBuf;

use crate::link::PortArgs;
use crate::scene::Scene;

/// Stop playing (the output mutes at once).
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    port: PortArgs,
    /// AUTD3 ports: scene file whose devices the rig has [default: the
    /// built-in array].
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let scene = Scene::load_or_default(self.scene.as_deref())?;
        let mut dev = crate::backend::open(&self.port, &scene)?;
        dev.stop()?;
        println!("stopped");
        Ok(())
    }
}
