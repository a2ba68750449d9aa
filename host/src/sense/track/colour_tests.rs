//! The colour stream: recordings replay with their colour frames, and the
//! projection of the LM circle lands on what the synthetic colour camera
//! renders of it.

use super::camera::CameraSetup;
use super::colour::{ColourCamera, Distortion};
use super::intrinsics::Intrinsics;
use super::overlay::ColourView;
use super::source::{FrameSource, Recorder, Replay, Synthetic, colour_beside};
use super::synth::{FingerSim, background_of};
use super::synth_colour::{ColourSim, MARKER_RADIUS_MM};
use crate::plan::scene::Scene;

fn paper() -> Scene {
    Scene::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/paper.toml"
    )))
    .unwrap()
}

/// A colour camera with a non-trivial placement and lens: turned 4° about
/// its y axis and 1.5° about x (column-major), 15 mm aside, and inverse
/// Brown-Conrady coefficients larger than a D4xx's.
fn skewed_camera() -> ColourCamera {
    let (sy, cy) = 4f64.to_radians().sin_cos();
    let (sx, cx) = 1.5f64.to_radians().sin_cos();
    // R = Rx · Ry, stored column by column.
    let r = [
        [cy, 0.0, -sy],
        [sx * sy, cx, sx * cy],
        [cx * sy, -sx, cx * cy],
    ];
    // Rows above; columns are r[.][k].
    let rotation = [
        r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], r[0][2], r[1][2], r[2][2],
    ];
    ColourCamera {
        model: Distortion::InverseBrownConrady,
        coeffs: [0.09, -0.21, 0.0012, -0.0009, 0.08],
        rotation,
        translation_m: [0.0148, 0.0004, -0.0011],
        ..ColourCamera::D435_848X480
    }
}

fn sim(scene: &Scene, cam: ColourCamera) -> (FingerSim, ColourSim) {
    let setup = CameraSetup::of_scene(scene).unwrap();
    let finger = FingerSim::new(setup, Intrinsics::D435_848X480, background_of(scene));
    let colour = ColourSim::new(cam, finger, scene.center_mm, scene.lm_plane);
    (finger, colour)
}

fn tmp(name: &str) -> crate::files::Scratch {
    crate::files::scratch_file("colour", name)
}

#[test]
fn colour_recordings_replay_with_their_frames() {
    let scene = paper();
    let (mut finger, colour) = sim(&scene, ColourCamera::D435_848X480);
    finger.window = Some(super::contact::Tracker::new(finger.intr, finger.setup).roi());
    let mut src = Synthetic::new(finger, 0.1).with_colour(colour, 3);
    let cam = src.colour_camera().unwrap();
    let p = tmp("rec.npy");
    let mut rec = Recorder::create(&p, finger.intr, Some(cam)).unwrap();
    let mut want = Vec::new();
    while let Some(f) = src.next_frame().unwrap() {
        rec.push(&f).unwrap();
        want.push((f.t_s, f.colour.clone()));
    }
    assert_eq!(rec.finish().unwrap(), 9);
    assert_eq!(want.iter().filter(|w| w.1.is_some()).count(), 3);
    for f in colour_beside(&p) {
        assert!(f.exists(), "{}", f.display());
    }
    let mut r = Replay::open_with_defaults(&p, None, None).unwrap();
    assert_eq!(r.colour_camera(), Some(cam));
    let mut got = Vec::new();
    while let Some(f) = r.next_frame().unwrap() {
        got.push((f.t_s, f.colour));
    }
    assert_eq!(got, want);
    // A colour stream whose camera is missing is refused, named.
    std::fs::remove_file(&colour_beside(&p)[1]).unwrap();
    let e = Replay::open_with_defaults(&p, None, None).err().unwrap();
    assert!(e.to_string().contains("colour.toml"), "{e}");
}

/// The acceptance bar of issue 27: the LM circle projected through the
/// pose, the extrinsics and the lens lies within 1 px of where the
/// synthetic colour camera (ray-cast per pixel through the inverse of
/// each step) draws the same circle, at 848 × 480.
#[test]
fn projected_circle_is_within_a_pixel_of_the_rendered_one() {
    let scene = paper();
    for cam in [ColourCamera::D435_848X480, skewed_camera()] {
        let (finger, colour) = sim(&scene, cam);
        let mut rgb = Vec::new();
        colour.render(None, &mut rgb);
        let view = ColourView {
            pose: finger.setup.camera,
            cam,
        };
        let curve = view.circle(scene.center_mm, &scene.lm_plane, MARKER_RADIUS_MM, 2048);
        let c = view.pixel(scene.center_mm).unwrap();
        let is_marker = |x: f64, y: f64| {
            let (u, v) = (x.round() as i64, y.round() as i64);
            if u < 0
                || v < 0
                || u >= i64::from(cam.pinhole.width)
                || v >= i64::from(cam.pinhole.height)
            {
                return false;
            }
            let i = (v as usize * cam.pinhole.width as usize + u as usize) * 3;
            rgb[i..i + 3] == [205, 228, 200]
        };
        let mut worst: f64 = 0.0;
        for k in 0..360 {
            let th = (k as f64).to_radians();
            let (dx, dy) = (th.cos(), th.sin());
            // The projected curve's radius in this direction.
            let want = curve
                .iter()
                .map(|p| {
                    let (px, py) = (p[0] - c[0], p[1] - c[1]);
                    let ang = (px * dy - py * dx).atan2(px * dx + py * dy).abs();
                    (ang, (px * px + py * py).sqrt())
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap()
                .1;
            // Radii (px) along it where the ring is drawn; the cross's
            // arms (a quarter of the radius) stay inside half of it.
            let hits: Vec<f64> = (0..1200)
                .map(|s| s as f64 * 0.1)
                .filter(|&s| s > want / 2.0 && is_marker(c[0] + s * dx, c[1] + s * dy))
                .collect();
            assert!(!hits.is_empty(), "no ring at {k}°");
            let drawn = hits.iter().sum::<f64>() / hits.len() as f64;
            worst = worst.max((drawn - want).abs());
        }
        assert!(
            worst <= 1.0,
            "{:?}: ring {worst:.3} px off the projection",
            cam.model
        );
        // The crop holds the whole circle.
        let [x0, y0, side] = view.crop(scene.center_mm, &scene.lm_plane, 15.0);
        assert!(
            curve
                .iter()
                .all(|p| p[0] >= x0 && p[0] <= x0 + side && p[1] >= y0 && p[1] <= y0 + side)
        );
    }
}
