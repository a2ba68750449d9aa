//! `lmhost study`: run a study protocol on the rig session (`run`),
//! summarise its answers (`report`), check a protocol (`check`) and print
//! the protocol and library files' JSON Schemas (`schema`).

use std::path::PathBuf;

use clap::{Subcommand, ValueEnum};
use lmhost::lab::study::push::PushOptions;
use lmhost::lab::study::{self, AnswerSource, FingerSource, RunOptions};

use super::args::{FingerArgs, FingerFeed, PortArgs};

/// Arguments of `lmhost study`.
#[derive(Debug, Subcommand)]
pub enum Args {
    /// Run (or resume) one participant's session of a protocol.
    Run(Box<RunArgs>),
    /// Summarise trials.csv files: summary.csv and box plots (PNG, SVG, PDF).
    Report(ReportArgs),
    /// Check a protocol and its library and print its trial plan (counts,
    /// procedure, the order a participant gets) without a device.
    Check(CheckArgs),
    /// Print the JSON Schema of the protocol or the library file, which
    /// editors use to complete and check them.
    Schema(SchemaArgs),
}

/// Arguments of `lmhost study schema`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Editors complete and check a TOML file with its schema: Taplo and \
    Even Better TOML (VS Code) read a first line `#:schema PATH-OR-URL`, as the files in \
    studies/ have. The committed copies and their reference page are in docs/schema/.\n\n\
    Examples:\n  \
    lmhost study schema protocol > protocol.schema.json\n  \
    lmhost study schema library"
)]
pub struct SchemaArgs {
    /// Which file's schema.
    #[arg(value_enum, value_name = "FORMAT")]
    format: SchemaFormat,
}

/// A file format with a schema.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SchemaFormat {
    /// A study protocol (`study check|run PROTOCOL`).
    Protocol,
    /// A stimulus library (a protocol's `library`, `session --library`).
    Library,
}

impl SchemaArgs {
    fn run(self) -> anyhow::Result<()> {
        let format = match self.format {
            SchemaFormat::Protocol => study::schema::Format::Protocol,
            SchemaFormat::Library => study::schema::Format::Library,
        };
        lmhost::out!("{}", study::schema::to_text(&format.schema()))?;
        Ok(())
    }
}

/// Arguments of `lmhost study check`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    lmhost study check studies/paper-exp1.toml\n  \
    lmhost study check studies/paper-exp1.toml --participant 3 --seed 7")]
pub struct CheckArgs {
    /// The protocol (TOML).
    #[arg(value_name = "PROTOCOL")]
    protocol: PathBuf,
    /// Print this participant's trials (their number, from 1, as `study
    /// run --index` takes it; a protocol with a latin-square order only)
    /// [default: a Latin square's every row].
    #[arg(long, value_name = "N", value_parser = super::whole::whole::<u64>(1, study::record::MAX_INDEX as u64))]
    participant: Option<u64>,
    /// The seed of a random order, as `study run --seed` takes it.
    #[arg(long, value_name = "N", value_parser = super::whole::whole::<u64>(0, u64::MAX))]
    seed: Option<u64>,
    /// The scene, as `study run --scene` takes it: the timeline is checked
    /// against every stimulus as planned in it [default: four AUTD3 in a
    /// flat 2×2 facing +z].
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// The time scale, as `study run --time-scale` takes it: the
    /// timeline is checked as the run would play it.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    time_scale: f64,
    /// The device the study will run on, as `study run --port` opens it
    /// (`lm`: the LM firmware or the simulated device; `autd3`: an AUTD3
    /// rig): the timeline is checked as planned for it [default: for
    /// both, so a protocol is valid on either].
    #[arg(long, value_enum, value_name = "DEVICE")]
    target: Option<super::plan::TargetArg>,
}

impl CheckArgs {
    fn run(self) -> anyhow::Result<()> {
        let p = study::protocol::Protocol::load(&self.protocol)?;
        let participant = self.participant.map(|i| i as usize);
        study::outline::check_participant(&p, participant)?;
        // The rule `run` applies before the device opens, on the device
        // named (else every one it may open): a protocol called valid here
        // plays there.
        let target = self.target.map(super::plan::TargetArg::target);
        study::check_timeline(&p, self.scene.as_deref(), self.time_scale, target)?;
        let text = study::outline::outline(&p, participant, self.seed);
        lmhost::out!("{text}")?;
        Ok(())
    }
}

/// Where the finger comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Finger {
    /// No finger (protocols that do not wait for one).
    None,
    /// A finger at the scene's centre touching for each trial.
    Synthetic,
}

/// Arguments of `lmhost study run`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    lmhost study run studies/paper-exp1.toml --port autd3:emulator --participant P01 --out results --finger synthetic\n  \
    lmhost study run studies/paper-exp1.toml --port autd3:emulator --participant P01 --out results --finger synthetic --resume\n  \
    lmhost study run studies/paper-exp3.toml --port autd3:emulator --participant P01 --out results --finger synthetic --stage sim --gauge sim\n\n\
    Writes OUT/ID/trials.csv, session.json and events.jsonl.")]
pub struct RunArgs {
    /// The protocol (TOML; see studies/paper-exp1.toml).
    #[arg(value_name = "PROTOCOL")]
    protocol: PathBuf,
    #[command(flatten)]
    port: PortArgs,
    /// The participant's id (names the folder OUT/ID).
    #[arg(long, value_name = "ID")]
    participant: String,
    /// The study's output folder.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Seed of the trial order [default: from the clock; recorded].
    #[arg(long, value_name = "N", value_parser = super::whole::whole::<u64>(0, u64::MAX))]
    seed: Option<u64>,
    /// The participant's number, from 1: picks the row of a
    /// `latin-square` protocol's order (recorded).
    #[arg(long, value_name = "N", value_parser = super::whole::whole::<u64>(1, study::record::MAX_INDEX as u64))]
    index: Option<u64>,
    /// Answers, one per line in the order asked (`na`: not perceived,
    /// where a question allows it), or `-`: stdin's lines, each read as
    /// its question is asked [default: keys at the terminal].
    #[arg(long, value_name = "FILE")]
    responses: Option<PathBuf>,
    /// A simulated observer answers a [staircase]'s "perceived?" from a
    /// psychometric function, e.g.
    /// `logistic:threshold=0.5,slope=12,guess=0,lapse=0.02,seed=1`
    /// (or `weibull:...`).
    #[arg(long, value_name = "SPEC", conflicts_with_all = ["responses", "view"])]
    observer: Option<String>,
    /// The finger source: a synthetic one (as --synthetic), or none
    /// (then one of the finger flags below may give a tracked one).
    #[arg(long, value_enum, default_value_t = Finger::None)]
    finger: Finger,
    #[command(flatten)]
    source: FingerArgs,
    /// Multiplies every duration of the timeline (recorded), above 0 and at
    /// most 100; checked before the run, so that the on-phase still plays
    /// a step of every stimulus and no phase exceeds 3600 s.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    time_scale: f64,
    /// Continue OUT/ID's session at its first unfinished trial (on the
    /// same rig: scene, backend, library CRCs, time scale).
    #[arg(long)]
    resume: bool,
    /// With --resume: go on although the rig differs (what differs is
    /// recorded in session.json).
    #[arg(long, requires = "resume")]
    resume_anyway: bool,
    /// Scene file (TOML) [default: four AUTD3 in a flat 2×2 facing +z].
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Serve the live view (the finger's video with the stimulus; the
    /// participant's page answers unless --responses is given) on ADDR:
    /// a port (on 127.0.0.1) or HOST:PORT; 0 picks a free port. Its
    /// addresses, with their token, are printed.
    #[arg(long, value_name = "ADDR", value_parser = super::args::view_addr)]
    view: Option<std::net::SocketAddr>,
    #[command(flatten)]
    instruments: InstrumentArgs,
}

/// Experiment 3's stage and gauge: they go together, and every flag here
/// needs both (one group's rule, so no flag states it again).
#[derive(Debug, clap::Args)]
#[group(multiple = true, requires_all = ["stage", "gauge"])]
#[command(
    next_help_heading = "Instruments (Experiment 3: the stage pushes the gauge in step with each on-phase)"
)]
struct InstrumentArgs {
    /// The stage's controller (Chuo Seiki QT) on a serial port, or `sim`
    /// (`sim:fail-after=N`: the twin falls silent after N moves).
    #[arg(long, value_name = "PORT")]
    stage: Option<String>,
    /// The force gauge on a serial port, or `sim` (the twin, on the
    /// simulated stage's finger pad).
    #[arg(long, value_name = "PORT")]
    gauge: Option<String>,
    /// The gauge's protocol [default: imada]. The real gauge's settings
    /// (--gauge-model, --gauge-baud) do not apply to `--gauge sim`.
    #[arg(long, value_enum)]
    gauge_model: Option<super::gauge::Model>,
    /// The gauge's baud rate [default: the model's factory rate].
    #[arg(long, value_name = "BAUD", value_parser = super::whole::whole::<u32>(300, 921_600))]
    gauge_baud: Option<u32>,
    /// Stage position where the probe touches the finger pad, mm
    /// (required with a serial stage) [default with sim: 5].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    contact: Option<f64>,
    /// Stage position between pushes, mm, at most --contact [default: --contact].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    rest: Option<f64>,
    /// The stage's lower soft limit, mm (required with a serial stage) [default with sim: 0].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    stage_min: Option<f64>,
    /// The stage's upper soft limit, mm (required with a serial stage) [default with sim: 30].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    stage_max: Option<f64>,
    /// The stage's speed, mm/s (the paper's 5).
    #[arg(long, value_name = "MM/S", default_value_t = lmhost::device::instruments::stage::PAPER_SPEED_MM_S, allow_negative_numbers = true)]
    stage_speed: f64,
    /// The controller's pushing axis: A, B or C [default: A]. The
    /// controller's settings (--stage-axis, --stage-step-um, --stage-baud)
    /// do not apply to `--stage sim`.
    #[arg(long, value_parser = super::stage::parse_axis)]
    stage_axis: Option<lmhost::device::instruments::Axis>,
    /// Micrometres per pulse of the stage [default: 1].
    #[arg(long, value_name = "UM")]
    stage_step_um: Option<f64>,
    /// The stage controller's baud rate [default: 9600].
    #[arg(long, value_name = "BAUD", value_parser = super::whole::whole::<u32>(300, 921_600))]
    stage_baud: Option<u32>,
}

impl InstrumentArgs {
    fn options(&self) -> anyhow::Result<Option<PushOptions>> {
        use lmhost::device::instruments::{GaugeOptions, StageLimits, StageOptions, StagePort};
        let (Some(stage), Some(gauge)) = (&self.stage, &self.gauge) else {
            return Ok(None);
        };
        let sim = matches!(StagePort::parse(stage)?, StagePort::Sim(_));
        let limits = match (self.stage_min, self.stage_max) {
            (Some(lo), Some(hi)) => StageLimits::new(lo, hi)?,
            (None, None) if sim => StageLimits::new(0.0, 30.0)?,
            _ => lmhost::bad_input!(
                "give the stage's soft limits with both --stage-min and --stage-max (mm); they are the rig's, never guessed"
            ),
        };
        let contact_mm = match self.contact {
            Some(c) => c,
            None if sim => 5.0,
            None => lmhost::bad_input!(
                "give --contact: the stage position (mm) where the probe touches the finger pad"
            ),
        };
        lmhost::device::instruments::stage::check_speed("--stage-speed", self.stage_speed)?;
        Ok(Some(PushOptions {
            stage: StageOptions {
                port: stage.clone(),
                limits,
                speed_mm_s: self.stage_speed,
                axis: self.stage_axis,
                step_um: self.stage_step_um,
                baud: self.stage_baud,
                flags: "--stage-",
            },
            gauge: GaugeOptions {
                port: gauge.clone(),
                model: self.gauge_model.map(super::gauge::Model::model),
                baud: self.gauge_baud,
                sim_depth_mm: None,
                seed: None,
                flags: "--gauge-",
            },
            contact_mm,
            rest_mm: self.rest.unwrap_or(contact_mm),
        }))
    }
}

/// Arguments of `lmhost study report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// A participant's folder, or the study's --out folder (every
    /// participant in it).
    #[arg(value_name = "DIR")]
    dir: PathBuf,
    /// Printed width of the box plots in mm, 60..=500 (one column 88, two
    /// columns 180); text is 7.5-8 pt at that width.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = lmhost::field::plot::ONE_COLUMN_MM,
        allow_negative_numbers = true
    )]
    width_mm: f64,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        match self {
            Self::Run(a) => (*a).run(),
            Self::Report(a) => a.run(),
            Self::Check(a) => a.run(),
            Self::Schema(a) => a.run(),
        }
    }
}

impl RunArgs {
    fn finger(&self) -> anyhow::Result<FingerSource> {
        let src = &self.source;
        if self.finger == Finger::Synthetic && src.any() && !src.synthetic {
            lmhost::bad_input!(
                "--finger synthetic and a tracked finger source (--stream, --udp, --depth, --camera, --depth-stream) exclude each other"
            );
        }
        let responses_stdin = self.responses.as_ref().is_none_or(|p| p.as_os_str() == "-");
        if src.reads_stdin() && responses_stdin {
            let flag = if src.stream.is_some() {
                "--stream"
            } else {
                "--depth-stream"
            };
            lmhost::bad_input!("{flag} - reads stdin, so the answers need --responses FILE");
        }
        src.check(self.scene.as_deref())?;
        let filter = src.filter().build();
        Ok(match src.start(self.scene.as_deref())? {
            FingerFeed::Samples(feed, intake, name) => FingerSource::Samples {
                feed,
                intake,
                filter,
                name,
            },
            FingerFeed::Synthetic => FingerSource::Synthetic,
            FingerFeed::None if self.finger == Finger::Synthetic => FingerSource::Synthetic,
            FingerFeed::None => FingerSource::None,
        })
    }

    fn run(self) -> anyhow::Result<()> {
        // Graceful from the start (the finger source starts here, before
        // the study's set-up): a signal ends the run with its end lines.
        lmhost::stop::graceful();
        let finger = self.finger()?;
        // The source's counts are shared with its thread: read at the end.
        let source = self.source.clone();
        let instruments = self.instruments.options()?;
        let r = study::run(RunOptions {
            protocol: self.protocol,
            port: self.port.spec(),
            scene: self.scene,
            participant: self.participant,
            out: self.out,
            seed: self.seed,
            index: self.index.map(|i| i as usize),
            answers: match (self.responses, self.observer) {
                (Some(p), _) => AnswerSource::File(p),
                (None, Some(spec)) => AnswerSource::Observer(spec),
                (None, None) => AnswerSource::Interactive,
            },
            finger,
            time_scale: self.time_scale,
            resume: self.resume,
            resume_anyway: self.resume_anyway,
            view: self.view,
            instruments,
            hooks: Default::default(),
        });
        // The source's counts are end lines whatever ended the run.
        source.print_end_lines(&r);
        let r = r?;
        let mean = |v: &[f64]| {
            if v.is_empty() {
                0.0
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        };
        lmhost::errln!(
            "lmhost: {} of {} trials done (this run {}, from trial {}; seed {}); mean trial {:.3} s, on {:.3} s; {} uploads, mean {:.3} s; {} switches{}; files in {}",
            r.first - 1 + r.ran,
            r.trials,
            r.ran,
            r.first,
            r.seed,
            mean(&r.trial_s),
            mean(&r.presented_s),
            r.uploads,
            r.upload_mean_s,
            r.switch_ms.len(),
            if r.switch_ms.is_empty() {
                String::new()
            } else {
                format!(", mean latency {:.2} ms", mean(&r.switch_ms))
            },
            r.dir.display()
        );
        Ok(())
    }
}

impl ReportArgs {
    fn run(self) -> anyhow::Result<()> {
        let fig = lmhost::field::plot::Figure {
            width_mm: self.width_mm,
            ..lmhost::field::plot::Figure::default()
        };
        let r = study::report::report_to(&self.dir, &fig)?;
        for (d, why) in &r.skipped {
            lmhost::errln!("warning: skipped {}: {why}", d.display());
        }
        for f in &r.torn {
            lmhost::errln!(
                "warning: {} ends in a torn row (a run stopped mid-write): its whole rows are reported",
                f.display()
            );
        }
        for f in &r.files {
            lmhost::outln!("{}", f.display())?;
        }
        lmhost::errln!(
            "lmhost: {} participants, {} trials summarised{}",
            r.participants,
            r.rows,
            if r.practice > 0 {
                format!(" ({} practice trials left out)", r.practice)
            } else {
                String::new()
            }
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;
    use clap::error::ErrorKind;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        instruments: super::InstrumentArgs,
    }

    #[test]
    fn every_instrument_flag_needs_the_stage_and_the_gauge() {
        assert!(Cli::try_parse_from(["x"]).is_ok());
        for flag in [
            ["--stage", "sim"],
            ["--gauge", "sim"],
            ["--gauge-model", "mark10"],
            ["--gauge-baud", "9600"],
            ["--contact", "3"],
            ["--rest", "-1"],
            ["--stage-min", "0"],
            ["--stage-max", "9"],
            ["--stage-speed", "3"],
            ["--stage-axis", "B"],
            ["--stage-step-um", "2"],
            ["--stage-baud", "9600"],
        ] {
            let e = Cli::try_parse_from(["x", flag[0], flag[1]]).unwrap_err();
            assert_eq!(
                e.kind(),
                ErrorKind::MissingRequiredArgument,
                "{flag:?}: {e}"
            );
            let mut both = vec!["x", flag[0], flag[1]];
            for pair in [["--stage", "sim"], ["--gauge", "sim"]] {
                if pair[0] != flag[0] {
                    both.extend(pair);
                }
            }
            let ok = Cli::try_parse_from(&both);
            assert!(ok.is_ok(), "{both:?}: {}", ok.err().unwrap());
        }
    }
}
