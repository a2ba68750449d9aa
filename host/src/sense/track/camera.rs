//! The depth camera and the detection box of a scene, together: the
//! scene's own `[camera]` and `[tracking]` ([`crate::plan::scene::camera`]), or a
//! setup derived from its LM plane.

use serde::Serialize;

use crate::geom::{cross, scale, sub};
use crate::plan::scene::Scene;
pub use crate::plan::scene::camera::{CameraPose, TrackBox};

/// The depth camera and the detection box of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CameraSetup {
    /// Camera pose.
    pub camera: CameraPose,
    /// Detection box.
    pub track_box: TrackBox,
}

/// Default `min_points` when a setup is derived: a 1 × 1 cm pad seen at
/// ≈ 0.5 mm per pixel covers hundreds of pixels; 20 rejects specks.
pub const DEFAULT_MIN_POINTS: u32 = 20;

impl CameraSetup {
    /// The scene's setup, or an error saying what is missing.
    pub fn of_scene(scene: &Scene) -> Result<CameraSetup, crate::InputError> {
        match (scene.camera, scene.tracking) {
            (Some(camera), Some(track_box)) => Ok(CameraSetup { camera, track_box }),
            (None, _) => Err(crate::InputError::new(format!(
                "scene `{}` has no [camera] section (needed to track depth frames)",
                scene.name
            ))),
            (_, None) => Err(crate::InputError::new(format!(
                "scene `{}` has no [tracking] section (needed to track depth frames)",
                scene.name
            ))),
        }
    }

    /// The scene's setup, or one derived from its LM plane and centre: the
    /// paper's box (1 × 1 × 2 cm, from the marker surface at the centre to
    /// 2 cm behind it along −c, the finger coming from +c) and a camera
    /// 250 mm from the centre whose optical axis is c turned 60° towards b,
    /// so it sees the finger pad obliquely from in front of the display
    /// (the same construction as `scenes/paper.toml`).
    pub fn of_scene_or_default(scene: &Scene) -> CameraSetup {
        Self::of_scene(scene).unwrap_or_else(|_| Self::derived(scene))
    }

    /// The derived setup described at [`CameraSetup::of_scene_or_default`].
    pub fn derived(scene: &Scene) -> CameraSetup {
        let p = &scene.lm_plane;
        let (a, b, c) = (p.a, p.b, p.c);
        let track_box = TrackBox {
            center_mm: sub(scene.center_mm, scale(c, 10.0)),
            axes: [a, b, c],
            size_mm: [10.0, 10.0, 20.0],
            min_points: DEFAULT_MIN_POINTS,
        };
        // Optical axis: c turned 60° away from b, so the camera sits on the
        // wave's side of the pad and sees it 60° off its normal (for the
        // paper's plane: above the display, 10° under the horizontal).
        // Image right is −a so that image down points down in the scene.
        let (s, co) = (60f64.to_radians().sin(), 60f64.to_radians().cos());
        let forward = sub(scale(c, co), scale(b, s));
        let x_axis = scale(a, -1.0);
        let y_axis = cross(forward, x_axis);
        let camera = CameraPose {
            position_mm: sub(scene.center_mm, scale(forward, 250.0)),
            axes: [x_axis, y_axis, forward],
        };
        CameraSetup { camera, track_box }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{dot, norm};
    use crate::plan::scene::camera::frame;

    #[test]
    fn derived_rig_is_orthonormal_and_sees_the_box() {
        let scene = Scene::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/paper.toml"
        )))
        .unwrap();
        let d = CameraSetup::derived(&scene);
        assert!(frame(d.camera.axes, "t").is_ok());
        // paper.toml's setup is the derived one, written out.
        let r = CameraSetup::of_scene(&scene).unwrap();
        for k in 0..3 {
            for i in 0..3 {
                assert!((r.camera.axes[k][i] - d.camera.axes[k][i]).abs() < 1e-9);
                assert!((r.track_box.axes[k][i] - d.track_box.axes[k][i]).abs() < 1e-9);
            }
            assert!((r.camera.position_mm[k] - d.camera.position_mm[k]).abs() < 1e-9);
            assert!((r.track_box.center_mm[k] - d.track_box.center_mm[k]).abs() < 1e-9);
        }
        // Every corner is in front of the camera.
        for c in r.track_box.corners() {
            assert!(r.camera.to_camera(c)[2] > 200.0);
        }
        // The marker surface (scene centre) is on the box's front face.
        let m = sub(scene.center_mm, r.track_box.center_mm);
        assert!((dot(m, r.track_box.axes[2]) - 10.0).abs() < 1e-9);
        let p = r.camera.to_scene(r.camera.to_camera([1.0, 2.0, 3.0]));
        assert!(norm(sub(p, [1.0, 2.0, 3.0])) < 1e-9);
    }
}
