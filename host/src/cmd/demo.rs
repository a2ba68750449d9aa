//! `lmhost demo`: the whole loop on the simulated device in a few seconds.
//!
//! Starts the simulated device on a pty, uploads the paper's LM-M stimulus
//! (A = 3 mm, 4 foci 3 mm apart, 5 Hz, 0.23 mm steps), plays it, streams a
//! synthetic finger that leaves and comes back, and reports upload size and
//! time, step timing, centroid latency and muting.

use anyhow::Context as _;
use clap::Parser as _;
use lm_proto::{DeviceState, Encoding, PlayAt};

use crate::backend::Backend;
use crate::clock::{monotonic_us, percentile};
use crate::connect::LmBackend;
use crate::link::transport::Serial;
use crate::link::{Client, UploadSpec};
use crate::simdev::{SimConfig, SimThread};
use crate::stream::filter::FilterKind;
use crate::stream::run::{Pace, stream};
use crate::stream::synthetic::FingerTrack;

/// The paper's LM-M stimulus as planner flags.
pub const LM_M_FLAGS: &[&str] = &[
    "--radius",
    "3",
    "--foci",
    "4",
    "--spacing",
    "3",
    "--freq",
    "5",
    "--step",
    "0.23",
];

/// Run the end-to-end demo on the simulated device.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Seconds of streamed finger (it leaves for the middle fifth).
    #[arg(long, value_name = "S", default_value_t = 4.0)]
    seconds: f64,
    /// Centroid filter.
    #[arg(long, value_enum, default_value_t = FilterKind::Kalman)]
    filter: FilterKind,
    /// How the host reaches the simulated device: `pty` (the serial path
    /// any tool uses) or `socket` (a socket pair: no tty layer, lowest
    /// latency).
    #[arg(long, value_enum, default_value_t = SimLink::Pty)]
    link: SimLink,
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
    #[arg(long, value_enum, default_value_t = Tracking::Centroids)]
    tracking: Tracking,
    /// Run on an AUTD3 rig instead of the simulated LM device:
    /// `autd3:emulator` (autd3's firmware emulator, in this process) or a
    /// real rig (`autd3:soem[:IF]`, `autd3:ethercrab[:IF]`,
    /// `autd3:remote:HOST:PORT`).
    #[arg(long, value_name = "PORT", conflicts_with_all = ["link", "plots", "tracking"])]
    port: Option<String>,
}

/// The demo's finger source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Tracking {
    /// A synthetic centroid track.
    Centroids,
    /// Synthetic depth frames, tracked.
    Depth,
}

#[derive(clap::Parser)]
struct SimulateOnly {
    #[command(flatten)]
    simulate: crate::cmd::simulate::Args,
}

/// Link to the demo's simulated device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SimLink {
    /// A pseudo-terminal, opened as a serial port.
    Pty,
    /// A Unix socket pair.
    Socket,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        if !(self.seconds.is_finite() && (1.0..=600.0).contains(&self.seconds)) {
            crate::bad_input!("--seconds {} must be between 1 and 600", self.seconds);
        }
        if let Some(p) = &self.port {
            if !crate::autd3::Autd3Port::is_autd3(p) {
                crate::bad_input!(
                    "demo --port takes an AUTD3 port (autd3:emulator, ...); without it the demo \
                     starts its own simulated LM device"
                );
            }
            let port = crate::autd3::Autd3Port::parse(p)?;
            return self.run_autd3(&port);
        }
        let plan = crate::sequence::Plan::paper_lm_m().context("planning LM-M")?;
        let spec = UploadSpec::from_plan(&plan, Encoding::Delta)?;
        let dwell_us = plan.sequence.dwell_us();
        let steps = spec.header.steps as u64;

        let (sim, transport): (SimThread, Box<dyn crate::link::Transport>) = match self.link {
            SimLink::Pty => {
                let sim = SimThread::start(SimConfig::default())?;
                let t = Box::new(Serial::open(&sim.path, 115_200)?);
                (sim, t)
            }
            SimLink::Socket => {
                let (sim, sock) = SimThread::start_socket(SimConfig::default())?;
                (sim, Box::new(crate::link::transport::Unix::new(sock)))
            }
        };
        let mut client = Client::new(transport);
        let info = client
            .info()
            .context("asking the simulated device for its info")?;
        spec.check_fits(&info, 0)
            .map_err(|e| anyhow::anyhow!("LM-M does not fit the simulated device: {e}"))?;
        let up = client
            .upload(&spec, 0, info.max_chunk as usize, |_, _| {})
            .context("uploading LM-M")?;
        client
            .play(0, PlayAt::NextCycle, false)
            .context("playing LM-M")?;

        let track = FingerTrack {
            center_mm: plan.scene.center_mm,
            away_s: Some((0.5 * self.seconds, 0.7 * self.seconds)),
            ..FingerTrack::default()
        };
        let realtime = crate::simdev::try_realtime();
        let s0 = client.status().context("reading status")?;
        let mut client = LmBackend::new(client, Encoding::Delta);
        let t0 = monotonic_us();
        let mut filter = self.filter.build();
        let scene = plan.scene.clone();
        let (mut left_us, mut back_us) = (None, None);
        let mut states = Vec::new();
        let mut n = 0u64;
        let mut depth = (self.tracking == Tracking::Depth)
            .then(|| crate::track::report::DepthFeed::new(&scene, self.filter, self.seconds));
        let mut pass = crate::stream::filter::Passthrough;
        let (samples, filter): (
            Box<dyn Iterator<Item = anyhow::Result<_>>>,
            &mut dyn crate::stream::filter::Filter,
        ) = match depth.as_mut() {
            Some(d) => (Box::new(d.samples()), &mut pass),
            None => (
                Box::new(track.samples().take_while(|s| s.t_s < self.seconds).map(Ok)),
                filter.as_mut(),
            ),
        };
        let report = stream(
            &mut client,
            samples,
            filter,
            |p| scene.drive_point(p),
            Pace::Timestamps,
            |c: &mut dyn Backend, s, now| {
                if !s.present && left_us.is_none() {
                    left_us = Some(now);
                }
                if s.present && left_us.is_some() && back_us.is_none() {
                    back_us = Some(now);
                }
                n += 1;
                if n.is_multiple_of(9) {
                    states.push((s.present, c.status()?.state));
                }
                Ok(())
            },
        )
        .context("streaming the synthetic finger")?;
        let s1 = client.status().context("reading status")?;
        let elapsed_us = monotonic_us() - t0;
        let stats = sim.stats();
        client.client.stop().context("stopping")?;
        drop(client);
        sim.stop()?;

        let played = (s1.cycles as u64 * steps + s1.step as u64)
            .saturating_sub(s0.cycles as u64 * steps + s0.step as u64);
        let mean_dwell_us = elapsed_us as f64 / played.max(1) as f64;
        let lat = |p| percentile(stats.latencies_us.iter().copied(), p).unwrap_or(0);
        let late_p99 = percentile(stats.step_late_us.iter().copied(), 99.0).unwrap_or(0);
        let first_change = |after: Option<u64>, muted: bool| {
            after.and_then(|a| {
                stats
                    .mute_changes
                    .iter()
                    .find(|(t, m)| *t >= a && *m == muted)
                    .map(|(t, _)| t.saturating_sub(a))
            })
        };
        let mute_ms = first_change(left_us, true).map(|us| us as f64 / 1e3);
        let resume_ms = first_change(back_us, false).map(|us| us as f64 / 1e3);
        let muted_while_away = states
            .iter()
            .filter(|(p, _)| !p)
            .all(|(_, st)| *st == DeviceState::Muted);
        let sounding_while_present = states
            .iter()
            .filter(|(p, _)| *p)
            .filter(|(_, st)| *st == DeviceState::Playing)
            .count();

        let v = serde_json::json!({
            "stimulus": "LM-M A=3 mm, 4 foci, 3 mm spacing, 5 Hz, 0.23 mm steps",
            "steps": spec.header.steps, "transducers": spec.header.transducers, "dwell_us": dwell_us,
            "upload": { "raw_bytes": up.raw_bytes, "encoded_bytes": up.sequence_bytes,
                "wire_bytes": up.wire_bytes_sent + up.wire_bytes_received,
                "wire_efficiency": up.wire_efficiency(), "seconds": up.seconds, "crc32": up.crc32 },
            "realtime_priority": realtime,
            "link": format!("{:?}", self.link).to_lowercase(),
            "steps_played": played, "mean_dwell_us": mean_dwell_us,
            "missed_deadlines": s1.missed_deadlines - s0.missed_deadlines,
            "step_late_p99_us": late_p99,
            "centroids": { "sent": report.acked, "applied": stats.centroids_applied, "filter": self.filter.name(),
                "latency_p50_us": lat(50.0), "latency_p99_us": lat(99.0), "latency_max_us": lat(100.0),
                "target_us": dwell_us + 1000.0,
                "ack_p99_us": report.ack_percentile_us(99.0) },
            "muting": { "mute_after_leave_ms": mute_ms, "resume_after_return_ms": resume_ms,
                "muted_in_every_status_while_away": muted_while_away,
                "playing_statuses_while_present": sounding_while_present },
            "tracking": depth.as_ref().map(|d| serde_json::json!({
                "source": "synthetic 848x480 depth frames", "centroid_error_rms_mm": d.rms_error_mm(),
                "presence_wrong_frames": d.presence_wrong, "track_p50_us": d.track_percentile_us(50.0),
                "track_p99_us": d.track_percentile_us(99.0), "filter_lag_ms": d.filter_lag_ms() })),
        });
        if self.json {
            crate::outln!("{v}")?;
            return Ok(());
        }
        crate::outln!(
            "lmhost demo: simulated device on {} over a {} ({})",
            sim_path_note(),
            if self.link == SimLink::Pty {
                "pty"
            } else {
                "socket pair"
            },
            if realtime {
                "real-time priority"
            } else {
                "normal priority: expect more jitter"
            }
        )?;
        crate::outln!(
            "stimulus   LM-M A = 3 mm, 4 foci 3 mm apart, 5 Hz, 0.23 mm steps: {} steps × {} transducers, dwell {:.0} µs",
            spec.header.steps,
            spec.header.transducers,
            dwell_us
        )?;
        crate::outln!(
            "upload     {} B raw → {} B delta, {} B on the wire ({:.1} % efficient) in {:.0} ms, CRC {:08x}",
            up.raw_bytes,
            up.sequence_bytes,
            up.wire_bytes_sent + up.wire_bytes_received,
            up.wire_efficiency() * 100.0,
            up.seconds * 1e3,
            up.crc32
        )?;
        crate::outln!(
            "steps      {played} played in {:.2} s: mean dwell {mean_dwell_us:.1} µs (planned {dwell_us:.1}), {} missed deadlines, p99 lateness {late_p99} µs",
            elapsed_us as f64 / 1e6,
            s1.missed_deadlines - s0.missed_deadlines
        )?;
        crate::outln!(
            "centroids  {} sent at 90 fps ({} filter), {} applied; latency to the applying step p50 {} µs, p99 {} µs, max {} µs (target ≤ dwell + 1 ms = {:.0} µs)",
            report.acked,
            self.filter.name(),
            stats.centroids_applied,
            lat(50.0),
            lat(99.0),
            lat(100.0),
            dwell_us + 1000.0
        )?;
        let fmt = |x: Option<f64>| x.map_or("n/a".to_owned(), |v| format!("{v:.1} ms"));
        crate::outln!(
            "muting     finger left → muted after {}; back → sounding after {}; every status while away: {}",
            fmt(mute_ms),
            fmt(resume_ms),
            if muted_while_away {
                "Muted"
            } else {
                "NOT muted"
            }
        )?;
        if let Some(d) = &depth {
            crate::outln!(
                "tracking   depth frames 848×480 → contact-area centroid: error {:.3} mm RMS vs truth, presence wrong on {} steady frames; track p50 {:.0} µs, p99 {:.0} µs per frame; frame → device ack p50 {} µs + the {} filter's lag {:.1} ms",
                d.rms_error_mm(),
                d.presence_wrong,
                d.track_percentile_us(50.0),
                d.track_percentile_us(99.0),
                report.ack_percentile_us(50.0).unwrap_or(0),
                self.filter.name(),
                d.filter_lag_ms()
            )?;
        }
        if let Some(dir) = &self.plots {
            let dir = dir.to_string_lossy();
            let args = std::iter::once("demo")
                .chain(LM_M_FLAGS.iter().copied())
                .chain(["--out", dir.as_ref()]);
            crate::outln!("field      simulating LM-M into {dir}:")?;
            SimulateOnly::try_parse_from(args)
                .context("building the simulate flags")?
                .simulate
                .run()
                .context("simulating the field")?;
        } else {
            crate::outln!(
                "field      maps: `lmhost demo --plots DIR` (or `lmhost simulate --foci 4 --out DIR`)"
            )?;
        }
        Ok(())
    }
}

impl Args {
    /// The demo on an AUTD3 rig: LM-M planned on the 25 µs grid, uploaded
    /// and read back, played tracked; the synthetic finger streams its
    /// centroids as phase corrections and leaves for the middle fifth.
    fn run_autd3(&self, port: &crate::autd3::Autd3Port) -> anyhow::Result<()> {
        let plan_args = crate::cmd::session::default_plan_args(None)?;
        #[derive(clap::Parser)]
        struct LmM {
            #[command(flatten)]
            plan: crate::cmd::plan::PlanArgs,
        }
        let plan_args =
            LmM::try_parse_from(std::iter::once("demo").chain(LM_M_FLAGS.iter().copied()))
                .map(|a| a.plan)
                .unwrap_or(plan_args);
        let port_args = crate::link::PortArgs {
            port: Some(port.to_string()),
            baud: 115_200,
            timeout_ms: None,
            tries: 1,
        };
        crate::stop::graceful();
        let t_up = std::time::Instant::now();
        let (mut dev, session) = crate::cmd::session::open_playing(&port_args, &plan_args)?;
        let up_s = t_up.elapsed().as_secs_f64();
        let session = session.context("an AUTD3 session uploads first")?;
        let scene = plan_args.load_scene()?;
        let track = FingerTrack {
            center_mm: scene.center_mm,
            away_s: Some((0.5 * self.seconds, 0.7 * self.seconds)),
            ..FingerTrack::default()
        };
        let mut filter = self.filter.build();
        let mut states = Vec::new();
        let mut n = 0u64;
        let report = stream(
            dev.as_mut(),
            track.samples().take_while(|s| s.t_s < self.seconds).map(Ok),
            filter.as_mut(),
            |p| scene.drive_point(p),
            Pace::Timestamps,
            |c: &mut dyn Backend, s, _now| {
                n += 1;
                if n.is_multiple_of(9) {
                    let st = c.status()?;
                    states.push((s.present, st.state, st.mute_reason));
                }
                Ok(())
            },
        )
        .context("streaming the synthetic finger")?;
        let end = dev.status().context("reading status")?;
        dev.stop().context("silencing the array")?;
        drop(dev);
        let muted_while_away = states
            .iter()
            .filter(|(p, ..)| !p)
            .all(|(_, st, _)| *st == DeviceState::Muted);
        let playing_while_present = states
            .iter()
            .filter(|(p, st, _)| *p && *st == DeviceState::Playing)
            .count();
        let away_reason = states.iter().find(|(p, ..)| !p).map(|(.., r)| *r);
        let lat = |p| report.ack_percentile_us(p).unwrap_or(0);
        let (u, g) = (&session.upload, &session.timing);
        let v = serde_json::json!({
            "port": port.to_string(),
            "stimulus": "LM-M A=3 mm, 4 foci, 3 mm spacing, 5 Hz, 0.23 mm steps",
            "steps": u.steps, "transducers": u.transducers,
            "dwell_us": u.dwell_us, "freq_hz": u.freq_hz, "step_mm": g.step_mm,
            "freq_error_hz": g.freq_error_hz, "step_error_mm": g.step_error_mm,
            "readback_mismatches": u.readback_mismatches,
            "upload": { "frames": u.frames, "seconds": up_s, "slot": u.slot },
            "centroids": { "sent": report.acked + report.outside_work_volume, "applied": report.acked,
                "filter": self.filter.name(),
                "correction_latency_p50_us": lat(50.0), "correction_latency_p99_us": lat(99.0),
                "correction_latency_max_us": lat(100.0) },
            "muting": { "muted_in_every_status_while_away": muted_while_away,
                "mute_reason_while_away": away_reason,
                "playing_statuses_while_present": playing_while_present,
                "state_at_end": end.state },
            "left_silent": true,
        });
        if self.json {
            crate::outln!("{v}")?;
            return Ok(());
        }
        crate::outln!("lmhost demo: {port} (autd3's firmware emulator when `autd3:emulator`)")?;
        crate::outln!(
            "stimulus   LM-M A = 3 mm, 4 foci 3 mm apart, asked 5 Hz, 0.23 mm steps: {} steps × {} transducers, \
             dwell {} µs on the 25 µs grid → {:.3} Hz ({:+.3} Hz), step {:.4} mm ({:+.4} mm)",
            u.steps,
            u.transducers,
            u.dwell_us,
            u.freq_hz,
            g.freq_error_hz,
            g.step_mm,
            g.step_error_mm
        )?;
        crate::outln!(
            "upload     GainSTM in {} frames, {:.0} ms with open and play; FPGA read-back: {}",
            u.frames,
            up_s * 1e3,
            u.readback_mismatches
                .map_or("not available on this link".into(), |n| format!(
                    "{n} mismatches"
                ))
        )?;
        crate::outln!(
            "centroids  {} applied as PhaseCorrection ({} filter); centroid → correction acked by the FPGA p50 {} µs, p99 {} µs, max {} µs",
            report.acked,
            self.filter.name(),
            lat(50.0),
            lat(99.0),
            lat(100.0)
        )?;
        crate::outln!(
            "muting     every status while away: {} ({}); {} statuses playing while present; left silent",
            if muted_while_away {
                "Muted"
            } else {
                "NOT muted"
            },
            away_reason.map_or("n/a", |r| r.describe()),
            playing_while_present
        )?;
        Ok(())
    }
}

fn sim_path_note() -> &'static str {
    "a thread of this process (lm-fw-core, real clock)"
}
