//! How a presentation reaches the device while another plays or waits:
//! queued there to take over at the playing cycle's end, or a new
//! timeline of the same stimulus at once (`over`); played for the steps
//! nearest its on-phase or until stopped (`start`); and, when the client
//! that asked for it goes away, the device's queued slot taken back by
//! queueing the playing one where the device can (`client_gone`).

use std::time::Duration;

use super::protocol::{EventKind, OffsetReason};
use super::stage::{OnPhase, Presentation, Stage};
use super::{Owner, Session};

impl Session {
    /// `p` presented while `old` plays (and `waiting` waits to take over
    /// from it, on the device's queue): another stimulus, a timed one, or
    /// any while the device holds a queued slot, queues on the device and
    /// takes over at the cycle end; the same stimulus again, endless,
    /// starts a new timeline at once. On failure the stage is as it was.
    pub(super) fn over(
        &mut self,
        old: Presentation,
        mut phase: OnPhase,
        p: Presentation,
        waiting: Option<Presentation>,
        now: u64,
    ) -> anyhow::Result<()> {
        let restore = |me: &mut Self, old, phase, waiting: Option<Presentation>, requested_us| {
            me.stage = match waiting {
                Some(to) => Stage::Switching {
                    from: old,
                    on: phase,
                    to,
                    requested_us,
                },
                None => Stage::On(old, phase),
            };
        };
        let queue = p.slot != old.slot || p.on.is_some() || waiting.is_some();
        if queue {
            if let Err(e) = self.start(p.slot, p.untracked, p.on) {
                restore(self, old, phase, waiting, now);
                return Err(e);
            }
            if let Some(w) = waiting {
                self.emit(EventKind::Cancelled {
                    stimulus: self.loaded[w.entry].id.clone(),
                });
            }
            self.stage = Stage::Switching {
                from: old,
                on: phase,
                to: p,
                requested_us: now,
            };
            self.next_status_us = 0;
            return Ok(());
        }
        // The same stimulus again, endless: a new timeline; the device
        // changes only with the gate.
        if old.untracked != p.untracked
            && let Err(e) = self.start(p.slot, p.untracked, None)
        {
            restore(self, old, phase, None, now);
            return Err(e);
        }
        let at = self.clock.now_us();
        self.offset_at(at, &old, &mut phase, OffsetReason::Replaced, None);
        self.begin_on(p, OnPhase::new(at, now));
        Ok(())
    }

    /// Plays `slot`: for `on` (the device stops itself after that many of
    /// the slot's steps, [`Backend::play_for`]) or until stopped.
    pub(super) fn start(
        &mut self,
        slot: u8,
        untracked: bool,
        on: Option<Duration>,
    ) -> anyhow::Result<()> {
        let r = match on {
            Some(on) => {
                let steps = self.steps_for(slot, on);
                self.dev.play_for(slot, untracked, steps)
            }
            None => self.dev.play(slot, untracked),
        };
        r.map_err(anyhow::Error::from)
    }

    /// Queues the playing `p` behind itself, which takes the device's
    /// queued slot back ([`Backend::replaces_queued`]): it plays on, a
    /// timed one for the steps it has left after this cycle (at least one).
    fn requeue(&mut self, p: &Presentation) -> anyhow::Result<()> {
        let Some(on) = p.on else {
            return self.start(p.slot, p.untracked, None);
        };
        let s = self
            .dev
            .status()
            .map_err(|e| e.context("reading the device status"))?;
        let n = u64::from(
            self.loaded[p.entry]
                .planned
                .plan
                .sequence
                .header
                .steps
                .max(1),
        );
        let played = u64::from(s.cycles) * n + u64::from(s.step);
        let cycle_end = (played / n + 1) * n;
        let left = u64::from(self.steps_for(p.slot, on)).saturating_sub(cycle_end);
        let left = left.clamp(1, u64::from(u32::MAX)) as u32;
        Ok(self.dev.play_for(p.slot, p.untracked, left)?)
    }

    /// The step count of `slot`'s stimulus closest to `on` (at least one).
    fn steps_for(&self, slot: u8, on: Duration) -> u32 {
        let dwell_us = self
            .loaded
            .iter()
            .find(|l| l.slot == Some(slot))
            .map_or(1.0, |l| l.planned.plan.sequence.dwell_us());
        ((on.as_secs_f64() * 1e6 / dwell_us).round() as u64).clamp(1, u64::from(u32::MAX)) as u32
    }

    /// The client `owner` went away: what it asked for and still plays or
    /// waits stops (a presentation waiting for its switch is cancelled,
    /// the one playing on plays on); another client's is left alone.
    /// Returns whether anything stopped.
    pub fn client_gone(&mut self, owner: Owner) -> anyhow::Result<bool> {
        match &self.stage {
            Stage::Switching { to, .. } if to.owner == owner => {
                let Stage::Switching { from, on, to, .. } = std::mem::take(&mut self.stage) else {
                    return Ok(false);
                };
                // Back to what plays: the queued slot is taken back by
                // queueing the playing one, where the device can.
                if self.dev.replaces_queued() {
                    self.requeue(&from)?;
                    self.emit(EventKind::Cancelled {
                        stimulus: self.loaded[to.entry].id.clone(),
                    });
                    self.stage = Stage::On(from, on);
                } else {
                    self.stage = Stage::Switching {
                        from,
                        on,
                        to,
                        requested_us: self.clock.now_us(),
                    };
                    self.stop(OffsetReason::Disconnect)?;
                }
                Ok(true)
            }
            Stage::On(p, _) | Stage::Off(p, _) if p.owner == owner => {
                self.stop(OffsetReason::Disconnect)?;
                Ok(true)
            }
            _ => Ok(false),
        }
    }
}
