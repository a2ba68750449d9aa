//! The stage's simulated twin: a push axis that moves at its set speed
//! (the paper's 5 mm/s by default) on a [`Clock`], so a test on a manual
//! clock runs a whole push cycle in no time, and that can be told to stop
//! answering at a given time (an unplugged cable, a crashed controller).
//!
//! Motion is constant speed from start to target (the real stage's
//! 100 ms acceleration ramps are below what the twin needs to show). The
//! position is shared through [`StageProbe`], which the simulated gauge
//! reads to know how deep the probe is in the finger.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::error::InstrumentError;
use super::stage::{
    Move, PAPER_SPEED_MM_S, Stage, StageLimits, check_speed, move_timeout, wait_idle,
};
use crate::clock::Clock;

/// The twin's name in messages.
pub const SIM_STAGE_PORT: &str = "sim-stage";

/// Where the axis is and where it is going.
#[derive(Debug, Clone, Copy)]
struct Motion {
    from_mm: f64,
    to_mm: f64,
    start_us: u64,
    speed_mm_s: f64,
}

impl Motion {
    fn at(&self, now_us: u64) -> f64 {
        let dt = now_us.saturating_sub(self.start_us) as f64 * 1e-6;
        let d = self.to_mm - self.from_mm;
        let travelled = (self.speed_mm_s * dt).min(d.abs());
        self.from_mm + travelled.copysign(d)
    }

    fn done(&self, now_us: u64) -> bool {
        self.at(now_us) == self.to_mm
    }
}

/// A read-only view of the twin's position, for the simulated gauge.
#[derive(Debug, Clone)]
pub struct StageProbe {
    motion: Arc<Mutex<Motion>>,
    clock: Clock,
}

impl StageProbe {
    /// The axis position now, mm.
    pub fn position_mm(&self) -> f64 {
        let m = *self.motion.lock().unwrap_or_else(|p| p.into_inner());
        m.at(self.clock.now_us())
    }

    /// The clock the stage moves on.
    pub fn clock(&self) -> &Clock {
        &self.clock
    }
}

/// The simulated stage.
#[derive(Debug)]
pub struct SimStage {
    motion: Arc<Mutex<Motion>>,
    clock: Clock,
    limits: StageLimits,
    home_mm: f64,
    speed_mm_s: f64,
    silent_from_us: Option<u64>,
    /// Moves it still answers before it falls silent ([`SimStage::fail_after_moves`]).
    moves_left: Option<u32>,
    reply_timeout: Duration,
}

impl SimStage {
    /// A twin at `home_mm` (inside `limits`, the mechanical origin) at the
    /// paper's speed, on `clock`.
    pub fn new(clock: Clock, limits: StageLimits, home_mm: f64) -> Result<Self, InstrumentError> {
        limits.check(SIM_STAGE_PORT, home_mm)?;
        let now = clock.now_us();
        Ok(Self {
            motion: Arc::new(Mutex::new(Motion {
                from_mm: home_mm,
                to_mm: home_mm,
                start_us: now,
                speed_mm_s: PAPER_SPEED_MM_S,
            })),
            clock,
            limits,
            home_mm,
            speed_mm_s: PAPER_SPEED_MM_S,
            silent_from_us: None,
            moves_left: None,
            reply_timeout: super::chuo::QT_REPLY_TIMEOUT,
        })
    }

    /// The view the simulated gauge reads.
    pub fn probe(&self) -> StageProbe {
        StageProbe {
            motion: self.motion.clone(),
            clock: self.clock.clone(),
        }
    }

    /// From `at_us` on the stage's clock, every request times out (the
    /// stage itself keeps doing what it was told last, as a controller
    /// whose cable was pulled does).
    pub fn fail_at_us(&mut self, at_us: u64) {
        self.silent_from_us = Some(at_us);
    }

    /// After `n` more moves, the next one starts and then every request
    /// times out (the stage keeps doing the last move it was told, as with
    /// [`SimStage::fail_at_us`]): a failure on cue in a run whose clock is
    /// real, where a time would be a guess (`--stage sim:fail-after=N`).
    pub fn fail_after_moves(&mut self, n: u32) {
        self.moves_left = Some(n);
    }

    fn motion(&self) -> Motion {
        *self.motion.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn set_motion(&self, m: Motion) {
        *self.motion.lock().unwrap_or_else(|p| p.into_inner()) = m;
    }

    /// `Err` once the stage is silent, after the time a driver would
    /// have waited for the reply.
    fn answer(&self, what: &str) -> Result<(), InstrumentError> {
        match self.silent_from_us {
            Some(t) if self.clock.now_us() >= t => {
                self.clock.advance(self.reply_timeout);
                Err(InstrumentError::timeout(
                    SIM_STAGE_PORT,
                    format!(
                        "no reply to {what} within {} ms (simulated failure)",
                        self.reply_timeout.as_millis()
                    ),
                ))
            }
            _ => Ok(()),
        }
    }

    fn go(&self, to_mm: f64) {
        let now = self.clock.now_us();
        let here = self.motion().at(now);
        self.set_motion(Motion {
            from_mm: here,
            to_mm,
            start_us: now,
            speed_mm_s: self.speed_mm_s,
        });
    }
}

impl Stage for SimStage {
    fn port(&self) -> &str {
        SIM_STAGE_PORT
    }

    fn clock(&self) -> &Clock {
        &self.clock
    }

    fn limits(&self) -> StageLimits {
        self.limits
    }

    fn speed_mm_s(&self) -> f64 {
        self.speed_mm_s
    }

    fn tolerance_mm(&self) -> f64 {
        0.001
    }

    fn set_speed(&mut self, mm_s: f64) -> Result<(), InstrumentError> {
        check_speed(SIM_STAGE_PORT, mm_s)?;
        self.answer("set speed")?;
        self.speed_mm_s = mm_s;
        Ok(())
    }

    fn position_mm(&mut self) -> Result<f64, InstrumentError> {
        self.answer("position")?;
        Ok(self.motion().at(self.clock.now_us()))
    }

    fn start_move(&mut self, to_mm: f64) -> Result<(), InstrumentError> {
        self.limits.check(SIM_STAGE_PORT, to_mm)?;
        self.answer("move")?;
        self.go(to_mm);
        match &mut self.moves_left {
            Some(0) => self.silent_from_us = Some(self.clock.now_us()),
            Some(n) => *n -= 1,
            None => {}
        }
        Ok(())
    }

    fn is_moving(&mut self) -> Result<bool, InstrumentError> {
        self.answer("state")?;
        Ok(!self.motion().done(self.clock.now_us()))
    }

    fn stop(&mut self) -> Result<(), InstrumentError> {
        self.answer("stop")?;
        let here = self.motion().at(self.clock.now_us());
        self.go(here);
        Ok(())
    }

    fn home(&mut self) -> Result<Move, InstrumentError> {
        let from_mm = self.position_mm()?;
        self.answer("home")?;
        self.go(self.home_mm);
        let timeout = move_timeout(self.home_mm - from_mm, self.speed_mm_s);
        let took = wait_idle(self, timeout, || "homing".to_owned())?;
        Ok(Move {
            from_mm,
            at_mm: self.position_mm()?,
            took_s: took.as_secs_f64(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stage() -> SimStage {
        SimStage::new(Clock::manual(), StageLimits::new(0.0, 30.0).unwrap(), 0.0).unwrap()
    }

    #[test]
    fn moves_at_the_paper_speed() {
        let mut s = stage();
        let m = s.move_to(10.0).unwrap();
        assert_eq!(m.at_mm, 10.0);
        // 10 mm at 5 mm/s is 2 s, give or take one 20 ms poll.
        assert!((m.took_s - 2.0).abs() <= 0.021, "{}", m.took_s);
        s.set_speed(10.0).unwrap();
        let m = s.move_to(0.0).unwrap();
        assert!((m.took_s - 1.0).abs() <= 0.021, "{}", m.took_s);
    }

    #[test]
    fn the_probe_sees_the_stage_mid_move() {
        let mut s = stage();
        let probe = s.probe();
        s.start_move(10.0).unwrap();
        s.clock().advance(Duration::from_millis(500));
        assert!((probe.position_mm() - 2.5).abs() < 1e-9);
        s.stop().unwrap();
        s.clock().advance(Duration::from_secs(1));
        assert!(
            (probe.position_mm() - 2.5).abs() < 1e-9,
            "stopped where it was"
        );
        assert!(!s.is_moving().unwrap());
    }

    #[test]
    fn a_silent_stage_times_out_mid_move() {
        let mut s = stage();
        s.fail_at_us(1_000_000);
        let err = s.move_to(20.0).unwrap_err();
        assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
        assert!(
            err.to_string().starts_with("sim-stage: no reply to state"),
            "{err}"
        );
    }

    #[test]
    fn a_stage_told_to_fail_after_moves_answers_that_many() {
        let mut s = stage();
        s.fail_after_moves(1);
        s.move_to(1.0).unwrap();
        // The second move starts, then nothing answers.
        let err = s.move_to(2.0).unwrap_err();
        assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
        assert!(s.stop().is_err());
    }

    #[test]
    fn outside_the_limits_nothing_moves() {
        let mut s = stage();
        let err = s.move_to(31.0).unwrap_err();
        assert!(matches!(err, InstrumentError::Limit { .. }), "{err}");
        assert_eq!(s.position_mm().unwrap(), 0.0);
        assert!(SimStage::new(Clock::manual(), StageLimits::new(0.0, 1.0).unwrap(), 2.0).is_err());
    }

    #[test]
    fn home_returns_to_the_origin() {
        let mut s = stage();
        s.move_to(12.0).unwrap();
        let h = s.home().unwrap();
        assert_eq!((h.from_mm, h.at_mm), (12.0, 0.0));
    }
}
