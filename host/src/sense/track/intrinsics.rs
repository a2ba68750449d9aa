//! Depth camera intrinsics (pinhole, no distortion) as TOML:
//!
//! ```toml
//! width = 848
//! height = 480
//! fx = 424.0        # focal lengths (pixels)
//! fy = 424.0
//! ppx = 424.0       # principal point (pixels)
//! ppy = 240.0
//! depth_scale = 0.001   # metres per depth unit
//! ```
//!
//! A pixel at column c, row r with depth Z (mm) is, in camera coordinates
//! (x right, y down, z forward), X = (c − ppx)/fx · Z, Y = (r − ppy)/fy · Z,
//! Z: librealsense's deprojection of an integer pixel without distortion.

use crate::InputError;

/// Pinhole intrinsics of the depth stream.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intrinsics {
    /// Frame width (pixels).
    pub width: u32,
    /// Frame height (pixels).
    pub height: u32,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point, column (pixels).
    pub ppx: f64,
    /// Principal point, row (pixels).
    pub ppy: f64,
    /// Metres per depth unit (the D4xx default is 0.001).
    pub depth_scale: f64,
}

/// Largest accepted focal length (pixels): a 8192-pixel-wide sensor
/// behind a lens with a 0.5° field of view.
pub const MAX_FOCAL_PX: f64 = 1e6;

impl Intrinsics {
    /// A D435 depth stream at 848 × 480 (≈ 87° horizontal field of view) with
    /// 100 µm depth units (the D4xx's depth units are settable; the
    /// synthetic finger uses these so quantisation stays below the noise).
    pub const D435_848X480: Intrinsics = Intrinsics {
        width: 848,
        height: 480,
        fx: 426.0,
        fy: 426.0,
        ppx: 423.5,
        ppy: 239.5,
        depth_scale: 0.0001,
    };

    /// Millimetres per depth unit.
    pub fn mm_per_unit(&self) -> f64 {
        self.depth_scale * 1000.0
    }

    /// Camera coordinates (mm) of pixel (`col`, `row`) at depth `z_mm`.
    pub fn deproject(&self, col: u32, row: u32, z_mm: f64) -> [f64; 3] {
        [
            (col as f64 - self.ppx) / self.fx * z_mm,
            (row as f64 - self.ppy) / self.fy * z_mm,
            z_mm,
        ]
    }

    /// Pixel coordinates (column, row) of a camera point with z > 0.
    pub fn project(&self, p: [f64; 3]) -> [f64; 2] {
        [
            p[0] / p[2] * self.fx + self.ppx,
            p[1] / p[2] * self.fy + self.ppy,
        ]
    }

    /// Check every field; `origin` names the file in the message.
    pub fn check(&self, origin: &str) -> Result<(), InputError> {
        let [w, h] = [self.width, self.height];
        check_pinhole([w, h], [self.fx, self.fy], [self.ppx, self.ppy])
            .map_err(|m| InputError::new(format!("intrinsics {origin}: {m}")))?;
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0 && self.depth_scale <= 1.0) {
            return Err(InputError::new(format!(
                "intrinsics {origin}: `depth_scale` must be in (0, 1] metres per unit, got {}",
                self.depth_scale
            )));
        }
        Ok(())
    }

    /// Error unless frames of `width` × `height` match these intrinsics.
    pub fn check_frames(&self, width: u32, height: u32, what: &str) -> Result<(), InputError> {
        if (width, height) != (self.width, self.height) {
            return Err(InputError::new(format!(
                "{what} has {width}×{height} frames but the intrinsics say {}×{}",
                self.width, self.height
            )));
        }
        Ok(())
    }
}

/// Checks a pinhole camera's image size, focal lengths and principal
/// point (the depth stream's and the colour stream's): why not, in words.
pub(super) fn check_pinhole(
    [width, height]: [u32; 2],
    focal: [f64; 2],
    principal: [f64; 2],
) -> Result<(), String> {
    let side = 1..=crate::npy::MAX_SIDE as u32;
    if !side.contains(&width) || !side.contains(&height) {
        return Err(format!(
            "width {width} and height {height} must be 1..={}",
            side.end()
        ));
    }
    for (name, v) in [("fx", focal[0]), ("fy", focal[1])] {
        if !(v.is_finite() && v > 0.0 && v <= MAX_FOCAL_PX) {
            return Err(format!(
                "`{name}` must be a positive number of pixels up to {MAX_FOCAL_PX}, got {}",
                crate::limits::show(v)
            ));
        }
    }
    // The principal point lies in the image (a camera's optical axis
    // meets its sensor); elsewhere is a typo, never a real camera.
    for (name, v, side) in [("ppx", principal[0], width), ("ppy", principal[1], height)] {
        if !(v.is_finite() && (0.0..=f64::from(side)).contains(&v)) {
            return Err(format!(
                "`{name}` must lie in the image, 0..={side} pixels, got {}",
                crate::limits::show(v)
            ));
        }
    }
    Ok(())
}

impl super::settings_file::SettingsFile for Intrinsics {
    const WHAT: &'static str = "intrinsics";

    fn check_values(&self, origin: &str) -> Result<(), InputError> {
        self.check(origin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sense::track::settings_file::SettingsFile as _;

    #[test]
    fn round_trips_and_rejects_bad_fields() {
        let i = Intrinsics::D435_848X480;
        assert_eq!(Intrinsics::from_toml(&i.to_toml(), "x").unwrap(), i);
        let bad = i.to_toml().replace("fx = 426.0", "fx = -1.0");
        let e = Intrinsics::from_toml(&bad, "cam.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`fx`") && e.contains("cam.toml"), "{e}");
        let e = Intrinsics::from_toml("width = 1", "c")
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing"), "{e}");
        assert!(i.check_frames(640, 480, "x").is_err());
    }

    #[test]
    fn deprojection_is_librealsense_pinhole() {
        let i = Intrinsics::D435_848X480;
        let p = i.deproject(100, 50, 300.0);
        assert!((p[0] - (100.0 - 423.5) / 426.0 * 300.0).abs() < 1e-12);
        assert!((p[1] - (50.0 - 239.5) / 426.0 * 300.0).abs() < 1e-12);
        let q = i.project(p);
        assert!((q[0] - 100.0).abs() < 1e-9 && (q[1] - 50.0).abs() < 1e-9);
    }
}
