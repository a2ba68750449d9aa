//! `lmhost plan`: plan an LM stimulus and print or write its phase sequence.
//!
//! The stimulus flags live in [`StimulusFlags`] (with the scene, in
//! [`PlanArgs`]) so `upload`, `simulate`, `stream` and `track` can
//! `#[command(flatten)]` them.

use std::path::PathBuf;

use clap::ValueEnum;
use lm_proto::codec::Encoding;

use lmhost::error::InputError;
use lmhost::geom::Vec3;
use lmhost::limits;
use lmhost::plan::scene::Scene;
use lmhost::plan::sequence::{Plan, Synthesis};
use lmhost::plan::stimulus::{Stimulus, TargetPlan, Timing};
use lmhost::plan::target::Target;
use lmhost::plan::trajectory::Cycle;

/// Multi-focus synthesis method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum Method {
    /// The paper's linear synthesis, equal weights (fast path).
    #[default]
    Linear,
    /// GS-PAT phase-only solver: equal pressure at every focus (slower).
    Gspat,
}

/// The stimulus flags of `plan`, `upload`, `simulate`, `stream` and `track
/// --port`. None has a clap default, so a streaming session knows which
/// were given (any one given plans that stimulus for the device, uploads
/// it into a free slot and plays it on every backend; none given keeps
/// what the LM firmware plays, and an AUTD3, which holds nothing, plays
/// the default stimulus); [`Self::stimulus`] fills in the paper's values.
/// The `[default: ...]` in each help line is checked against them by a
/// test.
#[derive(Debug, Clone, Default, clap::Args)]
#[command(next_help_heading = "Stimulus")]
pub struct StimulusFlags {
    /// LM circle radius A in mm, 0..=100 (0 = a static focus) [default: 3].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub radius: Option<f64>,
    /// Foci per step, 1..=32: 1 = LM-S, more = LM-M (foci rotate together)
    /// [default: 1].
    #[arg(long, value_name = "N", value_parser = super::whole::whole_for_library::<usize>(1, lmhost::plan::trajectory::MAX_FOCI as u64))]
    pub foci: Option<usize>,
    /// Spacing d between neighbouring foci along the circle in mm (LM-M),
    /// above 0 and at most 1000 [default: 3].
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub spacing: Option<f64>,
    /// LM frequency f in Hz (cycles per second), above 0 and at most 1000
    /// [default: 5].
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub freq: Option<f64>,
    /// Step width d_LM in mm, above 0 and at most 1000;
    /// N = round(2πA / d_LM) [default: 0.23].
    #[arg(
        long,
        value_name = "MM",
        conflicts_with = "steps",
        allow_negative_numbers = true
    )]
    pub step: Option<f64>,
    /// Steps per cycle N, 1..=65535 (instead of --step).
    #[arg(long, value_name = "N", value_parser = super::whole::whole_for_library::<usize>(1, lmhost::plan::trajectory::MAX_STEPS as u64))]
    pub steps: Option<usize>,
    /// LM centre X,Y,Z in mm (no spaces), finger space, each within ±2000 and in front
    /// of the array [default: the scene's centre, (0,0,200) for the
    /// built-in array].
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub center: Option<String>,
    /// Per-step depth along the LM plane's c axis in mm, each within ±100:
    /// one value, or one per step, comma-separated without spaces [default: 0].
    #[arg(long, value_name = "MM[,MM...]", allow_hyphen_values = true)]
    pub z: Option<String>,
    /// Multi-focus synthesis [default: linear].
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// GS-PAT iterations, 1..=1000 (with --method gspat) [default: 20].
    #[arg(long, value_name = "N", value_parser = super::whole::whole_for_library::<usize>(1, limits::MAX_ITERATIONS as u64))]
    pub iterations: Option<usize>,
    /// Real weight per focus, comma-separated without spaces, each within 0..=1e6 and
    /// not all zero (linear synthesis only).
    #[arg(long, value_name = "W,W,...", allow_hyphen_values = true)]
    pub weights: Option<String>,
    /// Output intensity, 0..=1 of full: the device scales its drive (the LM
    /// firmware's output frames carry it, an AUTD3 plays it as its
    /// modulation level). `simulate` models full output only [default: 1].
    #[arg(long, value_name = "0..1", allow_negative_numbers = true)]
    pub intensity: Option<f64>,
}

fn parse_list(flag: &str, s: &str) -> Result<Vec<f64>, InputError> {
    s.split(',')
        .map(|x| limits::exact_number(x).map_err(|m| InputError::new(format!("--{flag}: {m}"))))
        .collect()
}

/// Parses `--weights`: finite, each within 0..=[`limits::MAX_WEIGHT`]
/// (the synthesis refuses a negative weight), not all zero (all-zero
/// weights would play silence as if it were a plan).
fn parse_weights(s: &str) -> Result<Vec<f64>, InputError> {
    let w = parse_list("weights", s)?;
    for &x in &w {
        limits::in_range("--weights value", x, 0.0, limits::MAX_WEIGHT, "")?;
    }
    if w.iter().all(|&x| x == 0.0) {
        return Err(InputError::new(format!(
            "--weights `{s}` are all zero: at least one focus needs a non-zero weight"
        )));
    }
    Ok(w)
}

/// Parses `X,Y,Z` (mm); finite values only.
pub fn parse_vec3(flag: &str, s: &str) -> Result<Vec3, InputError> {
    let v = parse_list(flag, s)?;
    let v: Vec3 = v.try_into().map_err(|_| {
        InputError::new(format!(
            "--{flag} takes three comma-separated numbers X,Y,Z, got `{s}`"
        ))
    })?;
    if let Some((axis, x)) = ["X", "Y", "Z"]
        .into_iter()
        .zip(v)
        .find(|(_, x)| !x.is_finite())
    {
        return Err(InputError::new(format!(
            "--{flag} `{s}`: {axis} {} is not a finite number of mm",
            lmhost::limits::show(x)
        )));
    }
    Ok(v)
}

impl StimulusFlags {
    /// The flags given, by name (`--radius`, ...), in the order of `--help`.
    pub fn given(&self) -> Vec<&'static str> {
        let s = self;
        lmhost::limits::given(&[
            ("--radius", s.radius.is_some()),
            ("--foci", s.foci.is_some()),
            ("--spacing", s.spacing.is_some()),
            ("--freq", s.freq.is_some()),
            ("--step", s.step.is_some()),
            ("--steps", s.steps.is_some()),
            ("--center", s.center.is_some()),
            ("--z", s.z.is_some()),
            ("--method", s.method.is_some()),
            ("--iterations", s.iterations.is_some()),
            ("--weights", s.weights.is_some()),
            ("--intensity", s.intensity.is_some()),
        ])
    }

    /// The stimulus the flags describe, the paper's values where none is
    /// given (strings parsed, nothing planned). A flag that cannot apply
    /// (`--weights` with GS-PAT, `--iterations` without it, `--spacing`
    /// with one focus) is refused.
    pub fn stimulus(&self) -> Result<Stimulus, InputError> {
        let d = Stimulus::default();
        let center_mm = self
            .center
            .as_deref()
            .map(|c| parse_vec3("center", c))
            .transpose()?;
        let z_profile_mm = match &self.z {
            Some(z) => parse_list("z", z)?,
            None => d.cycle.z_profile_mm,
        };
        let synthesis = match (self.method.unwrap_or_default(), &self.weights) {
            (Method::Gspat, Some(_)) => {
                return Err(InputError::new("--weights applies to --method linear only"));
            }
            (Method::Gspat, None) => lmhost::plan::stimulus::gspat(
                self.iterations
                    .unwrap_or(lmhost::plan::stimulus::GSPAT_ITERATIONS),
            )?,
            (Method::Linear, _) if self.iterations.is_some() => {
                return Err(InputError::new(
                    "--iterations applies to --method gspat only",
                ));
            }
            (Method::Linear, Some(w)) => Synthesis::Weighted(parse_weights(w)?),
            (Method::Linear, None) => Synthesis::Linear,
        };
        let intensity = self.intensity.unwrap_or(d.intensity);
        Ok(Stimulus {
            cycle: Cycle {
                z_profile_mm,
                ..Cycle::given(
                    self.radius,
                    self.foci,
                    self.spacing,
                    self.freq,
                    self.step,
                    self.steps,
                )?
            },
            center_mm,
            synthesis,
            intensity: limits::in_range("--intensity", intensity, 0.0, 1.0, "")?,
            am: None,
        })
    }
}

/// What `plan`, `upload` and `simulate` plan from: the scene and the
/// stimulus flags (flattened last in each command: the flags' help
/// heading holds for every flag after them).
#[derive(Debug, Clone, clap::Args)]
pub struct PlanArgs {
    /// Scene file (TOML) [default: four AUTD3 in a flat 2×2 facing +z].
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// The stimulus (last: its help heading holds for what follows).
    #[command(flatten)]
    pub flags: StimulusFlags,
}

impl PlanArgs {
    /// The scene named by `--scene`, or the built-in one.
    pub fn load_scene(&self) -> Result<Scene, InputError> {
        Scene::load_or_default(self.scene.as_deref())
    }

    /// Loads the scene and plans the stimulus for `target`, printing its
    /// warnings (once per run, even when a command plans many stimuli).
    /// Bad flags or scene files are [`InputError`]s (exit code 2).
    pub fn plan_for(&self, target: &Target) -> anyhow::Result<TargetPlan> {
        let scene = self.load_scene()?;
        let planned = self.flags.stimulus()?.plan_for(target, scene)?;
        static WARNED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
        if !planned.warnings.is_empty() && !WARNED.swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            for w in &planned.warnings {
                lmhost::errln!("warning: {w}");
            }
        }
        Ok(planned)
    }

    /// [`Self::plan_for`] the LM firmware (the stimulus as asked).
    pub fn plan(&self) -> anyhow::Result<Plan> {
        Ok(self.plan_for(&Target::Lm)?.plan)
    }
}

/// `plan --target`: which device the plan is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TargetArg {
    /// The LM firmware (any whole-µs dwell).
    Lm,
    /// An AUTD3 (dwell on the 25 µs FPGA grid).
    Autd3,
}

impl TargetArg {
    /// The device kind to plan for (an AUTD3 plans alike on every link).
    pub fn target(self) -> Target {
        match self {
            Self::Lm => Target::Lm,
            Self::Autd3 => Target::Autd3,
        }
    }
}

/// Plan an LM stimulus: trajectory, phases, encodings.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    lmhost plan                                   # LM-S, A = 3 mm, 5 Hz, 0.23 mm steps\n  \
    lmhost plan --radius 6 --foci 4 --spacing 3   # LM-M\n  \
    lmhost plan --scene scenes/paper.toml --foci 4 --out lmm.npy\n  \
    lmhost plan --target autd3 --radius 5 --out autd3.npy  # what an AUTD3 plays (25 µs grid)\n  \
    lmhost plan --json --phases > plan.json")]
pub struct Args {
    /// The device the phases are for: `lm` plans the timing as asked (what
    /// the LM firmware plays), `autd3` on AUTD3's 25 µs dwell grid (N and
    /// the dwell an AUTD3 realises: exactly what `upload --port autd3:...`
    /// plays); the summary, `--json` and `--out` say the realised timing.
    #[arg(long, value_enum, default_value_t = TargetArg::Lm)]
    pub target: TargetArg,
    /// Print a machine-readable JSON summary instead of text.
    #[arg(long)]
    pub json: bool,
    /// Include the phases (steps × transducers) in the JSON summary.
    #[arg(long, requires = "json")]
    pub phases: bool,
    /// Write the sequence to FILE: .json (summary with phases), .npy
    /// (u8, shape steps × transducers) or anything else as raw bytes
    /// (step-major); `upload --phases` reads .json, .npy and .bin.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The scene and the stimulus (last, under their help heading).
    #[command(flatten)]
    pub plan: PlanArgs,
}

/// A short human summary.
pub fn summary_text(plan: &Plan) -> String {
    let t = &plan.trajectory;
    let s = &plan.sequence;
    let raw = s.encoded_len(Encoding::Raw);
    let delta = s.encoded_len(Encoding::Delta);
    let kind = if t.foci == 1 {
        "LM-S".to_string()
    } else {
        format!("LM-M ({} foci, l = {})", t.foci, t.index_offset)
    };
    let c = t.center_mm;
    let mut out = format!(
        "{kind} on {}: {} transducers\n\
         steps N = {}, step {:.4} mm, dwell {:.3} ms, period {:.1} ms ({:.3} Hz)\n\
         centre ({:.3}, {:.3}, {:.3}) mm{}\n\
         sequence {raw} bytes raw, {delta} bytes delta ({:.1} %), crc32 {:08x}",
        plan.scene.name,
        s.header.transducers,
        t.steps,
        t.step_mm,
        t.dwell_s * 1e3,
        t.period_s * 1e3,
        1.0 / t.period_s,
        c[0],
        c[1],
        c[2],
        if plan.scene.reflector.is_some() {
            ", foci mirrored through the reflector"
        } else {
            ""
        },
        100.0 * delta as f64 / raw as f64,
        s.crc32(),
    );
    if s.header.intensity < u8::MAX {
        out += &format!(
            "\n{} of full output",
            lmhost::plan::stimulus::intensity_words(s.header.intensity)
        );
    }
    out.push('\n');
    out
}

/// An AUTD3 plan's timing on its 25 µs grid and how far each value is
/// from the one asked, as `plan --target autd3` and `upload` print it.
pub fn grid_timing(t: &Timing) -> String {
    format!(
        "dwell {:.0} µs = {} × 25 µs ({:+.1} µs from {:.1} µs), {:.3} Hz ({:+.3} Hz from {} Hz), step {:.4} mm ({:+.4} mm from {:.4} mm)",
        t.dwell_us,
        t.divide.unwrap_or(0),
        t.dwell_error_us,
        t.requested_dwell_us,
        t.freq_hz,
        t.freq_error_hz,
        t.requested_freq_hz,
        t.step_mm,
        t.step_error_mm,
        t.requested_step_mm
    )
}

impl Args {
    /// Plans, prints and writes.
    pub fn run(self) -> anyhow::Result<()> {
        let planned = self.plan.plan_for(&self.target.target())?;
        let plan = &planned.plan;
        let target = self.target.target();
        if let Some(out) = &self.out {
            lmhost::files::not_an_input("--out", out)?;
            lmhost::files::write_whole(out, &planned.out_bytes(out, &target)?)?;
        }
        if self.json {
            let v = planned.summary_json(&target, self.phases);
            lmhost::outln!("{}", serde_json::to_string(&v)?)?;
        } else {
            lmhost::out!("{}", summary_text(plan))?;
            if self.target == TargetArg::Autd3 {
                lmhost::outln!("on AUTD3's 25 µs grid: {}", grid_timing(&planned.timing))?;
            }
            if let Some(out) = &self.out {
                lmhost::outln!("wrote {}", out.display())?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use lmhost::plan::trajectory::{Steps, paper};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        plan: PlanArgs,
    }

    fn args(a: &[&str]) -> PlanArgs {
        Cli::try_parse_from(std::iter::once("x").chain(a.iter().copied()))
            .unwrap()
            .plan
    }

    #[test]
    fn defaults_are_the_paper_lm_s() {
        let p = args(&[]).plan().unwrap();
        assert_eq!(p.trajectory.steps, 82);
        assert_eq!(p.trajectory.center_mm, [0.0, 0.0, 200.0]);
        assert_eq!(p.sequence.phases.len(), 82 * 996);
    }

    #[test]
    fn lm_m_flags() {
        let p = args(&["--foci", "4", "--step", "0.22", "--center", "0,0,220"])
            .plan()
            .unwrap();
        assert_eq!(p.trajectory.index_offset, 13);
        assert_eq!(p.trajectory.center_mm, [0.0, 0.0, 220.0]);
        let j = p.summary_json(false);
        assert_eq!(j["steps"], 86);
        assert!(j.get("phases").is_none());
        assert_eq!(j["foci_mm"][0].as_array().unwrap().len(), 4);
    }

    #[test]
    fn bad_flags_are_input_errors() {
        for a in [
            &["--radius", "-1"][..],
            &["--radius", "NaN"],
            &["--freq", "inf"],
            &["--center", "1,2"],
            &["--center", "1,x,3"],
            &["--center", "0,0,inf"],
            &["--z", "1,2,3"],
            &["--foci", "2", "--weights", "1"],
            &["--scene", "/nonexistent.toml"],
            &["--iterations", "5"],
            &["--method", "linear", "--iterations", "5"],
        ] {
            let e = args(a).plan().unwrap_err();
            assert!(e.chain().any(|c| c.is::<InputError>()), "{a:?}: {e}");
            assert!(!e.to_string().contains('\n'));
        }
    }

    /// The flags have no clap defaults (a session must see which were
    /// given), so their help states the defaults by hand: each must be
    /// the value [`StimulusFlags::stimulus`] fills in.
    #[test]
    fn help_states_the_defaults_the_stimulus_takes() {
        use clap::CommandFactory as _;
        let s = StimulusFlags::default().stimulus().unwrap();
        assert_eq!(s.cycle.steps, Steps::Width(paper::STEP_MM));
        assert_eq!(s.synthesis, Synthesis::Linear);
        assert!(s.center_mm.is_none() && s.cycle.z_profile_mm.is_empty());
        let gspat =
            lmhost::plan::stimulus::gspat(lmhost::plan::stimulus::GSPAT_ITERATIONS).unwrap();
        let mut cmd = Cli::command();
        let help = cmd.render_long_help().to_string();
        for (flag, default) in [
            ("radius", s.cycle.radius_mm.to_string()),
            ("foci", s.cycle.foci.to_string()),
            ("spacing", s.cycle.spacing_mm.to_string()),
            ("freq", s.cycle.freq_hz.to_string()),
            ("step", paper::STEP_MM.to_string()),
            ("method", "linear".to_string()),
            (
                "iterations",
                lmhost::plan::stimulus::GSPAT_ITERATIONS.to_string(),
            ),
            ("intensity", s.intensity.to_string()),
        ] {
            let arg = cmd
                .get_arguments()
                .find(|a| a.get_id() == flag)
                .unwrap_or_else(|| panic!("no --{flag}"));
            let doc = arg.get_long_help().or(arg.get_help()).unwrap().to_string();
            assert!(
                doc.ends_with(&format!("[default: {default}]")),
                "--{flag}: {doc}"
            );
        }
        assert!(help.contains("Stimulus:"), "{help}");
        // The GS-PAT default is the one `--method gspat` alone plans.
        let g = args(&["--method", "gspat"]).flags.stimulus().unwrap();
        assert_eq!(g.synthesis, gspat);
    }

    #[test]
    fn grid_timing_says_the_autd3_grid_and_what_was_asked() {
        let t = args(&["--radius", "5"])
            .plan_for(&Target::Autd3)
            .unwrap()
            .timing;
        let line = grid_timing(&t);
        assert!(line.starts_with("dwell 1475 µs = 59 × 25 µs ("), "{line}");
        assert!(line.contains("Hz from 5 Hz), step "), "{line}");
        assert!(!line.contains('\n'), "{line}");
    }

    #[test]
    fn paper_scene_defaults_to_the_marker() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml");
        let p = args(&["--scene", path, "--foci", "4"]).plan().unwrap();
        assert_eq!(p.trajectory.center_mm, [0.0, 30.0, 30.0]);
        assert_eq!(p.sequence.header.center_um, [0, 30_000, -30_000]);
        let j = p.summary_json(true);
        assert_eq!(j["phases"].as_array().unwrap().len(), 82);
        assert!(j["drive_foci_mm"].is_array());
    }

    #[test]
    fn out_of_range_plan_numbers_are_input_errors_naming_the_range() {
        for (a, want) in [
            (&["--weights", "0"][..], "all zero"),
            (&["--foci", "2", "--weights", "0,0"], "all zero"),
            (&["--weights", "1e300"], "1e300 is out of range"),
            // Refused as the flag's value, in the range the synthesis takes.
            (
                &["--foci", "2", "--weights", "-1,1"],
                "-1 is out of range: allowed 0..=",
            ),
            (&["--z", "1e12"], "-100..=100"),
            (&["--radius", "1e30", "--steps", "4"], "0..=100"),
            (&["--center", "0,0,1e30"], "±2000"),
            (&["--center", "0,0,-100"], "behind or in the plane"),
        ] {
            let e = args(a).plan().unwrap_err();
            assert!(e.chain().any(|c| c.is::<InputError>()), "{a:?}: {e}");
            assert!(e.to_string().contains(want), "{a:?}: {e}");
        }
        // A whole number out of its range: by the library's rule (the
        // words Python's `plan()` says too) where its type holds it, as
        // the flag's value where not.
        let e = args(&["--method", "gspat", "--iterations", "100000000"])
            .plan()
            .unwrap_err();
        assert!(e.chain().any(|c| c.is::<InputError>()), "{e}");
        assert_eq!(
            e.to_string(),
            "--iterations 100000000 is out of range: allowed 1..=1000"
        );
        let too_many = "99999999999999999999999";
        let Err(e) = Cli::try_parse_from(["x", "--method", "gspat", "--iterations", too_many])
        else {
            panic!("--iterations {too_many} parsed");
        };
        assert!(
            e.to_string()
                .contains(&format!("{too_many} is out of range: allowed 1..=1000")),
            "{e}"
        );
    }
}
