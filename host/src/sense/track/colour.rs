//! The colour camera beside the depth camera: its intrinsics with
//! librealsense's distortion models, the depth → colour extrinsics, and
//! the projection of a scene point into the colour image.
//!
//! As TOML (`REC.colour.toml` beside a recording; the `LMCOLOR1` stream's
//! header carries the same values):
//!
//! ```toml
//! width = 848
//! height = 480
//! fx = 613.0                       # focal lengths (pixels)
//! fy = 613.0
//! ppx = 423.5                      # principal point (pixels)
//! ppy = 239.5
//! model = "inverse_brown_conrady"  # none, brown_conrady, modified_brown_conrady, inverse_brown_conrady
//! coeffs = [0.0, 0.0, 0.0, 0.0, 0.0]   # k1, k2, p1, p2, k3 (librealsense's order)
//! rotation = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]   # depth → colour, column-major
//! translation_m = [0.015, 0.0, 0.0]    # depth → colour (metres)
//! ```
//!
//! The values are librealsense's own (`rs2_intrinsics` of the colour
//! stream, `rs2_extrinsics` from the depth stream to it, read by the
//! bridge with `get_extrinsics_to`), so they are stored as it reports
//! them: the rotation column-major (`rs2_transform_point_to_point` computes
//! `to[0] = r[0]·x + r[3]·y + r[6]·z + t[0]`) and the translation in
//! metres; the host converts to millimetres in [`ColourCamera::from_depth`].
//!
//! Projection is librealsense's `rs2_project_point_to_pixel`
//! (`src/rs.cpp`): for the modified and the inverse Brown-Conrady model
//! the radial factor is applied first and the tangential terms use the
//! scaled x, y; for Brown-Conrady the tangential terms use the unscaled
//! ones. The D4xx colour stream reports inverse Brown-Conrady (its
//! coefficients often all zero); the F-theta and Kannala-Brandt models
//! (fisheye lenses, not on a D4xx colour sensor) are refused.

use super::intrinsics::Pinhole;
use crate::InputError;
use crate::geom::Vec3;

/// librealsense's distortion models (`rs2_distortion`) this host projects
/// through.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Distortion {
    /// `RS2_DISTORTION_NONE` (0): a pinhole.
    None,
    /// `RS2_DISTORTION_MODIFIED_BROWN_CONRADY` (1).
    ModifiedBrownConrady,
    /// `RS2_DISTORTION_INVERSE_BROWN_CONRADY` (2): the D4xx colour stream.
    InverseBrownConrady,
    /// `RS2_DISTORTION_BROWN_CONRADY` (4).
    BrownConrady,
}

impl Distortion {
    /// The model of librealsense's enum value `v`, or why it is refused.
    pub fn from_rs2(v: u32) -> Result<Self, String> {
        match v {
            0 => Ok(Self::None),
            1 => Ok(Self::ModifiedBrownConrady),
            2 => Ok(Self::InverseBrownConrady),
            4 => Ok(Self::BrownConrady),
            3 | 5 => Err(format!(
                "distortion model {v} (a fisheye model) is not supported: lmhost projects through none, Brown-Conrady and its modified and inverse forms"
            )),
            _ => Err(format!("distortion model {v} is not one of librealsense's")),
        }
    }

    /// librealsense's enum value.
    pub fn to_rs2(self) -> u32 {
        match self {
            Self::None => 0,
            Self::ModifiedBrownConrady => 1,
            Self::InverseBrownConrady => 2,
            Self::BrownConrady => 4,
        }
    }
}

/// The colour stream's intrinsics and where it sits relative to the depth
/// camera.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "ColourFile")]
pub struct ColourCamera {
    /// Image size, focal lengths, principal point.
    #[serde(flatten)]
    pub pinhole: Pinhole,
    /// Distortion model.
    pub model: Distortion,
    /// k1, k2, p1, p2, k3.
    pub coeffs: [f64; 5],
    /// Depth → colour rotation, column-major (librealsense's layout).
    pub rotation: [f64; 9],
    /// Depth → colour translation (metres, librealsense's unit).
    pub translation_m: [f64; 3],
}

/// [`ColourCamera`] as the file spells it, flat (as `IntrinsicsFile`:
/// errors keep their line and key) and with arrays of exactly their length.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ColourFile {
    // Any number, refused in the frame's range (not a `u32`'s).
    width: crate::whole::Whole<1, { crate::npy::MAX_SIDE }>,
    height: crate::whole::Whole<1, { crate::npy::MAX_SIDE }>,
    fx: f64,
    fy: f64,
    ppx: f64,
    ppy: f64,
    model: Distortion,
    #[serde(deserialize_with = "crate::geom::exact::array")]
    coeffs: [f64; 5],
    #[serde(deserialize_with = "crate::geom::exact::array")]
    rotation: [f64; 9],
    #[serde(deserialize_with = "crate::geom::exact::array")]
    translation_m: [f64; 3],
}

impl From<ColourFile> for ColourCamera {
    fn from(f: ColourFile) -> Self {
        ColourCamera {
            pinhole: Pinhole::new(f.width.get(), f.height.get(), f.fx, f.fy, f.ppx, f.ppy),
            model: f.model,
            coeffs: f.coeffs,
            rotation: f.rotation,
            translation_m: f.translation_m,
        }
    }
}

/// Largest accepted |coefficient|: real lenses stay well below 1; larger
/// values fold the image over itself within the frame.
pub const MAX_COEFF: f64 = 10.0;

impl ColourCamera {
    /// A D435's colour stream at 848 × 480 (≈ 69° horizontal field of
    /// view), 15 mm beside the depth camera's origin, without distortion
    /// (what a D435 reports for it).
    pub const D435_848X480: ColourCamera = ColourCamera {
        pinhole: Pinhole::d435_848x480(613.0),
        model: Distortion::InverseBrownConrady,
        coeffs: [0.0; 5],
        rotation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        translation_m: [0.015, 0.0, 0.0],
    };

    /// A point in depth-camera coordinates (mm) in colour-camera
    /// coordinates (mm): `rs2_transform_point_to_point`.
    pub fn from_depth(&self, p: Vec3) -> Vec3 {
        let r = &self.rotation;
        let t = self.translation_m.map(|v| v * 1000.0);
        [
            r[0] * p[0] + r[3] * p[1] + r[6] * p[2] + t[0],
            r[1] * p[0] + r[4] * p[1] + r[7] * p[2] + t[1],
            r[2] * p[0] + r[5] * p[1] + r[8] * p[2] + t[2],
        ]
    }

    /// A point in colour-camera coordinates (mm) in depth-camera
    /// coordinates (mm): the inverse of [`from_depth`](Self::from_depth)
    /// (the rotation is orthonormal, so its inverse is its transpose).
    pub fn to_depth(&self, p: Vec3) -> Vec3 {
        let r = &self.rotation;
        let t = self.translation_m.map(|v| v * 1000.0);
        let q = [p[0] - t[0], p[1] - t[1], p[2] - t[2]];
        [
            r[0] * q[0] + r[1] * q[1] + r[2] * q[2],
            r[3] * q[0] + r[4] * q[1] + r[5] * q[2],
            r[6] * q[0] + r[7] * q[1] + r[8] * q[2],
        ]
    }

    /// The distorted normalised coordinates of the normalised point (x, y)
    /// (x = X/Z, y = Y/Z): the model's part of `rs2_project_point_to_pixel`.
    pub fn distort(&self, x: f64, y: f64) -> [f64; 2] {
        let [k1, k2, p1, p2, k3] = self.coeffs;
        let r2 = x * x + y * y;
        let f = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        match self.model {
            Distortion::None => [x, y],
            Distortion::ModifiedBrownConrady | Distortion::InverseBrownConrady => {
                let (x, y) = (x * f, y * f);
                [
                    x + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                    y + 2.0 * p2 * x * y + p1 * (r2 + 2.0 * y * y),
                ]
            }
            Distortion::BrownConrady => [
                x * f + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                y * f + 2.0 * p2 * x * y + p1 * (r2 + 2.0 * y * y),
            ],
        }
    }

    /// Pixel (column, row) of a colour-camera point (mm, z > 0):
    /// `rs2_project_point_to_pixel`. `None` behind the camera.
    pub fn project(&self, p: Vec3) -> Option<[f64; 2]> {
        if p[2].is_nan() || p[2] <= 0.0 {
            return None;
        }
        let xy = self.distort(p[0] / p[2], p[1] / p[2]);
        Some(self.pinhole.to_pixel(xy))
    }

    /// Pixel of a depth-camera point (mm): through the extrinsics, then
    /// [`project`](Self::project).
    pub fn project_from_depth(&self, p: Vec3) -> Option<[f64; 2]> {
        self.project(self.from_depth(p))
    }

    /// The colour-camera ray (z = 1) that projects to pixel (`u`, `v`):
    /// the distortion inverted by Newton's method on this model's own
    /// [`distort`](Self::distort), so a render through it and
    /// [`project`](Self::project) agree to far below a pixel.
    /// (librealsense's closed-form deprojection of the inverse model is
    /// only an approximate inverse of its projection; for the zero
    /// coefficients a D435 reports both are the pinhole.)
    pub fn ray(&self, u: f64, v: f64) -> Vec3 {
        let [xd, yd] = self.pinhole.normalised(u, v);
        let (mut x, mut y) = (xd, yd);
        if self.model != Distortion::None {
            for _ in 0..20 {
                let [fx, fy] = self.distort(x, y);
                let (ex, ey) = (fx - xd, fy - yd);
                if ex.abs() < 1e-12 && ey.abs() < 1e-12 {
                    break;
                }
                // Numeric Jacobian: the model is smooth and cheap.
                let h = 1e-7;
                let [ax, ay] = self.distort(x + h, y);
                let [bx, by] = self.distort(x, y + h);
                let (j00, j10, j01, j11) =
                    ((ax - fx) / h, (ay - fy) / h, (bx - fx) / h, (by - fy) / h);
                let det = j00 * j11 - j01 * j10;
                if det.abs() < 1e-12 {
                    break;
                }
                x -= (j11 * ex - j01 * ey) / det;
                y -= (-j10 * ex + j00 * ey) / det;
            }
        }
        [x, y, 1.0]
    }

    /// Bytes of an RGB image of this camera's size.
    pub fn image_bytes(&self) -> usize {
        self.pinhole.width as usize * self.pinhole.height as usize * 3
    }
}

/// One colour image: 8-bit RGB, row-major, shared between its readers
/// (the recorder, the view's encoder) without copying.
#[derive(Debug, Clone, PartialEq)]
pub struct ColourImage {
    /// Time stamp (s, the depth frames' clock).
    pub t_s: f64,
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// width × height × 3 bytes.
    pub rgb: std::sync::Arc<Vec<u8>>,
}

impl super::settings_file::SettingsFile for ColourCamera {
    const WHAT: &'static str = "colour camera";
    const KIND: &'static crate::files::kind::Kind = &crate::files::kind::COLOUR_CAMERA;

    /// Every field; `origin` names the source in the message.
    fn check(&self, origin: &str) -> Result<(), InputError> {
        let bad = |m: String| InputError::new(format!("colour camera {origin}: {m}"));
        self.pinhole.check().map_err(bad)?;
        if let Some(v) = self
            .coeffs
            .iter()
            .find(|v| !(v.is_finite() && v.abs() <= MAX_COEFF))
        {
            return Err(bad(format!(
                "`coeffs` must be numbers within ±{MAX_COEFF}, got {}",
                crate::limits::show(*v)
            )));
        }
        if let Some(v) = self
            .translation_m
            .iter()
            .find(|v| !(v.is_finite() && v.abs() <= 1.0))
        {
            return Err(bad(format!(
                "`translation_m` must be within ±1 m on each axis, got {}",
                crate::limits::show(*v)
            )));
        }
        // A rotation: orthonormal columns, determinant +1 (a mirror or a
        // row-major matrix read as column-major of a non-rotation is refused).
        let r = &self.rotation;
        let col = |k: usize| [r[3 * k], r[3 * k + 1], r[3 * k + 2]];
        let ok = r.iter().all(|v| v.is_finite())
            && (0..3).all(|k| (crate::geom::norm(col(k)) - 1.0).abs() < 1e-3)
            && crate::geom::dot(col(0), col(1)).abs() < 1e-3
            && crate::geom::dot(col(0), col(2)).abs() < 1e-3
            && crate::geom::dot(col(1), col(2)).abs() < 1e-3
            && crate::geom::dot(crate::geom::cross(col(0), col(1)), col(2)) > 0.0;
        if !ok {
            return Err(bad(
                "`rotation` must be a rotation matrix (9 numbers, column-major, orthonormal, determinant +1)"
                    .into(),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sense::track::settings_file::SettingsFile as _;

    fn rotated(deg: f64) -> ColourCamera {
        // A rotation about y by `deg`, written column-major.
        let (s, c) = deg.to_radians().sin_cos();
        ColourCamera {
            rotation: [c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c],
            translation_m: [0.015, -0.002, 0.001],
            model: Distortion::InverseBrownConrady,
            coeffs: [0.12, -0.25, 0.001, -0.0015, 0.1],
            ..ColourCamera::D435_848X480
        }
    }

    #[test]
    fn projection_is_librealsense_formula() {
        // Expected values from rs2_project_point_to_pixel's formulas,
        // evaluated by hand for one point.
        let cam = rotated(0.0);
        let p = [30.0, -20.0, 250.0];
        let (x, y) = (p[0] / p[2], p[1] / p[2]);
        let [k1, k2, p1, p2, k3] = cam.coeffs;
        let r2 = x * x + y * y;
        let f = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        let (xs, ys) = (x * f, y * f);
        let dx = xs + 2.0 * p1 * xs * ys + p2 * (r2 + 2.0 * xs * xs);
        let dy = ys + 2.0 * p2 * xs * ys + p1 * (r2 + 2.0 * ys * ys);
        let px = cam.project(p).unwrap();
        assert!((px[0] - (dx * 613.0 + 423.5)).abs() < 1e-9);
        assert!((px[1] - (dy * 613.0 + 239.5)).abs() < 1e-9);
        // Brown-Conrady differs: tangential terms on the unscaled x, y.
        let bc = ColourCamera {
            model: Distortion::BrownConrady,
            ..cam
        };
        let dx = x * f + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        assert!((bc.project(p).unwrap()[0] - (dx * 613.0 + 423.5)).abs() < 1e-9);
        assert!(cam.project([0.0, 0.0, -1.0]).is_none());
    }

    #[test]
    fn extrinsics_are_column_major_and_invert() {
        let cam = rotated(10.0);
        // The first column is where the depth camera's x axis goes.
        let q = cam.from_depth([1.0, 0.0, 0.0]);
        let t = [15.0, -2.0, 1.0];
        let (s, c) = 10f64.to_radians().sin_cos();
        assert!((q[0] - (c + t[0])).abs() < 1e-12 && (q[2] - (-s + t[2])).abs() < 1e-12);
        let p = [12.0, -7.0, 260.0];
        let back = cam.to_depth(cam.from_depth(p));
        assert!(crate::geom::norm(crate::geom::sub(back, p)) < 1e-9);
    }

    #[test]
    fn rays_invert_the_projection() {
        for model in [
            Distortion::None,
            Distortion::BrownConrady,
            Distortion::ModifiedBrownConrady,
            Distortion::InverseBrownConrady,
        ] {
            let cam = ColourCamera {
                model,
                ..rotated(3.0)
            };
            for (u, v) in [(0.0, 0.0), (847.0, 479.0), (423.5, 239.5), (100.0, 400.0)] {
                let r = cam.ray(u, v);
                let px = cam.project(crate::geom::scale(r, 300.0)).unwrap();
                assert!(
                    (px[0] - u).abs() < 1e-6 && (px[1] - v).abs() < 1e-6,
                    "{model:?} ({u}, {v}) -> {px:?}"
                );
            }
        }
    }

    #[test]
    fn toml_round_trips_and_bad_fields_are_input_errors() {
        let cam = rotated(5.0);
        assert_eq!(ColourCamera::from_toml(&cam.to_toml(), "x").unwrap(), cam);
        let mirror = ColourCamera {
            rotation: [-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            ..cam
        };
        let e = ColourCamera::from_toml(&mirror.to_toml(), "c.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`rotation`") && e.contains("c.toml"), "{e}");
        let e = ColourCamera::from_toml(
            &cam.to_toml().replace("inverse_brown_conrady", "ftheta"),
            "c",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("model") || e.contains("variant"), "{e}");
        assert!(Distortion::from_rs2(3).unwrap_err().contains("fisheye"));
        assert_eq!(Distortion::from_rs2(2), Ok(Distortion::InverseBrownConrady));
        let far = ColourCamera {
            translation_m: [2.0, 0.0, 0.0],
            ..cam
        };
        assert!(far.check("x").is_err());
    }
}
