//! The synthetic finger: depth frames of a fingertip approaching the
//! marker, resting on it with tremor, sliding, resting, and leaving, seen by
//! the setup's camera, with sensor noise and holes, and the ground truth.
//!
//! The fingertip is an ellipsoid (semi-axes 8 × 12 × 7 mm along the box's
//! a, b, c axes: a finger pad 16 mm wide) whose lowest point along −c is
//! the pad's tip; it comes in from +c. The background is the display plane
//! (the scene's reflector) where there is one, else no data. A second
//! object (a sphere) can be added. Each frame is rendered twice: without
//! noise and holes (the ground truth: its contact area through the same
//! box test) and with them (what the tracker sees).
//!
//! Motion, periodic over [`PERIOD_S`] = 6 s: approach 0–0.8 s (tip from
//! 15 mm in front of the marker surface to 4 mm into the box), rest with
//! tremor (≈ 0.1 mm at 8–11 Hz) to 2.5 s, slide ±2.5 mm along a to 4 s,
//! rest to 4.8 s, leave by 5.6 s, away to 6 s.

use super::camera::CameraSetup;
use super::contact::{Contact, Roi, Tracker};
use super::intrinsics::Intrinsics;
use crate::geom::{Vec3, add, dot, scale, sub};
use crate::rng::SplitMix64;

/// Length of one approach–rest–slide–leave cycle (s).
pub const PERIOD_S: f64 = 6.0;

/// Frames per second, the D435's depth rate the paper tracks at.
pub const RATE_HZ: f64 = 90.0;

/// Default depth noise (mm, 1 σ).
pub const NOISE_MM: f64 = 0.5;

/// Default fraction of pixels with no data.
pub const HOLES: f64 = 0.02;

/// The synthetic finger's settings.
#[derive(Debug, Clone, Copy)]
pub struct FingerSim {
    /// Camera and box.
    pub setup: CameraSetup,
    /// Frame format.
    pub intr: Intrinsics,
    /// Frame rate (Hz).
    pub rate_hz: f64,
    /// Depth noise (mm, 1 σ, along the ray's depth).
    pub noise_mm: f64,
    /// Fraction of pixels with no data (holes), 0–1.
    pub holes: f64,
    /// Ellipsoid semi-axes along the box's a, b, c (mm).
    pub semi_axes_mm: Vec3,
    /// How deep the tip rests inside the box (mm behind the marker surface).
    pub rest_depth_mm: f64,
    /// A second object: sphere centre (scene, mm) and radius (mm).
    pub second_object: Option<(Vec3, f64)>,
    /// Background plane (point, normal) — the display — or none.
    pub background: Option<(Vec3, Vec3)>,
    /// Noise seed.
    pub seed: u64,
    /// Length of one motion cycle (s); the timeline above is stretched to it.
    pub period_s: f64,
    /// Render only these pixels (the rest stay 0, no data), e.g. the
    /// tracker's rectangle: identical results for the tracker, far less work.
    pub window: Option<Roi>,
    /// Where in the motion cycle frame 0 is (s of the 6 s timeline).
    pub phase_s: f64,
}

/// Ground truth of one frame.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Truth {
    /// The pad's tip (scene, mm), or `None` while the finger is away.
    pub tip_mm: Option<Vec3>,
    /// The noise-free frame's contact area.
    pub contact: Contact,
    /// `contact.points >= min_points`.
    pub present: bool,
}

impl FingerSim {
    /// The paper's finger with default noise (0.5 mm) and 2 % holes.
    pub fn new(setup: CameraSetup, intr: Intrinsics, background: Option<(Vec3, Vec3)>) -> Self {
        Self {
            setup,
            intr,
            rate_hz: RATE_HZ,
            noise_mm: NOISE_MM,
            holes: HOLES,
            semi_axes_mm: [8.0, 12.0, 7.0],
            rest_depth_mm: 4.0,
            second_object: None,
            background,
            seed: 1,
            period_s: PERIOD_S,
            window: None,
            phase_s: 0.0,
        }
    }

    /// The pad tip in box coordinates at `t_s`, `None` while away.
    pub fn tip_box(&self, t_s: f64) -> Option<Vec3> {
        let t = (t_s / self.period_s * PERIOD_S + self.phase_s).rem_euclid(PERIOD_S);
        let face = self.setup.track_box.size_mm[2] / 2.0;
        let rest = face - self.rest_depth_mm;
        let out = face + 15.0;
        let smooth = |x: f64| {
            let x = x.clamp(0.0, 1.0);
            x * x * (3.0 - 2.0 * x)
        };
        let two_pi = 2.0 * std::f64::consts::PI;
        let tremor = [
            0.10 * (two_pi * 9.0 * t_s).sin(),
            0.08 * (two_pi * 11.0 * t_s + 1.0).sin(),
            0.05 * (two_pi * 8.0 * t_s + 2.0).sin(),
        ];
        let (c, a) = match t {
            t if t < 0.8 => (out + (rest - out) * smooth(t / 0.8), 0.0),
            t if t < 2.5 => (rest, 0.0),
            t if t < 4.0 => (rest, 2.5 * (two_pi * (t - 2.5) / 1.5).sin()),
            t if t < 4.8 => (rest, 0.0),
            t if t < 5.6 => (rest + (out - rest) * smooth((t - 4.8) / 0.8), 0.0),
            _ => return None,
        };
        Some([a + tremor[0], tremor[1], c + tremor[2]])
    }

    /// The pad tip in scene coordinates at `t_s`.
    pub fn tip_mm(&self, t_s: f64) -> Option<Vec3> {
        let b = &self.setup.track_box;
        self.tip_box(t_s).map(|p| {
            b.axes
                .iter()
                .zip(&p)
                .fold(b.center_mm, |acc, (a, &k)| add(acc, scale(*a, k)))
        })
    }

    /// Render frame `index` (noise and holes seeded by `seed` and `index`)
    /// into `out`, and return the ground truth computed with `tracker`.
    pub fn render(&self, index: u64, tracker: &Tracker, out: &mut Vec<u16>) -> (f64, Truth) {
        let t_s = index as f64 / self.rate_hz;
        let tip = self.tip_mm(t_s);
        self.render_clean(tip, out);
        let contact = tracker.track(out);
        let truth = Truth {
            tip_mm: tip,
            contact,
            present: contact.points >= self.setup.track_box.min_points,
        };
        let mut rng = SplitMix64::new(self.seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let mpu = self.intr.mm_per_unit();
        let table = normal_table();
        let hole_below = (self.holes.clamp(0.0, 1.0) * 4_294_967_296.0) as u64;
        for v in out.iter_mut() {
            if *v == 0 {
                continue;
            }
            let x = rng.next_u64();
            if x >> 32 < hole_below {
                *v = 0;
                continue;
            }
            if self.noise_mm > 0.0 {
                let z = *v as f64 * mpu + self.noise_mm * table[(x & 0xFFFF) as usize];
                *v = quantise(z, mpu);
            }
        }
        (t_s, truth)
    }

    /// Noise-free depth of the scene with the pad tip at `tip` (scene).
    ///
    /// Each shape is intersected in its own normalised frame, where the
    /// ray of pixel (c, r) with camera depth 1 is `o + d0 + c·dc + r·dr`
    /// (all linear in c and r), so the hit parameter is the camera depth Z.
    pub fn render_clean(&self, tip: Option<Vec3>, out: &mut Vec<u16>) {
        let intr = &self.intr;
        let cam = &self.setup.camera;
        let b = &self.setup.track_box;
        out.clear();
        out.resize(
            intr.pinhole.width as usize * intr.pinhole.height as usize,
            0,
        );
        let mpu = intr.mm_per_unit();
        // Camera-frame ray (depth 1) of pixel (c, r) = d0 + c·dc + r·dr.
        let d0 = cam.to_scene([
            -intr.pinhole.ppx / intr.pinhole.fx,
            -intr.pinhole.ppy / intr.pinhole.fy,
            1.0,
        ]);
        let d0 = sub(d0, cam.position_mm);
        let dc = scale(cam.axes[0], 1.0 / intr.pinhole.fx);
        let dr = scale(cam.axes[1], 1.0 / intr.pinhole.fy);
        let o = cam.position_mm;
        // Shapes as (origin, d0, dc, dr) in a frame where they are unit spheres.
        let mut spheres: Vec<[Vec3; 4]> = Vec::new();
        if let Some(t) = tip {
            let e = add(t, scale(b.axes[2], self.semi_axes_mm[2]));
            let m =
                |v: Vec3| -> Vec3 { [0, 1, 2].map(|k| dot(b.axes[k], v) / self.semi_axes_mm[k]) };
            spheres.push([m(sub(o, e)), m(d0), m(dc), m(dr)]);
        }
        if let Some((centre, rad)) = self.second_object {
            let m = |v: Vec3| scale(v, 1.0 / rad);
            spheres.push([m(sub(o, centre)), m(d0), m(dc), m(dr)]);
        }
        let win = self.window.unwrap_or(Roi {
            c0: 0,
            c1: intr.pinhole.width,
            r0: 0,
            r1: intr.pinhole.height,
        });
        let (c0, c1) = (
            win.c0.min(intr.pinhole.width),
            win.c1.min(intr.pinhole.width),
        );
        for r in win.r0..win.r1.min(intr.pinhole.height) {
            let rf = r as f64;
            let row_d = add(d0, scale(dr, rf));
            let row_s: Vec<(Vec3, Vec3, Vec3)> = spheres
                .iter()
                .map(|[so, sd0, sdc, sdr]| (*so, add(*sd0, scale(*sdr, rf)), *sdc))
                .collect();
            let line = &mut out
                [(r * intr.pinhole.width + c0) as usize..(r * intr.pinhole.width + c1) as usize];
            for (c, px) in (c0..).zip(line.iter_mut()) {
                let cf = c as f64;
                let mut z = f64::INFINITY;
                for (so, sd, sdc) in &row_s {
                    let d = [
                        sd[0] + cf * sdc[0],
                        sd[1] + cf * sdc[1],
                        sd[2] + cf * sdc[2],
                    ];
                    if let Some(t) = unit_sphere_hit(*so, d) {
                        z = z.min(t);
                    }
                }
                if let Some((p0, n)) = self.background {
                    let d = [
                        row_d[0] + cf * dc[0],
                        row_d[1] + cf * dc[1],
                        row_d[2] + cf * dc[2],
                    ];
                    let den = dot(d, n);
                    if den.abs() > 1e-12 {
                        let t = dot(sub(p0, o), n) / den;
                        if t > 0.0 {
                            z = z.min(t);
                        }
                    }
                }
                if z.is_finite() && z > 0.0 {
                    *px = quantise(z, mpu);
                }
            }
        }
    }
}

/// Depth `z_mm` as a depth unit: rounded, 0 (no data) below half a unit,
/// 65535 beyond the range (the sensor's saturation).
fn quantise(z_mm: f64, mm_per_unit: f64) -> u16 {
    let u = (z_mm / mm_per_unit).round();
    if u < 1.0 {
        0
    } else if u >= 65535.0 {
        65535
    } else {
        u as u16
    }
}

/// 65536 standard normal deviates (Box–Muller, fixed seed): per-pixel
/// noise by table look-up keeps rendering cheap.
fn normal_table() -> &'static [f64] {
    static TABLE: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut rng = SplitMix64::new(0x5EED);
        (0..65_536).map(|_| rng.normal()).collect()
    })
}

/// Nearest positive hit of `o + t d` with the unit sphere.
fn unit_sphere_hit(o: Vec3, d: Vec3) -> Option<f64> {
    let a = dot(d, d);
    let bh = dot(o, d);
    let c = dot(o, o) - 1.0;
    let disc = bh * bh - a * c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t0 = (-bh - s) / a;
    let t1 = (-bh + s) / a;
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 {
        Some(t1)
    } else {
        None
    }
}

/// The background of a scene: its reflector plane (the display), if any.
pub fn background_of(scene: &crate::plan::scene::Scene) -> Option<(Vec3, Vec3)> {
    scene.reflector.map(|r| (r.point_mm, r.normal))
}
