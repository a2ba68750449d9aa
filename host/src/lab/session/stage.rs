//! The session's stage: one enum for where a presentation's timeline is
//! (idle, on, off, switching from one stimulus to the next), and the
//! transitions [`Session::poll`] makes as time passes and the device's
//! status comes in. Every time is the session's [`Clock`](crate::clock::Clock)
//! in µs.

use std::time::Duration;

use lm_proto::{DeviceState, MuteReason, Status};

use super::protocol::{self, EventKind, OffsetReason};
use super::{Session, gate_of};

/// Who asked for a presentation: a control connection's id, or
/// [`IN_PROCESS`] for a caller in this process (the study, tests).
pub type Owner = u64;

/// The owner of presentations asked for in process.
pub const IN_PROCESS: Owner = 0;

/// One `present`: what plays, how long, how often, and how far it got.
#[derive(Debug, Clone)]
pub(super) struct Presentation {
    pub entry: usize,
    pub slot: u8,
    pub untracked: bool,
    pub on: Option<Duration>,
    pub off: Duration,
    pub repeat: u32,
    /// The on-phase playing or last played, 1-based.
    pub rep: u32,
    pub owner: Owner,
}

/// The bookkeeping of one on-phase.
#[derive(Debug, Clone, Copy)]
pub(super) struct OnPhase {
    /// Its onset (the event's stamp).
    pub since_us: u64,
    /// When it should have begun: the `present`, or the end of the
    /// off-phase before it.
    pub ideal_us: u64,
    /// When the device began it, by its own counters (first status read).
    pub device_start_us: Option<u64>,
    /// Muted since then in this on-phase, and the muted time before that.
    pub muted_since: Option<u64>,
    pub muted_us: u64,
}

impl OnPhase {
    pub fn new(since_us: u64, ideal_us: u64) -> Self {
        Self {
            since_us,
            ideal_us,
            device_start_us: None,
            muted_since: None,
            muted_us: 0,
        }
    }
}

/// Where the session's timeline is.
#[derive(Debug, Clone, Default)]
pub(super) enum Stage {
    /// Nothing presented: the array is silent.
    #[default]
    Idle,
    /// An on-phase plays.
    On(Presentation, OnPhase),
    /// Silent between on-phases until `until_us`.
    Off(Presentation, u64),
    /// `from` plays; `to` takes over at the end of its cycle (queued on
    /// the device since `requested_us`).
    Switching {
        from: Presentation,
        on: OnPhase,
        to: Presentation,
        requested_us: u64,
    },
}

impl Stage {
    /// The newest presentation (the one waiting, while switching).
    pub fn newest(&self) -> Option<&Presentation> {
        match self {
            Self::Idle => None,
            Self::On(p, _) | Self::Off(p, _) => Some(p),
            Self::Switching { to, .. } => Some(to),
        }
    }

    /// Its name in `status` replies.
    pub fn name(&self) -> Option<&'static str> {
        match self {
            Self::Idle => None,
            Self::On(..) => Some("on"),
            Self::Off(..) => Some("off"),
            Self::Switching { .. } => Some("switching"),
        }
    }

    /// Slots a load must not overwrite: playing, queued, or to play again
    /// after an off-phase.
    pub fn busy_slots(&self) -> Vec<u8> {
        match self {
            Self::Idle => Vec::new(),
            Self::On(p, _) | Self::Off(p, _) => vec![p.slot],
            Self::Switching { from, to, .. } => vec![from.slot, to.slot],
        }
    }
}

/// How often the device's status is read while a stimulus is presented
/// (mute changes, switches, the end of a timed on-phase).
pub const STATUS_EVERY: Duration = Duration::from_millis(5);

/// How often the device's housekeeping ([`Backend::tick`]) runs: AUTD3's
/// gate and timed stops, the LM firmware's lease.
///
/// [`Backend::tick`]: crate::device::backend::Backend::tick
pub const TICK_EVERY: Duration = Duration::from_millis(10);

/// How long after a timed on-phase should have ended the host stops a
/// device that has not stopped itself.
pub const LATE_STOP: Duration = Duration::from_secs(1);

/// Why a device stopped by itself stopped: its lease lapsed, or (the one
/// other reason) a timed play ran its steps.
fn stopped_by(s: &Status) -> OffsetReason {
    match s.mute_reason {
        MuteReason::LeaseExpired => OffsetReason::LeaseExpired,
        _ => OffsetReason::Timer,
    }
}

fn us(d: Duration) -> u64 {
    d.as_micros().min(u128::from(u64::MAX)) as u64
}

impl Session {
    /// When [`poll`](Self::poll) next has work (session clock, µs): the
    /// device's tick, a status read while presenting, the end of an
    /// off-phase, a late stop.
    pub fn poll_at(&self) -> u64 {
        let mut at = self.next_tick_us;
        let mut due = |t: u64| at = at.min(t);
        match &self.stage {
            Stage::Idle => {}
            Stage::On(p, on) => {
                due(self.next_status_us);
                if let Some(d) = p.on {
                    due(on.since_us + us(d) + us(LATE_STOP));
                }
            }
            Stage::Off(_, until) => {
                due(self.next_status_us);
                due(*until);
            }
            Stage::Switching { .. } => due(self.next_status_us),
        }
        at
    }

    /// Runs the timeline (on/off phases, switches) and the device's
    /// housekeeping; call it by [`poll_at`](Self::poll_at).
    pub fn poll(&mut self) -> anyhow::Result<()> {
        let now = self.clock.now_us();
        if now >= self.next_tick_us {
            self.next_tick_us = now + us(TICK_EVERY);
            self.dev.tick()?;
        }
        // The device ends a timed on-phase itself (seen in its status);
        // should it not have within LATE_STOP more, the host stops it.
        let late = matches!(&self.stage, Stage::On(p, on)
            if p.on.is_some_and(|d| now >= on.since_us + us(d) + us(LATE_STOP)));
        if late {
            return self.end_on_phase(None);
        }
        let next = match &mut self.stage {
            Stage::Off(p, until) if now >= *until => {
                p.rep += 1;
                Some((*until, p.slot, p.untracked, p.on))
            }
            _ => None,
        };
        if let Some((ideal, slot, untracked, on)) = next {
            self.start(slot, untracked, on)
                .map_err(|e| e.context("presenting the next on-phase"))?;
            let at = self.clock.now_us();
            if let Stage::Off(p, _) = std::mem::take(&mut self.stage) {
                self.begin_on(p, OnPhase::new(at, ideal));
            }
            return Ok(());
        }
        if !matches!(self.stage, Stage::Idle) && now >= self.next_status_us {
            self.next_status_us = now + us(STATUS_EVERY);
            let s = self
                .dev
                .status()
                .map_err(|e| e.context("reading the device status"))?;
            self.observe(&s)?;
        }
        Ok(())
    }

    /// Makes `p` the on-stage presentation, on since `on.since_us`, and
    /// emits its onset stamped then.
    pub(super) fn begin_on(&mut self, p: Presentation, on: OnPhase) {
        self.mute = None;
        self.next_status_us = 0;
        let kind = EventKind::Onset {
            stimulus: self.loaded[p.entry].id.clone(),
            slot: p.slot,
            gate: gate_of(p.untracked),
            rep: p.rep,
        };
        self.emit_at(on.since_us, kind);
        self.stage = Stage::On(p, on);
    }

    /// Emits the offset of `p`'s on-phase `on` at `at` (`device`: what the
    /// device played, s).
    pub(super) fn offset_at(
        &mut self,
        at: u64,
        p: &Presentation,
        on: &mut OnPhase,
        reason: OffsetReason,
        device: Option<f64>,
    ) {
        if let Some(m) = on.muted_since.take() {
            on.muted_us += at.saturating_sub(m);
        }
        let presented = at.saturating_sub(on.since_us) as f64 / 1e6;
        let muted = on.muted_us as f64 / 1e6;
        let kind = EventKind::Offset {
            stimulus: self.loaded[p.entry].id.clone(),
            slot: p.slot,
            rep: p.rep,
            reason,
            presented_s: presented,
            device_presented_s: device,
            muted_s: muted,
            present_fraction: if presented > 0.0 {
                (1.0 - muted / presented).clamp(0.0, 1.0)
            } else {
                0.0
            },
        };
        self.emit_at(at, kind);
    }

    /// Emits `done` for `p` at `at`.
    pub(super) fn done_at(&mut self, at: u64, p: &Presentation) {
        let kind = EventKind::Done {
            stimulus: self.loaded[p.entry].id.clone(),
            reps: p.rep,
        };
        self.emit_at(at, kind);
    }

    /// The end of a timed on-phase (`device`: what the device played when
    /// it stopped itself; `None`: the host stops it now): offset, then the
    /// off-phase before the next one, or done.
    fn end_on_phase(&mut self, device: Option<f64>) -> anyhow::Result<()> {
        let Stage::On(p, _) = &self.stage else {
            return Ok(());
        };
        let (slot, on) = (p.slot, p.on);
        let device = match device {
            Some(d) => Some(d),
            None => self.stop_device(slot)?,
        };
        if let (Some(d), Some(on)) = (device, on) {
            self.on_error_us
                .push((d * 1e6).round() as i64 - us(on) as i64);
        }
        let Stage::On(p, mut on) = std::mem::take(&mut self.stage) else {
            return Ok(());
        };
        let now = self.clock.now_us();
        self.offset_at(now, &p, &mut on, OffsetReason::Timer, device);
        if p.rep < p.repeat {
            let until = now + us(p.off);
            self.stage = Stage::Off(p, until);
        } else {
            self.done_at(now, &p);
        }
        Ok(())
    }

    /// Follows the device: a switch taking effect, a timed on-phase ending,
    /// the device's start of an on-phase, mute changes.
    fn observe(&mut self, s: &Status) -> anyhow::Result<()> {
        let now = self.clock.now_us();
        match std::mem::take(&mut self.stage) {
            Stage::Switching {
                from,
                mut on,
                to,
                requested_us,
            } => {
                if s.state == DeviceState::Stopped {
                    // The device ended the outgoing stimulus before its
                    // cycle end (dropping the queued one): timed, or its
                    // lease lapsed. Its offset, then the new one from
                    // silence.
                    let played = self.played_us(from.slot, s).map(|u| u as f64 / 1e6);
                    let reason = stopped_by(s);
                    self.offset_at(now, &from, &mut on, reason, played);
                    self.done_at(now, &from);
                    let (slot, untracked, len) = (to.slot, to.untracked, to.on);
                    self.start(slot, untracked, len)?;
                    let at = self.clock.now_us();
                    self.begin_on(to, OnPhase::new(at, now));
                } else if s.slot == Some(to.slot) && s.queued_slot != Some(to.slot) {
                    // The device switched before this status was read: by
                    // its own counters, `played` ago.
                    let played = self.played_us(to.slot, s).unwrap_or(0);
                    let at = now.saturating_sub(played).max(requested_us);
                    let latency = at - requested_us;
                    self.offset_at(at, &from, &mut on, OffsetReason::Switch, None);
                    self.done_at(at, &from);
                    self.switch_us.push(latency);
                    let kind = EventKind::Switch {
                        from: Some(self.loaded[from.entry].id.clone()),
                        to: self.loaded[to.entry].id.clone(),
                        latency_ms: latency as f64 / 1e3,
                        detected_ms: now.saturating_sub(requested_us) as f64 / 1e3,
                    };
                    self.emit_at(at, kind);
                    let mut phase = OnPhase::new(at, requested_us);
                    phase.device_start_us = Some(at);
                    self.begin_on(to, phase);
                } else {
                    // The outgoing one sounds on: its mute time counts.
                    self.follow_mute(now, s, &mut on);
                    self.stage = Stage::Switching {
                        from,
                        on,
                        to,
                        requested_us,
                    };
                }
            }
            Stage::On(p, mut on) => {
                let here = s.slot == Some(p.slot);
                if on.device_start_us.is_none()
                    && here
                    && matches!(s.state, DeviceState::Playing | DeviceState::Muted)
                {
                    let start = now.saturating_sub(self.played_us(p.slot, s).unwrap_or(0));
                    on.device_start_us = Some(start);
                    self.onset_us
                        .push(start.saturating_sub(on.ideal_us.min(start)));
                }
                if s.state == DeviceState::Stopped && here {
                    // The device ended the on-phase itself: its counters
                    // say how long it played.
                    let played = self.played_us(p.slot, s).map(|u| u as f64 / 1e6);
                    if stopped_by(s) == OffsetReason::LeaseExpired {
                        // Not the end of an on-phase: the presentation's.
                        self.offset_at(now, &p, &mut on, OffsetReason::LeaseExpired, played);
                        self.done_at(now, &p);
                        return Ok(());
                    }
                    if p.on.is_some() {
                        self.stage = Stage::On(p, on);
                        return self.end_on_phase(played);
                    }
                }
                self.follow_mute(now, s, &mut on);
                self.stage = Stage::On(p, on);
            }
            other => self.stage = other,
        }
        Ok(())
    }

    /// Mute and unmute events, and the muted time of the on-phase `on`.
    fn follow_mute(&mut self, now: u64, s: &Status, on: &mut OnPhase) {
        let mute = (s.state == DeviceState::Muted).then_some(s.mute_reason);
        if mute == self.mute {
            return;
        }
        match (on.muted_since, mute) {
            (None, Some(_)) => on.muted_since = Some(now),
            (Some(m), None) => {
                on.muted_us += now.saturating_sub(m);
                on.muted_since = None;
            }
            _ => {}
        }
        self.mute = mute;
        self.emit(match mute {
            Some(reason) => EventKind::Mute {
                reason: protocol::mute_name(reason),
            },
            None => EventKind::Unmute,
        });
    }

    /// Stops the device and returns the seconds it played since the
    /// on-phase began, by its own step and cycle counters.
    pub(super) fn stop_device(&mut self, slot: u8) -> anyhow::Result<Option<f64>> {
        self.dev
            .stop()
            .map_err(|e| e.context("stopping the device"))?;
        let s = self
            .dev
            .status()
            .map_err(|e| e.context("reading the device status"))?;
        Ok(self.played_us(slot, &s).map(|us| us as f64 / 1e6))
    }

    /// How long (µs) the device has played `slot`, by its step and cycle
    /// counters in `s` (`None` when it does not play `slot`).
    pub(super) fn played_us(&self, slot: u8, s: &Status) -> Option<u64> {
        let l = self.loaded.iter().find(|l| l.slot == Some(slot))?;
        let h = &l.planned.plan.sequence.header;
        (s.slot == Some(slot)).then(|| {
            let steps = u64::from(h.steps.max(1));
            let played = u64::from(s.cycles) * steps + u64::from(s.step);
            played * u64::from(h.period_us) / steps
        })
    }
}
