//! The streaming loop: samples in, filtered drive-space centroids out to
//! the device, one acked `Centroid` frame per sample, with per-update
//! timing.

use std::time::{Duration, Instant};

use lm_proto::Centroid;

use super::Sample;
use super::filter::Filter;
use crate::clock::monotonic_us;
use crate::link::{Client, LinkError, Transport, mm_to_um};

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
}

impl StreamReport {
    /// Percentile (0–100) of the ack latency, µs.
    pub fn ack_percentile_us(&self, p: f64) -> Option<u64> {
        crate::clock::percentile(self.ack_us.iter().copied(), p)
    }
}

/// Stream `samples` through `filter` to the device behind `client`;
/// `to_drive` maps a finger-space centroid (mm) into drive coordinates
/// (the scene's mirror). `between` runs after every acked update with the
/// sample and its host receipt time (µs, [`monotonic_us`]) (the demo
/// samples the device's status there).
pub fn stream<T: Transport, I>(
    client: &mut Client<T>,
    samples: I,
    filter: &mut dyn Filter,
    to_drive: impl Fn([f64; 3]) -> [f64; 3],
    pace: Pace,
    mut between: impl FnMut(&mut Client<T>, &Sample, u64) -> anyhow::Result<()>,
) -> anyhow::Result<StreamReport>
where
    I: IntoIterator<Item = anyhow::Result<Sample>>,
{
    let start = Instant::now();
    let mut first_t: Option<f64> = None;
    let mut report = StreamReport::default();
    let mut last_pos = [0i32; 3];
    let mut seq = client_seq_start(client)?;
    for sample in samples {
        let s = sample?;
        report.samples += 1;
        if pace == Pace::Timestamps {
            let t0 = *first_t.get_or_insert(s.t_s);
            let due = Duration::from_secs_f64((s.t_s - t0).max(0.0));
            if let Some(wait) = due.checked_sub(start.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        let received_us = monotonic_us();
        let filtered = filter.update(&s);
        if let Some(p) = filtered {
            last_pos = to_drive(p).map(mm_to_um);
            report.present += 1;
        }
        seq = seq.wrapping_add(1).max(1);
        let c = Centroid {
            seq,
            pos_um: last_pos,
            present: filtered.is_some(),
            host_time_us: received_us,
        };
        client.centroid(c).map_err(|e: LinkError| {
            anyhow::Error::new(e).context(format!("sending centroid #{seq}"))
        })?;
        crate::clock::push_ring(
            &mut report.ack_us,
            monotonic_us().saturating_sub(received_us),
        );
        report.acked += 1;
        report.last_seq = seq;
        between(client, &s, received_us)?;
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok(report)
}

/// Start numbering after the device's last accepted centroid, so a second
/// stream in the same play session is not refused as stale.
fn client_seq_start<T: Transport>(client: &mut Client<T>) -> anyhow::Result<u32> {
    use anyhow::Context as _;
    Ok(client
        .status()
        .context("reading the device status before streaming")?
        .last_centroid_seq)
}
