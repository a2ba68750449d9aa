//! `lmhost stage move|position|home`: drive the Experiment 3 stage (a
//! Chuo Seiki QT controller) or its simulated twin from the bench.

use clap::Subcommand;
use serde_json::json;

use lmhost::device::instruments::stage::PAPER_SPEED_MM_S;
use lmhost::device::instruments::{Axis, SIM, StageLimits, StageOptions, StagePort, open_stage};
use lmhost::limits::Num as N;

/// Drive the push axis of a Chuo Seiki QT stage controller, or its twin.
#[derive(Debug, Subcommand)]
pub enum Args {
    /// Move to an absolute position (mm) and wait until there.
    #[command(after_help = "Examples:\n  \
        lmhost stage move --port /dev/ttyUSB0 --min 0 --max 20 --to 4\n  \
        lmhost stage move --port sim --to 10 --speed 5")]
    Move(MoveArgs),
    /// Print the position (mm).
    Position(Common),
    /// Run the controller's origin search and wait until there.
    Home(Common),
}

#[derive(Debug, clap::Args)]
pub struct Common {
    /// Serial port of the controller, or `sim` for the simulated stage.
    #[arg(long, value_name = "PORT")]
    port: String,
    /// Lower soft limit, mm (required with a serial port: your rig's).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    min: Option<f64>,
    /// Upper soft limit, mm (required with a serial port: your rig's).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    max: Option<f64>,
    /// Speed, mm/s (the paper's 5).
    #[arg(long, value_name = "MM/S", default_value_t = PAPER_SPEED_MM_S, allow_negative_numbers = true)]
    speed: f64,
    /// The controller's pushing axis: A, B or C [default: A]. The
    /// controller's settings (--axis, --step-um, --baud) do not apply to
    /// `--port sim` and are refused with it.
    #[arg(long, value_parser = parse_axis)]
    axis: Option<Axis>,
    /// Micrometres per pulse of the stage (its lead and micro-stepping)
    /// [default: 1].
    #[arg(long, value_name = "UM")]
    step_um: Option<f64>,
    /// Baud rate [default: 9600].
    #[arg(long, value_name = "BAUD", value_parser = super::whole::whole::<u32>(300, 921_600))]
    baud: Option<u32>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub(super) fn parse_axis(s: &str) -> Result<Axis, String> {
    Axis::parse(s).ok_or_else(|| format!("'{s}' is not an axis (A, B or C)"))
}

#[derive(Debug, clap::Args)]
pub struct MoveArgs {
    #[command(flatten)]
    common: Common,
    /// Target position, mm.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    to: f64,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        // Ctrl-C stops a running move (the stage is told to stop), then
        // the command ends with an error saying so.
        lmhost::stop::graceful();
        match self {
            Self::Move(a) => {
                let mut stage = a.common.open()?;
                let m = stage.move_to(a.to)?;
                if a.common.json {
                    return lmhost::outln!("{}", serde_json::to_string(&m)?);
                }
                lmhost::outln!(
                    "at {} mm (from {} mm in {:.2} s)",
                    N(m.at_mm),
                    N(m.from_mm),
                    N(m.took_s)
                )
            }
            Self::Position(c) => {
                let mut stage = c.open()?;
                let at = stage.position_mm()?;
                if c.json {
                    return lmhost::outln!("{}", json!({ "at_mm": at }));
                }
                lmhost::outln!("at {} mm", N(at))
            }
            Self::Home(c) => {
                let mut stage = c.open()?;
                let m = stage.home()?;
                if c.json {
                    return lmhost::outln!("{}", serde_json::to_string(&m)?);
                }
                lmhost::outln!(
                    "home at {} mm (from {} mm in {:.2} s)",
                    N(m.at_mm),
                    N(m.from_mm),
                    N(m.took_s)
                )
            }
        }
    }
}

impl Common {
    fn open(&self) -> anyhow::Result<Box<dyn lmhost::device::instruments::Stage>> {
        // The port first: `sim ` (a space) is no twin, and was asked for
        // a real stage's limits.
        StagePort::parse(&self.port)?;
        let limits = match (self.min, self.max) {
            (Some(lo), Some(hi)) => StageLimits::new(lo, hi)?,
            (None, None) if self.port == SIM => StageLimits::new(0.0, 50.0)?,
            _ => lmhost::bad_input!(
                "give the stage's soft limits with both --min and --max (mm); they are the rig's, never guessed"
            ),
        };
        open_stage(&StageOptions {
            port: self.port.clone(),
            limits,
            speed_mm_s: self.speed,
            axis: self.axis,
            step_um: self.step_um,
            baud: self.baud,
            flags: "--",
        })
    }
}
