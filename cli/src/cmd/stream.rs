//! `lmhost stream`: finger centroids to the device, filtered and mirrored
//! into drive coordinates, one acked update per sample.

use anyhow::Context as _;
use std::path::PathBuf;

use super::args::PortArgs;
use crate::cmd::plan::StimulusFlags;
use lmhost::clock::Spread;
use lmhost::sense::stream::filter::{FilterKind, Kalman};
use lmhost::sense::stream::metrics::score;
use lmhost::sense::stream::run::{Pace, Threaded, on_thread, stream};
use lmhost::sense::stream::source;
use lmhost::sense::stream::synthetic::FingerTrack;

/// Seconds of the synthetic track the filter table is scored over
/// (offline, whatever the session's length, so a long or stopped session
/// does not wait on it).
const FILTER_SCORE_S: f64 = 20.0;

/// `--seconds` when none is given: the synthetic finger's length, UDP's
/// idle time.
const DEFAULT_SECONDS: f64 = 10.0;

/// Stream finger centroids (mm, scene frame) to the device.
///
/// Input lines are JSON (`{"t":0.011,"x":1.2,"y":-0.4,"z":201,"present":true}`)
/// or CSV (`t,x,y,z,present`, `,`-separated with `.` decimals), from stdin,
/// a file, or UDP datagrams; `present` is `true`, `false`, `1` or `0` in
/// both (CSV's in any case; JSON's may be left out: a finger).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Limits: a line may be at most 4096 bytes; a replayed file may \
    pause at most 60 s between time stamps. Lines may end in LF, CRLF or CR and the first \
    may open with a UTF-8 byte-order mark; UTF-16 and `;`- or tab-separated CSV are refused. Samples that cannot be a finger (time stamp \
    going backwards, a coordinate beyond ±2000 mm, a jump of more than 50 mm that 3 \
    samples in a row do not confirm) are dropped and counted in the report. With --udp, \
    a bad datagram is skipped and counted; 1000 bad datagrams in a row end the session.\n\n\
    Stopping: Ctrl-C (SIGINT) or SIGTERM ends the session, mutes the device (an update \
    with present = false), prints the report and frees the port for `lmhost stop` / \
    `lmhost status`. While `stream` runs it holds the port: stop it first. What it \
    played stops when it ends (the LM firmware by itself one host lease, --lease, \
    after lmhost dies).\n\n\
    The stimulus, alike on every backend: with any stimulus flag (--radius, --foci, \
    --spacing, --freq, --step, --steps, --center, --z, --method, --iterations, --weights) \
    that stimulus is planned for the device (on AUTD3's 25 µs dwell grid), uploaded into \
    a free slot and played before streaming, with a one-line summary on stderr. With \
    none, the LM firmware plays the entry it plays or played last, tracked (what \
    `lmhost upload` put there; a presentation lasts only while its host holds it), and \
    otherwise, like an AUTD3 (which holds nothing while lmhost is away), plays \
    the default stimulus (LM-S, A = 3 mm, 5 Hz, 0.23 mm steps). --scene alone only \
    mirrors the centroids."
)]
pub struct Args {
    #[command(flatten)]
    port: PortArgs,
    /// Read samples from FILE (`-` = stdin, the default) and replay them at
    /// their time stamps.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["udp", "synthetic"])]
    input: Option<PathBuf>,
    /// Receive samples as UDP datagrams on 127.0.0.1:PORT (1..=65535).
    #[arg(long, value_name = "PORT", conflicts_with = "synthetic", value_parser = super::whole::whole::<u16>(1, u16::MAX.into()))]
    udp: Option<u16>,
    /// Stream a synthetic finger (90 fps, depth-camera-like noise) and
    /// report every filter's lag and jitter on it.
    #[arg(long)]
    synthetic: bool,
    /// Synthetic finger: seconds to stream; UDP: stop after this long idle.
    /// At most 86400 (3600 with --synthetic --fast) [default: 10]. Lines
    /// (stdin, --input) end with their input: refused there.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    seconds: Option<f64>,
    /// Synthetic finger: away from START to END seconds, e.g. `4,5` (no
    /// spaces): a window holding at least one frame, starting before
    /// --seconds (END may lie beyond: the finger does not come back).
    #[arg(long, value_name = "START,END")]
    away: Option<String>,
    /// Centroid filter.
    #[arg(long, value_parser = super::args::filter(), default_value_t = FilterKind::Kalman)]
    filter: FilterKind,
    /// Kalman filter: predict this far ahead (ms), e.g. the link latency
    /// [default: 0].
    #[arg(long, value_name = "MS")]
    lead_ms: Option<f64>,
    /// Scene file (TOML): its reflector mirrors centroids into drive
    /// coordinates, and a stimulus is planned in it [default: four AUTD3
    /// in a flat 2×2 facing +z].
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Replay files and the synthetic finger as fast as the link allows
    /// (stdin and UDP are streamed as they arrive: refused there).
    #[arg(long)]
    fast: bool,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// The stimulus played while streaming (see below: given, it is
    /// uploaded and played on every backend); last, under its help heading.
    #[command(flatten)]
    stimulus: StimulusFlags,
}

fn parse_away(s: &str) -> Result<(f64, f64), lmhost::InputError> {
    let said = |m: String| lmhost::InputError::new(format!("--away `{s}`: {m}"));
    let (a, b) = s
        .split_once(',')
        .filter(|(_, b)| !b.contains(','))
        .ok_or_else(|| said("give START,END: two times in seconds, one comma between".into()))?;
    let number = |x: &str, part: &str| {
        lmhost::limits::exact_number(x).map_err(|m| said(format!("{part} {m}")))
    };
    let (a, b) = (number(a, "START")?, number(b, "END")?);
    if !(a.is_finite() && a >= 0.0) {
        return Err(said(format!(
            "START {} s is out of range: allowed 0 or more, finite",
            lmhost::limits::show(a)
        )));
    }
    if !(b.is_finite() && b > a) {
        return Err(said(format!(
            "END {} s is out of range: allowed after START ({} s), finite",
            lmhost::limits::show(b),
            lmhost::limits::show(a)
        )));
    }
    Ok((a, b))
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let max_s = if self.synthetic && self.fast {
            lmhost::limits::MAX_FAST_SYNTHETIC_S
        } else {
            lmhost::limits::MAX_SECONDS
        };
        // A source that ends by itself (lines on stdin or in a file) has
        // no length to give, and only a recording has a pace to skip.
        let lines = !self.synthetic && self.udp.is_none();
        if self.seconds.is_some() && lines {
            lmhost::bad_input!(
                "--seconds applies to --synthetic (its length) and --udp (its idle time): lines from stdin or --input end with their input"
            );
        }
        let from_file = self.input.as_ref().is_some_and(|p| p.as_os_str() != "-");
        if self.fast && !(self.synthetic || from_file) {
            lmhost::bad_input!(
                "--fast applies to --synthetic and --input FILE: stdin and --udp are streamed as they arrive"
            );
        }
        let asked_s = self.seconds.unwrap_or(DEFAULT_SECONDS);
        let seconds = lmhost::limits::duration_s("--seconds", asked_s, max_s)?;
        let lead_ms = self.lead_ms.unwrap_or(0.0);
        if !lead_ms.is_finite() || lead_ms.abs() > 1000.0 {
            lmhost::bad_input!("--lead-ms {lead_ms} must be within ±1000");
        }
        if self.lead_ms.is_some() && self.filter != FilterKind::Kalman {
            lmhost::bad_input!("--lead-ms applies to --filter kalman only");
        }
        let away = self.away.as_deref().map(parse_away).transpose()?;
        if away.is_some() && !self.synthetic {
            lmhost::bad_input!("--away only applies to --synthetic");
        }
        let scene = lmhost::plan::scene::Scene::load_or_default(self.scene.as_deref())?;
        let stimulus = match self.stimulus.given().is_empty() {
            true => None,
            false => Some(self.stimulus.stimulus()?),
        };
        let track = FingerTrack {
            center_mm: scene.center_mm,
            away_s: away,
            ..FingerTrack::default()
        };
        track.check_away(asked_s)?;
        let mut filter: Box<dyn lmhost::sense::stream::filter::Filter + Send> = match self.filter {
            FilterKind::Kalman => Box::new(Kalman::with_lead(lead_ms / 1e3)),
            other => other.build(),
        };
        let pace = if self.fast {
            Pace::Arrival
        } else {
            Pace::Timestamps
        };
        let udp_counts = std::sync::Arc::new(source::UdpCounts::default());
        // Every source is read on its own thread, so the loop keeps the
        // device's housekeeping (the AUTD3 staleness mute) running while a
        // live source is silent.
        let (samples, pace) = if self.synthetic {
            let secs = asked_s;
            (
                on_thread(move || track.samples().take_while(move |s| s.t_s < secs).map(Ok))?,
                pace,
            )
        } else if let Some(port) = self.udp {
            let udp = source::udp(port, seconds, udp_counts.clone())?;
            (on_thread(move || udp)?, Pace::Arrival)
        } else {
            match self.input.as_deref() {
                None => (stdin_samples()?, Pace::Arrival),
                Some(p) if p.as_os_str() == "-" => (stdin_samples()?, Pace::Arrival),
                Some(p) => {
                    let samples = source::replay_file("--input", p)?;
                    (on_thread(move || samples)?, pace)
                }
            }
        };
        lmhost::stop::graceful();
        let (mut dev, session) =
            crate::cmd::opening::open_playing(&self.port.spec(), &scene, stimulus.as_ref())?;
        let where_ = dev.describe();
        let needs_host = dev.needs_host();
        let (mut absent, mut muted_absent) = (0u64, 0u64);
        let report = stream(
            dev.as_mut(),
            samples,
            filter.as_mut(),
            |p| scene.drive_point(p),
            pace,
            |dev, s, _| {
                // AUTD3: the host runs the gate, so check it as it goes.
                if needs_host && !s.present {
                    absent += 1;
                    if dev.status()?.state == lm_proto::DeviceState::Muted {
                        muted_absent += 1;
                    }
                }
                Ok(())
            },
        )
        .map_err(|e| {
            // A bad line is the user's input: say so in one line.
            if e.downcast_ref::<lmhost::InputError>().is_some() {
                e
            } else {
                e.context(format!("streaming centroids to {where_}"))
            }
        })?;
        let status = dev
            .status()
            .context("reading the device status after streaming")?;
        if needs_host {
            // AUTD3: the array plays only while lmhost holds it; leave it
            // silent (STM stopped, null gain) before letting go.
            dev.stop().context("silencing the array")?;
        }
        let bad_datagrams = udp_counts
            .bad_datagrams
            .load(std::sync::atomic::Ordering::Relaxed);
        // Datagrams the kernel dropped (its buffer full): only a UDP stream
        // has any, and `None` where the system does not count them.
        let lost = udp_counts.lost().filter(|_| self.udp.is_some());
        // The filters are scored offline on the first 20 s of the same
        // synthetic track (a property of the track, so a long session does
        // not make the report slow); not after Ctrl-C, which asks to end now.
        let scores: Vec<_> = if self.synthetic && !report.stopped {
            FilterKind::ALL
                .iter()
                .map(|k| score(*k, &track, FILTER_SCORE_S))
                .collect()
        } else {
            Vec::new()
        };
        let ack = report.ack_us();
        if self.json {
            let v = serde_json::json!({
                "samples": report.samples, "acked": report.acked, "present": report.present,
                "last_seq": report.last_seq, "device_last_seq": status.last_centroid_seq,
                "seconds": report.seconds, "filter": self.filter.name(),
                "ack_us": ack,
                "device_state": status.state, "device_correction_um": status.correction_um,
                "filters": scores,
                "rejected": report.rejected, "bad_datagrams": bad_datagrams,
                "lost_datagrams": lost,
                "outside_work_volume": report.outside_work_volume,
                "stopped": report.stopped, "stopped_by": report.stopped_by,
                "muted_at_end": report.muted_at_end,
            });
            let mut v = v;
            // What was uploaded before streaming, on every backend (null:
            // the LM firmware kept what it played).
            v["upload"] = serde_json::to_value(&session)?;
            if needs_host {
                v["mute_reason"] = serde_json::to_value(status.mute_reason)?;
                v["applied"] = report.acked.into();
                v["absent_updates"] = absent.into();
                v["muted_absent_updates"] = muted_absent.into();
            }
            lmhost::outln!("{v}")?;
            return Ok(());
        }
        lmhost::outln!(
            "streamed {} ({} with a finger) to {where_} in {:.2} s with the {} filter; device at #{} ({:?})",
            lmhost::out::count(report.samples, "sample"),
            report.present,
            report.seconds,
            self.filter.name(),
            status.last_centroid_seq,
            status.state
        )?;
        lmhost::outln!(
            "latency host receipt → device ack: {}; applied at the next step boundary (≤ one dwell later)",
            Spread::describe_or(ack.as_ref(), |us| format!("{us} µs"))
        )?;
        if let Some(s) = session.as_ref().filter(|_| needs_host) {
            lmhost::outln!(
                "{} corrections applied on {where_} (dwell {:.1} µs, {:.3} Hz, read-back {}); muted on {muted_absent} of {absent} updates without a finger; at the end: {}; left silent",
                report.acked,
                lmhost::limits::Num(s.timing.dwell_us),
                s.timing.freq_hz,
                s.transfer
                    .readback_mismatches()
                    .map_or("n/a".into(), |n| n.to_string()),
                status.mute_reason.describe()
            )?;
        }
        if let Some(n) = lost.filter(|n| *n > 0) {
            lmhost::outln!(
                "lost {n} datagrams in the kernel's receive buffer (the tracker sent faster than the stream read; samples in them never arrived)"
            )?;
        }
        let dropped = report.rejected.total();
        if dropped > 0 || bad_datagrams > 0 {
            lmhost::outln!(
                "dropped {dropped} implausible samples ({} out of order, {}, {} out of range, {} jumps); skipped {bad_datagrams} bad datagrams",
                report.rejected.out_of_order,
                lmhost::out::count(report.rejected.time_jumps, "time jump"),
                report.rejected.out_of_range,
                report.rejected.jumps
            )?;
        }
        if report.outside_work_volume > 0 {
            lmhost::outln!(
                "{} updates outside the device's work volume (muted until the finger came back; see upload --max-offset)",
                report.outside_work_volume
            )?;
        }
        if report.stopped {
            lmhost::outln!(
                "stopped by {}; device {}",
                report.stopped_by.as_deref().unwrap_or("a signal"),
                if report.muted_at_end {
                    "muted"
                } else {
                    "NOT muted (the mute update failed)"
                }
            )?;
        }
        if !scores.is_empty() {
            lmhost::outln!("filter      lag (ms)  jitter (mm)  error vs now (mm)")?;
            for s in &scores {
                lmhost::outln!(
                    "{:<10} {:>8.1} {:>12.3} {:>18.3}",
                    s.filter.name(),
                    s.lag_ms,
                    s.jitter_mm,
                    s.error_mm
                )?;
            }
        }
        Ok(())
    }
}

/// Stdin samples, read on their own thread: Ctrl-C and the device's
/// housekeeping go on while no line arrives (a blocking read cannot be
/// interrupted; the thread is left to end with the process).
fn stdin_samples() -> anyhow::Result<Threaded> {
    on_thread(|| {
        let lines = source::read_lines(std::io::stdin().lock());
        source::not_empty(lines, "standard input".to_owned())
    })
}
