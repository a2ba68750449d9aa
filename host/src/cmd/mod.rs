//! One module per `lmhost` subcommand, each an `Args` struct with `run`.

use clap::Subcommand;

pub mod bench;
pub mod demo;
pub mod flash;
pub mod info;
pub mod plan;
pub mod play;
pub mod scene;
pub mod sim;
pub mod simulate;
pub mod status;
pub mod stop;
pub mod stream;
pub mod track;
pub mod upload;

/// Every `lmhost` subcommand.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Plan an LM stimulus: trajectory, phases, encodings.
    Plan(plan::Args),
    /// Show a scene or export its transducers.
    Scene(scene::Args),
    /// Simulate a stimulus's acoustic field and plot it.
    Simulate(simulate::Args),
    /// Time and check the numeric paths; print the bench report.
    Bench(bench::Args),
    /// Run the simulated device on a pty (prints its path).
    Sim(sim::Args),
    /// Show what the device is and what it can hold.
    Info(info::Args),
    /// Show what the device is doing and its error counters.
    Status(status::Args),
    /// Plan a stimulus, upload it, commit it and play it.
    Upload(upload::Args),
    /// Play a committed slot.
    Play(play::Args),
    /// Stop playing (mutes at once).
    Stop(stop::Args),
    /// Simulated device, LM-M upload, streamed finger, short report.
    Demo(demo::Args),
    /// Stream finger centroids to the device.
    Stream(stream::Args),
    /// Flash the firmware onto a board with a debug probe.
    Flash(flash::Args),
    /// Track the finger in depth frames (contact-area centroid), optionally
    /// streaming it to the device.
    Track(track::Args),
}

impl Command {
    /// Run the chosen subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        match self {
            Command::Plan(a) => a.run(),
            Command::Scene(a) => a.run(),
            Command::Simulate(a) => a.run(),
            Command::Bench(a) => a.run(),
            Command::Sim(a) => a.run(),
            Command::Info(a) => a.run(),
            Command::Status(a) => a.run(),
            Command::Upload(a) => a.run(),
            Command::Play(a) => a.run(),
            Command::Stop(a) => a.run(),
            Command::Demo(a) => a.run(),
            Command::Stream(a) => a.run(),
            Command::Flash(a) => a.run(),
            Command::Track(a) => a.run(),
        }
    }
}
