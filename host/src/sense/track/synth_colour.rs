//! The synthetic finger in colour: what the colour camera beside the
//! depth camera sees of the scene the synthetic finger ([`super::synth`])
//! renders in depth, so the view and Experiment 2 run without a camera.
//!
//! Each pixel's ray (through the colour camera's own model,
//! [`ColourCamera::ray`], the depth → colour extrinsics and the camera
//! pose) meets: the fingertip's ellipsoid (skin, Lambert-shaded by the
//! light at the camera), the midair image marker (a light ring of
//! [`MARKER_RADIUS_MM`] and a small cross at the scene's centre, in the LM
//! plane, drawn over what lies behind it), the display plane (the scene's
//! reflector, dark) or nothing (darker). The background and marker are
//! rendered once; each frame redraws only the pixels the finger's
//! bounding box covers.

use super::colour::ColourCamera;
use super::synth::FingerSim;
use crate::geom::{Vec3, add, dot, norm, scale, sub};
use crate::plan::scene::LmPlane;

/// The marker ring's radius (mm): a 16 mm finger pad covers it.
pub const MARKER_RADIUS_MM: f64 = 8.0;
/// Half the marker's line width (mm).
const MARKER_HALF_WIDTH_MM: f64 = 0.5;
/// Skin (RGB).
const SKIN: [f64; 3] = [226.0, 178.0, 150.0];
/// The marker (RGB): light, not blue, so an overlay's blue stays apart.
const MARKER: [u8; 3] = [205, 228, 200];
/// The display plane (RGB).
const DISPLAY: [u8; 3] = [38, 40, 46];
/// Where no surface is (RGB).
const VOID: [u8; 3] = [16, 16, 18];

/// Renders the synthetic finger's colour images.
pub struct ColourSim {
    /// The colour camera (its extrinsics from the depth camera).
    pub cam: ColourCamera,
    finger: FingerSim,
    marker_mm: Vec3,
    plane: LmPlane,
    /// The colour camera's centre (scene, mm).
    origin: Vec3,
    /// Each pixel's ray (scene, not normalised: camera depth 1).
    rays: Vec<[f32; 3]>,
    /// Background and marker, rendered once.
    base: Vec<u8>,
}

impl ColourSim {
    /// The colour view of `finger`'s scene with the marker at `marker_mm`
    /// in `plane`.
    pub fn new(cam: ColourCamera, finger: FingerSim, marker_mm: Vec3, plane: LmPlane) -> Self {
        let pose = finger.setup.camera;
        let origin = pose.to_scene(cam.to_depth([0.0; 3]));
        let mut rays = Vec::with_capacity(cam.pinhole.width as usize * cam.pinhole.height as usize);
        for v in 0..cam.pinhole.height {
            for u in 0..cam.pinhole.width {
                let r = cam.ray(f64::from(u), f64::from(v));
                let d = sub(pose.to_scene(cam.to_depth(r)), origin);
                rays.push(d.map(|x| x as f32));
            }
        }
        let mut me = Self {
            cam,
            finger,
            marker_mm,
            plane,
            origin,
            rays,
            base: Vec::new(),
        };
        me.base = (0..me.rays.len()).flat_map(|i| me.background(i)).collect();
        me
    }

    fn ray(&self, i: usize) -> Vec3 {
        self.rays[i].map(f64::from)
    }

    /// The background and marker seen by pixel `i`.
    fn background(&self, i: usize) -> [u8; 3] {
        let d = self.ray(i);
        let c = self.plane.c;
        let den = dot(d, c);
        if den.abs() > 1e-12 {
            let t = dot(sub(self.marker_mm, self.origin), c) / den;
            if t > 0.0 {
                let q = sub(add(self.origin, scale(d, t)), self.marker_mm);
                let (a, b) = (dot(q, self.plane.a), dot(q, self.plane.b));
                let ring = ((a * a + b * b).sqrt() - MARKER_RADIUS_MM).abs() < MARKER_HALF_WIDTH_MM;
                let cross = (a.abs() < MARKER_HALF_WIDTH_MM && b.abs() < 2.0)
                    || (b.abs() < MARKER_HALF_WIDTH_MM && a.abs() < 2.0);
                if ring || cross {
                    return MARKER;
                }
            }
        }
        match self.finger.background {
            Some((p0, n)) => {
                let den = dot(d, n);
                if den.abs() > 1e-12 && dot(sub(p0, self.origin), n) / den > 0.0 {
                    DISPLAY
                } else {
                    VOID
                }
            }
            None => VOID,
        }
    }

    /// Render the scene with the pad's tip at `tip` (scene, mm; `None`:
    /// the finger is away) into `out` (width × height × 3, RGB).
    pub fn render(&self, tip: Option<Vec3>, out: &mut Vec<u8>) {
        out.clear();
        out.extend_from_slice(&self.base);
        let Some(tip) = tip else {
            return;
        };
        let axes = self.finger.setup.track_box.axes;
        let semi = self.finger.semi_axes_mm;
        let centre = add(tip, scale(axes[2], semi[2]));
        // The pixels the ellipsoid's bounding box covers.
        let (mut c0, mut c1, mut r0, mut r1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for k in 0..8 {
            let corner = (0..3).fold(centre, |acc, j| {
                let s = if k >> j & 1 == 0 { -1.0 } else { 1.0 };
                add(acc, scale(axes[j], s * semi[j]))
            });
            let p = self
                .cam
                .project_from_depth(self.finger.setup.camera.to_camera(corner));
            let Some([u, v]) = p else {
                // A corner behind the camera: redraw everything.
                (c0, c1, r0, r1) = (0.0, f64::MAX, 0.0, f64::MAX);
                break;
            };
            (c0, c1, r0, r1) = (c0.min(u), c1.max(u), r0.min(v), r1.max(v));
        }
        let w = self.cam.pinhole.width as usize;
        let clamp = |x: f64, n: u32| (x.max(0.0) as usize).min(n as usize);
        let (c0, c1) = (
            clamp(c0 - 2.0, self.cam.pinhole.width),
            clamp(c1 + 3.0, self.cam.pinhole.width),
        );
        let (r0, r1) = (
            clamp(r0 - 2.0, self.cam.pinhole.height),
            clamp(r1 + 3.0, self.cam.pinhole.height),
        );
        // The ellipsoid as a unit sphere: coordinates along the box axes
        // divided by the semi-axes.
        let m = |v: Vec3| -> Vec3 { [0, 1, 2].map(|k| dot(axes[k], v) / semi[k]) };
        let o = m(sub(self.origin, centre));
        for r in r0..r1 {
            for c in c0..c1 {
                let i = r * w + c;
                let d = self.ray(i);
                let Some(t) = unit_sphere_hit(o, m(d)) else {
                    continue;
                };
                // Normal: the unit sphere's, back through the scaling.
                let s = add(o, scale(m(d), t));
                let n = (0..3).fold([0.0; 3], |acc, k| add(acc, scale(axes[k], s[k] / semi[k])));
                let lambert = -dot(n, d) / (norm(n) * norm(d));
                let shade = 0.35 + 0.65 * lambert.clamp(0.0, 1.0);
                for (k, px) in out[i * 3..i * 3 + 3].iter_mut().enumerate() {
                    *px = (SKIN[k] * shade).round() as u8;
                }
            }
        }
    }
}

/// Nearest positive hit of `o + t d` with the unit sphere.
fn unit_sphere_hit(o: Vec3, d: Vec3) -> Option<f64> {
    let a = dot(d, d);
    let bh = dot(o, d);
    let disc = bh * bh - a * (dot(o, o) - 1.0);
    if disc < 0.0 {
        return None;
    }
    let t = (-bh - disc.sqrt()) / a;
    (t > 0.0).then_some(t)
}
