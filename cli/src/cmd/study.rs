//! `lmhost study`: run a study protocol on the rig session (`run`) and
//! summarise its answers (`report`).

use std::path::PathBuf;

use clap::{Subcommand, ValueEnum};
use lmhost::lab::study::{self, AnswerSource, FingerSource, RunOptions};
use lmhost::sense::stream::filter::FilterKind;

use super::args::PortArgs;

/// Arguments of `lmhost study`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    cmd: Sub,
}

#[derive(Debug, Subcommand)]
enum Sub {
    /// Run (or resume) one participant's session of a protocol.
    Run(Box<RunArgs>),
    /// Summarise trials.csv files: summary.csv and box plots (PNG, SVG, PDF).
    Report(ReportArgs),
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
    lmhost study run studies/paper-exp1.toml --port autd3:emulator --participant P01 --out results --finger synthetic --resume\n\n\
    Writes OUT/ID/trials.csv, session.json and events.jsonl.")]
struct RunArgs {
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
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Answers, one per line in the order asked (`na`: not perceived,
    /// where a question allows it), or `-`: stdin's lines, each read as
    /// its question is asked [default: keys at the terminal].
    #[arg(long, value_name = "FILE")]
    responses: Option<PathBuf>,
    /// The finger source: a synthetic one, or none (then --stream or
    /// --udp may give tracked centroids).
    #[arg(long, value_enum, default_value_t = Finger::None)]
    finger: Finger,
    /// Tracked finger centroids as JSON or CSV lines from FILE, or `-` for
    /// stdin (`lmhost track --json` lines included).
    #[arg(long, value_name = "FILE", conflicts_with = "udp")]
    stream: Option<PathBuf>,
    /// Tracked finger centroids as UDP datagrams on 127.0.0.1:PORT.
    #[arg(long, value_name = "PORT")]
    udp: Option<u16>,
    /// Centroid filter for --stream / --udp.
    #[arg(long, value_parser = super::args::filter(), default_value_t = FilterKind::Kalman)]
    filter: FilterKind,
    /// Multiplies every duration of the timeline (recorded).
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
}

/// Arguments of `lmhost study report`.
#[derive(Debug, clap::Args)]
struct ReportArgs {
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
        match self.cmd {
            Sub::Run(a) => (*a).run(),
            Sub::Report(a) => a.run(),
        }
    }
}

impl RunArgs {
    fn finger(&self) -> anyhow::Result<FingerSource> {
        let tracked = self.stream.is_some() || self.udp.is_some();
        if tracked && self.finger == Finger::Synthetic {
            lmhost::bad_input!("--finger synthetic and --stream / --udp exclude each other");
        }
        let stdin = self.stream.as_ref().is_some_and(|p| p.as_os_str() == "-");
        let responses_stdin = self.responses.as_ref().is_none_or(|p| p.as_os_str() == "-");
        if stdin && responses_stdin {
            lmhost::bad_input!("--stream - reads stdin, so the answers need --responses FILE");
        }
        let filter = self.filter.build();
        let name = match (self.udp, &self.stream) {
            (Some(port), _) => format!("udp:{port}"),
            (None, Some(p)) => format!("stream:{}", p.display()),
            (None, None) => String::new(),
        };
        Ok(
            if let Some(feed) = super::args::centroid_feed(self.udp, self.stream.as_deref())? {
                FingerSource::Samples { feed, filter, name }
            } else if self.finger == Finger::Synthetic {
                FingerSource::Synthetic
            } else {
                FingerSource::None
            },
        )
    }

    fn run(self) -> anyhow::Result<()> {
        let finger = self.finger()?;
        let r = study::run(RunOptions {
            protocol: self.protocol,
            port: self.port.spec(),
            scene: self.scene,
            participant: self.participant,
            out: self.out,
            seed: self.seed,
            answers: match self.responses {
                Some(p) => AnswerSource::File(p),
                None => AnswerSource::Interactive,
            },
            finger,
            time_scale: self.time_scale,
            resume: self.resume,
            resume_anyway: self.resume_anyway,
            view: self.view,
        })?;
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
            "lmhost: {} participants, {} trials summarised",
            r.participants,
            r.rows
        );
        Ok(())
    }
}
