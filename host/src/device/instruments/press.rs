//! One push of Experiment 3, as the paper runs it: the stage drives the
//! gauge into the finger pad, the stimulus plays while the gauge samples
//! for the on-phase (2 s), the stimulus stops and the stage returns to
//! its rest position; the median of the series is the measure.
//!
//! Any failure on the way (a move or a reading that fails, the stimulus
//! callback refusing) ends the push safely, in this order: the stimulus
//! is told to stop (the array silent), the stage is stopped and sent back
//! to rest; the error says what failed and what the recovery did, in one
//! line.

use serde::Serialize;

use super::error::InstrumentError;
use super::gauge::{ForceGauge, Series, check_series};
use super::stage::{Move, Stage};
use crate::limits::show;

/// Where and how long to push.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PressPlan {
    /// The stage's rest position, clear of the finger, mm.
    pub rest_mm: f64,
    /// The pushed position, mm (the rig's contact position plus the depth).
    pub press_mm: f64,
    /// How long the gauge samples while pushed, s (the paper's 2).
    pub hold_s: f64,
    /// Sampling rate, Hz.
    pub rate_hz: f64,
}

/// A push that went as planned.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Pressed {
    /// The move in.
    pub reach: Move,
    /// The readings during the hold.
    pub series: Series,
    /// Their median, N.
    pub median_n: f64,
    /// The move back to rest.
    pub back: Move,
}

/// A push that failed, and what the recovery did.
#[derive(Debug, thiserror::Error)]
#[error("push to {} mm failed at {step} ({recovery})", show(*press_mm))]
pub struct PressError {
    /// The planned pushed position, mm.
    pub press_mm: f64,
    /// Which step failed: `moving in`, `starting the stimulus`, `sampling`,
    /// `stopping the stimulus`, `moving back`.
    pub step: &'static str,
    /// What the recovery did: the array silenced or not, the stage back at
    /// rest or why not.
    pub recovery: String,
    /// Why.
    #[source]
    pub cause: Box<dyn std::error::Error + Send + Sync + 'static>,
}

/// Push once (see the module docs). `stimulus(true)` starts the stimulus
/// once the stage is in, `stimulus(false)` stops it after the hold, and is
/// also called on every failure after the stage started moving.
pub fn press(
    stage: &mut dyn Stage,
    gauge: &mut dyn ForceGauge,
    plan: &PressPlan,
    stimulus: &mut dyn FnMut(bool) -> anyhow::Result<()>,
) -> Result<Pressed, PressError> {
    // Everything that can be refused is refused before anything moves.
    let refuse = |e: InstrumentError| PressError {
        press_mm: plan.press_mm,
        step: "checking the plan",
        recovery: "nothing moved".to_owned(),
        cause: Box::new(e),
    };
    let limits = stage.limits();
    limits.check(stage.port(), plan.rest_mm).map_err(refuse)?;
    limits.check(stage.port(), plan.press_mm).map_err(refuse)?;
    check_series(gauge.port(), plan.hold_s, plan.rate_hz).map_err(refuse)?;

    let reach = stage
        .move_to(plan.press_mm)
        .map_err(|e| recover(stage, stimulus, plan, "moving in", e.into()))?;
    stimulus(true)
        .map_err(|e| recover(stage, stimulus, plan, "starting the stimulus", e.into()))?;
    let series = match gauge.sample(plan.hold_s, plan.rate_hz) {
        Ok(s) => s,
        Err(e) => return Err(recover(stage, stimulus, plan, "sampling", e.into())),
    };
    stimulus(false)
        .map_err(|e| recover(stage, stimulus, plan, "stopping the stimulus", e.into()))?;
    let back = stage
        .move_to(plan.rest_mm)
        .map_err(|e| recover(stage, stimulus, plan, "moving back", e.into()))?;
    // A checked series has at least one reading, so there is a median.
    let median_n = series.median_n().unwrap_or(f64::NAN);
    Ok(Pressed {
        reach,
        series,
        median_n,
        back,
    })
}

/// Silence the stimulus, stop the stage, send it back to rest; say how it
/// went.
fn recover(
    stage: &mut dyn Stage,
    stimulus: &mut dyn FnMut(bool) -> anyhow::Result<()>,
    plan: &PressPlan,
    step: &'static str,
    cause: Box<dyn std::error::Error + Send + Sync + 'static>,
) -> PressError {
    let silenced = match stimulus(false) {
        Ok(()) => "array silenced".to_owned(),
        Err(e) => format!("silencing the array failed: {}", crate::error::one_line(&e)),
    };
    // A stage that does not answer is not waited for twice.
    // `retreat`: back to rest also after Ctrl-C.
    let back = match stage
        .stop()
        .and_then(|()| super::stage::retreat(stage, plan.rest_mm))
    {
        Ok(m) => format!("stage back at {} mm", show(m.at_mm)),
        Err(e) => format!("stage NOT back at rest: {e}"),
    };
    PressError {
        press_mm: plan.press_mm,
        step,
        recovery: format!("{silenced}, {back}"),
        cause,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::Clock;
    use crate::device::instruments::{FingerPad, SimGauge, SimStage, StageLimits};

    fn rig() -> (SimStage, SimGauge) {
        let stage =
            SimStage::new(Clock::manual(), StageLimits::new(0.0, 30.0).unwrap(), 0.0).unwrap();
        let gauge = SimGauge::new(stage.probe(), FingerPad::TYPICAL.at(10.0), 5);
        (stage, gauge)
    }

    const PLAN: PressPlan = PressPlan {
        rest_mm: 5.0,
        press_mm: 12.0,
        hold_s: 2.0,
        rate_hz: 50.0,
    };

    #[test]
    fn a_push_measures_the_pad_at_depth_and_comes_back() {
        let (mut stage, mut gauge) = rig();
        stage.move_to(5.0).unwrap();
        let mut calls = Vec::new();
        let p = press(&mut stage, &mut gauge, &PLAN, &mut |on| {
            calls.push(on);
            Ok(())
        })
        .unwrap();
        assert_eq!(calls, [true, false]);
        let want = FingerPad::TYPICAL.force_at_depth_n(2.0);
        assert!(
            (p.median_n - want).abs() <= 0.011,
            "{} vs {want}",
            p.median_n
        );
        assert_eq!((p.reach.at_mm, p.back.at_mm), (12.0, 5.0));
        // 7 mm at 5 mm/s each way.
        assert!((p.reach.took_s - 1.4).abs() <= 0.021, "{}", p.reach.took_s);
        assert_eq!(stage.position_mm().unwrap(), 5.0);
    }

    #[test]
    fn a_gauge_that_goes_silent_ends_the_push_safely() {
        let (mut stage, mut gauge) = rig();
        stage.move_to(5.0).unwrap();
        // Silent half-way through the hold.
        let t = stage.clock().now_us() + 1_400_000 + 1_000_000;
        gauge.fail_at_us(t);
        let mut on = false;
        let err = press(&mut stage, &mut gauge, &PLAN, &mut |v| {
            on = v;
            Ok(())
        })
        .unwrap_err();
        assert!(!on, "the stimulus was left on");
        assert_eq!(stage.position_mm().unwrap(), 5.0);
        let line = crate::error::one_line(&anyhow::Error::new(err));
        assert_eq!(
            line,
            "push to 12 mm failed at sampling (array silenced, stage back at 5 mm): sim-gauge: no reply to D within 500 ms (simulated failure)"
        );
    }

    #[test]
    fn a_stage_that_goes_silent_is_reported_not_waited_for() {
        let (mut stage, mut gauge) = rig();
        stage.fail_at_us(700_000);
        let mut on = None;
        let err = press(&mut stage, &mut gauge, &PLAN, &mut |v| {
            on = Some(v);
            Ok(())
        })
        .unwrap_err();
        assert_eq!(on, Some(false), "the array was not told to be silent");
        let line = crate::error::one_line(&anyhow::Error::new(err));
        assert!(line.starts_with("push to 12 mm failed at moving in (array silenced, stage NOT back at rest: sim-stage: no reply to stop"), "{line}");
    }

    #[test]
    fn a_bad_plan_moves_nothing() {
        let (mut stage, mut gauge) = rig();
        for plan in [
            PressPlan {
                press_mm: 40.0,
                ..PLAN
            },
            PressPlan {
                hold_s: 0.0,
                ..PLAN
            },
        ] {
            let err = press(&mut stage, &mut gauge, &plan, &mut |_| {
                panic!("stimulus touched")
            })
            .unwrap_err();
            assert_eq!(err.step, "checking the plan");
            let any = anyhow::Error::new(err);
            assert!(
                any.chain().any(|c| c.is::<crate::InputError>()),
                "not bad input: {any:#}"
            );
        }
        assert_eq!(stage.position_mm().unwrap(), 0.0);
    }

    #[test]
    fn a_stimulus_that_cannot_start_still_gets_the_stage_back() {
        let (mut stage, mut gauge) = rig();
        let err = press(&mut stage, &mut gauge, &PLAN, &mut |on| {
            if on {
                anyhow::bail!("device busy")
            } else {
                Ok(())
            }
        })
        .unwrap_err();
        assert_eq!(err.step, "starting the stimulus");
        assert_eq!(stage.position_mm().unwrap(), 5.0);
    }
}
