//! LM trajectories: the paper's LM-S (eq. 2-3) and LM-M (eq. 4-5), mirrored
//! through the scene's reflector (eq. 6-7). Equation numbers are the
//! paper's own (eq. 1 is the linear synthesis φ = Σ φ_i).
//!
//! - **Steps.** `N` is given, or derived from the step width as
//!   `N = max(1, round(2πA / d_LM))` (round to nearest: A = 3 mm,
//!   d_LM = 0.23 mm gives 2π·3/0.23 = 81.95 → 82). The realised step is
//!   `2πA / N`. A requested step wider than the circumference is an error.
//! - **Points.** `r_j = c + A(cos θ_j a + sin θ_j b) + z_j c_axis`,
//!   `θ_j = 2π j / N` for `j = 0..N` (the paper's `j − 1`); another
//!   [`Path`] (line, ellipse, Lissajous) puts its own `(u, v)` at `θ_j` in
//!   place of the circle's, and its length in place of `2πA` below.
//! - **Foci.** Focus `i` (0-based) at step `j` sits on point
//!   `(j + i·l) mod N` with `l = floor(d / d_LM + 1e-9)` computed from the
//!   realised step (the tiny guard keeps exact ratios such as 3/0.3 at 10).
//!   `l = 0` with several foci, or foci needing more than one lap
//!   (`foci · l > N`), is an error.
//! - **Dwell.** `t_d = 1 / (N f)`; shorter than the scene's minimum dwell is
//!   an error.

use crate::error::InputError;
use crate::geom::{Vec3, add, scale};
use crate::limits;
use crate::plan::path::Path;
use crate::plan::scene::{LmPlane, Scene};

/// Most foci per step the planner accepts: the most a device accepts in
/// `BeginUpload`'s `foci_per_step` ([`lm_proto::FOCI_PER_STEP`]), one
/// number for both ends.
pub const MAX_FOCI: usize = *lm_proto::FOCI_PER_STEP.end() as usize;
/// Most steps per cycle (the wire's `steps` is a u16).
pub const MAX_STEPS: usize = u16::MAX as usize;

/// The paper's 5 Hz stimulus: the one definition of every default
/// ([`Cycle::default`], and through it `LmParams::paper` and
/// `stimulus::Stimulus::default`; the CLI's flags).
pub mod paper {
    /// LM circle radius A (mm).
    pub const RADIUS_MM: f64 = 3.0;
    /// Foci per step (1: LM-S).
    pub const FOCI: usize = 1;
    /// Spacing d between neighbouring foci along the circle (mm).
    pub const SPACING_MM: f64 = 3.0;
    /// LM frequency f (Hz).
    pub const FREQ_HZ: f64 = 5.0;
    /// Step width d_LM (mm).
    pub const STEP_MM: f64 = 0.23;
    /// Foci of the paper's LM-M.
    pub const LM_M_FOCI: usize = 4;
}

/// How the number of steps is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Steps {
    /// Step width along the circle (mm); `N = round(2πA / d_LM)`.
    Width(f64),
    /// Step count `N` directly.
    Count(usize),
}

/// What one LM cycle is: the path its foci run along, how many foci, how
/// far apart, in how many steps, how fast, at what depth per step. Where
/// it is (centre, plane) and on which rig it plays are not part of it:
/// [`LmParams`] adds the place, [`crate::plan::stimulus::Stimulus`] the
/// output (synthesis, intensity, AM). Its [`Default`] is the paper's 5 Hz
/// LM-S from [`paper`].
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    /// Circle radius `A` (mm); 0 gives a static focus.
    pub radius_mm: f64,
    /// LM frequency `f` (Hz): cycles per second.
    pub freq_hz: f64,
    /// Step width or count.
    pub steps: Steps,
    /// Foci per step (1 = LM-S, more = LM-M).
    pub foci: usize,
    /// Spacing `d` between neighbouring foci along the circle (mm).
    pub spacing_mm: f64,
    /// Per-step depth `z_j` along the plane's c axis (mm): empty = 0,
    /// one value = constant, or exactly `N` values.
    pub z_profile_mm: Vec<f64>,
    /// The shape along which the foci run (the circle of `radius_mm`, or
    /// another [`Path`], which ignores `radius_mm`).
    pub path: Path,
}

impl Default for Cycle {
    /// The paper's LM-S at 5 Hz: A = 3 mm, d_LM = 0.23 mm, d = 3 mm, one
    /// focus, flat, on the circle.
    fn default() -> Self {
        Self {
            radius_mm: paper::RADIUS_MM,
            freq_hz: paper::FREQ_HZ,
            steps: Steps::Width(paper::STEP_MM),
            foci: paper::FOCI,
            spacing_mm: paper::SPACING_MM,
            z_profile_mm: Vec::new(),
            path: Path::Circle,
        }
    }
}

impl Cycle {
    /// The paper's LM-M: the default with [`paper::LM_M_FOCI`] foci.
    pub fn paper_lm_m() -> Self {
        Self {
            foci: paper::LM_M_FOCI,
            ..Self::default()
        }
    }

    /// The numbers a stimulus's flags, library entry or Python arguments
    /// give, each one not given the default cycle's. Flat, on the circle.
    /// A number that cannot apply is refused, never dropped (the one rule
    /// for every caller, worded with the flags' names): a step width with
    /// a step count, a spacing with one focus (no neighbour to space).
    pub fn given(
        radius_mm: Option<f64>,
        foci: Option<usize>,
        spacing_mm: Option<f64>,
        freq_hz: Option<f64>,
        step_mm: Option<f64>,
        steps: Option<usize>,
    ) -> Result<Self, InputError> {
        let d = Self::default();
        if step_mm.is_some() && steps.is_some() {
            return Err(InputError::new("give --step or --steps, not both"));
        }
        if spacing_mm.is_some() && foci.unwrap_or(d.foci) < 2 {
            return Err(InputError::new(
                "--spacing applies to LM-M only: give --foci 2 or more",
            ));
        }
        Ok(Self {
            radius_mm: radius_mm.unwrap_or(d.radius_mm),
            foci: foci.unwrap_or(d.foci),
            spacing_mm: spacing_mm.unwrap_or(d.spacing_mm),
            freq_hz: freq_hz.unwrap_or(d.freq_hz),
            steps: match (step_mm, steps) {
                (_, Some(n)) => Steps::Count(n),
                (Some(w), None) => Steps::Width(w),
                (None, None) => d.steps,
            },
            ..d
        })
    }

    /// Checks every number of the cycle (the one rule for the plan flags,
    /// a library entry and every planner: the firmware's trajectory and the
    /// AUTD3's dwell grid) and gives its step count `N`.
    pub fn check(&self) -> Result<usize, InputError> {
        finite_pos(self.radius_mm, "radius", "mm", true)?;
        finite_pos(self.freq_hz, "freq", "Hz", false)?;
        limits::in_range("radius", self.radius_mm, 0.0, limits::MAX_RADIUS_MM, "mm")?;
        limits::in_range(
            "frequency",
            self.freq_hz,
            limits::MIN_FREQ_HZ,
            limits::MAX_FREQ_HZ,
            "Hz",
        )?;
        if self.foci == 0 || self.foci > MAX_FOCI {
            return Err(InputError::new(format!(
                "foci must be 1..={MAX_FOCI}, got {}",
                self.foci
            )));
        }
        // Checked even for one focus, where it is unused: a NaN or negative
        // spacing is a typo, never silently ignored.
        finite_pos(self.spacing_mm, "spacing", "mm", false)?;
        limits::in_range_above(
            "spacing",
            self.spacing_mm,
            0.0,
            limits::MAX_SPACING_MM,
            "mm",
        )?;
        self.path.check()?;
        let circumference = self.path.length_mm(self.radius_mm);
        let length_name = self.path.length_name();
        Ok(match self.steps {
            Steps::Count(n) => {
                if n == 0 || n > MAX_STEPS {
                    return Err(InputError::new(format!(
                        "steps must be 1..={MAX_STEPS}, got {n}"
                    )));
                }
                n
            }
            Steps::Width(w) => {
                finite_pos(w, "step", "mm", false)?;
                limits::in_range_above("step", w, 0.0, limits::MAX_SPACING_MM, "mm")?;
                if circumference == 0.0 {
                    1
                } else {
                    // The length in digits that show it, however small
                    // (`{:.3}` said 0.000 mm for a radius of 1e-300).
                    let length = limits::Num(circumference);
                    if w > circumference {
                        return Err(InputError::new(format!(
                            "step {w} mm is wider than the {length_name} = {length:.3} mm; \
                             use a smaller --step or --steps 1"
                        )));
                    }
                    let n = (circumference / w).round().max(1.0);
                    if n > MAX_STEPS as f64 {
                        // The step's own range, not a step count derived
                        // from it (`1e-320` gave "inf steps").
                        return Err(InputError::new(format!(
                            "step {} mm is out of range: allowed {}..={} mm (a finer one takes more than {MAX_STEPS} steps along the {length_name} = {length:.3} mm)",
                            limits::show(w),
                            limits::Num(circumference / MAX_STEPS as f64),
                            limits::Num(circumference),
                        )));
                    }
                    n as usize
                }
            }
        })
    }

    /// A static focus: radius 0, one focus, one step (the force
    /// calibration's stimulus).
    pub fn static_focus() -> Self {
        Self {
            radius_mm: 0.0,
            foci: 1,
            steps: Steps::Count(1),
            ..Self::default()
        }
    }

    /// This cycle around `center_mm` in `plane`.
    pub fn at(&self, center_mm: Vec3, plane: LmPlane) -> LmParams {
        LmParams {
            cycle: self.clone(),
            center_mm,
            plane,
        }
    }
}

/// One LM cycle in place: what [`Trajectory::plan`] plans.
#[derive(Debug, Clone, PartialEq)]
pub struct LmParams {
    /// The cycle.
    pub cycle: Cycle,
    /// Circle centre in finger space (mm).
    pub center_mm: Vec3,
    /// Plane unit vectors.
    pub plane: LmPlane,
}

impl LmParams {
    /// The paper's LM-S ([`Cycle::default`]) around `center_mm` in the
    /// default plane.
    pub fn paper(center_mm: Vec3) -> Self {
        Cycle::default().at(center_mm, LmPlane::default())
    }
}

/// A planned trajectory: where each focus is at each step.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Trajectory {
    /// Steps per cycle `N`.
    pub steps: usize,
    /// Foci per step.
    pub foci: usize,
    /// Index offset `l` between neighbouring foci (0 for one focus).
    pub index_offset: usize,
    /// Realised step width `2πA / N` (mm).
    pub step_mm: f64,
    /// Dwell per step `1 / (N f)` (s).
    pub dwell_s: f64,
    /// Cycle period `1 / f` (s).
    pub period_s: f64,
    /// Circle centre in finger space (mm).
    pub center_mm: Vec3,
    /// Foci in finger space, step-major: `foci_mm[j * foci + i]`.
    pub foci_mm: Vec<Vec3>,
    /// Points the array focuses on (mirrored when the scene has a
    /// reflector), same layout as `foci_mm`.
    pub drive_mm: Vec<Vec3>,
    /// The shape the foci run along (`None`: foci from a file).
    #[serde(skip)]
    pub path: Option<Path>,
}

fn finite_pos(v: f64, name: &str, unit: &str, allow_zero: bool) -> Result<(), InputError> {
    let ok = v.is_finite() && (v > 0.0 || (allow_zero && v == 0.0));
    if ok {
        return Ok(());
    }
    let need = if allow_zero { "≥ 0" } else { "> 0" };
    let what = if name == "freq" { "frequency" } else { name };
    Err(InputError::new(format!(
        "{what} (--{name}) must be a finite number {need} {unit}, got {}",
        crate::limits::show(v)
    )))
}

/// The wire carries positions as i32 µm: ±2147 mm.
const WIRE_MAX_MM: f64 = i32::MAX as f64 / 1000.0;

fn check_wire_range(v: Vec3, what: &str) -> Result<(), InputError> {
    if v.iter().all(|x| x.abs() <= WIRE_MAX_MM) {
        Ok(())
    } else {
        Err(InputError::new(format!(
            "{what} [{}] mm is beyond the wire's range of ±{WIRE_MAX_MM:.0} mm per coordinate",
            v.map(limits::show).join(", ")
        )))
    }
}

impl Trajectory {
    /// Plans the trajectory for `at` in `scene` (its reflector and minimum
    /// dwell). Every rejection is an [`InputError`] naming the parameter.
    pub fn plan(at: &LmParams, scene: &Scene) -> Result<Self, InputError> {
        let p = &at.cycle;
        let n = p.check()?;
        if !at.center_mm.iter().all(|x| x.is_finite()) {
            return Err(InputError::new(format!(
                "center must be finite, got {:?}",
                at.center_mm
            )));
        }
        limits::position_mm("center", at.center_mm)?;
        let circumference = p.path.length_mm(p.radius_mm);
        let length_name = p.path.length_name();
        let step_mm = circumference / n as f64;
        let index_offset = if p.foci > 1 {
            if circumference == 0.0 {
                return Err(InputError::new(
                    "several foci need a radius > 0 (with radius 0 they coincide)",
                ));
            }
            let l = (p.spacing_mm / step_mm + 1e-9).floor();
            if l < 1.0 {
                return Err(InputError::new(format!(
                    "spacing {} mm is below one step ({step_mm:.4} mm): l = floor(d/d_LM) = 0 \
                     puts every focus on the same point",
                    p.spacing_mm
                )));
            }
            if l * p.foci as f64 > n as f64 {
                return Err(InputError::new(format!(
                    "{} foci {} mm apart need {:.3} mm of track but the {length_name} is {circumference:.3} mm; \
                     use fewer foci or a smaller spacing",
                    p.foci,
                    p.spacing_mm,
                    l * p.foci as f64 * step_mm
                )));
            }
            l as usize
        } else {
            0
        };
        let z_at: Box<dyn Fn(usize) -> f64> = match p.z_profile_mm.len() {
            0 => Box::new(|_| 0.0),
            1 => {
                let z = p.z_profile_mm[0];
                Box::new(move |_| z)
            }
            len if len == n => Box::new(|j| p.z_profile_mm[j]),
            len => {
                return Err(InputError::new(format!(
                    "z profile has {len} values; give 1 or one per step ({n})"
                )));
            }
        };
        if let Some(z) = p.z_profile_mm.iter().find(|z| !z.is_finite()) {
            return Err(InputError::new(format!(
                "z profile values must be finite, got {z}"
            )));
        }
        for &z in &p.z_profile_mm {
            limits::in_range("z", z, -limits::MAX_Z_MM, limits::MAX_Z_MM, "mm")?;
        }
        let period_s = 1.0 / p.freq_hz;
        let dwell_s = period_s / n as f64;
        if dwell_s < scene.min_dwell_s * (1.0 - 1e-12) {
            return Err(InputError::new(format!(
                "dwell 1/(N·f) = {:.4} ms is below the device minimum {:.4} ms (N = {n}, f = {} Hz); \
                 use a larger --step or a lower --freq",
                limits::Num(dwell_s * 1e3),
                limits::Num(scene.min_dwell_s * 1e3),
                p.freq_hz
            )));
        }
        let pl = &at.plane;
        let points: Vec<Vec3> = (0..n)
            .map(|j| {
                let th = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
                let (u, v) = p.path.at(th, p.radius_mm);
                let ring = add(scale(pl.a, u), scale(pl.b, v));
                add(add(at.center_mm, ring), scale(pl.c, z_at(j)))
            })
            .collect();
        let mut foci_mm = Vec::with_capacity(n * p.foci);
        for j in 0..n {
            for i in 0..p.foci {
                foci_mm.push(points[(j + i * index_offset) % n]);
            }
        }
        let drive_mm: Vec<Vec3> = foci_mm.iter().map(|&f| scene.drive_point(f)).collect();
        for (f, d) in foci_mm.iter().zip(&drive_mm) {
            check_wire_range(*f, "focus")?;
            check_wire_range(*d, "drive point (mirrored focus)")?;
        }
        if let Some(d) = drive_mm.iter().find(|d| !scene.faces(**d)) {
            return Err(InputError::new(format!(
                "focus [{:.1}, {:.1}, {:.1}] mm is behind or in the plane of every device \
                 (no transducer faces it); move the centre in front of the array",
                d[0], d[1], d[2]
            )));
        }
        Ok(Self {
            steps: n,
            foci: p.foci,
            index_offset,
            step_mm,
            dwell_s,
            period_s,
            center_mm: at.center_mm,
            foci_mm,
            drive_mm,
            path: Some(p.path),
        })
    }

    /// The drive points of step `j`.
    pub fn drive_step(&self, j: usize) -> &[Vec3] {
        &self.drive_mm[j * self.foci..(j + 1) * self.foci]
    }

    /// The finger-space foci of step `j`.
    pub fn foci_step(&self, j: usize) -> &[Vec3] {
        &self.foci_mm[j * self.foci..(j + 1) * self.foci]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's parameters at 200 mm, changed by `f`.
    fn tweaked(f: impl FnOnce(&mut LmParams)) -> LmParams {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        f(&mut p);
        p
    }

    /// Asserts `p` is refused with an error that says `says`.
    #[track_caller]
    fn refused(p: &LmParams, says: &str) {
        let e = plan(p).unwrap_err().0;
        assert!(e.contains(says), "{e}");
    }
    use crate::geom::{norm, sub};

    fn plan(p: &LmParams) -> Result<Trajectory, InputError> {
        Trajectory::plan(p, &Scene::default())
    }

    #[test]
    fn paper_lm_s_has_82_steps_and_2_439_ms_dwell() {
        let t = plan(&LmParams::paper([0.0, 0.0, 200.0])).unwrap();
        assert_eq!(t.steps, 82);
        assert!((t.dwell_s * 1e3 - 2.439).abs() < 5e-4, "{}", t.dwell_s);
        assert!((t.step_mm - 0.22987).abs() < 1e-4);
        assert!((t.period_s - 0.2).abs() < 1e-15);
        // Every point is A from the centre, in the plane.
        for f in &t.foci_mm {
            assert!((norm(sub(*f, t.center_mm)) - 3.0).abs() < 1e-12);
            assert_eq!(f[2], 200.0);
        }
        // θ_0 = 0 points along a.
        assert_eq!(t.foci_mm[0], [3.0, 0.0, 200.0]);
    }

    #[test]
    fn paper_lm_m_index_offset_is_13_at_0_22_mm() {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.steps = Steps::Width(0.22);
        p.cycle.foci = 4;
        let t = plan(&p).unwrap();
        assert_eq!(t.steps, 86);
        assert_eq!(t.index_offset, 13);
        // Focus i at step j is point (j + 13 i) mod N; step 80 wraps.
        let mut one = p.clone();
        one.cycle.foci = 1;
        let pts = plan(&one).unwrap();
        for (i, want) in [80usize, 7, 20, 33].iter().enumerate() {
            assert_eq!(t.foci_step(80)[i], pts.foci_mm[*want]);
        }
        // Neighbouring foci are 13 steps ≈ 2.85 mm of arc apart (< d = 3).
        let arc = 13.0 * t.step_mm;
        assert!(arc <= 3.0 && arc > 3.0 - t.step_mm);
    }

    #[test]
    fn exact_spacing_ratio_is_not_floored_down() {
        // 2π·A/N = 0.3 exactly when A = 0.3·N/2π; d = 3 → l = 10, not 9.
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.radius_mm = 0.3 * 100.0 / (2.0 * std::f64::consts::PI);
        p.cycle.steps = Steps::Count(100);
        p.cycle.freq_hz = 1.0;
        p.cycle.foci = 2;
        assert_eq!(plan(&p).unwrap().index_offset, 10);
    }

    #[test]
    fn radius_zero_is_a_static_focus() {
        let mut p = LmParams::paper([1.0, 2.0, 150.0]);
        p.cycle.radius_mm = 0.0;
        let t = plan(&p).unwrap();
        assert_eq!(t.steps, 1);
        assert_eq!(t.foci_mm, vec![[1.0, 2.0, 150.0]]);
        p.cycle.foci = 2;
        assert!(plan(&p).unwrap_err().0.contains("radius > 0"));
    }

    #[test]
    fn n_equals_one() {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.steps = Steps::Count(1);
        p.cycle.freq_hz = 1.0;
        let t = plan(&p).unwrap();
        assert_eq!((t.steps, t.dwell_s), (1, 1.0));
        assert_eq!(t.foci_mm, vec![[3.0, 0.0, 200.0]]);
    }

    #[test]
    fn step_wider_than_circumference_is_an_error() {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.steps = Steps::Width(19.0);
        refused(&p, "wider than the circumference");
        // Just inside the circumference it rounds to one step.
        p.cycle.steps = Steps::Width(18.8);
        p.cycle.freq_hz = 1.0;
        assert_eq!(plan(&p).unwrap().steps, 1);
    }

    #[test]
    fn spacing_below_one_step_is_l_zero_error() {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.foci = 4;
        p.cycle.spacing_mm = 0.1;
        refused(&p, "l = floor(d/d_LM) = 0");
    }

    #[test]
    fn foci_times_spacing_longer_than_circumference_is_an_error() {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.radius_mm = 2.0;
        p.cycle.foci = 5;
        p.cycle.spacing_mm = 3.0;
        refused(&p, "circumference");
        // Four foci at 3 mm fit on a 2 mm circle (12.57 mm).
        p.cycle.foci = 4;
        assert_eq!(plan(&p).unwrap().foci, 4);
    }

    #[test]
    fn nan_inf_and_negative_inputs_are_rejected() {
        let bad = [
            tweaked(|p| p.cycle.radius_mm = f64::NAN),
            tweaked(|p| p.cycle.radius_mm = -1.0),
            tweaked(|p| p.cycle.freq_hz = f64::INFINITY),
            tweaked(|p| p.cycle.freq_hz = 0.0),
            tweaked(|p| p.cycle.steps = Steps::Width(-0.2)),
            tweaked(|p| p.center_mm = [0.0, f64::NAN, 0.0]),
            tweaked(|p| {
                p.cycle.foci = 2;
                p.cycle.spacing_mm = f64::NEG_INFINITY;
            }),
            tweaked(|p| p.cycle.z_profile_mm = vec![f64::NAN]),
        ];
        for p in bad {
            let e = plan(&p).unwrap_err().0;
            assert!(!e.contains('\n') && !e.is_empty(), "{e}");
        }
    }

    #[test]
    fn dwell_below_device_minimum_is_rejected() {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.freq_hz = 25.0; // 82 steps at 25 Hz: 0.49 ms
        refused(&p, "below the device minimum");
        // The paper's 25 Hz condition uses 4 mm steps: N = 5, 8 ms.
        p.cycle.steps = Steps::Width(4.0);
        let t = plan(&p).unwrap();
        assert_eq!(t.steps, 5);
        assert!((t.dwell_s - 0.008).abs() < 1e-12);
    }

    #[test]
    fn z_profile_constant_or_per_step() {
        let mut p = LmParams::paper([0.0, 0.0, 200.0]);
        p.cycle.steps = Steps::Count(4);
        p.cycle.freq_hz = 1.0;
        p.cycle.z_profile_mm = vec![1.0, 2.0, 3.0, 4.0];
        let t = plan(&p).unwrap();
        let z: Vec<f64> = t.foci_mm.iter().map(|f| f[2]).collect();
        assert_eq!(z, vec![201.0, 202.0, 203.0, 204.0]);
        p.cycle.z_profile_mm = vec![1.0, 2.0];
        assert!(plan(&p).unwrap_err().0.contains("z profile"));
    }

    #[test]
    fn reflector_mirrors_drive_points_and_tilted_plane_is_used() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml");
        let scene = Scene::load(std::path::Path::new(path)).unwrap();
        let mut p = LmParams::paper(scene.center_mm);
        p.plane = scene.lm_plane;
        let t = Trajectory::plan(&p, &scene).unwrap();
        for (f, d) in t.foci_mm.iter().zip(&t.drive_mm) {
            assert_eq!([f[0], f[1]], [d[0], d[1]]);
            assert!((f[2] + d[2]).abs() < 1e-12);
            assert!((norm(sub(*f, scene.center_mm)) - 3.0).abs() < 1e-9);
        }
        // θ = 90° goes along b = (0, sin 50°, cos 50°), across the wave.
        let q = t.foci_mm[82 / 4];
        assert!(q[1] > 30.0 && q[2] > 30.0, "{q:?}");
    }

    #[test]
    fn plan_numbers_outside_their_ranges_are_refused() {
        let cases = [
            ("radius", tweaked(|p| p.cycle.radius_mm = 1e30)),
            ("frequency", tweaked(|p| p.cycle.freq_hz = 1e9)),
            ("center", tweaked(|p| p.center_mm = [0.0, 0.0, 1e12])),
            ("z", tweaked(|p| p.cycle.z_profile_mm = vec![1e12])),
            ("step", tweaked(|p| p.cycle.steps = Steps::Width(1e30))),
        ];
        for (what, p) in cases {
            let e = plan(&p).unwrap_err();
            assert!(e.0.contains(what) && e.0.contains("range"), "{what}: {e}");
        }
    }

    #[test]
    fn a_focus_behind_or_in_the_plane_of_the_array_is_refused() {
        for z in [-100.0, 0.0] {
            let e = plan(&LmParams::paper([0.0, 0.0, z])).unwrap_err();
            assert!(e.0.contains("behind or in the plane"), "{e}");
        }
        assert!(plan(&LmParams::paper([0.0, 0.0, 1.0])).is_ok());
    }
}
