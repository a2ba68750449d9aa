//! `lmhost simulate`: plan a stimulus, simulate its acoustic field on the
//! LM plane and write figures (PNG, SVG and PDF), maps (`.npy`) and a JSON
//! summary.

use std::path::PathBuf;

use crate::cmd::plan::{PlanArgs, parse_vec3};
use lmhost::error::InputError;
use lmhost::field::study::{View, simulate_plan, write_outputs};
use lmhost::field::{self, Radiation, compare, plot};

/// Simulate the acoustic field of an LM stimulus and plot it.
/// The flags a stimulus from a library stands in for.
const FROM_LIBRARY: [&str; 13] = [
    "compare",
    "radius",
    "foci",
    "spacing",
    "freq",
    "step",
    "steps",
    "center",
    "z",
    "method",
    "iterations",
    "intensity",
    "weights",
];

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Writes into --out one figure per map as PNG (288 dpi), SVG and PDF, \
    --width-mm wide: mean_pressure (time-averaged radiation pressure), lm_power (power at \
    the LM frequency), pressure, amplitude (step 0) and max_pressure; one .npy per map and \
    summary.json. Figures have no title: axes a, b are the scene's LM plane axes (mm from \
    the LM centre), with a legend for the orbit, the foci and the gauge disk. The PDF \
    embeds its font (a subset of DejaVu Sans).\n\nExamples:\n  \
    lmhost simulate --radius 3 --foci 4 --out lmm3\n  \
    lmhost simulate --scene scenes/paper.toml --radius 3 --width-mm 180 --out paper\n  \
    lmhost simulate --compare --out compare       # the paper's 3 x 5 grid\n  \
    lmhost simulate --library lib.toml --stimulus liss --out liss\n\n\
    A library entry with an amplitude modulation adds am_power (power at the AM frequency) \
    and the summary's `am` (the force spectrum's peak among them)."
)]
pub struct Args {
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR", default_value = "simulate-out")]
    out: PathBuf,
    /// Observation plane size in mm, each at most 1000: `S` (square) or
    /// `W,H`, no spaces [default: 20].
    #[arg(long, value_name = "MM[,MM]")]
    plane_size: Option<String>,
    /// Observation grid step in mm. The whole run is limited to 5e10
    /// points × transducers × steps (5e9 with --reference), ~10 s.
    #[arg(long, value_name = "MM", default_value_t = field::study::PLANE_STEP_MM, allow_negative_numbers = true)]
    plane_step: f64,
    /// Observation plane centre X,Y,Z in mm, no spaces [default: the LM centre].
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    plane_center: Option<String>,
    /// Observation plane axes `UX,UY,UZ,VX,VY,VZ`, no spaces [default: the scene's LM
    /// plane axes a, b].
    #[arg(long, value_name = "UX,UY,UZ,VX,VY,VZ", allow_hyphen_values = true)]
    plane_axes: Option<String>,
    /// Radiation-pressure coefficient α in α|p|²/(2ρc²), above 0 and at
    /// most 2 (2 = perfect reflector).
    #[arg(long, value_name = "A", default_value_t = field::DEFAULT_RADIATION_ALPHA, allow_negative_numbers = true)]
    alpha: f64,
    /// Air density ρ in kg/m³, above 0 and at most 100.
    #[arg(long, value_name = "KG_M3", default_value_t = field::DEFAULT_DENSITY_KG_M3, allow_negative_numbers = true)]
    density: f64,
    /// Diameter in mm of the disk the force is integrated over, above 0 and
    /// at most 1000 (the paper's gauge disk is 15 mm).
    #[arg(long, value_name = "MM", default_value_t = field::study::DISK_MM, allow_negative_numbers = true)]
    disk: f64,
    /// Factor on the simulated radiation pressure (measured / simulated
    /// force), in place of the scene's [calibration] (see `lmhost calibrate
    /// force`); 1e-6..=1e6. Every map and force carries it.
    #[arg(long, value_name = "K", allow_negative_numbers = true)]
    calibration: Option<f64>,
    /// Use the plain f64 loop instead of the fast path (slow; for checking).
    #[arg(long)]
    reference: bool,
    /// Stimulus library (TOML) to take the stimulus from, with --stimulus
    /// (in place of the plan flags; --scene still applies).
    #[arg(long, value_name = "FILE", requires = "stimulus", conflicts_with_all = FROM_LIBRARY)]
    library: Option<PathBuf>,
    /// The library entry to simulate (its `id`).
    // Its conflicts are stated too: clap waives `requires` when the flag
    // required conflicts with one given, so a plan flag would have let
    // --stimulus be ignored.
    #[arg(long, value_name = "ID", requires = "library", conflicts_with_all = FROM_LIBRARY)]
    stimulus: Option<String>,
    /// Render the paper's 3 x 5 grid instead of a single stimulus: rows
    /// LM-S and LM-M (--foci, or 4 if --foci is 1) at --freq with --step,
    /// then LM-S at 25 Hz with 4 mm steps; columns A = 2-6 mm (so
    /// --radius, which the columns replace, is refused).
    #[arg(long, conflicts_with = "radius")]
    compare: bool,
    /// Printed figure width in mm, 60..=500 (one column 88, two columns
    /// 180); tick labels are 7.5 pt at that width.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = plot::ONE_COLUMN_MM,
        allow_negative_numbers = true
    )]
    width_mm: f64,
    /// The scene and the stimulus (last, under their help heading).
    #[command(flatten)]
    plan: PlanArgs,
}

fn positive(flag: &str, v: f64) -> Result<f64, InputError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(InputError::new(format!(
            "--{flag} must be a finite number > 0, got {v}"
        )))
    }
}

impl Args {
    fn view(&self) -> Result<View, InputError> {
        let size_mm = match &self.plane_size {
            None => (20.0, 20.0),
            Some(s) => {
                let v: Result<Vec<f64>, _> =
                    s.split(',').map(lmhost::limits::exact_number).collect();
                if let Err(m) = &v {
                    return Err(InputError::new(format!("--plane-size: {m}")));
                }
                match v.as_deref() {
                    Ok([a]) => (positive("plane-size", *a)?, *a),
                    Ok([a, b]) => (positive("plane-size", *a)?, positive("plane-size", *b)?),
                    _ => {
                        return Err(InputError::new(format!(
                            "--plane-size takes S or W,H in mm, got `{s}`"
                        )));
                    }
                }
            }
        };
        let axes = match &self.plane_axes {
            None => None,
            Some(s) => {
                let v: Vec<f64> = s
                    .split([',', ';'])
                    .map(lmhost::limits::exact_number)
                    .collect::<Result<_, _>>()
                    .map_err(|m| InputError::new(format!("--plane-axes: {m}")))?;
                if v.len() != 6 {
                    return Err(InputError::new(format!(
                        "--plane-axes takes six numbers UX,UY,UZ,VX,VY,VZ, got `{s}`"
                    )));
                }
                Some(([v[0], v[1], v[2]], [v[3], v[4], v[5]]))
            }
        };
        let view = View {
            size_mm,
            step_mm: self.plane_step,
            center_mm: self
                .plane_center
                .as_deref()
                .map(|c| parse_vec3("plane-center", c))
                .transpose()?,
            axes,
            rad: Radiation { alpha: self.alpha },
            density: self.density,
            disk_mm: self.disk,
            calibration: self.calibration,
            reference: self.reference,
        };
        view.check()?;
        Ok(view)
    }

    /// Run the subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        let view = self.view()?;
        let fig = plot::Figure {
            width_mm: self.width_mm,
            ..plot::Figure::default()
        };
        fig.check()?;
        // A library entry replaces the plan flags; read before any output.
        let entry = match (&self.library, &self.stimulus) {
            (Some(path), Some(id)) => {
                let lib = lmhost::plan::library::Library::load(path)?;
                let (_, e) = lib.find(id).ok_or_else(|| {
                    InputError::new(format!(
                        "stimulus library {} has no stimulus `{}`",
                        path.display(),
                        id.escape_debug()
                    ))
                })?;
                Some(e.clone())
            }
            _ => None,
        };
        // The flags' stimulus (the default one beside a library entry:
        // the flags conflict with it); refused before any output directory
        // is made, as is an intensity below full.
        let flags = self.plan.flags.stimulus()?;
        lmhost::field::study::check_full_output(lmhost::plan::stimulus::intensity_byte(
            entry
                .as_ref()
                .map_or(flags.intensity, |e| e.stimulus.intensity),
        )?)?;
        // The scene is an input: refuse an --out that is it, before writing.
        self.plan.load_scene()?;
        // Removed again, while empty, when the run is refused or stopped.
        let _made = lmhost::files::output_dir("--out", &self.out)?;
        if self.compare {
            let multi = if flags.cycle.foci > 1 {
                flags.cycle.foci
            } else {
                lmhost::plan::trajectory::paper::LM_M_FOCI
            };
            let conditions = compare::paper_conditions(multi, flags.cycle.freq_hz);
            let plan_for = |c: &compare::Condition, radius| {
                let mut a = self.plan.clone();
                a.flags.radius = Some(radius);
                a.flags.foci = Some(c.foci);
                a.flags.freq = Some(c.freq_hz);
                if let Some(step) = c.step_mm {
                    a.flags.step = Some(step);
                    a.flags.steps = None;
                }
                a.plan()
            };
            return compare::compare(&conditions, plan_for, &view, &fig, &self.out);
        }
        let (plan, r) = match &entry {
            // Phases or foci from a file plan as the LM firmware plays them.
            Some(e) if e.file.is_some() => (
                e.plan_for(&lmhost::plan::target::Target::Lm, self.plan.load_scene()?)?
                    .plan,
                0.0,
            ),
            Some(e) => (
                e.stimulus.plan(self.plan.load_scene()?)?.plan,
                e.stimulus.cycle.radius_mm,
            ),
            None => (self.plan.plan()?, flags.cycle.radius_mm),
        };
        let sim = simulate_plan(&plan, &view)?;
        write_outputs(&plan, &sim, &view, r, &fig, &self.out)?;
        lmhost::outln!("{}", sim.text_summary(&plan, r))?;
        lmhost::outln!("wrote {}", self.out.display())?;
        Ok(())
    }
}
