//! `lmhost calibrate camera|force`: measure the rig, write the scene.

use std::path::PathBuf;

use clap::Subcommand;
use serde_json::json;

use lmhost::error::InputError;
use lmhost::lab::calibrate::{self, Dest, camera, force};
use lmhost::limits::Num as N;
use lmhost::plan::scene::Scene;
use lmhost::sense::track::intrinsics::Intrinsics;
use lmhost::sense::track::settings_file::SettingsFile as _;
use lmhost::sense::track::source::intrinsics_beside;

use crate::cmd::plan::parse_vec3;

/// Calibrate the rig and write the result into its scene file.
#[derive(Debug, Subcommand)]
pub enum Args {
    /// The depth camera's pose ([camera]) from recordings of a ball held at
    /// known scene points.
    #[command(
        after_help = "POINTS is a TOML file (recordings relative to it):\n\n  \
        ball_diameter_mm = 40.0\n  \
        background = \"empty.npy\"     # optional: the view without the ball\n  \
        [[point]]\n  \
        at_mm = [0, 30, 30]          # ball centre in the scene (mm)\n  \
        depth = \"p1.npy\"             # (frames, height, width) uint16, e.g. from `lmhost track --camera --record`\n\n\
        Give 3 or more positions, not on one line, spread over the tracking volume.\n\n\
        Examples:\n  \
        lmhost calibrate camera rig/points.toml --scene scenes/paper.toml --write\n  \
        lmhost calibrate camera rig/points.toml --scene scenes/paper.toml --out rig.toml --json"
    )]
    Camera(CameraArgs),
    /// The force calibration ([calibration]) from a measured static focus.
    #[command(
        after_help = "Measure the force of a static focus at the LM centre with a force \
        gauge carrying a 15 mm disk that faces the wave (the paper measured 0.022 N), then:\n\n  \
        lmhost calibrate force --measured 0.022 --scene scenes/paper.toml --write\n\n\
        Every simulated radiation pressure and force is then multiplied by \
        measured / simulated (amplitudes by its square root), a factor that must come out \
        in 1e-6..=1e6; `simulate --calibration K` replaces the scene's factor for one run."
    )]
    Force(ForceArgs),
}

/// Where the result goes, shared by both.
#[derive(Debug, clap::Args)]
struct Output {
    /// Scene file to calibrate [default: the built-in flat 2 × 2 array,
    /// which can only be printed].
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Write the updated scene (every other line kept) to FILE.
    #[arg(long, value_name = "FILE", conflicts_with = "write")]
    out: Option<PathBuf>,
    /// Replace the scene file itself with the updated one.
    #[arg(long)]
    write: bool,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, clap::Args)]
pub struct CameraArgs {
    /// The points file: ball size, background, positions and recordings.
    #[arg(value_name = "POINTS")]
    points: PathBuf,
    /// Camera intrinsics TOML [default: beside the first recording].
    #[arg(long, value_name = "FILE")]
    intrinsics: Option<PathBuf>,
    /// Refuse the calibration when a ball lands farther than MM from its
    /// known position.
    #[arg(long, value_name = "MM", default_value_t = camera::MAX_RESIDUAL_MM, allow_negative_numbers = true)]
    max_residual: f64,
    #[command(flatten)]
    output: Output,
}

#[derive(Debug, clap::Args)]
pub struct ForceArgs {
    /// The measured force of the static focus (N), 0.0001..=100: a reading
    /// below a gauge's 0.1 mN resolution is refused.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    measured: f64,
    /// Diameter of the gauge's disk (mm).
    #[arg(long, value_name = "MM", default_value_t = lmhost::field::study::DISK_MM, allow_negative_numbers = true)]
    disk: f64,
    /// Where the focus was, X,Y,Z (mm, no spaces) [default: the scene's LM centre].
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    center: Option<String>,
    #[command(flatten)]
    output: Output,
}

impl Output {
    fn dest(&self) -> Result<Dest, InputError> {
        if self.scene.is_none() && (self.out.is_some() || self.write) {
            return Err(InputError::new(
                "--out and --write need --scene FILE (the built-in scene has no file to update)",
            ));
        }
        Ok(match (&self.out, self.write) {
            (Some(p), _) => {
                lmhost::files::not_an_input("--out", p)?;
                Dest::Out(p.clone())
            }
            (None, true) => Dest::Write,
            (None, false) => Dest::Print,
        })
    }

    /// The scene and its text.
    fn load(&self) -> Result<(Scene, String), InputError> {
        match &self.scene {
            Some(p) => {
                let text = lmhost::limits::read_text_file("scene file", p)?;
                let scene = Scene::from_toml(&text, &p.display().to_string())?;
                Ok((scene, text))
            }
            None => Ok((Scene::default(), String::new())),
        }
    }

    /// Writes (or prints) `[name]` = `body`; returns what was written.
    fn finish(
        &self,
        dest: &Dest,
        text: &str,
        name: &str,
        body: &str,
    ) -> anyhow::Result<Option<PathBuf>> {
        match &self.scene {
            Some(p) => calibrate::write_scene(p, text, name, body, dest),
            None => Ok(None),
        }
    }

    fn report(
        &self,
        v: serde_json::Value,
        text: String,
        name: &str,
        body: &str,
        wrote: Option<PathBuf>,
    ) -> anyhow::Result<()> {
        if self.json {
            let mut v = v;
            v["wrote"] = json!(wrote);
            return lmhost::outln!("{}", serde_json::to_string(&v)?);
        }
        lmhost::outln!("{text}")?;
        match wrote {
            Some(p) => lmhost::outln!("wrote [{name}] into {}", p.display()),
            None => lmhost::outln!("\n[{name}]\n{}", body.trim_end()),
        }
    }
}

impl Args {
    /// Run the subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        match self {
            Self::Force(a) => a.run(),
            Self::Camera(a) => a.run(),
        }
    }
}

impl ForceArgs {
    fn run(self) -> anyhow::Result<()> {
        let center = self
            .center
            .as_deref()
            .map(|c| parse_vec3("center", c))
            .transpose()?;
        // The scene read first: an --out that is it is then refused as
        // the input it is, by its flag, before the work.
        let (scene, text) = self.output.load()?;
        let dest = self.output.dest()?;
        let cal = force::calibrate(&scene, self.measured, self.disk, center)?;
        let body = cal.table();
        let wrote = self.output.finish(&dest, &text, "calibration", &body)?;
        let c = cal.center_mm;
        let summary = format!(
            "static focus at ({}, {}, {}) mm on a {} mm disk: simulated {:.5} N, measured {} N\n\
             pressure_scale = {:.5}: pressures and forces × {:.5}, amplitudes × {:.5}",
            N(c[0]),
            N(c[1]),
            N(c[2]),
            N(cal.disk_mm),
            cal.simulated_n,
            N(cal.measured_n),
            cal.pressure_scale,
            cal.pressure_scale,
            cal.pressure_scale.sqrt(),
        );
        self.output.report(
            serde_json::to_value(&cal)?,
            summary,
            "calibration",
            &body,
            wrote,
        )
    }
}

impl CameraArgs {
    fn run(self) -> anyhow::Result<()> {
        if !(self.max_residual.is_finite() && self.max_residual > 0.0 && self.max_residual <= 100.0)
        {
            lmhost::bad_input!(
                "--max-residual must be in (0, 100] mm, got {}",
                self.max_residual
            );
        }
        let target = camera::Target::load(&self.points)?;
        let ipath = match &self.intrinsics {
            Some(p) => p.clone(),
            None => {
                let p = intrinsics_beside(&target.points[0].1);
                if !p.exists() {
                    lmhost::bad_input!(
                        "--intrinsics is needed (no {} beside the first recording)",
                        p.display()
                    );
                }
                p
            }
        };
        let intr = Intrinsics::load(&ipath)?;
        let (_, text) = self.output.load()?;
        let dest = self.output.dest()?;
        let cal = camera::calibrate(&target, &intr, self.max_residual)?;
        let body = cal.table();
        let wrote = self.output.finish(&dest, &text, "camera", &body)?;
        let mut summary = format!(
            "{} ball positions: residual RMS {:.3} mm\n",
            cal.balls.len(),
            cal.rms_mm
        );
        for (i, (b, e)) in cal.balls.iter().zip(&cal.residuals_mm).enumerate() {
            summary.push_str(&format!(
                "  point[{i}]: {} points, fit RMS {:.2} mm, residual {:.3} mm\n",
                b.points, b.rms_mm, e
            ));
        }
        let p = cal.pose.position_mm;
        summary.push_str(&format!(
            "camera at ({:.2}, {:.2}, {:.2}) mm, looking along ({:.4}, {:.4}, {:.4})",
            p[0], p[1], p[2], cal.pose.axes[2][0], cal.pose.axes[2][1], cal.pose.axes[2][2]
        ));
        self.output
            .report(serde_json::to_value(&cal)?, summary, "camera", &body, wrote)
    }
}
