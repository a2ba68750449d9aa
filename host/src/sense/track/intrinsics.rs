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

/// A pinhole camera's image size, focal lengths and principal point: the
/// part the depth stream and the colour stream share (in their TOML files,
/// these keys at the top level).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Pinhole {
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
}

impl Pinhole {
    /// From a file's flat fields, in the order the files list them.
    pub const fn new(width: u32, height: u32, fx: f64, fy: f64, ppx: f64, ppy: f64) -> Self {
        Self {
            width,
            height,
            fx,
            fy,
            ppx,
            ppy,
        }
    }

    /// A D435 stream at 848 × 480 with focal length `f` (pixels) in both
    /// axes and the principal point at the frame's centre: the frame both
    /// the depth and the colour stream's defaults share; only their field
    /// of view (`f`) differs.
    pub const fn d435_848x480(f: f64) -> Self {
        Self::new(848, 480, f, f, 423.5, 239.5)
    }

    /// Pixel (column, row) of the normalised image point (x, y) = (X/Z, Y/Z).
    pub fn to_pixel(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        [x * self.fx + self.ppx, y * self.fy + self.ppy]
    }

    /// The normalised image point (X/Z, Y/Z) of pixel (`u`, `v`): the
    /// inverse of [`to_pixel`](Self::to_pixel).
    pub fn normalised(&self, u: f64, v: f64) -> [f64; 2] {
        [(u - self.ppx) / self.fx, (v - self.ppy) / self.fy]
    }

    /// Checks the image size, focal lengths and principal point: why not,
    /// in words.
    pub fn check(&self) -> Result<(), String> {
        let [width, height] = [self.width, self.height];
        let side = 1..=crate::npy::MAX_SIDE as u32;
        if !side.contains(&width) || !side.contains(&height) {
            return Err(format!(
                "width {width} and height {height} must be 1..={}",
                side.end()
            ));
        }
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && (MIN_FOCAL_PX..=MAX_FOCAL_PX).contains(&v)) {
                return Err(format!(
                    "`{name}` must be a focal length of {MIN_FOCAL_PX}..={MAX_FOCAL_PX} pixels, got {}",
                    crate::limits::show(v)
                ));
            }
        }
        // The principal point lies in the image (a camera's optical axis
        // meets its sensor); elsewhere is a typo, never a real camera.
        for (name, v, side) in [("ppx", self.ppx, width), ("ppy", self.ppy, height)] {
            if !(v.is_finite() && (0.0..=f64::from(side)).contains(&v)) {
                return Err(format!(
                    "`{name}` must lie in the image, 0..={side} pixels, got {}",
                    crate::limits::show(v)
                ));
            }
        }
        Ok(())
    }
}

/// Intrinsics of the depth stream: a pinhole and its depth units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "IntrinsicsFile")]
pub struct Intrinsics {
    /// Image size, focal lengths, principal point.
    #[serde(flatten)]
    pub pinhole: Pinhole,
    /// Metres per depth unit (the D4xx default is 0.001).
    pub depth_scale: f64,
}

/// [`Intrinsics`] as the file spells it, flat: read without
/// `serde(flatten)`, whose errors lose the line and the key of a bad value.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct IntrinsicsFile {
    // Any number, refused in the frame's range (not a `u32`'s).
    width: crate::whole::Whole<1, { crate::npy::MAX_SIDE }>,
    height: crate::whole::Whole<1, { crate::npy::MAX_SIDE }>,
    fx: f64,
    fy: f64,
    ppx: f64,
    ppy: f64,
    depth_scale: f64,
}

impl From<IntrinsicsFile> for Intrinsics {
    fn from(f: IntrinsicsFile) -> Self {
        Intrinsics {
            pinhole: Pinhole::new(f.width.get(), f.height.get(), f.fx, f.fy, f.ppx, f.ppy),
            depth_scale: f.depth_scale,
        }
    }
}

/// Smallest accepted focal length (pixels): at 1 px even an 848-pixel
/// frame would span 179.7°, wider than any depth camera's fisheye (the
/// widest see about 180°); depth cameras have 300 to 2000 px.
pub const MIN_FOCAL_PX: f64 = 1.0;
/// Largest accepted focal length (pixels): an 8192-pixel-wide sensor
/// would then see 4.7° across, a telephoto no depth camera has (they see
/// 40° to 90°); more is a typo or a value in other units.
pub const MAX_FOCAL_PX: f64 = 100_000.0;
/// Smallest accepted depth unit, metres: the finest a depth camera offers
/// is the D4xx's settable 1 µm (1e-6); finer units could not even hold a
/// finger's 0.3 m in 16 bits, and 1e-300 is a slip, not a camera.
pub const MIN_DEPTH_SCALE_M: f64 = 1e-6;
/// Largest accepted depth unit, metres: 1 m per unit (no camera counts
/// depth in coarser steps).
pub const MAX_DEPTH_SCALE_M: f64 = 1.0;

impl Intrinsics {
    /// A D435 depth stream at 848 × 480 (≈ 87° horizontal field of view) with
    /// 100 µm depth units (the D4xx's depth units are settable; the
    /// synthetic finger uses these so quantisation stays below the noise).
    pub const D435_848X480: Intrinsics = Intrinsics {
        pinhole: Pinhole::d435_848x480(426.0),
        depth_scale: 0.0001,
    };

    /// Millimetres per depth unit.
    pub fn mm_per_unit(&self) -> f64 {
        self.depth_scale * 1000.0
    }

    /// Camera coordinates (mm) of pixel (`col`, `row`) at depth `z_mm`.
    pub fn deproject(&self, col: u32, row: u32, z_mm: f64) -> [f64; 3] {
        let [x, y] = self.pinhole.normalised(col as f64, row as f64);
        [x * z_mm, y * z_mm, z_mm]
    }

    /// Pixel coordinates (column, row) of a camera point with z > 0.
    pub fn project(&self, p: [f64; 3]) -> [f64; 2] {
        self.pinhole.to_pixel([p[0] / p[2], p[1] / p[2]])
    }

    /// Error unless frames of `width` × `height` match these intrinsics.
    pub fn check_frames(&self, width: u32, height: u32, what: &str) -> Result<(), InputError> {
        let p = &self.pinhole;
        if (width, height) != (p.width, p.height) {
            return Err(InputError::new(format!(
                "{what} has {width}×{height} frames but the intrinsics say {}×{}",
                p.width, p.height
            )));
        }
        Ok(())
    }
}

impl super::settings_file::SettingsFile for Intrinsics {
    const WHAT: &'static str = "intrinsics";
    const KIND: &'static crate::files::kind::Kind = &crate::files::kind::INTRINSICS;

    /// Every field; `origin` names the file in the message.
    fn check(&self, origin: &str) -> Result<(), InputError> {
        self.pinhole
            .check()
            .map_err(|m| InputError::new(format!("intrinsics {origin}: {m}")))?;
        let scale = MIN_DEPTH_SCALE_M..=MAX_DEPTH_SCALE_M;
        if !(self.depth_scale.is_finite() && scale.contains(&self.depth_scale)) {
            return Err(InputError::new(format!(
                "intrinsics {origin}: `depth_scale` must be {}..={} metres per unit, got {}",
                crate::limits::show(MIN_DEPTH_SCALE_M),
                crate::limits::show(MAX_DEPTH_SCALE_M),
                crate::limits::show(self.depth_scale)
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sense::track::colour::ColourCamera;
    use crate::sense::track::settings_file::SettingsFile;

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
    fn values_no_depth_camera_has_are_refused_naming_the_range() {
        let d = Intrinsics::D435_848X480;
        let with = |f: &dyn Fn(&mut Intrinsics)| {
            let mut i = d;
            f(&mut i);
            SettingsFile::check(&i, "cam.toml")
                .err()
                .map(|e| e.to_string())
        };
        assert_eq!(
            with(&|i| i.pinhole.fx = 1e-300).unwrap(),
            "intrinsics cam.toml: `fx` must be a focal length of 1..=100000 pixels, got 1e-300"
        );
        assert_eq!(
            with(&|i| i.pinhole.fy = 2e5).unwrap(),
            "intrinsics cam.toml: `fy` must be a focal length of 1..=100000 pixels, got 200000"
        );
        assert_eq!(
            with(&|i| i.depth_scale = 1e-300).unwrap(),
            "intrinsics cam.toml: `depth_scale` must be 1e-6..=1 metres per unit, got 1e-300"
        );
        assert_eq!(
            with(&|i| i.pinhole.ppx = -0.5).unwrap(),
            "intrinsics cam.toml: `ppx` must lie in the image, 0..=848 pixels, got -0.5"
        );
        // The edges of each range are a camera's.
        for ok in [
            &(|i: &mut Intrinsics| i.pinhole.fx = 1.0) as &dyn Fn(&mut Intrinsics),
            &|i| i.pinhole.fy = 1e5,
            &|i| i.depth_scale = 1e-6,
            &|i| i.depth_scale = 1.0,
            &|i| i.pinhole.ppy = 480.0,
        ] {
            assert_eq!(with(ok), None);
        }
    }

    #[test]
    fn a_depth_scale_refused_is_shown_in_a_few_digits() {
        // From a stream's header: no literal check before this one.
        for (v, shown) in [(-5e-324, "got -5e-324"), (1e300, "got 1e300")] {
            let i = Intrinsics {
                depth_scale: v,
                ..Intrinsics::D435_848X480
            };
            let e = SettingsFile::check(&i, "cam").unwrap_err().to_string();
            assert!(e.ends_with(shown) && e.len() < 100, "{e}");
        }
    }

    #[test]
    fn the_file_keeps_its_flat_keys_and_refuses_unknown_ones() {
        // The pinhole's keys stand at the top level beside `depth_scale`,
        // as the files written before the pinhole was shared.
        let text = Intrinsics::D435_848X480.to_toml();
        assert_eq!(
            text,
            "width = 848\nheight = 480\nfx = 426.0\nfy = 426.0\nppx = 423.5\nppy = 239.5\ndepth_scale = 0.0001\n"
        );
        let e = Intrinsics::from_toml(&format!("{text}fz = 1.0\n"), "i.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("fz") && e.contains("i.toml"), "{e}");
        let e = ColourCamera::from_toml(
            &format!(
                "{}depth_scale = 0.001\n",
                ColourCamera::D435_848X480.to_toml()
            ),
            "c.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("depth_scale"), "{e}");
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
