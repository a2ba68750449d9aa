//! `lmhost scene`: show a scene and export every transducer.

use std::path::PathBuf;

use serde_json::json;

use lmhost::plan::scene::Scene;

/// Show a scene; `--json` exports every transducer's position and normal.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file (TOML) [default: four AUTD3 in a flat 2×2 facing +z].
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Print JSON: the scene's settings and `transducers` as
    /// `{pos_mm: [x, y, z], normal: [x, y, z]}` in global index order.
    #[arg(long)]
    pub json: bool,
}

impl Args {
    /// Loads and prints.
    pub fn run(self) -> anyhow::Result<()> {
        let s = Scene::load_or_default(self.scene.as_deref())?;
        let t = s.transducers();
        if self.json {
            let tr: Vec<_> = t
                .iter()
                .map(|t| json!({"pos_mm": t.pos_mm, "normal": t.normal}))
                .collect();
            let v = json!({
                "name": s.name,
                "devices": s.devices.len(),
                "sound_speed_m_s": s.sound_speed_m_s,
                "attenuation_np_per_m": s.attenuation_np_per_m,
                "directivity": s.directivity,
                "reflector": s.reflector,
                "lm_plane": s.lm_plane,
                "center_mm": s.center_mm,
                "min_dwell_s": s.min_dwell_s,
                "transducers": tr,
            });
            lmhost::outln!("{}", serde_json::to_string(&v)?)?;
        } else {
            lmhost::outln!(
                "{}: {} devices, {} transducers",
                s.name,
                s.devices.len(),
                t.len()
            )?;
            lmhost::outln!(
                "medium {:.2} m/s (λ = {:.3} mm), attenuation {} Np/m, directivity {:?}",
                s.sound_speed_m_s,
                2.0 * std::f64::consts::PI / s.wavenumber_rad_per_mm(),
                lmhost::limits::Num(s.attenuation_np_per_m),
                s.directivity
            )?;
            for (i, d) in s.devices.iter().enumerate() {
                let n = [d.rotation[0][2], d.rotation[1][2], d.rotation[2][2]];
                lmhost::outln!(
                    "  device {i}: centre ({:.1}, {:.1}, {:.1}) mm, normal ({:.3}, {:.3}, {:.3})",
                    d.center_mm[0],
                    d.center_mm[1],
                    d.center_mm[2],
                    n[0],
                    n[1],
                    n[2]
                )?;
            }
            if let Some(r) = &s.reflector {
                lmhost::outln!(
                    "reflector through ({:.1}, {:.1}, {:.1}) mm, normal ({:.3}, {:.3}, {:.3})",
                    r.point_mm[0],
                    r.point_mm[1],
                    r.point_mm[2],
                    r.normal[0],
                    r.normal[1],
                    r.normal[2]
                )?;
            }
            let c = s.center_mm;
            lmhost::outln!(
                "default LM centre ({:.1}, {:.1}, {:.1}) mm",
                c[0],
                c[1],
                c[2]
            )?;
        }
        Ok(())
    }
}
