//! One module per `lmhost` subcommand, each an `Args` struct with `run`.

use clap::Subcommand;

pub mod bench;
pub mod plan;
pub mod scene;

/// Every `lmhost` subcommand.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Plan an LM stimulus: trajectory, phases, encodings.
    Plan(plan::Args),
    /// Show a scene or export its transducers.
    Scene(scene::Args),
    /// Time and check the numeric paths; print the bench report.
    Bench(bench::Args),
}

impl Command {
    /// Run the chosen subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        match self {
            Command::Plan(a) => a.run(),
            Command::Scene(a) => a.run(),
            Command::Bench(a) => a.run(),
        }
    }
}
