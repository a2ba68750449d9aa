//! The scene's `[camera]` and `[tracking]` sections: where the depth camera
//! sits and the detection box the contact area is measured in.
//!
//! ```toml
//! [camera]                       # the camera's axes in scene coordinates
//! position_mm = [0, 276.2, 73.4]
//! x_axis = [-1, 0, 0]            # image right
//! y_axis = [0, 0.174, -0.985]    # image down
//! z_axis = [0, -0.985, -0.174]   # forward (optical axis)
//!
//! [tracking]
//! box_center_mm = [0, 36.43, 22.34]
//! box_axes = [[1, 0, 0], [0, 0.766, 0.643], [0, -0.643, 0.766]]
//! box_size_mm = [10, 10, 20]     # full extent along each axis
//! min_points = 20                # contact area present at ≥ this many points
//! ```
//!
//! Axes must be unit vectors (within 1e-6), mutually orthogonal (within
//! 1e-6) and right-handed (x × y = z); nothing is normalised silently.

use serde::{Deserialize, Serialize};

use crate::geom::{Vec3, add, cross, dot, norm, scale, sub};
use crate::scene::Scene;

/// Tolerance on unit length and orthogonality of given axes.
pub const AXIS_TOL: f64 = 1e-6;

/// `[camera]` as written in the scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    position_mm: Vec3,
    x_axis: Vec3,
    y_axis: Vec3,
    z_axis: Vec3,
}

/// `[tracking]` as written in the scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackingFile {
    box_center_mm: Vec3,
    box_axes: [Vec3; 3],
    box_size_mm: Vec3,
    min_points: u32,
}

/// The depth camera's pose: camera coordinates (x right, y down, z forward,
/// mm) to scene coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CameraPose {
    /// Optical centre in the scene (mm).
    pub position_mm: Vec3,
    /// Camera x (right), y (down), z (forward) in scene coordinates.
    pub axes: [Vec3; 3],
}

impl CameraPose {
    /// A camera point (mm) in scene coordinates.
    pub fn to_scene(&self, p: Vec3) -> Vec3 {
        let mut out = self.position_mm;
        for (axis, &c) in self.axes.iter().zip(&p) {
            out = add(out, scale(*axis, c));
        }
        out
    }

    /// A scene point (mm) in camera coordinates.
    pub fn to_camera(&self, p: Vec3) -> Vec3 {
        let d = sub(p, self.position_mm);
        self.axes.map(|a| dot(a, d))
    }
}

/// The detection box: an oriented box in the scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackBox {
    /// Centre (mm, scene).
    pub center_mm: Vec3,
    /// The box's three axes (unit, orthogonal, right-handed).
    pub axes: [Vec3; 3],
    /// Full extent along each axis (mm), centred on `center_mm`.
    pub size_mm: Vec3,
    /// The contact area is present when at least this many points fall inside.
    pub min_points: u32,
}

impl TrackBox {
    /// Whether a scene point lies inside (faces included).
    pub fn contains(&self, p: Vec3) -> bool {
        let d = sub(p, self.center_mm);
        self.axes
            .iter()
            .zip(&self.size_mm)
            .all(|(a, s)| dot(*a, d).abs() <= s / 2.0)
    }

    /// The eight corners (mm, scene).
    pub fn corners(&self) -> [Vec3; 8] {
        let mut out = [[0.0; 3]; 8];
        for (i, c) in out.iter_mut().enumerate() {
            let mut p = self.center_mm;
            for k in 0..3 {
                let sign = if i >> k & 1 == 1 { 0.5 } else { -0.5 };
                p = add(p, scale(self.axes[k], sign * self.size_mm[k]));
            }
            *c = p;
        }
        out
    }
}

/// The depth camera and the detection box of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Rig {
    /// Camera pose.
    pub camera: CameraPose,
    /// Detection box.
    pub track_box: TrackBox,
}

/// Default `min_points` when a rig is derived: a 1 × 1 cm pad seen at
/// ≈ 0.5 mm per pixel covers hundreds of pixels; 20 rejects specks.
pub const DEFAULT_MIN_POINTS: u32 = 20;

impl Rig {
    /// The scene's rig, or an error saying what is missing.
    pub fn of_scene(scene: &Scene) -> Result<Rig, crate::InputError> {
        match (scene.camera, scene.tracking) {
            (Some(camera), Some(track_box)) => Ok(Rig { camera, track_box }),
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

    /// The scene's rig, or one derived from its LM plane and centre: the
    /// paper's box (1 × 1 × 2 cm, from the marker surface at the centre to
    /// 2 cm behind it along −c, the finger coming from +c) and a camera
    /// 250 mm from the centre whose optical axis is c turned 60° towards b,
    /// so it sees the finger pad obliquely from in front of the display
    /// (the same construction as `scenes/paper.toml`).
    pub fn of_scene_or_default(scene: &Scene) -> Rig {
        Self::of_scene(scene).unwrap_or_else(|_| Self::derived(scene))
    }

    /// The derived rig described at [`Rig::of_scene_or_default`].
    pub fn derived(scene: &Scene) -> Rig {
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
        Rig { camera, track_box }
    }
}

fn finite(v: Vec3, field: &str) -> Result<Vec3, String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(format!("field `{field}` must be finite, got {v:?}"))
    }
}

/// Check three axes are unit, orthogonal and right-handed.
fn frame(axes: [Vec3; 3], field: &str) -> Result<[Vec3; 3], String> {
    for (i, a) in axes.iter().enumerate() {
        finite(*a, field)?;
        if (norm(*a) - 1.0).abs() > AXIS_TOL {
            return Err(format!(
                "field `{field}`: axis {i} has length {}, must be 1 (within {AXIS_TOL})",
                norm(*a)
            ));
        }
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let d = dot(axes[i], axes[j]);
        if d.abs() > AXIS_TOL {
            return Err(format!(
                "field `{field}`: axes {i} and {j} are not orthogonal (dot {d:.3e})"
            ));
        }
    }
    if dot(cross(axes[0], axes[1]), axes[2]) < 0.0 {
        return Err(format!(
            "field `{field}`: axes must be right-handed (x × y = z)"
        ));
    }
    Ok(axes)
}

/// Resolve the optional sections (called by the scene loader).
pub fn resolve(
    camera: Option<CameraFile>,
    tracking: Option<TrackingFile>,
) -> Result<(Option<CameraPose>, Option<TrackBox>), String> {
    let camera = camera
        .map(|c| -> Result<CameraPose, String> {
            Ok(CameraPose {
                position_mm: finite(c.position_mm, "camera.position_mm")?,
                axes: frame(
                    [c.x_axis, c.y_axis, c.z_axis],
                    "camera.x_axis/y_axis/z_axis",
                )?,
            })
        })
        .transpose()?;
    let tracking = tracking
        .map(|t| -> Result<TrackBox, String> {
            let size = finite(t.box_size_mm, "tracking.box_size_mm")?;
            if size.iter().any(|s| !(*s > 0.0 && *s <= 1000.0)) {
                return Err(format!(
                    "field `tracking.box_size_mm` must be in (0, 1000] mm on every axis, got {size:?}"
                ));
            }
            if t.min_points == 0 {
                return Err("field `tracking.min_points` must be at least 1".into());
            }
            Ok(TrackBox {
                center_mm: finite(t.box_center_mm, "tracking.box_center_mm")?,
                axes: frame(t.box_axes, "tracking.box_axes")?,
                size_mm: size,
                min_points: t.min_points,
            })
        })
        .transpose()?;
    Ok((camera, tracking))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_rig_is_orthonormal_and_sees_the_box() {
        let scene = Scene::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/paper.toml"
        )))
        .unwrap();
        let d = Rig::derived(&scene);
        assert!(frame(d.camera.axes, "t").is_ok());
        // paper.toml's rig is the derived one, written out.
        let r = Rig::of_scene(&scene).unwrap();
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

    #[test]
    fn bad_sections_say_which_field() {
        let base =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml"))
                .unwrap();
        let bad = base.replace("x_axis = [-1.0, 0.0, 0.0]", "x_axis = [-1.0, 0.1, 0.0]");
        assert_ne!(bad, base);
        let e = Scene::from_toml(&bad, "p").unwrap_err().to_string();
        assert!(e.contains("camera.x_axis"), "{e}");
        let bad = base.replace("min_points = 20", "min_points = 0");
        let e = Scene::from_toml(&bad, "p").unwrap_err().to_string();
        assert!(e.contains("min_points"), "{e}");
        let bad = base.replace(
            "box_size_mm = [10.0, 10.0, 20.0]",
            "box_size_mm = [10.0, -1.0, 20.0]",
        );
        let e = Scene::from_toml(&bad, "p").unwrap_err().to_string();
        assert!(e.contains("box_size_mm"), "{e}");
    }
}
