//! `lmhost gauge read`: a force gauge's reading, or the median of a series
//! (bench testing the Experiment 3 gauge, or its simulated twin).

use clap::Subcommand;
use serde_json::json;

use lmhost::device::instruments::{ForceUnit, GaugeModel, GaugeOptions, gauge, open_gauge};
use lmhost::limits::Num as N;

/// Read a force gauge (IMADA ZTS/ZTA, Mark-10) or its simulated twin.
#[derive(Debug, Subcommand)]
pub enum Args {
    /// One reading in newtons, or with --for the median of a series.
    #[command(after_help = "Examples:\n  \
        lmhost gauge read --port /dev/ttyUSB0 --model imada\n  \
        lmhost gauge read --port /dev/ttyACM0 --model mark10 --for 2\n  \
        lmhost gauge read --port sim --sim-depth 2 --for 2")]
    Read(ReadArgs),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Model {
    /// IMADA ZTS/ZTA (`D` request, 19200 baud from the factory).
    Imada,
    /// Mark-10 Series 4/5/7 (`?` request, 115200 baud from the factory).
    Mark10,
}

#[derive(Debug, clap::Args)]
pub struct ReadArgs {
    /// Serial port of the gauge, or `sim` for the simulated ZTS-50N.
    #[arg(long, value_name = "PORT")]
    port: String,
    /// The gauge's protocol [default: imada]; not with `--port sim`.
    #[arg(long, value_enum)]
    model: Option<Model>,
    /// Baud rate [default: the model's factory setting]; not with `--port
    /// sim`, which has no serial link.
    #[arg(long, value_name = "BAUD", value_parser = super::whole::whole::<u32>(300, 921_600))]
    baud: Option<u32>,
    /// Sample for S seconds and print the median (the paper's 2 s).
    #[arg(long = "for", value_name = "S", allow_negative_numbers = true)]
    for_s: Option<f64>,
    /// Sampling rate with --for, Hz [default: 50]: at least one reading
    /// in --for's seconds (1 / S) and at most 1000. Without --for there is
    /// no series to sample: refused rather than ignored.
    #[arg(
        long,
        value_name = "HZ",
        requires = "for_s",
        allow_negative_numbers = true
    )]
    rate: Option<f64>,
    /// With `--port sim`: how deep the probe sits in the finger pad, mm
    /// (0 to 7: the simulated pad reaches the gauge's 50 N capacity at 7.5).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    sim_depth: Option<f64>,
    /// With `--port sim`: the noise seed [default: 1].
    #[arg(long, value_name = "N", value_parser = super::whole::whole::<u64>(0, u64::MAX))]
    seed: Option<u64>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

impl Model {
    /// The library's name for it.
    pub(super) fn model(self) -> GaugeModel {
        match self {
            Self::Imada => GaugeModel::Imada,
            Self::Mark10 => GaugeModel::Mark10,
        }
    }
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        match self {
            Self::Read(a) => a.run(),
        }
    }
}

impl ReadArgs {
    fn run(self) -> anyhow::Result<()> {
        let options = GaugeOptions {
            port: self.port.clone(),
            model: self.model.map(Model::model),
            baud: self.baud,
            sim_depth_mm: self.sim_depth,
            seed: self.seed,
            flags: "--",
        };
        let mut gauge = open_gauge(&options)?;
        let Some(for_s) = self.for_s else {
            let r = gauge.read()?;
            return if self.json {
                lmhost::outln!("{}", serde_json::to_string(&r)?)
            } else if r.unit == ForceUnit::N {
                lmhost::outln!("{:.3} N", N(r.force_n))
            } else {
                lmhost::outln!("{:.3} N ({} {} as sent)", N(r.force_n), N(r.value), r.unit)
            };
        };
        // Ctrl-C ends the series (an error saying so), not the process.
        lmhost::stop::graceful();
        let rate = self.rate.unwrap_or(gauge::DEFAULT_RATE_HZ);
        let series = gauge.sample(for_s, rate)?;
        let median = series.median_n().unwrap_or(f64::NAN);
        if self.json {
            return lmhost::outln!("{}", json!({ "median_n": median, "series": series }));
        }
        let forces = series.samples.iter().map(|r| r.force_n);
        let min = forces.clone().fold(f64::INFINITY, f64::min);
        let max = forces.fold(f64::NEG_INFINITY, f64::max);
        lmhost::outln!(
            "median {:.3} N of {} over {} s at {} Hz (min {:.3}, max {:.3} N)",
            N(median),
            lmhost::out::count(series.samples.len() as u64, "reading"),
            N(for_s),
            N(rate),
            N(min),
            N(max)
        )
    }
}
