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
//! c = [0.0, 0.0, 1.0]              # optional: a × b
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

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::array::{self, Transducer};
use crate::directivity::Directivity;
use crate::error::InputError;
use crate::units;

/// A 3-vector in millimetres or a unit vector.
pub type Vec3 = [f64; 3];

/// Default minimum dwell of an AUTD3-class device (s): its 1 kHz update limit.
pub const DEFAULT_MIN_DWELL_S: f64 = 1e-3;

/// Default LM centre for the built-in flat array (mm).
pub const DEFAULT_FLAT_CENTER_MM: Vec3 = [0.0, 0.0, 200.0];

/// One placed AUTD3 device.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Device {
    /// Scene position of the centre of the device's transducer grid (mm).
    pub center_mm: Vec3,
    /// Rotation matrix (row-major) from device-local to scene axes.
    pub rotation: [[f64; 3]; 3],
}

impl Device {
    /// A device with grid centre `center_mm` and Euler angles `rotation_deg`
    /// (x, then y, then z, fixed axes; see the module docs).
    pub fn new(center_mm: Vec3, rotation_deg: Vec3) -> Self {
        Self {
            center_mm,
            rotation: euler_xyz_deg(rotation_deg),
        }
    }

    /// The device's 249 transducers in scene coordinates, AUTD3 index order.
    pub fn transducers(&self) -> impl Iterator<Item = Transducer> + '_ {
        let c = array::autd3_local_center_mm();
        let normal = mat_vec(&self.rotation, [0.0, 0.0, 1.0]);
        array::autd3_local_positions_mm().map(move |p| {
            let local = sub(p, c);
            Transducer {
                pos_mm: add(mat_vec(&self.rotation, local), self.center_mm),
                normal,
            }
        })
    }
}

/// A flat reflector (the paper's display surface).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reflector {
    /// Any point on the surface (mm).
    pub point_mm: Vec3,
    /// Unit normal of the surface.
    pub normal: Vec3,
}

impl Reflector {
    /// Mirror image of `p` through the plane (paper eq. 6):
    /// `p + 2((point − p)·n) n`. Mirroring twice gives `p` back.
    pub fn mirror(&self, p: Vec3) -> Vec3 {
        let s = 2.0 * dot(sub(self.point_mm, p), self.normal);
        add(p, scale(self.normal, s))
    }

    /// Mirror image of a direction (no translation).
    pub fn mirror_dir(&self, v: Vec3) -> Vec3 {
        sub(v, scale(self.normal, 2.0 * dot(v, self.normal)))
    }
}

/// Orthonormal unit vectors of the LM plane (the paper's `r_a`, `r_b`,
/// `r_c`): the circle is drawn in the a-b plane, the per-step depth along c.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LmPlane {
    /// First in-plane axis (θ = 0 points here).
    pub a: Vec3,
    /// Second in-plane axis (θ = 90° points here).
    pub b: Vec3,
    /// Depth axis for the per-step z profile.
    pub c: Vec3,
}

impl Default for LmPlane {
    fn default() -> Self {
        Self {
            a: [1.0, 0.0, 0.0],
            b: [0.0, 1.0, 0.0],
            c: [0.0, 0.0, 1.0],
        }
    }
}

impl LmPlane {
    /// Checks and normalises three vectors; `c` defaults to `a × b`.
    /// `what` names the source for the error message.
    pub fn new(a: Vec3, b: Vec3, c: Option<Vec3>, what: &str) -> Result<Self, InputError> {
        let a = unit(a, &format!("{what}.a"))?;
        let b = unit(b, &format!("{what}.b"))?;
        if dot(a, b).abs() > 1e-3 {
            return Err(InputError::new(format!(
                "{what}: a and b must be perpendicular (a·b = {:.4})",
                dot(a, b)
            )));
        }
        let c = match c {
            Some(c) => {
                let c = unit(c, &format!("{what}.c"))?;
                if dot(a, c).abs() > 1e-3 || dot(b, c).abs() > 1e-3 {
                    return Err(InputError::new(format!(
                        "{what}.c must be perpendicular to a and b"
                    )));
                }
                c
            }
            None => cross(a, b),
        };
        Ok(Self { a, b, c })
    }
}

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
    pub camera: Option<crate::track::rig::CameraPose>,
    /// Detection box (`[tracking]`), for `lmhost track`.
    pub tracking: Option<crate::track::rig::TrackBox>,
}

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
        let file: SceneFile = toml::from_str(text).map_err(|e| {
            InputError::new(format!(
                "scene file {origin}: {}",
                toml_error_line(text, &e)
            ))
        })?;
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

/// One line from a TOML error: `line N, field `key`: message`.
fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let msg = e.message().lines().next().unwrap_or("invalid TOML").trim();
    match e.span() {
        Some(span) => {
            let start = span.start.min(text.len());
            let line_no = text[..start].matches('\n').count() + 1;
            let line = text.lines().nth(line_no - 1).unwrap_or("");
            let key = line.split('=').next().unwrap_or("").trim();
            if line.contains('=') && !key.is_empty() {
                format!("line {line_no}, field `{key}`: {msg}")
            } else {
                format!("line {line_no}: {msg}")
            }
        }
        None => msg.to_string(),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: Option<String>,
    directivity: Option<Directivity>,
    center_mm: Option<Vec3>,
    min_dwell_ms: Option<f64>,
    medium: Option<MediumFile>,
    reflector: Option<ReflectorFile>,
    lm_plane: Option<PlaneFile>,
    rig: Option<PoseFile>,
    #[serde(default)]
    device: Vec<DeviceFile>,
    camera: Option<crate::track::rig::CameraFile>,
    tracking: Option<crate::track::rig::TrackingFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MediumFile {
    sound_speed_m_s: Option<f64>,
    temperature_c: Option<f64>,
    attenuation_np_per_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ReflectorFile {
    point_mm: Vec3,
    normal: Vec3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlaneFile {
    a: Vec3,
    b: Vec3,
    c: Option<Vec3>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseFile {
    #[serde(default)]
    position_mm: Vec3,
    #[serde(default)]
    rotation_deg: Vec3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceFile {
    center_mm: Vec3,
    #[serde(default)]
    rotation_deg: Vec3,
}

fn finite3(v: Vec3, field: &str) -> Result<Vec3, String> {
    if field.ends_with("rotation_deg") && !v.iter().all(|x| x.abs() <= 360.0) {
        return Err(format!("field `{field}` must be within ±360°, got {v:?}"));
    }
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(format!("field `{field}` must be finite, got {v:?}"))
    }
}

impl SceneFile {
    fn resolve(self, origin: &str) -> Result<Scene, String> {
        let d = Scene::default();
        if self.device.is_empty() {
            return Err("needs at least one [[device]]".into());
        }
        let max_devices = usize::from(u16::MAX) / array::AUTD3_TRANSDUCERS;
        if self.device.len() > max_devices {
            return Err(format!(
                "{} devices exceed the {max_devices} a u16 transducer count allows",
                self.device.len()
            ));
        }
        let rig = self.rig.unwrap_or(PoseFile {
            position_mm: [0.0; 3],
            rotation_deg: [0.0; 3],
        });
        let rig_pos = finite3(rig.position_mm, "rig.position_mm")?;
        let rig_r = euler_xyz_deg(finite3(rig.rotation_deg, "rig.rotation_deg")?);
        let mut devices = Vec::with_capacity(self.device.len());
        for (i, dev) in self.device.iter().enumerate() {
            let c = finite3(dev.center_mm, &format!("device[{i}].center_mm"))?;
            let r = finite3(dev.rotation_deg, &format!("device[{i}].rotation_deg"))?;
            let local = Device::new(c, r);
            let center_mm = add(mat_vec(&rig_r, local.center_mm), rig_pos);
            crate::limits::position_mm(
                &format!("field `device[{i}].center_mm` (after [rig])"),
                center_mm,
            )
            .map_err(|e| e.0)?;
            devices.push(Device {
                center_mm,
                rotation: mat_mul(&rig_r, &local.rotation),
            });
        }
        check_overlap(&devices)?;
        let (mut c_m_s, mut att) = (d.sound_speed_m_s, 0.0);
        if let Some(m) = self.medium {
            match (m.sound_speed_m_s, m.temperature_c) {
                (Some(_), Some(_)) => {
                    return Err(
                        "give medium.sound_speed_m_s or medium.temperature_c, not both".into(),
                    );
                }
                (Some(c), None) => {
                    if !(c.is_finite() && c > 0.0) {
                        return Err(format!(
                            "field `medium.sound_speed_m_s` must be > 0, got {c}"
                        ));
                    }
                    c_m_s = c;
                }
                (None, Some(t)) => {
                    if !(t.is_finite() && t > -273.15) {
                        return Err(format!(
                            "field `medium.temperature_c` must be above absolute zero, got {t}"
                        ));
                    }
                    c_m_s = units::sound_speed_from_celsius(t);
                }
                (None, None) => {}
            }
            if let Some(a) = m.attenuation_np_per_m {
                if !(a.is_finite() && a >= 0.0) {
                    return Err(format!(
                        "field `medium.attenuation_np_per_m` must be ≥ 0, got {a}"
                    ));
                }
                att = a;
            }
        }
        let reflector = match self.reflector {
            Some(r) => Some(Reflector {
                point_mm: crate::limits::position_mm(
                    "field `reflector.point_mm`",
                    finite3(r.point_mm, "reflector.point_mm")?,
                )
                .map_err(|e| e.0)?,
                normal: unit(r.normal, "reflector.normal").map_err(|e| e.0)?,
            }),
            None => None,
        };
        let lm_plane = match self.lm_plane {
            Some(p) => LmPlane::new(p.a, p.b, p.c, "lm_plane").map_err(|e| e.0)?,
            None => LmPlane::default(),
        };
        let center_mm = match self.center_mm {
            Some(c) => crate::limits::position_mm("field `center_mm`", finite3(c, "center_mm")?)
                .map_err(|e| e.0)?,
            None => d.center_mm,
        };
        let min_dwell_s = match self.min_dwell_ms {
            Some(ms) if ms.is_finite() && ms > 0.0 && ms <= 1000.0 => ms * 1e-3,
            Some(ms) => {
                return Err(format!(
                    "field `min_dwell_ms` must be in (0, 1000] ms, got {}",
                    crate::limits::show(ms)
                ));
            }
            None => DEFAULT_MIN_DWELL_S,
        };
        let (camera, tracking) = crate::track::rig::resolve(self.camera, self.tracking)?;
        Ok(Scene {
            camera,
            tracking,
            name: self.name.unwrap_or_else(|| origin.to_string()),
            devices,
            reflector,
            sound_speed_m_s: c_m_s,
            attenuation_np_per_m: att,
            directivity: self.directivity.unwrap_or_default(),
            lm_plane,
            center_mm,
            min_dwell_s,
        })
    }
}

/// Two devices overlap when transducers of different devices are closer
/// than [`crate::limits::MIN_TRANSDUCER_GAP_MM`] (two devices at the same
/// pose, or boards pushed into each other). Grid-hashed: linear time.
fn check_overlap(devices: &[Device]) -> Result<(), String> {
    use std::collections::HashMap;
    let gap = crate::limits::MIN_TRANSDUCER_GAP_MM;
    let cell = |p: Vec3| p.map(|x| (x / gap).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<(usize, Vec3)>> = HashMap::new();
    for (d, dev) in devices.iter().enumerate() {
        for t in dev.transducers() {
            let c = cell(t.pos_mm);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(v) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                            continue;
                        };
                        if let Some((other, _)) = v
                            .iter()
                            .find(|(o, q)| *o != d && norm(sub(*q, t.pos_mm)) < gap)
                        {
                            return Err(format!(
                                "device[{other}] and device[{d}] overlap (transducers closer than \
                                 {gap} mm); give each device its own place"
                            ));
                        }
                    }
                }
            }
            grid.entry(c).or_default().push((d, t.pos_mm));
        }
    }
    Ok(())
}

/// `v / |v|`, or an error naming `field` when `v` is zero or not finite.
pub fn unit(v: Vec3, field: &str) -> Result<Vec3, InputError> {
    let n = norm(v);
    if !(n.is_finite() && n > 1e-12) {
        return Err(InputError::new(format!(
            "field `{field}` must be a finite non-zero vector, got {v:?}"
        )));
    }
    Ok(scale(v, 1.0 / n))
}

/// Rotation matrix `Rz(z) · Ry(y) · Rx(x)` from angles in degrees.
pub fn euler_xyz_deg(deg: Vec3) -> [[f64; 3]; 3] {
    let [x, y, z] = deg.map(f64::to_radians);
    let (sx, cx) = x.sin_cos();
    let (sy, cy) = y.sin_cos();
    let (sz, cz) = z.sin_cos();
    let rx = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rz = [[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]];
    mat_mul(&rz, &mat_mul(&ry, &rx))
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn mat_vec(m: &[[f64; 3]; 3], v: Vec3) -> Vec3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// Dot product.
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a + b`.
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a − b`.
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `s · v`.
pub fn scale(v: Vec3, s: f64) -> Vec3 {
    [v[0] * s, v[1] * s, v[2] * s]
}

/// Euclidean length.
pub fn norm(v: Vec3) -> f64 {
    dot(v, v).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3, tol: f64) -> bool {
        norm(sub(a, b)) < tol
    }

    #[test]
    fn default_scene_is_a_flat_2x2_centred_on_the_origin() {
        let s = Scene::default();
        let t = s.transducers();
        assert_eq!(t.len(), 996);
        assert_eq!(s.transducer_count(), 996);
        let mut c = [0.0; 3];
        for tr in &t {
            assert_eq!(tr.pos_mm[2], 0.0);
            assert_eq!(tr.normal, [0.0, 0.0, 1.0]);
            c = add(c, tr.pos_mm);
        }
        // The missing corner positions make the centroid slightly off 0 in
        // y, but x and y stay within one pitch of the origin.
        let c = scale(c, 1.0 / t.len() as f64);
        assert!(c[0].abs() < 10.16 && c[1].abs() < 10.16, "{c:?}");
        // Devices do not overlap: the two lower devices' grids are 192 mm apart.
        assert!((t[249].pos_mm[0] - t[0].pos_mm[0] - 192.0).abs() < 1e-9);
    }

    #[test]
    fn euler_rotations_follow_the_right_hand_rule() {
        let r = euler_xyz_deg([90.0, 0.0, 0.0]);
        assert!(close(mat_vec(&r, [0.0, 0.0, 1.0]), [0.0, -1.0, 0.0], 1e-12));
        let r = euler_xyz_deg([0.0, 90.0, 0.0]);
        assert!(close(mat_vec(&r, [0.0, 0.0, 1.0]), [1.0, 0.0, 0.0], 1e-12));
        let r = euler_xyz_deg([0.0, 0.0, 90.0]);
        assert!(close(mat_vec(&r, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], 1e-12));
        // x first, then z: z-axis → (0,-1,0) → (1,0,0).
        let r = euler_xyz_deg([90.0, 0.0, 90.0]);
        assert!(close(mat_vec(&r, [0.0, 0.0, 1.0]), [1.0, 0.0, 0.0], 1e-12));
    }

    #[test]
    fn mirroring_is_an_involution_and_keeps_points_on_the_plane() {
        let r = Reflector {
            point_mm: [0.0, 0.0, 10.0],
            normal: unit([0.0, 1.0, 1.0], "n").unwrap(),
        };
        let p = [3.0, 30.0, 30.0];
        let m = r.mirror(p);
        assert!(close(r.mirror(m), p, 1e-12));
        assert!(!close(m, p, 1.0));
        let on = [5.0, -4.0, 14.0];
        assert!(close(r.mirror(on), on, 1e-12));
        // Plane z = 0: mirror flips z.
        let z = Reflector {
            point_mm: [0.0; 3],
            normal: [0.0, 0.0, 1.0],
        };
        assert!(close(z.mirror([1.0, 2.0, 3.0]), [1.0, 2.0, -3.0], 1e-12));
    }

    #[test]
    fn scene_file_round_trip_with_rig_and_medium() {
        let s = Scene::from_toml(
            r#"
            directivity = "omni"
            center_mm = [0.0, 30.0, 30.0]
            [medium]
            temperature_c = 20.0
            [rig]
            position_mm = [0.0, 0.0, 100.0]
            rotation_deg = [180.0, 0.0, 0.0]
            [[device]]
            center_mm = [0.0, 0.0, 0.0]
            "#,
            "t.toml",
        )
        .unwrap();
        assert_eq!(s.directivity, Directivity::Omni);
        assert!((s.sound_speed_m_s - 343.2).abs() < 0.1);
        let t = s.transducers();
        assert_eq!(t.len(), 249);
        assert!(close(t[0].normal, [0.0, 0.0, -1.0], 1e-12));
        assert!(t.iter().all(|tr| (tr.pos_mm[2] - 100.0).abs() < 1e-9));
        assert_eq!(s.name, "t.toml");
    }

    #[test]
    fn scene_file_errors_name_the_file_and_field() {
        let cases = [
            ("[[device]]\ncenter_mm = [0.0, 0.0]\n", "center_mm"),
            (
                "[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\nspin = 3\n",
                "spin",
            ),
            (
                "directivity = \"laser\"\n[[device]]\ncenter_mm = [0,0,0]\n",
                "directivity",
            ),
            ("name = \"x\"\n", "[[device]]"),
            (
                "[reflector]\npoint_mm = [0.0,0.0,0.0]\nnormal = [0.0,0.0,0.0]\n[[device]]\ncenter_mm = [0.0,0.0,0.0]\n",
                "reflector.normal",
            ),
            (
                "[medium]\nsound_speed_m_s = -3.0\n[[device]]\ncenter_mm = [0.0,0.0,0.0]\n",
                "medium.sound_speed_m_s",
            ),
            (
                "[lm_plane]\na = [1.0,0.0,0.0]\nb = [1.0,1.0,0.0]\n[[device]]\ncenter_mm = [0.0,0.0,0.0]\n",
                "lm_plane",
            ),
        ];
        for (text, field) in cases {
            let e = Scene::from_toml(text, "bad.toml").unwrap_err().to_string();
            assert!(e.starts_with("scene file bad.toml: "), "{e}");
            assert!(e.contains(field), "{e} should name {field}");
            assert!(!e.contains('\n'), "multi-line: {e}");
        }
    }

    #[test]
    fn missing_scene_file_is_a_one_line_input_error() {
        let e = Scene::load(Path::new("/nonexistent/scene.toml")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cannot read scene file /nonexistent/scene.toml: no such file"
        );
    }

    #[test]
    fn paper_scene_parses_and_aims_at_the_mirrored_marker() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml");
        let s = Scene::load(Path::new(path)).unwrap();
        assert_eq!(s.transducer_count(), 996);
        assert_eq!(s.center_mm, [0.0, 30.0, 30.0]);
        let refl = s.reflector.expect("paper scene has a reflector");
        let target = refl.mirror(s.center_mm);
        // Every device faces the mirrored marker within 25° (tilted 20° in).
        for d in &s.devices {
            let n = mat_vec(&d.rotation, [0.0, 0.0, 1.0]);
            let to = unit(sub(target, d.center_mm), "to").unwrap();
            let ang = dot(n, to).clamp(-1.0, 1.0).acos().to_degrees();
            assert!(ang < 25.0, "device off target by {ang}°");
        }
        // The LM plane is orthonormal.
        let p = s.lm_plane;
        assert!(dot(p.a, p.b).abs() < 1e-9 && (norm(p.c) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn overlapping_or_far_away_devices_are_refused() {
        let two = |a: &str, b: &str| {
            format!("[[device]]\ncenter_mm = {a}\n[[device]]\ncenter_mm = {b}\n")
        };
        let e = Scene::from_toml(&two("[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]"), "t").unwrap_err();
        assert!(e.0.contains("overlap"), "{e}");
        let e = Scene::from_toml(&two("[0.0, 0.0, 0.0]", "[100.0, 0.0, 0.0]"), "t").unwrap_err();
        assert!(e.0.contains("overlap"), "{e}");
        assert!(Scene::from_toml(&two("[0.0, 0.0, 0.0]", "[192.0, 0.0, 0.0]"), "t").is_ok());
        let e = Scene::from_toml("[[device]]\ncenter_mm = [1e300, 0.0, 0.0]\n", "t").unwrap_err();
        assert!(e.0.contains("±2000 mm") && e.0.contains("1e300"), "{e}");
    }

    #[test]
    fn faces_means_strictly_in_front_of_some_device() {
        let s = Scene::default();
        assert!(s.faces([0.0, 0.0, 200.0]));
        assert!(!s.faces([0.0, 0.0, 0.0]));
        assert!(!s.faces([0.0, 0.0, -100.0]));
    }

    #[test]
    fn lm_plane_beam_angle_flags_a_plane_that_contains_the_beam() {
        let s = Scene::default();
        let a = s.lm_plane_beam_angle_deg([0.0, 0.0, 200.0]).unwrap();
        assert!((a - 90.0).abs() < 1e-9, "{a}");
        let mut edge = s.clone();
        edge.lm_plane = LmPlane::new([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], None, "t").unwrap();
        assert!(edge.lm_plane_beam_angle_deg([0.0, 0.0, 200.0]).unwrap() < 1e-9);
        let paper = Scene::load(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/paper.toml"
        )))
        .unwrap();
        let a = paper.lm_plane_beam_angle_deg(paper.center_mm).unwrap();
        assert!(
            a > 80.0,
            "the paper scene's circle must face the reflected wave: {a}°"
        );
    }
}
