//! The demo: the paper's LM-M on a device, played tracked while a synthetic
//! finger leaves for the middle fifth and comes back, and what it measured.
//!
//! One path for every device, through [`Backend`]: the simulated LM device
//! (a thread of this process, over a pty or a socket pair; see
//! [`SimDevice`]) or an AUTD3 (autd3's emulator or a rig). The finger is a
//! synthetic centroid track, or synthetic depth frames tracked by the
//! paper's contact-area centroid ([`Finger::Depth`]). `lmhost demo` prints
//! the [`Report`].

use anyhow::Context as _;
use lm_proto::{DeviceState, Encoding, MuteReason, Status};
use serde::Serialize;

use crate::clock::{Spread, monotonic_us};
use crate::device::backend::{Backend, Transfer};
use crate::device::connect::LmBackend;
use crate::device::link::Client;
use crate::device::simdev::{SimConfig, SimStats, SimThread};
use crate::plan::scene::Scene;
use crate::plan::stimulus::{Stimulus, Timing};
use crate::plan::target::Target;
use crate::sense::stream::filter::{FilterKind, Passthrough};
use crate::sense::stream::run::{Pace, stream};
use crate::sense::stream::synthetic::FingerTrack;
use crate::sense::track::report::DepthFeed;

/// The stimulus the demo plays, in words.
pub const STIMULUS: &str = "LM-M A=3 mm, 4 foci, 3 mm spacing, 5 Hz, 0.23 mm steps";

/// Where the demo's finger comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Finger {
    /// A synthetic centroid track.
    Centroids,
    /// Synthetic 848 × 480 depth frames, tracked.
    Depth,
}

/// How the host reaches the simulated LM device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SimLink {
    /// A pseudo-terminal, opened as a serial port.
    Pty,
    /// A Unix socket pair (no tty layer).
    Socket,
}

/// What the demo runs.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Seconds of streamed finger, 1..=600.
    pub seconds: f64,
    /// Centroid filter.
    pub filter: FilterKind,
    /// The finger source.
    pub finger: Finger,
}

/// The simulated LM device the demo starts, and how it is reached.
pub struct SimDevice {
    sim: SimThread,
    link: SimLink,
    realtime: bool,
}

impl SimDevice {
    /// Starts the simulated device and opens it over `link`.
    pub fn start(link: SimLink) -> anyhow::Result<(SimDevice, Box<dyn Backend>)> {
        let (sim, client) = match link {
            SimLink::Pty => {
                let sim = SimThread::start(SimConfig::default())?;
                let t = crate::device::link::transport::Serial::open(&sim.path, 115_200)?;
                (
                    sim,
                    Client::new(Box::new(t) as Box<dyn crate::device::link::Transport>),
                )
            }
            SimLink::Socket => {
                let (sim, sock) = SimThread::start_socket(SimConfig::default())?;
                let t = crate::device::link::transport::Unix::new(sock);
                (
                    sim,
                    Client::new(Box::new(t) as Box<dyn crate::device::link::Transport>),
                )
            }
        };
        let realtime = crate::device::simdev::try_realtime();
        let dev = Box::new(LmBackend::new(client, Encoding::Delta));
        Ok((
            SimDevice {
                sim,
                link,
                realtime,
            },
            dev,
        ))
    }
}

/// What the upload took.
#[derive(Debug, Clone, Serialize)]
pub struct UploadFigures {
    /// Slot written.
    pub slot: u8,
    /// Seconds from upload to play (with the open, on AUTD3).
    pub seconds: f64,
    /// How it travelled: the LM serial link's report or the autd3 crates'
    /// counts. In the JSON the keys `frames` (autd3's emulator), and from
    /// the LM link `raw_bytes`, `encoded_bytes` (Delta), `wire_bytes` (both
    /// ways), `wire_efficiency` (payload share) and `crc32` (of the raw
    /// sequence), each `null` where this link has no such figure.
    #[serde(flatten, serialize_with = "demo_keys")]
    pub transfer: Transfer,
}

/// `UploadFigures::transfer` as the keys the demo's report always had.
fn demo_keys<S: serde::Serializer>(t: &Transfer, s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeStruct as _;
    let w = t.wire();
    let mut st = s.serialize_struct("Transfer", 6)?;
    st.serialize_field("frames", &t.frames())?;
    st.serialize_field("raw_bytes", &w.map(|w| w.raw_bytes))?;
    st.serialize_field("encoded_bytes", &w.map(|w| w.sequence_bytes))?;
    st.serialize_field(
        "wire_bytes",
        &w.map(|w| w.wire_bytes_sent + w.wire_bytes_received),
    )?;
    st.serialize_field("wire_efficiency", &w.map(|w| w.wire_efficiency()))?;
    st.serialize_field("crc32", &w.map(|w| w.crc32))?;
    st.end()
}

/// The simulated device's own clockwork (LM simulated device only).
#[derive(Debug, Clone, Serialize)]
pub struct Playback {
    /// Steps played while the finger streamed.
    pub steps_played: u64,
    /// Mean dwell over them (µs).
    pub mean_dwell_us: f64,
    /// Deadlines the player missed.
    pub missed_deadlines: u32,
    /// Step lateness (µs).
    pub step_late_us: Option<Spread<u64>>,
}

/// Centroid figures.
#[derive(Debug, Clone, Serialize)]
pub struct Centroids {
    /// Updates sent.
    pub sent: u64,
    /// Updates the device applied (simulated device: to an output frame).
    pub applied: u64,
    /// The filter.
    pub filter: &'static str,
    /// Centroid → acknowledged by the device (AUTD3: the correction
    /// written to the FPGA), µs.
    pub correction_latency_us: Option<Spread<u64>>,
    /// Centroid → the first step that used it (simulated device), µs.
    pub latency_us: Option<Spread<u64>>,
    /// The target for it: one dwell + 1 ms, µs.
    pub target_us: Option<f64>,
}

/// Muting figures.
#[derive(Debug, Clone, Serialize)]
pub struct Muting {
    /// Finger left → output muted (simulated device), ms.
    pub mute_after_leave_ms: Option<f64>,
    /// Finger back → output sounding again (simulated device), ms.
    pub resume_after_return_ms: Option<f64>,
    /// Every status sampled while the finger was away said Muted.
    pub muted_in_every_status_while_away: bool,
    /// Why, in the first status while away.
    pub mute_reason_while_away: Option<MuteReason>,
    /// Statuses that said Playing while the finger was present.
    pub playing_statuses_while_present: usize,
    /// The state after the stream.
    pub state_at_end: DeviceState,
}

/// Depth-frame tracking figures (`Finger::Depth`).
#[derive(Debug, Clone, Serialize)]
pub struct Tracking {
    /// What was tracked.
    pub source: &'static str,
    /// Centroid error vs the synthetic truth, mm RMS.
    pub centroid_error_rms_mm: f64,
    /// Frames whose presence was wrong away from transitions.
    pub presence_wrong_frames: u64,
    /// Tracking time per frame, µs.
    pub track_us: Option<Spread<f64>>,
    /// The filter's lag at 90 fps, ms.
    pub filter_lag_ms: f64,
}

/// What the demo measured (`lmhost demo --json`).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The device, as it describes itself.
    pub device: String,
    /// The simulated device's link (`pty`, `socket`).
    pub link: Option<SimLink>,
    /// Whether the simulated device's loop got real-time priority.
    pub realtime_priority: Option<bool>,
    /// [`STIMULUS`].
    pub stimulus: &'static str,
    /// Transducers.
    pub transducers: usize,
    /// Steps, dwell, frequency and step width, realised and requested.
    #[serde(flatten)]
    pub timing: Timing,
    /// Phases read back that differ from the plan (`None`: no read-back).
    pub readback_mismatches: Option<u64>,
    /// The upload.
    pub upload: UploadFigures,
    /// The simulated device's playback (`null` on other devices: an
    /// object of its own, so every backend's report has the same keys).
    pub playback: Option<Playback>,
    /// Centroids.
    pub centroids: Centroids,
    /// Muting.
    pub muting: Muting,
    /// Depth tracking (`Finger::Depth`).
    pub tracking: Option<Tracking>,
    /// The array was left silent.
    pub left_silent: bool,
}

/// Plans LM-M for `target`, uploads it to `dev`, plays it tracked, streams
/// the synthetic finger, stops, and reports; `sim` is the simulated LM
/// device when that is what `dev` is.
pub fn run(
    dev: &mut dyn Backend,
    target: &Target,
    sim: Option<&SimDevice>,
    opts: Options,
) -> anyhow::Result<Report> {
    let scene = Scene::default();
    let planned = Stimulus::paper_lm_m()
        .plan_for(target, scene.clone())
        .context("planning LM-M")?;
    let plan = &planned.plan;
    let t_up = std::time::Instant::now();
    // A read-back that differs fails the upload itself.
    let up = dev.upload(plan, None).context("uploading LM-M")?;
    dev.play(up.slot, false).context("playing LM-M")?;
    let up_s = t_up.elapsed().as_secs_f64();

    let s0 = dev.status().context("reading status")?;
    let t0 = monotonic_us();
    let (mut left_us, mut back_us) = (None, None);
    let mut states: Vec<(bool, Status)> = Vec::new();
    let mut n = 0u64;
    let mut filter = opts.filter.build();
    let mut depth =
        (opts.finger == Finger::Depth).then(|| DepthFeed::new(&scene, opts.filter, opts.seconds));
    let track = FingerTrack {
        center_mm: scene.center_mm,
        away_s: Some((0.5 * opts.seconds, 0.7 * opts.seconds)),
        ..FingerTrack::default()
    };
    let mut pass = Passthrough;
    let (samples, filter): (
        Box<dyn Iterator<Item = anyhow::Result<_>>>,
        &mut dyn crate::sense::stream::filter::Filter,
    ) = match depth.as_mut() {
        Some(d) => (Box::new(d.samples()), &mut pass),
        None => (
            Box::new(track.samples().take_while(|s| s.t_s < opts.seconds).map(Ok)),
            filter.as_mut(),
        ),
    };
    let report = stream(
        dev,
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
                states.push((s.present, c.status()?));
            }
            Ok(())
        },
    )
    .context("streaming the synthetic finger")?;
    let s1 = dev.status().context("reading status")?;
    let elapsed_us = monotonic_us() - t0;
    let stats = sim.map(|s| s.sim.stats());
    dev.stop().context("silencing the array")?;

    let away = || states.iter().filter(|(p, _)| !p);
    let dwell_us = planned.timing.dwell_us;
    Ok(Report {
        device: dev.describe(),
        link: sim.map(|s| s.link),
        realtime_priority: sim.map(|s| s.realtime),
        stimulus: STIMULUS,
        transducers: up.transducers,
        timing: planned.timing.clone(),
        readback_mismatches: up.readback_mismatches(),
        upload: UploadFigures {
            slot: up.slot,
            seconds: up.wire().map_or(up_s, |w| w.seconds),
            transfer: up.transfer,
        },
        playback: stats
            .as_ref()
            .map(|st| playback(&s0, &s1, up.steps, elapsed_us, st)),
        centroids: Centroids {
            sent: report.acked + report.outside_work_volume,
            applied: stats.as_ref().map_or(report.acked, |s| s.centroids_applied),
            filter: opts.filter.name(),
            correction_latency_us: report.ack_us(),
            latency_us: stats
                .as_ref()
                .and_then(|s| Spread::of(s.latencies_us.iter().copied())),
            target_us: sim.map(|_| dwell_us + 1000.0),
        },
        muting: Muting {
            mute_after_leave_ms: stats.as_ref().and_then(|s| first_change(s, left_us, true)),
            resume_after_return_ms: stats.as_ref().and_then(|s| first_change(s, back_us, false)),
            muted_in_every_status_while_away: away().all(|(_, st)| st.state == DeviceState::Muted),
            mute_reason_while_away: away().next().map(|(_, st)| st.mute_reason),
            playing_statuses_while_present: states
                .iter()
                .filter(|(p, st)| *p && st.state == DeviceState::Playing)
                .count(),
            state_at_end: s1.state,
        },
        tracking: depth.as_ref().map(|d| Tracking {
            source: "synthetic 848x480 depth frames",
            centroid_error_rms_mm: d.rms_error_mm(),
            presence_wrong_frames: d.presence_wrong,
            track_us: d.track_us(),
            filter_lag_ms: d.filter_lag_ms(),
        }),
        left_silent: true,
    })
}

/// Steps played between two statuses and the simulated player's timing.
fn playback(s0: &Status, s1: &Status, steps: usize, elapsed_us: u64, st: &SimStats) -> Playback {
    let at = |s: &Status| u64::from(s.cycles) * steps as u64 + u64::from(s.step);
    let played = at(s1).saturating_sub(at(s0));
    Playback {
        steps_played: played,
        mean_dwell_us: elapsed_us as f64 / played.max(1) as f64,
        missed_deadlines: s1.missed_deadlines.saturating_sub(s0.missed_deadlines),
        step_late_us: Spread::of(st.step_late_us.iter().copied()),
    }
}

/// ms from `after` until the device's output was `muted` (or sounding):
/// 0 when it already was at `after` (its last change before then was to
/// that state: tracking that went stale first, under load, mutes the
/// output before the finger is seen to leave), else to its first change
/// to that state after. `None` when it never got there.
fn first_change(st: &SimStats, after: Option<u64>, muted: bool) -> Option<f64> {
    let a = after?;
    let before = st.mute_changes.iter().rev().find(|(t, _)| *t <= a);
    if before.is_some_and(|(_, m)| *m == muted) {
        return Some(0.0);
    }
    st.mute_changes
        .iter()
        .find(|(t, m)| *t >= a && *m == muted)
        .map(|(t, _)| t.saturating_sub(a) as f64 / 1e3)
}

impl SimDevice {
    /// Stops the simulated device's thread.
    pub fn stop(self) -> anyhow::Result<()> {
        self.sim.stop()
    }
}

/// Simulates LM-M's acoustic field on the default view and writes the maps
/// into `dir` (as `lmhost simulate --foci 4 --out DIR`); returns the
/// summary text.
pub fn write_field(dir: &std::path::Path) -> anyhow::Result<String> {
    use crate::field::study::{View, simulate_plan, write_outputs};
    let plan = Stimulus::paper_lm_m().plan(Scene::default())?.plan;
    let view = View::default();
    let sim = simulate_plan(&plan, &view)?;
    let _made = crate::files::output_dir("--plots", dir)?;
    write_outputs(
        &plan,
        &sim,
        &view,
        crate::plan::trajectory::paper::RADIUS_MM,
        &crate::field::plot::Figure::default(),
        dir,
    )?;
    Ok(sim.text_summary(&plan, crate::plan::trajectory::paper::RADIUS_MM))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn changes(c: &[(u64, bool)]) -> SimStats {
        SimStats {
            mute_changes: c.iter().copied().collect(),
            ..SimStats::default()
        }
    }

    #[test]
    fn mute_after_leave_is_zero_when_stale_tracking_muted_first() {
        // Muted at the play, sounding once tracked, then muted by stale
        // tracking at 900 µs, before the finger was seen to leave at 1000.
        let st = changes(&[(0, true), (100, false), (900, true), (5000, false)]);
        assert_eq!(first_change(&st, Some(1000), true), Some(0.0));
        // Back at 4000: sounding again 1 ms later.
        assert_eq!(first_change(&st, Some(4000), false), Some(1.0));
    }

    #[test]
    fn mute_after_leave_counts_from_the_leave_to_the_mute_it_caused() {
        let st = changes(&[(0, true), (100, false), (1500, true)]);
        assert_eq!(first_change(&st, Some(1000), true), Some(0.5));
        // A stale mute that ended before the leave does not count.
        let st = changes(&[
            (0, true),
            (100, false),
            (800, true),
            (900, false),
            (1200, true),
        ]);
        assert_eq!(first_change(&st, Some(1000), true), Some(0.2));
        // Never muted after: no figure; no leave: none either.
        let st = changes(&[(0, true), (100, false)]);
        assert_eq!(first_change(&st, Some(1000), true), None);
        assert_eq!(first_change(&st, None, true), None);
    }
}
