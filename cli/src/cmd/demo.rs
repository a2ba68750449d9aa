//! `lmhost demo`: the whole loop on a device in a few seconds ([`lmhost::lab::demo`]):
//! the simulated LM device by default, or an AUTD3 with `--port`.

use anyhow::Context as _;

use lmhost::clock::Spread;
use lmhost::lab::demo::{Finger, Options, Report, SimDevice, SimLink};
use lmhost::plan::target::Target;
use lmhost::sense::stream::filter::FilterKind;

/// Run the end-to-end demo on the simulated device (or an AUTD3).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Seconds of streamed finger, 1..=600 (it leaves for the middle fifth).
    #[arg(long, value_name = "S", default_value_t = 4.0)]
    seconds: f64,
    /// Centroid filter.
    #[arg(long, value_parser = super::args::filter(), default_value_t = FilterKind::Kalman)]
    filter: FilterKind,
    /// How the host reaches the simulated device: `pty` (the serial path
    /// any tool uses) or `socket` (a socket pair: no tty layer, lowest
    /// latency).
    #[arg(long, value_enum, default_value_t = LinkArg::Pty)]
    link: LinkArg,
    /// Also simulate the stimulus's acoustic field and write the maps
    /// (PNG, .npy, JSON) to DIR, as `lmhost simulate` does.
    #[arg(long, value_name = "DIR", conflicts_with = "json")]
    plots: Option<std::path::PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// Where the finger comes from: ready-made `centroids` (a synthetic
    /// track) or `depth` (synthetic 848 × 480 depth frames tracked by the
    /// paper's contact-area centroid, as `lmhost track` does).
    #[arg(long, value_enum, default_value_t = TrackingArg::Centroids)]
    tracking: TrackingArg,
    /// Run on an AUTD3 rig instead of the simulated LM device:
    /// `autd3:emulator` (autd3's firmware emulator, in this process) or a
    /// real rig (`autd3:soem[:IF]`, `autd3:ethercrab[:IF]`,
    /// `autd3:remote:HOST:PORT`).
    #[arg(long, value_name = "PORT", conflicts_with = "link")]
    port: Option<String>,
}

/// The demo's finger source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum TrackingArg {
    /// A synthetic centroid track.
    Centroids,
    /// Synthetic depth frames, tracked.
    Depth,
}

/// Link to the demo's simulated device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum LinkArg {
    /// A pseudo-terminal, opened as a serial port.
    Pty,
    /// A Unix socket pair.
    Socket,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        if !(self.seconds.is_finite() && (1.0..=600.0).contains(&self.seconds)) {
            lmhost::bad_input!(
                "--seconds {} must be between 1 and 600",
                lmhost::limits::show(self.seconds)
            );
        }
        // The plots' folder is made first: a path that cannot be one is
        // refused before the demo runs, not after it.
        let _made = match &self.plots {
            Some(dir) => Some(lmhost::files::output_dir("--plots", dir)?),
            None => None,
        };
        let opts = Options {
            seconds: self.seconds,
            filter: self.filter,
            finger: match self.tracking {
                TrackingArg::Centroids => Finger::Centroids,
                TrackingArg::Depth => Finger::Depth,
            },
        };
        let report = match &self.port {
            Some(p) => {
                if !lmhost::device::autd3::Autd3Port::is_autd3(p) {
                    lmhost::bad_input!(
                        "demo --port takes an AUTD3 port (autd3:emulator, ...); without it the \
                         demo starts its own simulated LM device"
                    );
                }
                lmhost::device::autd3::Autd3Port::parse(p)?;
                let target = Target::Autd3;
                let port = lmhost::device::link::PortSpec::new(Some(p.clone()));
                lmhost::stop::graceful();
                let mut dev =
                    lmhost::device::connect::open(&port, &lmhost::plan::scene::Scene::default())?;
                lmhost::lab::demo::run(dev.as_mut(), &target, None, opts)?
            }
            None => {
                let link = match self.link {
                    LinkArg::Pty => SimLink::Pty,
                    LinkArg::Socket => SimLink::Socket,
                };
                let (sim, mut dev) = SimDevice::start(link)?;
                let report = lmhost::lab::demo::run(dev.as_mut(), &Target::Lm, Some(&sim), opts);
                drop(dev);
                sim.stop()?;
                report?
            }
        };
        if self.json {
            return lmhost::outln!("{}", serde_json::to_string(&report)?);
        }
        print_text(&report)?;
        match &self.plots {
            Some(dir) => {
                lmhost::outln!("field      simulating LM-M into {}:", dir.display())?;
                let text = lmhost::lab::demo::write_field(dir).context("simulating the field")?;
                lmhost::outln!("{text}")?;
                lmhost::outln!("wrote {}", dir.display())
            }
            None => lmhost::outln!(
                "field      maps: `lmhost demo --plots DIR` (or `lmhost simulate --foci 4 --out DIR`)"
            ),
        }
    }
}

fn print_text(r: &Report) -> anyhow::Result<()> {
    let via = match (r.link, r.realtime_priority) {
        (Some(l), Some(rt)) => format!(
            " (a thread of this process over a {}, {})",
            if l == SimLink::Pty {
                "pty"
            } else {
                "socket pair"
            },
            if rt {
                "real-time priority"
            } else {
                "normal priority: expect more jitter"
            }
        ),
        _ => String::new(),
    };
    lmhost::outln!("lmhost demo: {}{via}", r.device)?;
    let t = &r.timing;
    let grid = if t.divide.is_some() {
        " on the 25 µs grid"
    } else {
        ""
    };
    lmhost::outln!(
        "stimulus   {}: {} steps × {} transducers, dwell {:.0} µs{grid}, {:.3} Hz ({:+.3} Hz), step {:.4} mm ({:+.4} mm)",
        r.stimulus,
        t.steps,
        r.transducers,
        t.dwell_us,
        t.freq_hz,
        t.freq_error_hz,
        t.step_mm,
        t.step_error_mm
    )?;
    let u = &r.upload;
    let bytes = match u.transfer.wire() {
        Some(w) => format!(
            "{} B raw → {} B delta, {} B on the wire ({:.1} % efficient), ",
            w.raw_bytes,
            w.sequence_bytes,
            w.wire_bytes_sent + w.wire_bytes_received,
            w.wire_efficiency() * 100.0
        ),
        None => u
            .transfer
            .frames()
            .map_or(String::new(), |f| format!("GainSTM in {f} frames, ")),
    };
    let readback = r
        .readback_mismatches
        .map_or("not available".into(), |n| format!("{n} mismatches"));
    lmhost::outln!(
        "upload     {bytes}{:.0} ms; read-back {readback}; slot {}",
        u.seconds * 1e3,
        u.slot
    )?;
    if let Some(p) = &r.playback {
        lmhost::outln!(
            "steps      {} played: mean dwell {:.1} µs (planned {:.1}), {} missed deadlines, p99 lateness {}",
            p.steps_played,
            p.mean_dwell_us,
            t.dwell_us,
            p.missed_deadlines,
            p.step_late_us
                .map_or("n/a".into(), |s| format!("{} µs", s.p99))
        )?;
    }
    let c = &r.centroids;
    let us = |v: &u64| format!("{v} µs");
    lmhost::outln!(
        "centroids  {} sent at 90 fps ({} filter), {} applied; acked {}",
        c.sent,
        c.filter,
        c.applied,
        Spread::describe_or(c.correction_latency_us.as_ref(), us)
    )?;
    if let (Some(t), Some(l)) = (c.target_us, &c.latency_us) {
        lmhost::outln!(
            "           to the applying step {} (target ≤ dwell + 1 ms = {t:.0} µs)",
            l.describe(us)
        )?;
    }
    let m = &r.muting;
    let ms = |x: Option<f64>| x.map_or("n/a".to_owned(), |v| format!("{v:.1} ms"));
    // Only the built-in simulated device keeps the times of its mute
    // changes; elsewhere say so rather than print a bare n/a.
    let untimed = if r.playback.is_none() {
        " (only the simulated device times these)"
    } else {
        ""
    };
    lmhost::outln!(
        "muting     finger left → muted after {}; back → sounding after {}{untimed}; every status while away: {} ({}); left silent",
        ms(m.mute_after_leave_ms),
        ms(m.resume_after_return_ms),
        if m.muted_in_every_status_while_away {
            "Muted"
        } else {
            "NOT muted"
        },
        m.mute_reason_while_away.map_or("n/a", |r| r.describe())
    )?;
    if let Some(t) = &r.tracking {
        lmhost::outln!(
            "tracking   depth frames 848×480 → contact-area centroid: error {:.3} mm RMS vs truth, presence wrong on {} steady frames; track {} per frame; the {} filter's lag {:.1} ms",
            t.centroid_error_rms_mm,
            t.presence_wrong_frames,
            Spread::describe_or(t.track_us.as_ref(), |v| format!("{v:.0} µs")),
            c.filter,
            t.filter_lag_ms
        )?;
    }
    Ok(())
}
