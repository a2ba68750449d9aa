//! The player: which step of which slot is due when.
//!
//! Knows nothing of the protocol or the output; [`Player::tick`] tells the
//! caller whether a new step is due and which one. Step boundaries come
//! from [`Schedule`] (drift-free, integer only). A queued slot takes over
//! exactly at the next cycle boundary of the playing one (that boundary's
//! time becomes the new sequence's cycle start, so nothing drifts across
//! the swap either). A step boundary that has passed before the step could
//! be entered is counted as a missed deadline and skipped.
//!
//! A play may carry a limit (`Play.steps`): the player counts the steps
//! played since the slot began (its start, or its takeover) and stops by
//! itself at the boundary where the limit is reached, even when that
//! boundary was passed late.

use crate::time::Schedule;

/// Player state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlayState {
    /// Nothing played since reset.
    Idle,
    /// Playing a slot.
    Playing,
    /// Stopped by `Stop`, or by itself at a play's step limit.
    Stopped,
}

/// What the player needs to know about a slot to schedule it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// Steps per cycle.
    pub steps: u16,
    /// Cycle period, µs.
    pub period_us: u32,
}

/// A step that became due.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Due {
    /// Slot.
    pub slot: u8,
    /// Step within the cycle.
    pub step: u16,
    /// Timer count at which the step was due.
    pub at: u64,
    /// The play's step limit was reached at this boundary: the player has
    /// stopped (`step` is the frozen position) and the caller stops and
    /// mutes the output from `at` on.
    pub stop: bool,
}

/// The player.
#[derive(Debug, Clone)]
pub struct Player {
    timer_hz: u32,
    state: PlayState,
    slot: Option<u8>,
    steps: u16,
    sched: Option<Schedule>,
    /// Step within the cycle.
    k: u16,
    /// Current step not yet handed out.
    fresh: bool,
    pending: Option<(u8, Timing, u32)>,
    /// Steps the playing slot plays before stopping (0 = until `stop`).
    limit: u32,
    cycles: u32,
    missed: u32,
}

impl Player {
    /// An idle player for a timer at `timer_hz`.
    pub const fn new(timer_hz: u32) -> Self {
        Self {
            timer_hz,
            state: PlayState::Idle,
            slot: None,
            steps: 1,
            sched: None,
            k: 0,
            fresh: false,
            pending: None,
            limit: 0,
            cycles: 0,
            missed: 0,
        }
    }

    /// Whether `timing` can be scheduled on this timer (≥ 1 count per step).
    pub fn schedulable(&self, timing: Timing) -> bool {
        Schedule::new(0, timing.period_us, timing.steps, self.timer_hz).is_some()
    }

    /// Starts `slot` now, from step 0, to play `limit` steps (0 = until
    /// [`stop`](Self::stop)). Returns false if the timing cannot be
    /// scheduled.
    pub fn start(&mut self, slot: u8, timing: Timing, now: u64, limit: u32) -> bool {
        let Some(s) = Schedule::new(now, timing.period_us, timing.steps, self.timer_hz) else {
            return false;
        };
        self.begin(slot, timing.steps, s, limit);
        self.cycles = 0;
        self.pending = None;
        true
    }

    fn begin(&mut self, slot: u8, steps: u16, s: Schedule, limit: u32) {
        self.state = PlayState::Playing;
        self.slot = Some(slot);
        self.steps = steps;
        self.sched = Some(s);
        self.k = 0;
        self.fresh = true;
        self.limit = limit;
    }

    /// Queues `slot` to take over at the next cycle boundary (at once if
    /// nothing is playing) and then play `limit` steps, counted from the
    /// takeover (0 = until [`stop`](Self::stop)); the playing slot's own
    /// limit holds until then. Returns false if the timing cannot be
    /// scheduled.
    pub fn queue(&mut self, slot: u8, timing: Timing, now: u64, limit: u32) -> bool {
        if self.state != PlayState::Playing {
            return self.start(slot, timing, now, limit);
        }
        if !self.schedulable(timing) {
            return false;
        }
        self.pending = Some((slot, timing, limit));
        true
    }

    /// Stops playing (the caller mutes the output).
    pub fn stop(&mut self) {
        if self.state == PlayState::Playing {
            self.state = PlayState::Stopped;
        }
        self.sched = None;
        self.pending = None;
        self.fresh = false;
        self.limit = 0;
    }

    /// State.
    pub fn state(&self) -> PlayState {
        self.state
    }

    /// Slot playing (or last played).
    pub fn slot(&self) -> Option<u8> {
        self.slot
    }

    /// Slot queued for the next cycle boundary.
    pub fn pending(&self) -> Option<u8> {
        self.pending.map(|p| p.0)
    }

    /// Whether writes to `slot` must be refused: it plays or is queued.
    pub fn busy(&self, slot: u8) -> bool {
        (self.state == PlayState::Playing && self.slot == Some(slot))
            || self.pending() == Some(slot)
    }

    /// Step within the cycle.
    pub fn step(&self) -> u16 {
        self.k
    }

    /// Cycles completed since the playing slot began (its start or its
    /// takeover); after a stop at the limit, frozen so that
    /// `cycles × steps + step` is the limit.
    pub fn cycles(&self) -> u32 {
        self.cycles
    }

    /// The playing slot's step limit (0 = until [`stop`](Self::stop)).
    pub fn limit(&self) -> u32 {
        self.limit
    }

    /// Step boundaries skipped because they passed before the step was
    /// entered.
    pub fn missed(&self) -> u32 {
        self.missed
    }

    /// The next time [`tick`](Self::tick) has work: the next step boundary
    /// (or now, if the current step has not been handed out yet).
    pub fn deadline(&self) -> Option<u64> {
        let s = self.sched.as_ref()?;
        Some(if self.fresh { s.current() } else { s.next() })
    }

    /// Start of the current step.
    pub fn current_start(&self) -> Option<u64> {
        self.sched.as_ref().map(|s| s.current())
    }

    /// Advances to the step due at `now`; returns it if it has not been
    /// handed out before.
    pub fn tick(&mut self, now: u64) -> Option<Due> {
        self.slot?;
        let s = self.sched?;
        if now >= s.next() {
            if let Some((p, timing, limit)) = self.pending {
                let to_end = u64::from(self.steps - self.k);
                let end_index = s.index() + to_end;
                let end = if to_end == 1 {
                    s.next()
                } else {
                    s.start_time() + s.offset_of(end_index)
                };
                // A limit before the cycle end stops first (and drops the
                // queued slot); one on the cycle end lets the takeover
                // happen: the playing slot has played exactly its steps.
                let stops_first = self.limit != 0 && u64::from(self.limit) < end_index;
                if now >= end && !stops_first {
                    self.missed = self.missed.saturating_add((to_end - 1) as u32);
                    // The queued slot's own play begins: its cycles count
                    // from 0, so step and cycles say how long it has played.
                    self.cycles = 0;
                    self.pending = None;
                    // Checked schedulable when queued.
                    if let Some(ns) =
                        Schedule::new(end, timing.period_us, timing.steps, self.timer_hz)
                    {
                        self.begin(p, timing.steps, ns, limit);
                        if let Some(d) = self.stop_at_limit(now) {
                            return Some(d);
                        }
                        self.catch_up(now);
                        return self.hand_out();
                    }
                }
            }
            if let Some(d) = self.stop_at_limit(now) {
                return Some(d);
            }
            self.catch_up(now);
        }
        self.hand_out()
    }

    /// Stops at the limit's boundary if `now` has reached it: the steps
    /// before it that were never entered count as missed, step and cycles
    /// freeze at the limit, and the returned [`Due`] (with `stop`) carries
    /// the boundary's time.
    fn stop_at_limit(&mut self, now: u64) -> Option<Due> {
        if self.limit == 0 {
            return None;
        }
        let s = self.sched?;
        let limit = u64::from(self.limit);
        let at = s.start_time() + s.offset_of(limit);
        if now < at || s.index() >= limit {
            return None;
        }
        // Steps index+1 .. limit-1 were skipped, and the current one too
        // if it was never handed out.
        let skipped = limit - s.index() - 1 + u64::from(self.fresh);
        self.missed = self
            .missed
            .saturating_add(skipped.min(u64::from(u32::MAX)) as u32);
        let steps = u64::from(self.steps);
        self.k = (limit % steps) as u16;
        self.cycles = (limit / steps) as u32;
        let slot = self.slot?;
        self.stop();
        Some(Due {
            slot,
            step: self.k,
            at,
            stop: true,
        })
    }

    /// Moves the schedule to the step due at `now` (boundary already passed).
    fn catch_up(&mut self, now: u64) {
        let Some(s) = self.sched.as_mut() else { return };
        if now < s.next() {
            return;
        }
        if self.fresh {
            // The current step was never handed out.
            self.missed = self.missed.saturating_add(1);
        }
        let old = s.index();
        s.advance();
        if now >= s.next() {
            let extra = s.catch_up(now);
            self.missed = self
                .missed
                .saturating_add(extra.saturating_add(1).min(u32::MAX as u64) as u32);
        }
        let delta = s.index() - old;
        let steps = u64::from(self.steps);
        let pos = u64::from(self.k) + delta;
        if pos < steps {
            self.k = pos as u16;
        } else {
            self.k = (pos % steps) as u16;
            self.cycles = self.cycles.wrapping_add((pos / steps) as u32);
        }
        self.fresh = true;
    }

    fn hand_out(&mut self) -> Option<Due> {
        if !self.fresh {
            return None;
        }
        self.fresh = false;
        Some(Due {
            slot: self.slot?,
            step: self.k,
            at: self.sched?.current(),
            stop: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Some(Due { slot, step, at })`.
    fn due(slot: u8, step: u16, at: u64) -> Option<Due> {
        Some(Due {
            slot,
            step,
            at,
            stop: false,
        })
    }

    /// `Some(Due { .., stop: true })`: stopped at the limit.
    fn stopped(slot: u8, step: u16, at: u64) -> Option<Due> {
        Some(Due {
            slot,
            step,
            at,
            stop: true,
        })
    }

    const T: Timing = Timing {
        steps: 4,
        period_us: 1000,
    };

    /// A 1 MHz player that started slot 0 (timing [`T`]) at 0 and ticked
    /// its first step.
    fn playing_slot_0() -> Player {
        let mut p = Player::new(1_000_000);
        p.start(0, T, 0, 0);
        p.tick(0);
        p
    }

    #[test]
    fn plays_steps_on_schedule() {
        let mut p = Player::new(1_000_000);
        assert!(p.start(0, T, 100, 0));
        assert_eq!(p.tick(100), due(0, 0, 100));
        assert_eq!(p.tick(300), None);
        assert_eq!(p.deadline(), Some(350));
        assert_eq!(p.tick(350), due(0, 1, 350));
        assert_eq!(p.tick(600), due(0, 2, 600));
        assert_eq!(p.tick(850), due(0, 3, 850));
        assert_eq!(p.tick(1100), due(0, 0, 1100));
        assert_eq!(p.cycles(), 1);
        assert_eq!(p.missed(), 0);
    }

    #[test]
    fn late_ticks_count_missed_steps() {
        let mut p = playing_slot_0();
        // Boundaries 250, 500, 750 passed; 750 is entered, 250 and 500 missed.
        assert_eq!(p.tick(760), due(0, 3, 750));
        assert_eq!(p.missed(), 2);
        // Far behind: 10 cycles later.
        assert_eq!(p.tick(10_999), due(0, 3, 10_750));
        assert_eq!(p.missed(), 2 + 39);
        assert_eq!(p.cycles(), 10);
    }

    #[test]
    fn queued_slot_starts_at_cycle_boundary() {
        let mut p = playing_slot_0();
        p.tick(250);
        let t2 = Timing {
            steps: 2,
            period_us: 300,
        };
        assert!(p.queue(1, t2, 260, 0));
        assert!(p.busy(1) && p.busy(0));
        assert_eq!(p.tick(500).map(|d| d.slot), Some(0));
        assert_eq!(p.tick(750).map(|d| d.step), Some(3));
        assert_eq!(p.tick(1000), due(1, 0, 1000));
        assert_eq!(p.tick(1150), due(1, 1, 1150));
        assert_eq!(p.cycles(), 0);
        assert_eq!(p.tick(1300), due(1, 0, 1300));
        assert_eq!(p.cycles(), 1);
        assert!(!p.busy(0));
        assert_eq!(p.missed(), 0);
    }

    #[test]
    fn queued_swap_when_late_counts_the_rest_of_the_cycle() {
        let mut p = playing_slot_0();
        p.queue(1, T, 10, 0);
        // Jump past the end of cycle 0 and into step 1 of the new slot.
        assert_eq!(p.tick(1300), due(1, 1, 1250));
        assert_eq!(p.missed(), 3 + 1);
    }

    #[test]
    fn stop_clears_schedule() {
        let mut p = Player::new(1_000_000);
        p.start(0, T, 0, 0);
        p.stop();
        assert_eq!(p.state(), PlayState::Stopped);
        assert_eq!(p.deadline(), None);
        assert_eq!(p.tick(1000), None);
        assert!(!p.busy(0));
    }

    #[test]
    fn limit_stops_at_its_boundary_with_frozen_counters() {
        let mut p = Player::new(1_000_000);
        assert!(p.start(0, T, 0, 6));
        let mut handed = 0;
        let mut last = None;
        for now in (0..3000).step_by(10) {
            if let Some(d) = p.tick(now) {
                if d.stop {
                    last = Some(d);
                    break;
                }
                handed += 1;
            }
        }
        assert_eq!(handed, 6);
        // Step 6 (cycle 1, step 2) starts at 1500: the stop lands there.
        assert_eq!(last, stopped(0, 2, 1500));
        assert_eq!(p.state(), PlayState::Stopped);
        assert_eq!((p.cycles(), p.step()), (1, 2));
        assert_eq!(u64::from(p.cycles()) * 4 + u64::from(p.step()), 6);
        assert_eq!(p.deadline(), None);
        assert_eq!(p.tick(5000), None);
        assert_eq!(p.missed(), 0);
        assert!(!p.busy(0));
    }

    #[test]
    fn limit_on_a_cycle_end_freezes_at_step_0() {
        let mut p = Player::new(1_000_000);
        p.start(0, T, 0, 8);
        for now in [0, 250, 500, 750, 1000, 1250, 1500, 1750] {
            assert!(!p.tick(now).unwrap().stop);
        }
        assert_eq!(p.deadline(), Some(2000));
        assert_eq!(p.tick(2000), stopped(0, 0, 2000));
        assert_eq!((p.cycles(), p.step()), (2, 0));
    }

    #[test]
    fn late_tick_past_the_limit_stops_at_the_limit() {
        let mut p = playing_slot_0();
        p.start(0, T, 0, 5);
        p.tick(0);
        // Far past boundary 5 (1250): steps 1-4 were never entered.
        assert_eq!(p.tick(9_999), stopped(0, 1, 1250));
        assert_eq!(p.missed(), 4);
        assert_eq!((p.cycles(), p.step()), (1, 1));
        // A late tick just after the limit while the step before it was
        // never handed out: that one is missed too.
        let mut p = Player::new(1_000_000);
        p.start(0, T, 0, 3);
        p.tick(0);
        p.tick(250);
        assert_eq!(p.tick(760), stopped(0, 3, 750));
        assert_eq!(p.missed(), 1);
    }

    #[test]
    fn limit_zero_plays_on_and_stop_or_a_new_play_replaces_the_limit() {
        let mut p = Player::new(1_000_000);
        p.start(0, T, 0, 0);
        for now in (0..100_000).step_by(250) {
            assert!(!p.tick(now).unwrap().stop);
        }
        assert_eq!(p.cycles(), 99);
        p.start(0, T, 100_000, 2);
        assert_eq!(p.limit(), 2);
        p.start(0, T, 100_000, 0);
        assert_eq!(p.limit(), 0);
        p.tick(100_000);
        assert!(!p.tick(100_500).unwrap().stop);
        p.start(1, T, 200_000, 3);
        p.stop();
        assert_eq!(p.limit(), 0);
    }

    #[test]
    fn queued_limit_counts_from_the_takeover() {
        let mut p = playing_slot_0();
        p.tick(250);
        assert!(p.queue(1, T, 260, 5));
        // The playing slot has no limit: it plays out its cycle.
        assert_eq!(p.limit(), 0);
        p.tick(500);
        p.tick(750);
        assert_eq!(p.tick(1000), due(1, 0, 1000));
        assert_eq!(p.limit(), 5);
        for (now, step) in [(1250, 1), (1500, 2), (1750, 3), (2000, 0)] {
            assert_eq!(p.tick(now), due(1, step, now));
        }
        assert_eq!(p.tick(2250), stopped(1, 1, 2250));
        assert_eq!((p.slot(), p.cycles(), p.step()), (Some(1), 1, 1));
    }

    #[test]
    fn a_limit_inside_the_cycle_drops_the_queued_slot() {
        let mut p = Player::new(1_000_000);
        p.start(0, T, 0, 2);
        p.tick(0);
        assert!(p.queue(1, T, 10, 0));
        assert_eq!(p.tick(250), due(0, 1, 250));
        assert_eq!(p.tick(500), stopped(0, 2, 500));
        assert_eq!(p.pending(), None);
        assert_eq!(p.tick(1000), None);
        // On the cycle end, the queued slot takes over instead.
        let mut p = Player::new(1_000_000);
        p.start(0, T, 0, 4);
        p.tick(0);
        p.queue(1, T, 10, 0);
        for now in [250, 500, 750] {
            p.tick(now);
        }
        assert_eq!(p.tick(1000), due(1, 0, 1000));
        assert_eq!(p.state(), PlayState::Playing);
    }
}
