//! The streaming loop: samples in, filtered drive-space centroids out to
//! the device, one acked `Centroid` frame per sample, with per-update
//! timing.

use std::time::{Duration, Instant};

use super::Sample;
use super::filter::Filter;
use super::intake::{Intake, SharedCounts, Timing};
use super::plausible::PlausibilityCounts;
use crate::clock::monotonic_us;
use crate::device::backend::{Backend, CentroidOutcome};
use crate::device::centroids::CentroidSender;
use crate::units::mm_to_um;

use crate::stop::requested as stop_requested;

/// Sleep `d`, waking early when a stop is requested; the device's
/// housekeeping ([`Backend::tick`]: the host-side staleness mute of an
/// AUTD3) runs every 10 ms meanwhile.
fn sleep_unless_stopped(dev: &mut dyn Backend, d: Duration) -> anyhow::Result<()> {
    let end = Instant::now() + d;
    while !stop_requested() {
        let now = Instant::now();
        if now >= end {
            return Ok(());
        }
        std::thread::sleep((end - now).min(Duration::from_millis(10)));
        dev.tick()?;
    }
    Ok(())
}

/// How to pace samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pace {
    /// Send each sample as soon as it arrives (stdin, UDP: already live).
    Arrival,
    /// Replay at the samples' own time stamps (files, the synthetic finger).
    Timestamps,
}

/// What a streaming run measured.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct StreamReport {
    /// Samples read.
    pub samples: u64,
    /// Centroid updates acked by the device.
    pub acked: u64,
    /// Updates sent with the finger present.
    pub present: u64,
    /// Per update: µs from host receipt of the sample to the device's ack.
    /// Bounded: the most recent [`crate::clock::STATS_RING`].
    #[serde(skip)]
    pub ack_us: std::collections::VecDeque<u64>,
    /// Seconds of streaming.
    pub seconds: f64,
    /// `seq` of the last update sent.
    pub last_seq: u32,
    /// Samples the plausibility gate dropped (not sent), by reason.
    pub rejected: PlausibilityCounts,
    /// Updates the device refused as outside the slot's work volume (it
    /// mutes until the finger is back in range; the session goes on).
    pub outside_work_volume: u64,
    /// Whether a stop (Ctrl-C, SIGTERM, ...) ended the session.
    pub stopped: bool,
    /// What stopped it (`SIGTERM`), when something did.
    pub stopped_by: Option<String>,
    /// Whether the device was muted at the end (after a stop or an error).
    pub muted_at_end: bool,
}

impl StreamReport {
    /// The ack latency, µs; `None` before the first ack.
    pub fn ack_us(&self) -> Option<crate::clock::Spread<u64>> {
        crate::clock::Spread::of(self.ack_us.iter().copied())
    }
}

/// How often the device's housekeeping ([`Backend::tick`]) runs while
/// the loop waits for a sample: the AUTD3 host-side staleness mute needs
/// it at least every 10 ms.
pub const TICK: Duration = Duration::from_millis(10);

/// Samples buffered between a reader thread and the loop ([`on_thread`]).
const READ_AHEAD: usize = 64;

pub use super::intake::Feed;
pub use crate::sense::reader::Next;

/// Samples read on their own thread ([`crate::sense::reader`]), so a source
/// blocked on input (stdin, a socket, a camera) does not hold up the
/// loop's housekeeping. Made by [`on_thread`].
pub struct Threaded(crate::sense::reader::Reader<Sample>);

impl Feed for Threaded {
    fn next_within(&mut self, wait: Duration) -> Next<anyhow::Result<Sample>> {
        self.0.next_within(wait)
    }
}

/// Run the source `make` builds on a reader thread of its own (built
/// there, so it need not be `Send`); see [`crate::sense::reader::spawn`].
pub fn on_thread<F, I>(make: F) -> anyhow::Result<Threaded>
where
    F: FnOnce() -> I + Send + 'static,
    I: IntoIterator<Item = anyhow::Result<Sample>>,
{
    crate::sense::reader::spawn("lmhost-samples", READ_AHEAD, make).map(Threaded)
}

/// Stream the samples of `feed` through `filter` to the device `dev`;
/// `to_drive` maps a finger-space centroid (mm) into drive coordinates
/// (the scene's mirror). `between` runs after every acked update with the
/// sample and its host receipt time (µs, [`monotonic_us`]) (the demo
/// samples the device's status there). The device's housekeeping
/// ([`Backend::tick`]) runs every [`TICK`] throughout, also while a live
/// feed ([`on_thread`]) is silent.
pub fn stream(
    client: &mut dyn Backend,
    mut feed: impl Feed,
    filter: &mut dyn Filter,
    to_drive: impl Fn([f64; 3]) -> [f64; 3],
    pace: Pace,
    mut between: impl FnMut(&mut dyn Backend, &Sample, u64) -> anyhow::Result<()>,
) -> anyhow::Result<StreamReport> {
    let start = Instant::now();
    let mut report = StreamReport::default();
    // Numbered after the device's last accepted centroid, so a second
    // stream in the same play session is not refused as stale.
    let mut sender = CentroidSender::after(client)
        .map_err(|e| e.context("reading the device status before streaming"))?;
    let result = pump(
        client,
        &mut feed,
        filter,
        &to_drive,
        pace,
        &mut between,
        &mut report,
        &mut sender,
        start,
    );
    report.stopped = stop_requested();
    report.stopped_by = crate::stop::cause().map(|c| c.to_string());
    if result.is_err() || report.stopped {
        // The session ends early: leave the device muted, not steering to
        // the last centroid. Best effort when the link itself failed.
        if sender.send(client, None, monotonic_us()).is_ok() {
            report.muted_at_end = true;
            report.last_seq = sender.last_seq();
        }
    }
    result?;
    report.seconds = start.elapsed().as_secs_f64();
    Ok(report)
}

#[allow(clippy::too_many_arguments)]
fn pump(
    client: &mut dyn Backend,
    feed: &mut dyn Feed,
    filter: &mut dyn Filter,
    to_drive: &impl Fn([f64; 3]) -> [f64; 3],
    pace: Pace,
    between: &mut impl FnMut(&mut dyn Backend, &Sample, u64) -> anyhow::Result<()>,
    report: &mut StreamReport,
    sender: &mut CentroidSender,
    start: Instant,
) -> anyhow::Result<()> {
    let mut first_t: Option<f64> = None;
    // A live sample arrives when taken off the reader's queue (which the
    // loop keeps empty); a replayed one when the one before it was due.
    let mut intake = Intake::new(
        match pace {
            Pace::Arrival => Timing::Live,
            Pace::Timestamps => Timing::Replay,
        },
        std::sync::Arc::new(SharedCounts::default()),
    );
    let mut next_tick = Instant::now() + TICK;
    loop {
        if stop_requested() {
            break;
        }
        // Housekeeping on time whatever the samples do: a silent source,
        // or a run of samples the gate drops, sends no update.
        let now = Instant::now();
        if now >= next_tick {
            client.tick()?;
            next_tick = now + TICK;
        }
        let next = intake.next(feed, next_tick.saturating_duration_since(now));
        report.samples = intake.counts().read();
        report.rejected = intake.counts().dropped();
        let s = match next {
            Next::Ready(s) => s?,
            Next::Idle => continue,
            Next::End => break,
        };
        if pace == Pace::Timestamps {
            let t0 = *first_t.get_or_insert(s.t_s);
            let due = Duration::try_from_secs_f64((s.t_s - t0).max(0.0)).map_err(|_| {
                crate::InputError::new(format!(
                    "sample {}: time stamp {} s is too far from the first one to replay",
                    report.samples,
                    crate::limits::show(s.t_s)
                ))
            })?;
            if let Some(wait) = due.checked_sub(start.elapsed()) {
                sleep_unless_stopped(client, wait)?;
                if stop_requested() {
                    break;
                }
            }
        }
        let received_us = monotonic_us();
        let filtered = filter.update(&s);
        if filtered.is_some() {
            report.present += 1;
        }
        let pos_um = filtered.map(|p| to_drive(p).map(mm_to_um));
        let outcome = sender.send(client, pos_um, received_us);
        let seq = sender.last_seq();
        match outcome {
            Ok(CentroidOutcome::Applied) => {}
            // The device refused to steer there and muted; keep following
            // the finger, it unmutes when the finger is back in range.
            Ok(CentroidOutcome::OutOfRange) => {
                report.outside_work_volume += 1;
                report.last_seq = seq;
                continue;
            }
            Err(e) => {
                return Err(anyhow::Error::from(e).context(format!("sending centroid #{seq}")));
            }
        }
        crate::clock::push_ring(
            &mut report.ack_us,
            monotonic_us().saturating_sub(received_us),
        );
        report.acked += 1;
        report.last_seq = seq;
        between(client, &s, received_us)?;
    }
    Ok(())
}
