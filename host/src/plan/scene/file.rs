//! The scene file's TOML schema and its parse errors (one line each).

use serde::Deserialize;

use crate::geom::Vec3;
use crate::plan::directivity::Directivity;

/// One line from a TOML error: `line N, field `key`: message`.
pub(crate) fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
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
pub(super) struct SceneFile {
    pub(super) name: Option<String>,
    pub(super) directivity: Option<Directivity>,
    pub(super) center_mm: Option<Vec3>,
    pub(super) min_dwell_ms: Option<f64>,
    pub(super) medium: Option<MediumFile>,
    pub(super) reflector: Option<ReflectorFile>,
    pub(super) lm_plane: Option<PlaneFile>,
    pub(super) rig: Option<PoseFile>,
    #[serde(default)]
    pub(super) device: Vec<DeviceFile>,
    pub(super) camera: Option<super::camera::CameraFile>,
    pub(super) tracking: Option<super::camera::TrackingFile>,
    pub(super) calibration: Option<CalibrationFile>,
}

/// `[calibration]`: the force calibration `lmhost calibrate force` writes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CalibrationFile {
    pub(super) pressure_scale: f64,
    pub(super) measured_n: Option<f64>,
    pub(super) simulated_n: Option<f64>,
    pub(super) disk_mm: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MediumFile {
    pub(super) sound_speed_m_s: Option<f64>,
    pub(super) temperature_c: Option<f64>,
    pub(super) attenuation_np_per_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ReflectorFile {
    pub(super) point_mm: Vec3,
    pub(super) normal: Vec3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PlaneFile {
    pub(super) a: Vec3,
    pub(super) b: Vec3,
    pub(super) c: Option<Vec3>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PoseFile {
    #[serde(default)]
    pub(super) position_mm: Vec3,
    #[serde(default)]
    pub(super) rotation_deg: Vec3,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DeviceFile {
    pub(super) center_mm: Vec3,
    #[serde(default)]
    pub(super) rotation_deg: Vec3,
}
