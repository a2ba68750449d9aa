//! A stimulus as a study names it, its defaults, and its plan for a device.
//!
//! [`Stimulus`] holds what the plan flags (`--radius`, `--foci`, ...), the
//! demo and a stimulus library entry say: everything about the stimulus
//! and nothing about the rig, its LM cycle a [`Cycle`]. Its [`Default`] is
//! the paper's 5 Hz condition (LM-S, A = 3 mm, 0.23 mm steps) from
//! [`Cycle::default`], which reads [`paper`](crate::plan::trajectory::paper),
//! the one place the defaults are written; the CLI's flag defaults read
//! the same. [`Stimulus::plan_for`] is the one
//! entry point from a stimulus to the phases a given device plays: on an
//! AUTD3 on its 25 µs dwell grid, on the LM firmware as asked.

use crate::error::InputError;
use crate::geom::Vec3;
use crate::plan::grid::GridTiming;
use crate::plan::modulation::Am;
use crate::plan::scene::Scene;
use crate::plan::sequence::{Plan, Synthesis};
use crate::plan::target::Target;
use crate::plan::trajectory::{Cycle, LmParams, Steps};

/// Default GS-PAT iterations.
pub const GSPAT_ITERATIONS: usize = 20;

/// Below this angle between the LM plane and the beam axis the circle runs
/// along the beam instead of across the finger pad.
pub const MIN_LM_PLANE_BEAM_ANGLE_DEG: f64 = 30.0;

/// One stimulus, independent of the rig: an LM cycle, where it plays if
/// not at the scene's centre, and how the output makes it.
#[derive(Debug, Clone, PartialEq)]
pub struct Stimulus {
    /// The LM cycle.
    pub cycle: Cycle,
    /// Circle centre in finger space (mm); `None`: the scene's centre.
    pub center_mm: Option<Vec3>,
    /// Multi-focus synthesis.
    pub synthesis: Synthesis,
    /// Output intensity, 0..=1 (1 = full); the plan's header carries
    /// `round(intensity × 255)` (the device puts it in every output frame).
    pub intensity: f64,
    /// Amplitude modulation of the output, if any.
    pub am: Option<Am>,
}

impl Default for Stimulus {
    /// The paper's LM-S at 5 Hz ([`Cycle::default`]) at the scene's
    /// centre, linear synthesis, full output, no AM.
    fn default() -> Self {
        Self::of(Cycle::default())
    }
}

/// A stimulus planned for one device.
#[derive(Debug, Clone)]
pub struct TargetPlan {
    /// The plan (on the device's dwell grid).
    pub plan: Plan,
    /// What the device will play against what was asked.
    pub timing: Timing,
    /// One-line warnings about the stimulus in this scene.
    pub warnings: Vec<String>,
}

impl TargetPlan {
    /// The JSON summary `lmhost plan --json --target ...` prints: the
    /// plan's [`Plan::summary_json`] with the target and its realised timing.
    pub fn summary_json(&self, target: &Target, phases: bool) -> serde_json::Value {
        let mut v = self.plan.summary_json(phases);
        v["target"] = serde_json::json!(target.name());
        v["timing"] = serde_json::json!(self.timing);
        v
    }

    /// What `lmhost plan --out PATH` writes, by `PATH`'s extension: `.json`
    /// (the summary with the phases), `.npy` (u8, steps × transducers),
    /// anything else the raw phase bytes (step-major).
    pub fn out_bytes(&self, path: &std::path::Path, target: &Target) -> anyhow::Result<Vec<u8>> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        Ok(match ext.as_deref() {
            Some("json") => {
                let mut b = serde_json::to_vec(&self.summary_json(target, true))?;
                b.push(b'\n');
                b
            }
            Some("npy") => self.plan.sequence.to_npy(),
            _ => self.plan.sequence.phases.clone(),
        })
    }
}

/// Realised timing against the request, on every backend: the LM firmware
/// plays the asked frequency (its step is the nearest whole `N`), an AUTD3
/// the nearest on its 25 µs grid.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Timing {
    /// Steps per cycle `N`.
    pub steps: usize,
    /// Dwell per step (µs).
    pub dwell_us: f64,
    /// Dwell the request asked for, `1 / (N f)` (µs).
    pub requested_dwell_us: f64,
    /// `dwell_us - requested_dwell_us`.
    pub dwell_error_us: f64,
    /// Realised LM frequency (Hz).
    pub freq_hz: f64,
    /// Requested LM frequency (Hz).
    pub requested_freq_hz: f64,
    /// `freq_hz - requested_freq_hz`.
    pub freq_error_hz: f64,
    /// Realised step width `2πA / N` (mm).
    pub step_mm: f64,
    /// Requested step width (mm; for a step count, `2πA / N`).
    pub requested_step_mm: f64,
    /// `step_mm - requested_step_mm`.
    pub step_error_mm: f64,
    /// AUTD3: dwell = `divide` × 25 µs (`None`, JSON `null`, elsewhere).
    pub divide: Option<u16>,
    /// Realised amplitude modulation frequency (Hz; `None`, JSON `null`,
    /// without AM): on an AUTD3 4 kHz over whole samples per period, on
    /// the LM firmware whole AM periods per cycle over the cycle's period.
    pub am_freq_hz: Option<f64>,
}

impl Timing {
    fn new(
        plan: &Plan,
        requested_freq_hz: f64,
        requested_step_mm: f64,
        divide: Option<u16>,
    ) -> Self {
        // What the device plays: the header's whole-µs period.
        let t = &plan.trajectory;
        let period_us = f64::from(plan.sequence.header.period_us);
        let dwell_us = plan.sequence.dwell_us();
        let requested_dwell_us = 1e6 / (requested_freq_hz * t.steps as f64);
        let freq_hz = 1e6 / period_us;
        Self {
            steps: t.steps,
            dwell_us,
            requested_dwell_us,
            dwell_error_us: dwell_us - requested_dwell_us,
            freq_hz,
            requested_freq_hz,
            freq_error_hz: freq_hz - requested_freq_hz,
            step_mm: t.step_mm,
            requested_step_mm,
            step_error_mm: t.step_mm - requested_step_mm,
            divide,
            am_freq_hz: plan.am.map(|a| a.realised_freq_hz()),
        }
    }
}

impl Stimulus {
    /// `cycle` at the scene's centre, linear synthesis, full output, no AM.
    pub fn of(cycle: Cycle) -> Self {
        Self {
            cycle,
            center_mm: None,
            synthesis: Synthesis::Linear,
            intensity: 1.0,
            am: None,
        }
    }

    /// The paper's LM-M: the default with four foci 3 mm apart.
    pub fn paper_lm_m() -> Self {
        Self::of(Cycle::paper_lm_m())
    }

    /// The trajectory parameters in `scene` (its centre and LM plane unless
    /// the stimulus names a centre).
    pub fn params(&self, scene: &Scene) -> LmParams {
        self.cycle
            .at(self.center_mm.unwrap_or(scene.center_mm), scene.lm_plane)
    }

    /// Plans the stimulus in `scene` for the device `target` names. A plan
    /// that cannot be made is one error and no warning. An amplitude
    /// modulation becomes, for the LM firmware, the sequence's intensity
    /// table ([`Am::lm_table`]: refused, with the frequencies that fit,
    /// when the cycle's steps cannot carry it), for an AUTD3 its
    /// modulation; `timing.am_freq_hz` is what the device plays.
    pub fn plan_for(&self, target: &Target, scene: Scene) -> anyhow::Result<TargetPlan> {
        let mut p = self.plan_unchecked(target, scene)?;
        if let (Target::Lm, Some(am)) = (target, &self.am) {
            let lm = am.lm_table(p.plan.trajectory.steps, p.plan.sequence.header.period_us)?;
            p.plan.sequence.intensity_table = Some(lm.table);
            p.timing.am_freq_hz = Some(lm.freq_hz);
        }
        Ok(p)
    }

    /// Plans the stimulus in `scene` as asked, an amplitude modulation
    /// included (at its AUTD3 realisation, no intensity table), for a
    /// simulation or a plan file (no device plays it).
    pub fn plan(&self, scene: Scene) -> anyhow::Result<TargetPlan> {
        self.plan_unchecked(&Target::Lm, scene)
    }

    fn plan_unchecked(&self, target: &Target, scene: Scene) -> anyhow::Result<TargetPlan> {
        let intensity = intensity_byte(self.intensity)?;
        if let Some(am) = &self.am {
            am.check()?;
        }
        let params = self.params(&scene);
        let (mut plan, grid) = target.plan_on_grid(&params, &scene, &self.synthesis)?;
        plan.sequence.header.intensity = intensity;
        // Before the timing, which reports the modulation's frequency.
        plan.am = self.am;
        let warnings = lm_plane_warning(&plan.scene, params.center_mm)
            .into_iter()
            .collect();
        let timing = match grid {
            Some(GridTiming {
                divide,
                requested_freq_hz,
                requested_step_mm,
                ..
            }) => Timing::new(&plan, requested_freq_hz, requested_step_mm, Some(divide)),
            None => {
                let requested_step_mm = match self.cycle.steps {
                    Steps::Width(w) => w,
                    Steps::Count(_) => plan.trajectory.step_mm,
                };
                Timing::new(&plan, self.cycle.freq_hz, requested_step_mm, None)
            }
        };
        Ok(TargetPlan {
            plan,
            timing,
            warnings,
        })
    }
}

/// The wire intensity `round(intensity × 255)` of an intensity in 0..=1;
/// anything else (NaN included) is an [`InputError`], never clamped.
pub fn intensity_byte(intensity: f64) -> Result<u8, InputError> {
    if !(0.0..=1.0).contains(&intensity) {
        return Err(InputError::new(format!(
            "intensity {intensity} is out of range: allowed 0..=1 (1 = full)"
        )));
    }
    let level = (intensity * 255.0).round() as u8;
    // Some output asked for, none played: refused, not rounded to silence.
    if level == 0 && intensity > 0.0 {
        return Err(InputError::new(format!(
            "intensity {} rounds to level 0 of 255, silence: give 0 for silence or at least {} (level 1)",
            crate::limits::show(intensity),
            // Rounded up, so the value named plays (0.5/255 shown in 6
            // digits would round back down to silence).
            crate::limits::show((0.5 / 255.0 * 1e5_f64).ceil() / 1e5)
        )));
    }
    Ok(level)
}

/// A wire intensity in words, as reports print it: `intensity 0.501961
/// (128/255)`, the fraction of full output the level stands for.
pub fn intensity_words(level: u8) -> String {
    format!(
        "intensity {} ({level}/255)",
        crate::limits::show(f64::from(level) / 255.0)
    )
}

/// A one-line warning when the scene's LM plane is within
/// [`MIN_LM_PLANE_BEAM_ANGLE_DEG`] of containing the beam axis.
pub fn lm_plane_warning(scene: &Scene, center_mm: Vec3) -> Option<String> {
    let a = scene.lm_plane_beam_angle_deg(center_mm)?;
    (a < MIN_LM_PLANE_BEAM_ANGLE_DEG).then(|| {
        format!(
            "the LM plane of {} is {a:.0}° from the beam axis (under {MIN_LM_PLANE_BEAM_ANGLE_DEG:.0}°): \
             the circle runs along the wave, not across the finger pad; set lm_plane.c along the wave",
            scene.name
        )
    })
}

/// Checks a GS-PAT iteration count (1..=[`crate::limits::MAX_ITERATIONS`]).
pub fn gspat(iterations: usize) -> Result<Synthesis, InputError> {
    if !(1..=crate::limits::MAX_ITERATIONS).contains(&iterations) {
        return Err(InputError::new(format!(
            "--iterations {iterations} is out of range: allowed 1..={}",
            crate::limits::MAX_ITERATIONS
        )));
    }
    Ok(Synthesis::GsPat { iterations })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::trajectory::paper;

    #[test]
    fn the_default_is_the_papers_5_hz_lm_s_and_lm_m_adds_foci() {
        let scene = Scene::default();
        let p = Stimulus::default().params(&scene);
        assert_eq!(p, LmParams::paper(scene.center_mm));
        let m = Stimulus::paper_lm_m().plan(scene.clone()).unwrap();
        assert_eq!(m.plan.trajectory.foci, 4);
        assert_eq!(m.plan.trajectory.steps, 82);
        assert!(m.timing.divide.is_none() && m.warnings.is_empty());
        // 200 ms is a whole number of µs: the LM firmware plays 5 Hz exactly.
        assert_eq!(m.timing.freq_error_hz, 0.0, "{:?}", m.timing);
        assert!(
            (m.timing.step_error_mm - (2.0 * std::f64::consts::PI * 3.0 / 82.0 - 0.23)).abs()
                < 1e-12
        );
    }

    #[test]
    fn params_put_the_cycle_in_the_scenes_plane_at_its_centre_or_the_stimulus_own() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml");
        let scene = Scene::load(std::path::Path::new(path)).unwrap();
        assert_ne!(scene.lm_plane, Scene::default().lm_plane, "a tilted plane");
        let s = Stimulus::paper_lm_m();
        let p = s.params(&scene);
        assert_eq!(
            (&p.cycle, p.center_mm, p.plane),
            (&s.cycle, scene.center_mm, scene.lm_plane)
        );
        let own = [1.0, 2.0, 150.0];
        let p = Stimulus {
            center_mm: Some(own),
            ..s.clone()
        }
        .params(&scene);
        assert_eq!((p.center_mm, p.plane), (own, scene.lm_plane));
        assert_eq!(p.cycle.foci, paper::LM_M_FOCI);
    }

    #[test]
    fn intensity_goes_into_the_header_and_out_of_range_is_input_error() {
        let half = Stimulus {
            intensity: 0.5,
            ..Stimulus::default()
        };
        let p = half.plan(Scene::default()).unwrap();
        assert_eq!(p.plan.sequence.header.intensity, 128);
        let full = Stimulus::default().plan(Scene::default()).unwrap();
        assert_eq!(full.plan.sequence.header.intensity, 255);
        assert_eq!(intensity_byte(0.0).unwrap(), 0);
        for bad in [-0.01, 1.01, f64::NAN, f64::INFINITY] {
            let s = Stimulus {
                intensity: bad,
                ..Stimulus::default()
            };
            let e = s.plan(Scene::default()).unwrap_err();
            assert!(e.downcast_ref::<InputError>().is_some(), "{bad}: {e}");
            assert!(!e.to_string().contains('\n'), "one line: {e}");
        }
    }

    #[test]
    fn an_lm_plan_carries_am_as_its_intensity_table_and_reports_its_frequency() {
        use crate::plan::modulation::{Am, AmShape};
        let am = |freq_hz| Stimulus {
            am: Some(Am {
                shape: AmShape::Square,
                freq_hz,
                depth: 1.0,
            }),
            intensity: 0.5,
            ..Stimulus::default()
        };
        let plain = Stimulus::default()
            .plan_for(&Target::Lm, Scene::default())
            .unwrap();
        assert_eq!(plain.plan.sequence.intensity_table, None);
        assert_eq!(plain.timing.am_freq_hz, None);
        let p = am(20.0).plan_for(&Target::Lm, Scene::default()).unwrap();
        let table = p.plan.sequence.intensity_table.as_ref().unwrap();
        // 82 steps, 4 periods: each half period is 10.25 steps.
        assert_eq!(table.len(), 82);
        assert_eq!(
            &table[..12],
            &[255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0]
        );
        assert_eq!(
            p.plan.sequence.header.intensity, 128,
            "the entry's level stays"
        );
        assert_eq!(p.timing.am_freq_hz, Some(20.0));
        // The commit CRC covers the table: the same phases with and
        // without AM are different entries.
        assert_eq!(p.plan.sequence.phases, plain.plan.sequence.phases);
        assert_ne!(p.plan.sequence.crc32(), plain.plan.sequence.crc32());
        // A simulation's plan has no table; an AUTD3's reports its 4 kHz
        // realisation (200 samples a period: 20 Hz).
        assert_eq!(
            am(20.0)
                .plan(Scene::default())
                .unwrap()
                .plan
                .sequence
                .intensity_table,
            None
        );
        let a = am(20.0).plan_for(&Target::Autd3, Scene::default()).unwrap();
        assert_eq!(
            (a.timing.am_freq_hz, a.plan.sequence.intensity_table),
            (Some(20.0), None)
        );
        let e = am(30.5)
            .plan_for(&Target::Lm, Scene::default())
            .unwrap_err();
        assert!(e.downcast_ref::<InputError>().is_some(), "{e}");
        assert!(e.to_string().contains("nearest: 30 or 35 Hz"), "{e}");
    }

    #[test]
    fn an_autd3_plan_lands_on_the_25_us_grid() {
        let target = Target::Autd3;
        let t = Stimulus::default()
            .plan_for(&target, Scene::default())
            .unwrap();
        let g = &t.timing;
        assert_eq!(g.divide, Some(98), "{g:?}");
        assert!((g.dwell_us - 2450.0).abs() < 1e-9, "{g:?}");
        assert!((g.freq_error_hz + 0.0229).abs() < 1e-3, "{g:?}");
        assert!(
            (g.dwell_error_us - (2450.0 - 1e6 / (5.0 * 82.0))).abs() < 1e-9,
            "{g:?}"
        );
    }
}
