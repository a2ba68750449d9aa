//! The placed parts of a scene: AUTD3 devices, the reflector and the LM
//! plane's unit vectors.

use serde::{Deserialize, Serialize};

use crate::error::InputError;
use crate::geom::{Vec3, add, cross, dot, euler_xyz_deg, mat_vec, norm, scale, sub};
use crate::plan::array::{self, Transducer};

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
                // c = −(a × b) is perpendicular too, but left-handed: the
                // circle (θ from a towards b) would then run clockwise
                // about c, and the per-step depth z_j along c lie on the
                // other side of the plane, than the same a, b give with c
                // left out; which one was meant cannot be told, so it is
                // refused (as the track box's left-handed axes are).
                let ab = cross(a, b);
                if dot(ab, c) < 0.0 {
                    return Err(InputError::new(format!(
                        "{what}.c must be a × b = [{}, {}, {}] (a, b, c right-handed): this c is −(a × b), which reverses the circle's direction about c and the side the depth profile is on; give a × b or leave c out",
                        crate::limits::show(ab[0] + 0.0),
                        crate::limits::show(ab[1] + 0.0),
                        crate::limits::show(ab[2] + 0.0)
                    )));
                }
                c
            }
            None => cross(a, b),
        };
        Ok(Self { a, b, c })
    }
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
