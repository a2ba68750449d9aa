//! The depth-tracking feed of `lmhost demo --tracking depth`, the filter
//! lag it reports, and the timed frame the `track` bench section
//! ([`crate::lab::bench`]) and the criterion bench share.

use super::camera::CameraSetup;
use super::contact::Tracker;
use super::intrinsics::Intrinsics;
use super::presence::Hysteresis;
use super::synth::{FingerSim, background_of};
use super::{FrameResult, Pipeline};
use crate::plan::scene::Scene;
use crate::sense::stream::Sample;
use crate::sense::stream::filter::FilterKind;

/// The paper's scene if it is found beside the binary's sources, else the
/// built-in one with a derived setup.
fn bench_setup() -> (Scene, CameraSetup) {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml");
    let scene = Scene::load(&p).unwrap_or_default();
    let setup = CameraSetup::of_scene_or_default(&scene);
    (scene, setup)
}

/// One 848 × 480 frame with the finger resting on the marker (noise 0.5 mm,
/// 2 % holes), its tracker and its synthetic finger.
pub fn bench_frame() -> (Tracker, Vec<u16>, FingerSim) {
    let (scene, setup) = bench_setup();
    let intr = Intrinsics::D435_848X480;
    let tracker = Tracker::new(intr, setup);
    let sim = FingerSim::new(setup, intr, background_of(&scene));
    let mut f = Vec::new();
    sim.render(180, &tracker, &mut f);
    (tracker, f, sim)
}

/// The synthetic finger rendered, tracked and gated, as samples for the
/// streaming loop (the demo's `--tracking depth`), with its own tally.
pub struct DepthFeed {
    sim: FingerSim,
    pipe: Pipeline,
    frames: u64,
    index: u64,
    buf: Vec<u16>,
    /// Per frame: seconds to track.
    pub track_s: Vec<f64>,
    /// Squared centroid error sum vs the ground truth and its count.
    pub err: (f64, u64),
    /// Frames whose raw presence differs from the truth away from transitions.
    pub presence_wrong: u64,
    truth_hist: [Option<(bool, bool)>; 2],
    /// The filter's kind.
    pub filter: FilterKind,
}

impl DepthFeed {
    /// `seconds` of the synthetic finger about `scene`'s centre, tracked
    /// with `filter` and the default gate (2 frames in, 2 out). Its
    /// approach–rest–slide–leave cycle is stretched to 0.6 × `seconds` and
    /// starts resting on the marker, so the finger leaves after ≈ 0.38 ×
    /// `seconds` and is back after ≈ 0.54 × `seconds`.
    pub fn new(scene: &Scene, filter: FilterKind, seconds: f64) -> Self {
        let setup = CameraSetup::of_scene_or_default(scene);
        let intr = Intrinsics::D435_848X480;
        let mut sim = FingerSim::new(setup, intr, background_of(scene));
        sim.period_s = 0.6 * seconds;
        sim.phase_s = 1.0;
        let tracker = Tracker::new(intr, setup);
        let mut pipe = Pipeline::new(tracker, Hysteresis::default(), filter.build());
        // The finger is already on the marker when the demo starts: open the
        // gate on frame 0 seen just before.
        let mut buf = Vec::new();
        sim.render(0, &pipe.tracker, &mut buf);
        for k in (1..=pipe.gate.enter()).rev() {
            pipe.step(-(k as f64) / sim.rate_hz, &buf);
        }
        Self {
            sim,
            pipe,
            frames: (seconds * sim.rate_hz) as u64,
            index: 0,
            buf,
            track_s: Vec::new(),
            err: (0.0, 0),
            presence_wrong: 0,
            truth_hist: [None; 2],
            filter,
        }
    }

    fn step(&mut self) -> Option<FrameResult> {
        if self.index >= self.frames {
            return None;
        }
        let (t, truth) = self
            .sim
            .render(self.index, &self.pipe.tracker, &mut self.buf);
        self.index += 1;
        let r = self.pipe.step(t, &self.buf);
        self.track_s.push(r.track_s);
        if let [Some((t2, _)), Some((t1, raw1))] = self.truth_hist
            && t2 == t1
            && t1 == truth.present
            && raw1 != t1
        {
            self.presence_wrong += 1;
        }
        self.truth_hist = [self.truth_hist[1], Some((truth.present, r.present))];
        if let (true, Some(c), Some(g)) =
            (truth.present, r.centroid_mm(), truth.contact.centroid_mm)
        {
            self.err.0 += (0..3).map(|k| (c[k] - g[k]).powi(2)).sum::<f64>();
            self.err.1 += 1;
        }
        Some(r)
    }

    /// The samples (filtered, gated: stream them through `Passthrough`).
    pub fn samples(&mut self) -> impl Iterator<Item = anyhow::Result<Sample>> + '_ {
        std::iter::from_fn(move || self.step().map(|r| Ok(r.sample())))
    }

    /// RMS centroid error vs the ground truth (mm).
    pub fn rms_error_mm(&self) -> f64 {
        (self.err.0 / self.err.1.max(1) as f64).sqrt()
    }

    /// The time to track one frame (µs); `None` before the first frame.
    pub fn track_us(&self) -> Option<crate::clock::Spread<f64>> {
        crate::clock::Spread::of_f64(self.track_s.iter().map(|s| s * 1e6))
    }

    /// The filter's lag (ms): [`filter_lag_ms`] at the feed's frame rate.
    pub fn filter_lag_ms(&self) -> f64 {
        filter_lag_ms(self.filter, self.sim.rate_hz)
    }
}

/// A filter's lag (ms) on a finger moving at constant speed: none for
/// `none`, the Gaussian's (N − 1)/2 = 4.5 frames at `rate_hz`, else
/// measured on the synthetic centroid track (`stream::metrics::score`).
pub fn filter_lag_ms(kind: FilterKind, rate_hz: f64) -> f64 {
    match kind {
        FilterKind::None => 0.0,
        FilterKind::Gaussian => 4.5 / rate_hz * 1e3,
        k => {
            crate::sense::stream::metrics::score(
                k,
                &crate::sense::stream::synthetic::FingerTrack::default(),
                20.0,
            )
            .lag_ms
        }
    }
}
