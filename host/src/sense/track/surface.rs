//! The finger surface's depth along the planned circle (the paper's z_j).
//!
//! The paper takes the z of each focal point from the depth map of the
//! fingertip. The device applies one centroid offset to every step, so the
//! host keeps the per-step depth profile *relative to the centroid* and
//! re-plans (uploads a new sequence) only when the measured profile moves
//! more than a threshold from the planned one ([`Replanner`]).
//! [`compare`] measures, on the synthetic finger, how far the focus sits
//! from the skin with the centroid alone, with re-planning on a threshold,
//! and with a fresh profile every frame (sending z_j to the device).

use super::contact::Tracker;
use super::synth::FingerSim;
use crate::geom::Vec3;

/// The measured surface depth (box c coordinate, mm) at each of `steps`
/// points of the circle of `radius_mm` about `center_ab` (box a, b), and at
/// the centre (last element). The contact area's points are fitted by least
/// squares with a quadric c = k0 + k1 a + k2 b + k3 a² + k4 ab + k5 b²
/// (about the centre), which is evaluated at each step: a fingertip is
/// smooth at this scale, and the fit averages the depth noise of every
/// point. `None` everywhere with fewer than 12 points or a degenerate fit.
pub fn profile(
    tracker: &Tracker,
    depth: &[u16],
    center_ab: [f64; 2],
    radius_mm: f64,
    steps: usize,
) -> Vec<Option<f64>> {
    let mut ata = [[0.0f64; 6]; 6];
    let mut atb = [0.0f64; 6];
    let mut n = 0u32;
    tracker.for_each_inside(depth, |_, _, p| {
        let (x, y) = (p[0] - center_ab[0], p[1] - center_ab[1]);
        let row = [1.0, x, y, x * x, x * y, y * y];
        for i in 0..6 {
            for j in 0..6 {
                ata[i][j] += row[i] * row[j];
            }
            atb[i] += row[i] * p[2];
        }
        n += 1;
    });
    let k = if n >= 12 { solve6(ata, atb) } else { None };
    (0..steps)
        .map(|j| {
            let th = 2.0 * std::f64::consts::PI * j as f64 / steps as f64;
            [radius_mm * th.cos(), radius_mm * th.sin()]
        })
        .chain(std::iter::once([0.0, 0.0]))
        .map(|[x, y]| {
            k.map(|k| k[0] + k[1] * x + k[2] * y + k[3] * x * x + k[4] * x * y + k[5] * y * y)
        })
        .collect()
}

/// Solve a 6 × 6 system by Gaussian elimination with partial pivoting.
fn solve6(mut a: [[f64; 6]; 6], mut b: [f64; 6]) -> Option<[f64; 6]> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..6 {
        let piv = (col..6).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() <= 1e-12 * scale.max(1e-300) {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for r in col + 1..6 {
            let f = a[r][col] / a[col][col];
            let pivot_row = a[col];
            for (x, p) in a[r][col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 6];
    for r in (0..6).rev() {
        let s: f64 = (r + 1..6).map(|c| a[r][c] * x[c]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Profile relative to its centre, with steps that saw nothing at 0.
pub fn relative(profile: &[Option<f64>]) -> Option<Vec<f64>> {
    let (centre, steps) = profile.split_last()?;
    let c = (*centre)?;
    Some(steps.iter().map(|z| z.map_or(0.0, |z| z - c)).collect())
}

/// Re-plan the depth profile when it moves more than `threshold_mm`.
#[derive(Debug, Clone)]
pub struct Replanner {
    /// Largest tolerated per-step change (mm).
    pub threshold_mm: f64,
    planned: Option<Vec<f64>>,
    /// Re-plans so far.
    pub replans: u64,
}

impl Replanner {
    /// A re-planner with nothing planned yet.
    pub fn new(threshold_mm: f64) -> Self {
        Self {
            threshold_mm,
            planned: None,
            replans: 0,
        }
    }

    /// Feed the measured relative profile; `true` when a re-plan is due
    /// (the first profile always is).
    pub fn update(&mut self, measured: &[f64]) -> bool {
        let due = match &self.planned {
            None => true,
            Some(p) => p
                .iter()
                .zip(measured)
                .any(|(a, b)| (a - b).abs() > self.threshold_mm),
        };
        if due {
            self.planned = Some(measured.to_vec());
            self.replans += 1;
        }
        due
    }

    /// The profile currently planned.
    pub fn planned(&self) -> Option<&[f64]> {
        self.planned.as_deref()
    }
}

/// RMS distance (mm, along c) from focus to skin for each strategy.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SurfaceComparison {
    /// Frames with the finger present that were scored.
    pub frames: u64,
    /// Flat circle at the centroid's surface depth (Centroid frames only).
    pub centroid_only_mm: f64,
    /// Profile re-planned when it moved more than the threshold.
    pub replan_mm: f64,
    /// Threshold used (mm).
    pub threshold_mm: f64,
    /// Re-plans per second of contact.
    pub replans_per_s: f64,
    /// A fresh profile every frame (z_j sent to the device each frame).
    pub per_frame_mm: f64,
}

/// Score the three strategies on `seconds` of the synthetic finger for a
/// circle of `radius_mm` with `steps` steps; the skin is the ellipsoid's
/// exact surface under each focal point.
pub fn compare(
    sim: &FingerSim,
    seconds: f64,
    radius_mm: f64,
    steps: usize,
    threshold_mm: f64,
) -> SurfaceComparison {
    let tracker = Tracker::new(sim.intr, sim.setup);
    let mut frame = Vec::new();
    let mut replan = Replanner::new(threshold_mm);
    let (mut e_flat, mut e_replan, mut e_frame, mut n, mut frames) = (0.0, 0.0, 0.0, 0u64, 0u64);
    let total = (seconds * sim.rate_hz) as u64;
    for i in 0..total {
        let (t, truth) = sim.render(i, &tracker, &mut frame);
        let (Some(tip), true) = (sim.tip_box(t), truth.present) else {
            continue;
        };
        let c = tracker.track(&frame);
        let Some(cen) = c.centroid_mm else { continue };
        let b = &sim.setup.track_box;
        let rel = crate::geom::sub(cen, b.center_mm);
        let ab = [
            crate::geom::dot(b.axes[0], rel),
            crate::geom::dot(b.axes[1], rel),
        ];
        let prof = profile(&tracker, &frame, ab, radius_mm, steps);
        let Some(measured) = relative(&prof) else {
            continue;
        };
        let centre_z = prof[steps].expect("relative() checked the centre");
        // The previous frame's plan applies to this frame (upload latency).
        let planned = replan.planned().map(<[f64]>::to_vec);
        replan.update(&measured);
        frames += 1;
        for j in 0..steps {
            let th = 2.0 * std::f64::consts::PI * j as f64 / steps as f64;
            let p = [ab[0] + radius_mm * th.cos(), ab[1] + radius_mm * th.sin()];
            let Some(skin) = skin_c(sim, tip, p) else {
                continue;
            };
            e_flat += (centre_z - skin).powi(2);
            let pl = planned.as_ref().map_or(0.0, |v| v[j]);
            e_replan += (centre_z + pl - skin).powi(2);
            e_frame += (centre_z + measured[j] - skin).powi(2);
            n += 1;
        }
    }
    let rms = |e: f64| {
        if n == 0 {
            f64::NAN
        } else {
            (e / n as f64).sqrt()
        }
    };
    SurfaceComparison {
        frames,
        centroid_only_mm: rms(e_flat),
        replan_mm: rms(e_replan),
        threshold_mm,
        replans_per_s: replan.replans as f64 / (frames.max(1) as f64 / sim.rate_hz),
        per_frame_mm: rms(e_frame),
    }
}

/// The ellipsoid's lower (−c) surface under box point (a, b), if any.
fn skin_c(sim: &FingerSim, tip_box: Vec3, ab: [f64; 2]) -> Option<f64> {
    let s = sim.semi_axes_mm;
    let e = [tip_box[0], tip_box[1], tip_box[2] + s[2]];
    let q = 1.0 - ((ab[0] - e[0]) / s[0]).powi(2) - ((ab[1] - e[1]) / s[1]).powi(2);
    (q >= 0.0).then(|| e[2] - s[2] * q.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replanner_waits_for_the_threshold() {
        let mut r = Replanner::new(0.5);
        assert!(r.update(&[0.0, 1.0]));
        assert!(!r.update(&[0.3, 1.2]));
        assert!(r.update(&[0.6, 1.0]));
        assert_eq!(r.replans, 2);
        assert_eq!(r.planned(), Some(&[0.6, 1.0][..]));
    }

    #[test]
    fn profile_tracks_the_curved_pad_better_than_a_flat_circle() {
        let scene = crate::plan::scene::Scene::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/paper.toml"
        )))
        .unwrap();
        let setup = super::super::camera::CameraSetup::of_scene(&scene).unwrap();
        let mut intr = super::super::intrinsics::Intrinsics::D435_848X480;
        // A half-size frame keeps the debug-build test quick.
        intr.pinhole.width = 424;
        intr.pinhole.height = 240;
        intr.pinhole.fx /= 2.0;
        intr.pinhole.fy /= 2.0;
        intr.pinhole.ppx = 211.5;
        intr.pinhole.ppy = 119.5;
        let sim = FingerSim::new(setup, intr, super::super::synth::background_of(&scene));
        let c = compare(&sim, 2.5, 3.0, 16, 0.3);
        eprintln!("{c:?}");
        assert!(c.frames > 50, "{c:?}");
        // The pad curves away from its centre by r²/2R ≈ 0.6 mm at 3 mm.
        assert!(c.centroid_only_mm > 0.3, "{c:?}");
        assert!(c.replan_mm < 0.7 * c.centroid_only_mm, "{c:?}");
        assert!(c.per_frame_mm < 0.7 * c.centroid_only_mm, "{c:?}");
    }
}
