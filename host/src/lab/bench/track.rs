//! The `track` section: the contact-area centroid of one frame against the
//! 90 fps budget and the f64 reference, the synthetic render, and the
//! finger-surface depth comparison.

use serde::Serialize;

use super::{Options, Section, time_per_call};
use crate::sense::track::contact::reference;
use crate::sense::track::report::bench_frame;
use crate::sense::track::surface::{SurfaceComparison, compare};

/// Frame budget at the paper's 90 fps (ms).
pub const FRAME_BUDGET_MS: f64 = 1000.0 / 90.0;

/// Figures of the `track` bench section.
#[derive(Debug, Clone, Serialize)]
pub struct TrackFigures {
    /// Frame size.
    pub width: u32,
    /// Frame size.
    pub height: u32,
    /// Pixels in the box's rectangle (the only ones read).
    pub roi_pixels: usize,
    /// Points in the contact area of the timed frame.
    pub points: u32,
    /// Median time to track one frame (µs).
    pub track_us: f64,
    /// The same frame by the full-frame f64 reference (µs).
    pub reference_us: f64,
    /// The fast path's count and centroid equal the reference's.
    pub matches_reference: bool,
    /// `track_us` as a share of the 90 fps frame budget.
    pub budget_fraction: f64,
    /// Rendering one synthetic frame (µs), for the demo's and tests' cost.
    pub render_us: f64,
    /// Finger-surface depth along a 3 mm, 16-step circle: focus-to-skin RMS.
    pub surface: SurfaceComparison,
}

/// The `track` section.
pub fn section(opts: &Options) -> anyhow::Result<Section> {
    let (tracker, frame, sim) = bench_frame();
    let intr = *tracker.intrinsics();
    let reps = if opts.quick { 50 } else { 500 };
    let fast = tracker.track(&frame);
    let slow = reference(&intr, tracker.setup(), &frame);
    let matches = fast.points == slow.points
        && match (fast.centroid_mm, slow.centroid_mm) {
            (Some(a), Some(b)) => (0..3).all(|k| (a[k] - b[k]).abs() < 1e-9),
            (None, None) => true,
            _ => false,
        };
    let track_s = time_per_call(9, reps, || {
        std::hint::black_box(tracker.track(std::hint::black_box(&frame)));
    });
    let reference_s = time_per_call(3, if opts.quick { 1 } else { 5 }, || {
        std::hint::black_box(reference(&intr, tracker.setup(), &frame));
    });
    let mut out = Vec::new();
    let render_s = time_per_call(3, if opts.quick { 1 } else { 5 }, || {
        sim.render(180, &tracker, &mut out);
    });
    let mut quick_sim = sim;
    quick_sim.window = Some(tracker.roi());
    let surface = compare(&quick_sim, if opts.quick { 3.0 } else { 6.0 }, 3.0, 16, 0.3);
    let f = TrackFigures {
        width: intr.pinhole.width,
        height: intr.pinhole.height,
        roi_pixels: tracker.roi().pixels(),
        points: fast.points,
        track_us: track_s * 1e6,
        reference_us: reference_s * 1e6,
        matches_reference: matches,
        budget_fraction: track_s * 1e3 / FRAME_BUDGET_MS,
        render_us: render_s * 1e6,
        surface,
    };
    let s = &f.surface;
    let text = format!(
        "track  (contact-area centroid, one {}×{} frame, finger on the marker, {} points)\n  \
         box rectangle {} px; {:.1} µs per frame = {:.2} % of the 11.1 ms frame budget at 90 fps \
         (full-frame f64 reference {:.0} µs, same result: {}); synthetic render {:.0} µs\n  \
         focus-to-skin RMS along a 3 mm circle over {} frames: centroid only {:.3} mm, \
         re-plan above {:.1} mm {:.3} mm ({:.1} re-plans/s), z_j every frame {:.3} mm\n",
        f.width,
        f.height,
        f.points,
        f.roi_pixels,
        f.track_us,
        f.budget_fraction * 100.0,
        f.reference_us,
        if f.matches_reference { "yes" } else { "NO" },
        f.render_us,
        s.frames,
        s.centroid_only_mm,
        s.threshold_mm,
        s.replan_mm,
        s.replans_per_s,
        s.per_frame_mm
    );
    Section::new("track", &f, text)
}
