//! One module per `lmhost` subcommand, each an `Args` struct with `run`.

use clap::Subcommand;
use serde::Serialize;

use args::DeviceArgs;
use lmhost::device::backend::Backend;

pub mod args;
pub mod bench;
pub mod calibrate;
pub mod demo;
pub mod doctor;
pub mod flash;
pub mod gauge;
pub mod info;
pub mod opening;
pub mod plan;
pub mod play;
#[cfg(test)]
mod requires;
pub mod scene;
pub mod selftest;
pub mod session;
pub mod sim;
pub mod simulate;
pub mod stage;
pub mod status;
pub mod stop;
pub mod stream;
pub mod study;
pub mod track;
pub mod upload;
pub mod whole;
pub mod wiring;

/// `cmd` with every flag's value allowed to be a negative number, in
/// every subcommand: `--hold -1` is then refused as the value it is
/// (the flag's range, named), not as an unknown flag `-1`.
pub fn negative_numbers_are_values(cmd: clap::Command) -> clap::Command {
    every_arg(cmd, |a| {
        if a.get_action().takes_values() && !a.is_positional() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
}

/// Every number flag (an `f64`) read exactly: a literal that underflows
/// (`--radius 1e-400` reads as 0) is refused as `1e400` is
/// ([`lmhost::limits::exact_literal`]), not handed on as another value.
/// Set on every subcommand's `f64` flags at once, as
/// [`negative_numbers_are_values`] does; none has a parser of its own.
pub fn exact_floats(cmd: clap::Command) -> clap::Command {
    every_arg(cmd, |a| {
        if a.get_value_parser().type_id() == std::any::TypeId::of::<f64>() {
            a.value_parser(exact_f64)
        } else {
            a
        }
    })
}

/// `cmd` with `f` applied to each of its arguments and to each argument
/// of every subcommand, at every depth.
fn every_arg(cmd: clap::Command, f: fn(clap::Arg) -> clap::Arg) -> clap::Command {
    let cmd = cmd.mut_args(f);
    let subs: Vec<String> = cmd
        .get_subcommands()
        .map(|s| s.get_name().to_owned())
        .collect();
    subs.iter()
        .fold(cmd, |c, name| c.mut_subcommand(name, |s| every_arg(s, f)))
}

/// clap's own `f64` parse, and [`lmhost::limits::exact_literal`]; a value
/// that is no number says so in words (Rust's "invalid float literal"
/// named neither the value nor what to give).
fn exact_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| lmhost::limits::not_a_number(s))?;
    lmhost::limits::exact_literal(s, v)?;
    Ok(v)
}

/// Every `lmhost` subcommand.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Plan an LM stimulus: trajectory, phases, encodings.
    Plan(plan::Args),
    /// Show a scene or export its transducers.
    Scene(scene::Args),
    /// Which driver-board header pin drives which transducer (CSV).
    Wiring(wiring::Args),
    /// Check the rig: what is connected, and what to do about what is not.
    Doctor(doctor::Args),
    /// Simulate a stimulus's acoustic field and plot it.
    Simulate(simulate::Args),
    /// Time and check the numeric paths; print the bench report.
    Bench(bench::Args),
    /// Run the simulated device on a pty (prints its path).
    Sim(sim::Args),
    /// Show what the device is and what it can hold.
    Info(QueryArgs),
    /// Show what the device is doing and its error counters.
    Status(QueryArgs),
    /// Plan a stimulus, upload it, commit it and play it.
    Upload(upload::Args),
    /// Play a committed slot.
    Play(play::Args),
    /// Stop playing (mutes at once).
    Stop(stop::Args),
    /// Run the board's SPI loopback self-test (a jumper from MOSI to MISO).
    Selftest(selftest::Args),
    /// Simulated device, LM-M upload, streamed finger, short report.
    Demo(demo::Args),
    /// Stream finger centroids to the device.
    Stream(stream::Args),
    /// Flash the firmware onto a board with a debug probe.
    Flash(flash::Args),
    /// Hold the device for a study: preload a stimulus library, present on
    /// command (a control socket), log what played.
    Session(session::Args),
    /// Run a study protocol on the rig session, or summarise its answers.
    #[command(subcommand)]
    Study(study::Args),
    /// Track the finger in depth frames (contact-area centroid), optionally
    /// streaming it to the device.
    Track(track::Args),
    /// Calibrate the rig (camera pose, force) into its scene file.
    #[command(subcommand)]
    Calibrate(calibrate::Args),
    /// Read a force gauge (IMADA, Mark-10) or its simulated twin.
    #[command(subcommand)]
    Gauge(gauge::Args),
    /// Drive a motorised stage (Chuo Seiki QT) or its simulated twin.
    #[command(subcommand)]
    Stage(stage::Args),
}

impl Command {
    /// Run the chosen subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        match self {
            Command::Plan(a) => a.run(),
            Command::Scene(a) => a.run(),
            Command::Wiring(a) => a.run(),
            Command::Doctor(a) => a.run(),
            Command::Simulate(a) => a.run(),
            Command::Bench(a) => a.run(),
            Command::Sim(a) => a.run(),
            Command::Info(a) => info::run(&a),
            Command::Status(a) => status::run(&a),
            Command::Upload(a) => a.run(),
            Command::Play(a) => a.run(),
            Command::Stop(a) => a.run(),
            Command::Selftest(a) => a.run(),
            Command::Demo(a) => a.run(),
            Command::Stream(a) => a.run(),
            Command::Flash(a) => a.run(),
            Command::Track(a) => a.run(),
            Command::Session(a) => a.run(),
            Command::Study(a) => a.run(),
            Command::Calibrate(a) => a.run(),
            Command::Gauge(a) => a.run(),
            Command::Stage(a) => a.run(),
        }
    }
}

/// Arguments of a command that asks the device one thing and prints the
/// answer (`info`, `status`).
#[derive(Debug, clap::Args)]
pub struct QueryArgs {
    #[command(flatten)]
    device: DeviceArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

impl QueryArgs {
    /// Opens the device; returns it and what it is (for messages).
    fn open(&self) -> anyhow::Result<(Box<dyn Backend>, String)> {
        let dev = self.device.open()?;
        let where_ = dev.describe();
        Ok((dev, where_))
    }

    /// The host lease `--lease` asks for, ms.
    fn lease_ms(&self) -> u16 {
        self.device.lease_ms()
    }

    /// Prints `v` as one line of JSON with `--json`, else with `text`.
    fn print<T: Serialize>(
        &self,
        v: &T,
        text: impl FnOnce(&T) -> anyhow::Result<()>,
    ) -> anyhow::Result<()> {
        if self.json {
            lmhost::outln!("{}", serde_json::to_string(v)?)
        } else {
            text(v)
        }
    }
}
