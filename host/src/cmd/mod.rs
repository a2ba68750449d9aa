//! One module per `lmhost` subcommand, each an `Args` struct with `run`.

use clap::Subcommand;

/// Every `lmhost` subcommand.
#[derive(Debug, Subcommand)]
pub enum Command {}

impl Command {
    /// Run the chosen subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        match self {}
    }
}
