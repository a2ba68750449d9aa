//! The motorised stage: one push axis in millimetres, soft limits checked
//! before anything moves, moves that finish within a timeout computed from
//! distance and speed, or are stopped.
//!
//! A driver implements the primitives (start a move, ask whether it still
//! moves, stop, home); [`Stage::move_to`] is written once on top of them,
//! so the real controller and the simulated twin wait, time out and stop
//! the same way.

use std::time::Duration;

use serde::Serialize;

use super::error::InstrumentError;
use crate::clock::Clock;
use crate::limits::show;

/// The paper's stage speed (Experiment 3: "the speed of the force gauge
/// was 5 mm/s").
pub const PAPER_SPEED_MM_S: f64 = 5.0;
/// Slowest speed a stage is set to, mm/s: slower moves would make the
/// timeouts meaningless (minutes per millimetre).
pub const MIN_SPEED_MM_S: f64 = 0.01;
/// Fastest speed, mm/s. A probe pushing a finger has no business going
/// faster; the QT controllers' own maximum depends on the stage.
pub const MAX_SPEED_MM_S: f64 = 50.0;
/// How often a running move is polled.
pub const POLL: Duration = Duration::from_millis(20);

/// The soft limits of the push axis, mm (stage coordinates). Larger
/// positions push further towards (into) the finger.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StageLimits {
    /// Lowest position a move may go to.
    pub min_mm: f64,
    /// Highest position a move may go to.
    pub max_mm: f64,
}

impl StageLimits {
    /// Limits `min_mm..=max_mm`, checked (finite, ordered).
    pub fn new(min_mm: f64, max_mm: f64) -> Result<Self, crate::InputError> {
        if !(min_mm.is_finite() && max_mm.is_finite() && min_mm < max_mm) {
            return Err(crate::InputError::new(format!(
                "stage limits must be finite with min < max, got {}..{} mm",
                show(min_mm),
                show(max_mm)
            )));
        }
        Ok(Self { min_mm, max_mm })
    }

    /// `Ok` when `mm` is a position the stage may go to.
    pub fn check(&self, port: &str, mm: f64) -> Result<(), InstrumentError> {
        if mm.is_finite() && (self.min_mm..=self.max_mm).contains(&mm) {
            Ok(())
        } else {
            Err(InstrumentError::limit(
                port,
                format!(
                    "position {} mm is outside the stage's soft limits {}..={} mm",
                    show(mm),
                    show(self.min_mm),
                    show(self.max_mm)
                ),
            ))
        }
    }

    /// The longest move inside the limits, mm.
    pub fn span_mm(&self) -> f64 {
        self.max_mm - self.min_mm
    }
}

/// `Ok` when `mm_s` is a speed a stage may be set to.
pub fn check_speed(port: &str, mm_s: f64) -> Result<(), InstrumentError> {
    if mm_s.is_finite() && (MIN_SPEED_MM_S..=MAX_SPEED_MM_S).contains(&mm_s) {
        Ok(())
    } else {
        Err(InstrumentError::limit(
            port,
            format!(
                "stage speed {} mm/s is outside {}..={} mm/s",
                show(mm_s),
                show(MIN_SPEED_MM_S),
                show(MAX_SPEED_MM_S)
            ),
        ))
    }
}

/// The time a move of `distance_mm` at `speed_mm_s` may take before it is
/// called stuck: half as long again as the move at full speed, plus 1 s
/// for acceleration, the controller's reply time and polling. Generous on
/// purpose: a stage that is merely slow must not be stopped mid-push, a
/// stalled or unplugged one must not be waited for long.
pub fn move_timeout(distance_mm: f64, speed_mm_s: f64) -> Duration {
    let s = 1.5 * distance_mm.abs() / speed_mm_s.max(MIN_SPEED_MM_S) + 1.0;
    Duration::from_secs_f64(s.min(3_600.0))
}

/// A finished move.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Move {
    /// Where the stage was, mm.
    pub from_mm: f64,
    /// Where it stopped, as it reports, mm.
    pub at_mm: f64,
    /// How long the move took, s (on the stage's clock).
    pub took_s: f64,
}

/// A motorised stage's push axis.
pub trait Stage {
    /// The port (or `sim-stage`), for messages.
    fn port(&self) -> &str;
    /// The clock moves are timed on.
    fn clock(&self) -> &Clock;
    /// The soft limits.
    fn limits(&self) -> StageLimits;
    /// The speed moves run at, mm/s.
    fn speed_mm_s(&self) -> f64;
    /// How far from its target a finished move may stop, mm (the stage's
    /// step).
    fn tolerance_mm(&self) -> f64;

    /// Set the speed of later moves, mm/s (checked against
    /// [`MIN_SPEED_MM_S`]..=[`MAX_SPEED_MM_S`]).
    fn set_speed(&mut self, mm_s: f64) -> Result<(), InstrumentError>;
    /// The position the stage reports, mm.
    fn position_mm(&mut self) -> Result<f64, InstrumentError>;
    /// Start an absolute move to `to_mm` (already checked against the
    /// limits) and return without waiting.
    fn start_move(&mut self, to_mm: f64) -> Result<(), InstrumentError>;
    /// Whether a move (or homing) is still running.
    fn is_moving(&mut self) -> Result<bool, InstrumentError>;
    /// Stop at once (decelerating), wherever the stage is.
    fn stop(&mut self) -> Result<(), InstrumentError>;
    /// Find the mechanical origin and wait until there (the controller's
    /// own homing); afterwards the position is the origin's.
    fn home(&mut self) -> Result<Move, InstrumentError>;

    /// Move to `to_mm` and wait until the stage is there: refused outside
    /// the soft limits before anything moves; stopped, and a
    /// [`InstrumentError::Timeout`], if it has not finished within
    /// [`move_timeout`]; a [`InstrumentError::Refused`] if it stopped
    /// further than [`Stage::tolerance_mm`] from the target.
    fn move_to(&mut self, to_mm: f64) -> Result<Move, InstrumentError> {
        self.limits().check(self.port(), to_mm)?;
        let from_mm = self.position_mm()?;
        let timeout = move_timeout(to_mm - from_mm, self.speed_mm_s());
        self.start_move(to_mm)?;
        let took = wait_idle(self, timeout, || {
            format!("move from {} to {} mm", show(from_mm), show(to_mm))
        })?;
        let at_mm = self.position_mm()?;
        if (at_mm - to_mm).abs() > self.tolerance_mm() {
            return Err(InstrumentError::refused(
                self.port(),
                format!(
                    "move to {} mm stopped at {} mm (limit switch or obstacle?)",
                    show(to_mm),
                    show(at_mm)
                ),
            ));
        }
        Ok(Move {
            from_mm,
            at_mm,
            took_s: took.as_secs_f64(),
        })
    }
}

/// Moves to `to_mm` (a rest position clear of the finger) and waits, as
/// [`Stage::move_to`] does except that a stop request does not cut it
/// short: after Ctrl-C the probe must still leave the finger. A stuck
/// move still times out and is stopped.
pub fn retreat<S: Stage + ?Sized>(stage: &mut S, to_mm: f64) -> Result<Move, InstrumentError> {
    stage.limits().check(stage.port(), to_mm)?;
    let from_mm = stage.position_mm()?;
    let timeout = move_timeout(to_mm - from_mm, stage.speed_mm_s());
    stage.start_move(to_mm)?;
    let took = wait(stage, timeout, false, || {
        format!("move back from {} to {} mm", show(from_mm), show(to_mm))
    })?;
    Ok(Move {
        from_mm,
        at_mm: stage.position_mm()?,
        took_s: took.as_secs_f64(),
    })
}

/// Poll until the stage is idle; past `timeout`, stop it and fail. Returns
/// the time waited.
pub fn wait_idle<S: Stage + ?Sized>(
    stage: &mut S,
    timeout: Duration,
    what: impl Fn() -> String,
) -> Result<Duration, InstrumentError> {
    wait(stage, timeout, true, what)
}

fn wait<S: Stage + ?Sized>(
    stage: &mut S,
    timeout: Duration,
    heed_stop: bool,
    what: impl Fn() -> String,
) -> Result<Duration, InstrumentError> {
    let clock = stage.clock().clone();
    let t0 = clock.now();
    loop {
        if !stage.is_moving()? {
            return Ok(clock.now().saturating_sub(t0));
        }
        if heed_stop && crate::stop::requested() {
            let stopped = match stage.stop() {
                Ok(()) => "stopped".to_owned(),
                Err(e) => format!("stop failed: {e}"),
            };
            return Err(InstrumentError::Interrupted {
                port: stage.port().to_owned(),
                detail: format!("{} interrupted by a stop request ({stopped})", what()),
            });
        }
        if clock.now().saturating_sub(t0) >= timeout {
            // A stuck move is stopped before anything else is said; a stop
            // that fails too is reported with it.
            let stopped = match stage.stop() {
                Ok(()) => "stopped".to_owned(),
                Err(e) => format!("stop failed too: {e}"),
            };
            return Err(InstrumentError::timeout(
                stage.port(),
                format!(
                    "{} not finished within {} s ({stopped})",
                    what(),
                    show(timeout.as_secs_f64())
                ),
            ));
        }
        clock.sleep(POLL);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timeout_grows_with_distance_and_shrinks_with_speed() {
        assert_eq!(move_timeout(10.0, 5.0), Duration::from_secs(4));
        assert_eq!(move_timeout(-10.0, 5.0), Duration::from_secs(4));
        assert_eq!(move_timeout(0.0, 5.0), Duration::from_secs(1));
        assert!(move_timeout(10.0, 1.0) > move_timeout(10.0, 5.0));
    }

    #[test]
    fn limits_are_checked_and_named() {
        let l = StageLimits::new(0.0, 20.0).unwrap();
        assert!(l.check("p", 0.0).is_ok() && l.check("p", 20.0).is_ok());
        let e = l.check("/dev/ttyUSB0", 20.5).unwrap_err();
        assert_eq!(
            e.to_string(),
            "/dev/ttyUSB0: position 20.5 mm is outside the stage's soft limits 0..=20 mm"
        );
        assert!(l.check("p", f64::NAN).is_err());
        assert!(StageLimits::new(5.0, 5.0).is_err());
        assert!(StageLimits::new(0.0, f64::INFINITY).is_err());
        assert!(check_speed("p", 5.0).is_ok());
        assert!(check_speed("p", 0.0).is_err() && check_speed("p", 51.0).is_err());
    }
}
