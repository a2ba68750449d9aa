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

use super::finite3;
use crate::geom::{Vec3, add, cross, dot, norm, scale, sub};

/// Tolerance on unit length and orthogonality of given axes.
pub const AXIS_TOL: f64 = 1e-6;

/// `[camera]` as written in the scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraFile {
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    position_mm: Vec3,
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    x_axis: Vec3,
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    y_axis: Vec3,
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    z_axis: Vec3,
}

/// `[tracking]` as written in the scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TrackingFile {
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    box_center_mm: Vec3,
    #[serde(deserialize_with = "crate::geom::exact::axes")]
    box_axes: [Vec3; 3],
    #[serde(deserialize_with = "crate::geom::exact::vec3")]
    box_size_mm: Vec3,
    /// At least 1, at most a frame's pixels; any number refused so.
    min_points: crate::whole::Whole<1, MAX_MIN_POINTS>,
}

/// Most points a contact area can hold: every pixel of the largest frame.
const MAX_MIN_POINTS: u64 = crate::npy::MAX_SIDE * crate::npy::MAX_SIDE;

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

/// Check three axes are unit, orthogonal and right-handed.
pub(crate) fn frame(axes: [Vec3; 3], field: &str) -> Result<[Vec3; 3], String> {
    for (i, a) in axes.iter().enumerate() {
        finite3(*a, field)?;
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
pub(super) fn resolve(
    camera: Option<CameraFile>,
    tracking: Option<TrackingFile>,
) -> Result<(Option<CameraPose>, Option<TrackBox>), String> {
    let camera = camera
        .map(|c| -> Result<CameraPose, String> {
            Ok(CameraPose {
                position_mm: crate::limits::position_mm(
                    "field `camera.position_mm`",
                    finite3(c.position_mm, "camera.position_mm")?,
                )
                .map_err(|e| e.0)?,
                axes: frame(
                    [c.x_axis, c.y_axis, c.z_axis],
                    "camera.x_axis/y_axis/z_axis",
                )?,
            })
        })
        .transpose()?;
    let tracking = tracking
        .map(|t| -> Result<TrackBox, String> {
            let size = finite3(t.box_size_mm, "tracking.box_size_mm")?;
            if size.iter().any(|s| !(*s > 0.0 && *s <= 1000.0)) {
                return Err(format!(
                    "field `tracking.box_size_mm` must be in (0, 1000] mm on every axis, got {size:?}"
                ));
            }
            Ok(TrackBox {
                center_mm: crate::limits::position_mm(
                    "field `tracking.box_center_mm`",
                    finite3(t.box_center_mm, "tracking.box_center_mm")?,
                )
                .map_err(|e| e.0)?,
                axes: frame(t.box_axes, "tracking.box_axes")?,
                size_mm: size,
                min_points: t.min_points.get(),
            })
        })
        .transpose()?;
    Ok((camera, tracking))
}

#[cfg(test)]
mod tests {
    use super::super::Scene;

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

    #[test]
    fn vectors_are_exactly_three_numbers_and_positions_in_range() {
        let base =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml"))
                .unwrap();
        for (from, to, want) in [
            // The TOML reader would keep [1, 0, 0] of these without a word.
            (
                "x_axis = [-1.0, 0.0, 0.0]",
                "x_axis = [-1.0, 0.0, 0.0, 5.0]",
                "invalid length 4",
            ),
            (
                "box_axes = [[1.0, 0.0, 0.0],",
                "box_axes = [[1.0, 0.0, 0.0, 0.0],",
                "length 4",
            ),
            (
                "center_mm = [0.0, 30.0, 30.0]",
                "center_mm = [0.0, 30.0, 30.0, 9.0]",
                "center_mm",
            ),
            (
                "position_mm = [0.0, 276",
                "position_mm = [1e300, 276",
                "camera.position_mm",
            ),
            (
                "box_center_mm = [0.0,",
                "box_center_mm = [-1e9,",
                "tracking.box_center_mm",
            ),
            (
                "sound_speed_m_s = 340.0",
                "sound_speed_m_s = 1e300",
                "100-2000 m/s",
            ),
        ] {
            let bad = base.replacen(from, to, 1);
            assert_ne!(bad, base, "{from}");
            let e = Scene::from_toml(&bad, "p").unwrap_err().to_string();
            assert!(e.contains(want), "{to}: {e}");
        }
    }
}
