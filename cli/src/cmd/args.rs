//! Flag parsers the subcommands share: library enums offered as clap
//! values without the library knowing clap.

use std::path::{Path, PathBuf};

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};

use lmhost::device::backend::Backend;
use lmhost::device::link::PortSpec;
use lmhost::plan::scene::Scene;
use lmhost::sense::stream::filter::FilterKind;

/// Port flags shared by every command that talks to a device.
#[derive(Debug, Clone, clap::Args)]
pub struct PortArgs {
    /// Serial port or pty path, `tcp:HOST:PORT`, or an AUTD3 rig
    /// (`autd3:emulator`, `autd3:soem[:IFNAME]`, `autd3:ethercrab[:IFNAME]`,
    /// `autd3:remote:HOST:PORT`) [default: $LMHOST_PORT, else the one LM
    /// board found by USB id].
    #[arg(long, value_name = "PATH")]
    pub port: Option<String>,
    /// LM firmware: baud rate for real serial ports (ptys ignore it), above
    /// 0 [default: 115200].
    #[arg(long, value_name = "BAUD", value_parser = super::whole::whole::<u32>(1, u32::MAX.into()))]
    pub baud: Option<u32>,
    /// LM firmware: response timeout per attempt, ms, 1..=60000 [default:
    /// $LMHOST_TIMEOUT_MS (set for every device, so an AUTD3 port, which
    /// refuses the flag, leaves it be), else 100 + twice the time a full
    /// chunk takes at --baud; a slow link or an emulated board on a busy
    /// machine wants more].
    #[arg(long, value_name = "MS", env = "LMHOST_TIMEOUT_MS", value_parser = super::whole::whole::<u64>(1, lmhost::limits::MAX_TIMEOUT_MS))]
    pub timeout_ms: Option<u64>,
    /// LM firmware: attempts per request before giving up, 1..=100
    /// [default: 8].
    #[arg(long, value_name = "N", value_parser = super::whole::whole::<u32>(1, lmhost::limits::MAX_TRIES.into()))]
    pub tries: Option<u32>,
    /// LM firmware: the host lease, 0.1 to 60 s. What lmhost plays stops
    /// by itself this long after the device last heard from it (lmhost
    /// renews it every quarter lease while it holds the port), so the
    /// array falls silent when lmhost dies [default: 1].
    #[arg(long, value_name = "S", value_parser = lease_ms, allow_negative_numbers = true)]
    pub lease: Option<u16>,
}

/// `--lease S` as milliseconds, within the device's bounds.
fn lease_ms(s: &str) -> Result<u16, String> {
    let (lo, hi) = (*lm_proto::LEASE_MS.start(), *lm_proto::LEASE_MS.end());
    let bad = || {
        format!(
            "{s} is not a lease: {} to {} s (there is no \"forever\")",
            f64::from(lo) / 1000.0,
            f64::from(hi) / 1000.0
        )
    };
    let secs: f64 = s.trim().parse().map_err(|_| bad())?;
    let ms = (secs * 1000.0).round();
    if !(f64::from(lo)..=f64::from(hi)).contains(&ms) {
        return Err(bad());
    }
    Ok(ms as u16)
}

impl PortArgs {
    /// The library's port description.
    pub fn spec(&self) -> PortSpec {
        PortSpec {
            port: self.port.clone(),
            baud: self.baud,
            timeout_ms: self.timeout_ms,
            tries: self.tries,
            lease_ms: self.lease,
        }
    }
}

/// The device a command talks to: its port and, for AUTD3 ports, the
/// scene whose devices the rig has (`info`, `status`, `play`, `stop`).
#[derive(Debug, clap::Args)]
pub struct DeviceArgs {
    #[command(flatten)]
    port: PortArgs,
    /// AUTD3 ports: scene file whose devices the rig has [default: the
    /// built-in array].
    #[arg(long, value_name = "FILE")]
    scene: Option<std::path::PathBuf>,
}

impl DeviceArgs {
    /// The host lease `--lease` asks for, ms.
    pub fn lease_ms(&self) -> u16 {
        self.port.lease.unwrap_or(lm_proto::DEFAULT_LEASE_MS)
    }

    /// Refuses `--lease` for `command`, which plays nothing: the lease is
    /// what a play carries, so it would be dropped without a word.
    pub fn plays_nothing(&self, command: &str) -> Result<(), lmhost::InputError> {
        match self.port.lease {
            Some(_) => Err(lmhost::InputError::new(format!(
                "--lease applies to what lmhost plays; `lmhost {command}` plays nothing"
            ))),
            None => Ok(()),
        }
    }

    /// Loads the scene and opens the device ([`lmhost::device::connect::open`]).
    /// A scene is refused for the LM firmware, which holds the array it
    /// was given with its upload and would not read it.
    pub fn open(&self) -> anyhow::Result<Box<dyn Backend>> {
        let spec = self.port.spec();
        let scene = Scene::load_or_default(self.scene.as_deref())?;
        if self.scene.is_some() && spec.device()? == lmhost::device::connect::DeviceKind::Lm {
            lmhost::bad_input!(
                "--scene applies to an AUTD3 port, whose devices it names; the LM firmware takes its array with each upload"
            );
        }
        lmhost::device::connect::open(&spec, &scene)
    }
}

/// `--filter`: one of [`FilterKind::ALL`] by name, with each one's help.
pub fn filter() -> impl TypedValueParser<Value = FilterKind> {
    PossibleValuesParser::new(
        FilterKind::ALL.map(|k| PossibleValue::new(k.name()).help(k.describe())),
    )
    .map(|name: String| {
        FilterKind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .unwrap_or(FilterKind::Kalman)
    })
}

/// The finger source flags `session` and `study run` share: a synthetic
/// finger, the finger tracked in depth frames (a recording, the camera, an
/// LMDEPTH1 stream), or its centroids (a file, stdin, UDP).
#[derive(Debug, Clone, clap::Args)]
pub struct FingerArgs {
    /// A synthetic finger resting at the scene's centre.
    #[arg(long, conflicts_with_all = ["stream", "udp", "depth", "camera", "depth_stream"])]
    pub synthetic: bool,
    /// The finger tracked in recorded depth frames (`.npy`, uint16,
    /// frames × height × width; intrinsics and time stamps beside it),
    /// replayed at their recorded speed; needs --scene with [camera] and
    /// [tracking].
    #[arg(long, value_name = "FILE.npy", conflicts_with_all = ["stream", "udp", "camera", "depth_stream"])]
    pub depth: Option<PathBuf>,
    /// The finger tracked live from a RealSense camera (needs --scene).
    #[arg(long, conflicts_with_all = ["stream", "udp", "depth_stream"])]
    pub camera: bool,
    /// The finger tracked in an LMDEPTH1 depth stream from FILE, `-` for
    /// stdin (the camera bridge's output; needs --scene).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["stream", "udp"])]
    pub depth_stream: Option<PathBuf>,
    /// Camera intrinsics (TOML) for --depth [default: beside it].
    #[arg(long, value_name = "FILE")]
    pub intrinsics: Option<PathBuf>,
    /// Time stamps for --depth [default: beside it, else 90 fps].
    #[arg(long, value_name = "FILE")]
    pub timestamps: Option<PathBuf>,
    /// Finger centroids as JSON or CSV lines from FILE, replayed at their
    /// time stamps, or `-` for stdin, as they come (the formats `lmhost
    /// stream` reads, `lmhost track --json` lines included).
    #[arg(long, value_name = "FILE", conflicts_with = "udp")]
    pub stream: Option<PathBuf>,
    /// Finger centroids as UDP datagrams on 127.0.0.1:PORT (1..=65535).
    #[arg(long, value_name = "PORT", value_parser = super::whole::whole::<u16>(1, u16::MAX.into()))]
    pub udp: Option<u16>,
    /// What the UDP source counted (datagrams, bad ones, ones the kernel
    /// dropped), for the line at the end.
    #[arg(skip)]
    pub udp_counts: std::sync::Arc<lmhost::sense::stream::source::UdpCounts>,
    /// What the plausibility gate read and dropped of a tracked or
    /// streamed finger, for the line at the end.
    #[arg(skip)]
    pub gate_counts: std::sync::Arc<lmhost::sense::stream::intake::SharedCounts>,
    /// Centroid filter for the tracked finger or its centroids (not the
    /// synthetic finger, which rests still) [default: kalman].
    #[arg(long, value_parser = filter())]
    pub filter: Option<FilterKind>,
}

/// What the finger flags give.
pub enum FingerFeed {
    /// No finger source.
    None,
    /// The synthetic finger.
    Synthetic,
    /// Samples on a reader thread, the plausibility gate they pass (its
    /// state boxed: the gate is large beside the other variants), and
    /// what they come from (for records).
    Samples(
        lmhost::sense::stream::run::Threaded,
        Box<lmhost::sense::stream::intake::Intake>,
        String,
    ),
}

impl FingerArgs {
    /// With `--udp`, what its source counted, as a line for the end of a
    /// session or study: skipped and lost datagrams are samples the
    /// finger never gave.
    pub fn udp_summary(&self) -> Option<String> {
        use std::sync::atomic::Ordering::Relaxed;
        let port = self.udp?;
        let c = &self.udp_counts;
        Some(format!(
            "lmhost: UDP 127.0.0.1:{port}: {}, {} skipped as bad, {} lost in the kernel's receive buffer",
            lmhost::out::count(c.datagrams.load(Relaxed), "datagram"),
            c.bad_datagrams.load(Relaxed),
            c.lost().map_or("uncounted".to_owned(), |n| n.to_string())
        ))
    }

    /// With a tracked or streamed finger, what the plausibility gate read
    /// and dropped, as a line for the end of a session or study.
    pub fn gate_summary(&self) -> Option<String> {
        self.samples()
            .then(|| format!("lmhost: {}", self.gate_counts.summary()))
    }

    /// The source's end lines (UDP, plausibility gate) for a session or
    /// study that ended with `result`: whatever ended it (success, a
    /// failure, an interrupt), except bad input, which is one line alone.
    pub fn print_end_lines<T>(&self, result: &anyhow::Result<T>) {
        let bad_input = result
            .as_ref()
            .err()
            .is_some_and(|e| e.chain().any(|c| c.is::<lmhost::InputError>()));
        if bad_input {
            return;
        }
        for line in [self.udp_summary(), self.gate_summary()]
            .into_iter()
            .flatten()
        {
            lmhost::errln!("{line}");
        }
    }

    /// Whether a source reads stdin.
    pub fn reads_stdin(&self) -> bool {
        [&self.stream, &self.depth_stream]
            .iter()
            .any(|s| s.as_ref().is_some_and(|p| p.as_os_str() == "-"))
    }

    /// Whether the finger is tracked in depth frames (needs a scene).
    pub fn tracked(&self) -> bool {
        self.depth.is_some() || self.camera || self.depth_stream.is_some()
    }

    /// Whether any source is given.
    pub fn any(&self) -> bool {
        self.synthetic || self.samples()
    }

    /// Whether a source gives finger samples, which the filter smooths.
    fn samples(&self) -> bool {
        self.tracked() || self.stream.is_some() || self.udp.is_some()
    }

    /// The centroid filter: `--filter`, else the Kalman filter.
    pub fn filter(&self) -> FilterKind {
        self.filter.unwrap_or(FilterKind::Kalman)
    }

    /// Checks the flags against each other and `scene`, and opens (so
    /// remembers as inputs) every file the source will read: the depth
    /// recording and its intrinsics and time stamps, given or beside it,
    /// and a centroid or depth stream file. Before any output is created.
    pub fn check(&self, scene: Option<&Path>) -> anyhow::Result<()> {
        use lmhost::files::open_input;
        use lmhost::sense::track::source::{intrinsics_beside, timestamps_beside};
        if (self.intrinsics.is_some() || self.timestamps.is_some()) && self.depth.is_none() {
            lmhost::bad_input!("--intrinsics and --timestamps apply to --depth only");
        }
        if self.filter.is_some() && !self.samples() {
            lmhost::bad_input!(
                "--filter applies to a finger tracked or streamed (--depth, --camera, --depth-stream, --stream, --udp)"
            );
        }
        if self.tracked() && scene.is_none() {
            lmhost::bad_input!(
                "--scene is needed with --depth, --camera and --depth-stream: its [camera] and [tracking] place the box"
            );
        }
        if let Some(d) = &self.depth {
            open_input("--depth recording", d)?;
            match &self.intrinsics {
                Some(i) => drop(open_input("--intrinsics", i)?),
                None => {
                    let i = intrinsics_beside(d);
                    if !i.exists() {
                        lmhost::bad_input!(
                            "--intrinsics is needed (no {} beside the recording)",
                            i.display()
                        );
                    }
                    open_input("--depth recording's intrinsics", &i)?;
                }
            }
            match &self.timestamps {
                Some(t) => drop(open_input("--timestamps", t)?),
                None => {
                    let t = timestamps_beside(d);
                    if t.exists() {
                        open_input("--depth recording's time stamps", &t)?;
                    }
                }
            }
        }
        for (flag, what, p) in [
            ("--stream", "--stream file", &self.stream),
            ("--depth-stream", "--depth-stream file", &self.depth_stream),
        ] {
            if let Some(p) = p.as_deref().filter(|p| p.as_os_str() != "-") {
                lmhost::files::not_a_pipe(what, flag, p)?;
                open_input(what, p)?;
            }
        }
        Ok(())
    }

    /// Starts the source (its reader thread) on `scene`.
    pub fn start(&self, scene: Option<&Path>) -> anyhow::Result<FingerFeed> {
        use lmhost::sense::stream::intake::{Intake, Timing};
        use lmhost::sense::stream::run::on_thread;
        use lmhost::sense::stream::source;
        use lmhost::sense::track::run::{Options, Source};
        // Every source of samples passes the one gate, counted for the end
        // line; a recording (depth frames, centroids) by its time stamps
        // alone, as `lmhost track` and `lmhost stream` replay it.
        let intake = |timing| Box::new(Intake::new(timing, self.gate_counts.clone()));
        if self.tracked() {
            let source = match (&self.depth, &self.depth_stream) {
                (Some(depth), _) => Source::Recorded {
                    depth: depth.clone(),
                    timestamps: self.timestamps.clone(),
                    intrinsics: self.intrinsics.clone(),
                },
                (None, Some(path)) => Source::Stream {
                    path: path.clone(),
                    intrinsics: None,
                },
                (None, None) => Source::Camera { intrinsics: None },
            };
            // The session filters the samples itself.
            let opts = Options {
                scene: scene.map(Path::to_path_buf),
                filter: Some(FilterKind::None),
                ..Options::new(source)
            };
            let name = match (&self.depth, &self.depth_stream) {
                (Some(d), _) => format!("depth:{}", d.display()),
                (None, Some(s)) => format!("depth-stream:{}", s.display()),
                (None, None) => "camera".to_owned(),
            };
            let feed = on_thread(move || {
                let it: Box<dyn Iterator<Item = anyhow::Result<lmhost::sense::stream::Sample>>> =
                    match lmhost::sense::track::run::TrackRun::open(opts) {
                        Ok(s) => Box::new(s.samples()),
                        Err(e) => Box::new(std::iter::once(Err(e))),
                    };
                it
            })?;
            let timing = if self.depth.is_some() {
                Timing::Replay
            } else {
                Timing::Live
            };
            return Ok(FingerFeed::Samples(feed, intake(timing), name));
        }
        if self.synthetic {
            return Ok(FingerFeed::Synthetic);
        }
        if let Some(port) = self.udp {
            let max = lmhost::limits::MAX_SECONDS;
            let idle = lmhost::limits::duration_s("--udp idle time", max, max)?;
            let udp = source::udp(port, idle, self.udp_counts.clone())?;
            return Ok(FingerFeed::Samples(
                on_thread(move || udp)?,
                intake(Timing::Live),
                format!("udp:{port}"),
            ));
        }
        let Some(p) = &self.stream else {
            return Ok(FingerFeed::None);
        };
        let name = format!("stream:{}", p.display());
        Ok(if p.as_os_str() == "-" {
            FingerFeed::Samples(
                on_thread(|| source::read_lines(std::io::stdin().lock()))?,
                intake(Timing::Live),
                name,
            )
        } else {
            // A recording plays at its time stamps, as in `lmhost stream`.
            let samples = source::replay_file("--stream", p)?;
            FingerFeed::Samples(
                on_thread(move || source::paced(samples, lmhost::clock::Clock::real()))?,
                intake(Timing::Replay),
                name,
            )
        })
    }
}

/// `--view ADDR`: a port (on 127.0.0.1, local only) or HOST:PORT.
pub fn view_addr(s: &str) -> Result<std::net::SocketAddr, String> {
    if let Ok(port) = s.parse::<u16>() {
        return Ok(std::net::SocketAddr::from(([127, 0, 0, 1], port)));
    }
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) {
        return Err(format!(
            "port {s} is out of range: give 0..=65535 (0: any free port)"
        ));
    }
    s.parse()
        .map_err(|_| format!("`{s}` is neither a port nor HOST:PORT (e.g. 8000 or 127.0.0.1:8000)"))
}
