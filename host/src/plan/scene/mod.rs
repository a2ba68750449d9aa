//! Scenes: where the transducers are, what they radiate into, and how the
//! LM plane is oriented.
//!
//! A scene is a set of AUTD3 devices placed with a position and a rotation,
//! an optional reflector plane (the paper's display surface), the medium,
//! the transducer directivity model and the LM plane's unit vectors
//! (the paper's `r_a`, `r_b`, `r_c`). Lengths are millimetres
//! (see [`crate::units`]).
//!
//! # Scene file (TOML)
//!
//! ```toml
//! name = "my rig"                 # optional
//! directivity = "t4010a1"          # or "omni"; default t4010a1
//! center_mm = [0.0, 0.0, 200.0]    # default LM centre (finger space)
//! min_dwell_ms = 1.0               # device's shortest step (1 kHz update limit)
//!
//! [medium]                         # optional; default 340 m/s, no attenuation
//! sound_speed_m_s = 340.0          # or: temperature_c = 20.0 (not both)
//! attenuation_np_per_m = 0.0
//!
//! [reflector]                      # optional: foci are mirrored through it
//! point_mm = [0.0, 0.0, 0.0]
//! normal = [0.0, 0.0, 1.0]
//!
//! [lm_plane]                       # optional; default x, y, z
//! a = [1.0, 0.0, 0.0]
//! b = [0.0, 1.0, 0.0]
//! c = [0.0, 0.0, 1.0]              # optional: a × b (given, it must be)
//!
//! [rig]                            # optional pose applied after each device's own
//! position_mm = [0.0, 0.0, 0.0]
//! rotation_deg = [0.0, 0.0, 0.0]
//!
//! [[device]]                       # one per AUTD3, at least one
//! center_mm = [-96.0, -75.7, 0.0]
//! rotation_deg = [0.0, 0.0, 0.0]
//! ```
//!
//! **Device pose.** `center_mm` is where the centre of the device's
//! transducer grid goes; the device is rotated about that centre.
//! `rotation_deg = [rx, ry, rz]` rotates first about the scene's x axis by
//! `rx`, then about y by `ry`, then about z by `rz` (fixed axes, right-hand
//! rule, degrees), i.e. `R = Rz · Ry · Rx`. With no rotation a device lies in
//! a z = const plane, its long side along x, facing +z. The `[rig]` pose then
//! moves every device as one body (`p ↦ rig.R · p + rig.position`).
//!
//! **Finger space.** The LM centre, the LM plane and the trajectory live where
//! the finger is. With a reflector the array focuses on the mirror image of
//! each point (paper eq. 6), so after reflection the focus lands on it.
//!
//! One concern per file: the placed parts (`parts`: devices, reflector, LM
//! plane), the depth camera and detection box (`rig`), the TOML schema
//! (`file`) and its checks (`check`); the vector maths
//! is [`crate::geom`]'s.

mod check;
mod file;
pub(crate) use file::{field_at, from_toml, line_of};
pub mod camera;
mod parts;
mod tables;
pub(super) fn finite3(v: Vec3, field: &str) -> Result<Vec3, String> {
    if field.ends_with("rotation_deg") && !v.iter().all(|x| x.abs() <= 360.0) {
        return Err(format!("field `{field}` must be within ±360°, got {v:?}"));
    }
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(format!("field `{field}` must be finite, got {v:?}"))
    }
}

#[cfg(test)]
mod tests;

use std::path::Path;

use serde::Serialize;

use crate::error::InputError;
use crate::geom::{Vec3, add, dot, mat_vec, norm, scale, sub};
use crate::plan::array::{self, Transducer};
use crate::plan::directivity::Directivity;
use crate::units;

pub use parts::{Device, LmPlane, Reflector, unit};

/// Default minimum dwell of an AUTD3-class device (s): its 1 kHz update limit.
pub const DEFAULT_MIN_DWELL_S: f64 = 1e-3;

/// Default LM centre for the built-in flat array (mm).
pub const DEFAULT_FLAT_CENTER_MM: Vec3 = [0.0, 0.0, 200.0];

/// A resolved scene: geometry, medium and defaults the planner uses.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scene {
    /// Human-readable name (file name or "built-in flat 2x2").
    pub name: String,
    /// Devices in index order; transducer `i` of device `d` has global index
    /// `249 d + i`.
    pub devices: Vec<Device>,
    /// Optional reflector; foci are mirrored through it.
    pub reflector: Option<Reflector>,
    /// Speed of sound (m/s).
    pub sound_speed_m_s: f64,
    /// Amplitude attenuation of air (Np/m); the field simulator applies it.
    pub attenuation_np_per_m: f64,
    /// Transducer directivity model.
    pub directivity: Directivity,
    /// LM plane orientation (finger space).
    pub lm_plane: LmPlane,
    /// Default LM centre (finger space, mm).
    pub center_mm: Vec3,
    /// Shortest dwell per step the device accepts (s).
    pub min_dwell_s: f64,
    /// Depth camera pose (`[camera]`), for `lmhost track`.
    pub camera: Option<camera::CameraPose>,
    /// Detection box (`[tracking]`), for `lmhost track`.
    pub tracking: Option<camera::TrackBox>,
    /// Force calibration (`[calibration]`), applied to every simulated
    /// radiation-pressure map and force.
    pub calibration: Option<Calibration>,
}

/// The scene's force calibration: the simulated radiation pressure (and
/// so every force) times `pressure_scale` is what the rig measures. The
/// sound-pressure amplitude scales by its square root, power at the LM
/// frequency (Pa²) by its square. `lmhost calibrate force` derives it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Calibration {
    /// Factor on the simulated radiation pressure, in
    /// [`MIN_PRESSURE_SCALE`]..=[`MAX_PRESSURE_SCALE`].
    pub pressure_scale: f64,
    /// The measured static-focus force it was derived from (N).
    pub measured_n: Option<f64>,
    /// The uncalibrated simulated force it was derived from (N).
    pub simulated_n: Option<f64>,
    /// Diameter of the gauge disk of the measurement (mm).
    pub disk_mm: Option<f64>,
}

/// Smallest `[calibration] pressure_scale` (and `--calibration`) taken:
/// below it every map is silence, not a calibration.
pub const MIN_PRESSURE_SCALE: f64 = 1e-6;
/// Largest `[calibration] pressure_scale` (and `--calibration`) taken.
pub const MAX_PRESSURE_SCALE: f64 = 1e6;

impl Default for Scene {
    /// Four AUTD3 in a flat 2 × 2 array centred on the origin, facing +z,
    /// devices abutting at AUTD3's board pitch (192 × 151.4 mm).
    fn default() -> Self {
        let (hx, hy) = (
            array::AUTD3_DEVICE_WIDTH_MM / 2.0,
            array::AUTD3_DEVICE_HEIGHT_MM / 2.0,
        );
        let devices = [[-hx, -hy], [hx, -hy], [-hx, hy], [hx, hy]]
            .iter()
            .map(|&[x, y]| Device::new([x, y, 0.0], [0.0; 3]))
            .collect();
        Self {
            name: "built-in flat 2x2".into(),
            devices,
            reflector: None,
            sound_speed_m_s: units::DEFAULT_SOUND_SPEED_M_S,
            attenuation_np_per_m: 0.0,
            directivity: Directivity::T4010A1,
            lm_plane: LmPlane::default(),
            center_mm: DEFAULT_FLAT_CENTER_MM,
            min_dwell_s: DEFAULT_MIN_DWELL_S,
            camera: None,
            tracking: None,
            calibration: None,
        }
    }
}

impl Scene {
    /// The scene in `path`, or the built-in default when `None`.
    pub fn load_or_default(path: Option<&Path>) -> Result<Self, InputError> {
        match path {
            Some(p) => Self::load(p),
            None => Ok(Self::default()),
        }
    }

    /// Reads and checks a scene file. Errors are one line naming the file
    /// and the field.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let text = crate::limits::read_text_file("scene file", path)?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Parses a scene from TOML text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, InputError> {
        let file: file::SceneFile = file::from_toml(text, &crate::files::kind::SCENE)
            .map_err(|m| InputError::new(format!("scene file {origin}: {m}")))?;
        file.resolve(origin)
            .map_err(|msg| InputError::new(format!("scene file {origin}: {msg}")))
    }

    /// Every transducer in global index order.
    pub fn transducers(&self) -> Vec<Transducer> {
        self.devices.iter().flat_map(|d| d.transducers()).collect()
    }

    /// Number of transducers.
    pub fn transducer_count(&self) -> usize {
        self.devices.len() * array::AUTD3_TRANSDUCERS
    }

    /// Wavenumber of the carrier in this medium (rad/mm).
    pub fn wavenumber_rad_per_mm(&self) -> f64 {
        units::wavenumber_rad_per_mm(self.sound_speed_m_s)
    }

    /// Whether at least one device faces `p` (drive coordinates): `p` is
    /// strictly in front of that device's transducer plane. A point behind
    /// every device or in their plane cannot be focused on (the directivity
    /// is zero behind the face).
    pub fn faces(&self, p: Vec3) -> bool {
        self.devices.iter().any(|d| {
            let n = mat_vec(&d.rotation, [0.0, 0.0, 1.0]);
            dot(n, sub(p, d.center_mm)) > 1e-9
        })
    }

    /// Angle (degrees, 0..=90) between the LM plane and the beam axis at
    /// `center_mm`: the direction the wave travels when it reaches the
    /// centre, from the array's centroid (or its mirror image, with a
    /// reflector). 90° means the circle faces the wave (the finger pad); near
    /// 0° the plane contains the beam and the LM circle runs along it, where
    /// the field shows standing-wave bands instead of the paper's ring.
    pub fn lm_plane_beam_angle_deg(&self, center_mm: Vec3) -> Option<f64> {
        let n = self.devices.len() as f64;
        let centroid = self
            .devices
            .iter()
            .fold([0.0; 3], |acc, d| add(acc, scale(d.center_mm, 1.0 / n)));
        // In finger space the wave comes from the array's mirror image.
        let source = self.drive_point(centroid);
        let axis = sub(center_mm, source);
        let len = norm(axis);
        if !(len.is_finite() && len > 1e-9) {
            return None;
        }
        let s = (dot(axis, self.lm_plane.c) / len).abs().min(1.0);
        Some(s.asin().to_degrees())
    }

    /// The point the array must focus on so the focus forms at `p`
    /// (finger space): `p` itself, or its mirror image with a reflector.
    pub fn drive_point(&self, p: Vec3) -> Vec3 {
        match &self.reflector {
            Some(r) => r.mirror(p),
            None => p,
        }
    }
}
