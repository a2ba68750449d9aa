//! From the parsed scene file to a checked [`Scene`]: finite values, the
//! documented limits, one medium, no overlapping devices.

use crate::geom::{Vec3, add, euler_xyz_deg, mat_mul, mat_vec, norm, sub};
use crate::plan::array;
use crate::units;

use super::file::{CalibrationFile, PoseFile, SceneFile};
use super::{
    Calibration, DEFAULT_MIN_DWELL_S, Device, LmPlane, MAX_PRESSURE_SCALE, MIN_PRESSURE_SCALE,
    Reflector, Scene, finite3, unit,
};

impl SceneFile {
    pub(super) fn resolve(self, origin: &str) -> Result<Scene, String> {
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
                    // The range a device takes, here where the file is
                    // named, not first when a plan is uploaded.
                    units::sound_speed_mm_s(c)
                        .map_err(|e| format!("field `medium.sound_speed_m_s`: {}", e.0))?;
                    c_m_s = c;
                }
                (None, Some(t)) => {
                    if !(t.is_finite() && t > -273.15) {
                        return Err(format!(
                            "field `medium.temperature_c` must be above absolute zero, got {t}"
                        ));
                    }
                    c_m_s = units::sound_speed_from_celsius(t);
                    units::sound_speed_mm_s(c_m_s).map_err(|e| {
                        format!(
                            "field `medium.temperature_c` {}: {}",
                            crate::limits::show(t),
                            e.0
                        )
                    })?;
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
        if let Some(name) = &self.name {
            check_name(name)?;
        }
        let (camera, tracking) = super::camera::resolve(self.camera, self.tracking)?;
        let calibration = self.calibration.map(calibration).transpose()?;
        Ok(Scene {
            camera,
            tracking,
            calibration,
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

/// `[calibration]`: a scale in [`MIN_PRESSURE_SCALE`]..=[`MAX_PRESSURE_SCALE`],
/// positive finite figures.
fn calibration(c: CalibrationFile) -> Result<Calibration, String> {
    let k = c.pressure_scale;
    if !(MIN_PRESSURE_SCALE..=MAX_PRESSURE_SCALE).contains(&k) {
        return Err(format!(
            "field `calibration.pressure_scale` must be {MIN_PRESSURE_SCALE:e}..={MAX_PRESSURE_SCALE:e}, got {}",
            crate::limits::show(k)
        ));
    }
    let positive = |v: Option<f64>, name: &str, max: f64| match v {
        Some(x) if !(x.is_finite() && x > 0.0 && x <= max) => Err(format!(
            "field `calibration.{name}` must be > 0 and at most {max}, got {}",
            crate::limits::show(x)
        )),
        _ => Ok(v),
    };
    Ok(Calibration {
        pressure_scale: k,
        measured_n: positive(c.measured_n, "measured_n", 1e3)?,
        simulated_n: positive(c.simulated_n, "simulated_n", 1e3)?,
        disk_mm: positive(c.disk_mm, "disk_mm", 1000.0)?,
    })
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

/// Longest scene `name` (characters): it heads every report and is
/// recorded with every run.
pub const MAX_NAME_CHARS: usize = 200;

/// A scene's `name`: one line of at most [`MAX_NAME_CHARS`] (a name of
/// 200 000 characters was printed whole in every report's first line).
fn check_name(name: &str) -> Result<(), String> {
    let n = name.chars().count();
    if n > MAX_NAME_CHARS {
        return Err(format!(
            "field `name` has {n} characters, more than {MAX_NAME_CHARS}: a scene's name heads every report"
        ));
    }
    if name.chars().any(char::is_control) {
        return Err(format!(
            "field `name` `{}` holds a line break or control character: give one line",
            name.escape_debug()
        ));
    }
    Ok(())
}
