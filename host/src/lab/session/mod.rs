//! The rig session: one process holds the device and the finger source for
//! its whole life, presents stimuli from a [`Library`] on command and logs
//! what was actually played as [`Event`]s.
//!
//! [`Session`] is the core and has no I/O of its own besides the device:
//! it takes [`Command`]s and finger samples, runs each presentation's
//! timeline in [`Session::poll`], and queues events the caller drains
//! ([`Session::drain_events`]) to a log, the control socket's subscribers
//! or a study. [`serve`](crate::lab::session::serve::serve) runs it behind a control
//! socket (`lmhost session`); the study runner drives it in process. The
//! protocol is specified in `host/src/lab/session/PROTOCOL.md`.
//!
//! Stimuli are planned for the device at start. Where the device has a slot
//! per entry, every entry is uploaded before the first command (the LM
//! firmware's resident library); otherwise (an AUTD3's two segments) the
//! library stays on the host and an entry goes into the idle slot when
//! presented or, ahead of time, on `prepare`. A stimulus presented while
//! another plays takes over at the playing cycle's end (`switch` event with
//! its latency); one presented from silence starts at once.
//!
//! Time stamps: `t_host_us` is the host's monotonic clock
//! ([`crate::clock::monotonic_us`]); what the device played is read from
//! its own step and cycle counters at the offset (`device_presented_s`).

pub mod protocol;
pub mod serve;

use std::time::Duration;

use lm_proto::{DeviceState, MuteReason, Status};

use crate::clock::monotonic_us;
use crate::device::backend::{Backend, BackendInfo, CentroidOutcome, ErrorKind};
use crate::device::centroids::CentroidSender;
use crate::error::InputError;
use crate::plan::library::Library;
use crate::plan::scene::Scene;
use crate::plan::stimulus::TargetPlan;
use crate::units::mm_to_um;

pub use protocol::{Command, Event, EventKind, Gate, LibraryItem, OffsetReason, Present, Reply};

/// How often the device's status is read while a stimulus plays (mute
/// changes, switches).
pub const STATUS_EVERY: Duration = Duration::from_millis(5);

/// How long after a timed on-phase should have ended the host stops a
/// device that has not stopped itself.
pub const LATE_STOP: Duration = Duration::from_secs(1);

/// Longest `on_s` / `off_s`, seconds.
pub const MAX_PHASE_S: f64 = 3_600.0;

/// Most on-phases one `present` asks for.
pub const MAX_REPEAT: u32 = 10_000;

/// A library entry planned for this device, and where it is on it.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The entry's id.
    pub id: String,
    /// The stimulus.
    pub stimulus: crate::plan::stimulus::Stimulus,
    /// Its plan on this device's grid.
    pub planned: TargetPlan,
    /// Its default gate.
    pub untracked: bool,
    /// The slot holding it now, if any.
    pub slot: Option<u8>,
    /// CRC-32 of its phases.
    pub crc32: u32,
}

/// What a session measured (from its events).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Figures {
    /// Switches between stimuli at a cycle end.
    pub switches: usize,
    /// Median switch latency, request to the device playing the new one (ms).
    pub switch_p50_ms: Option<f64>,
    /// 99th percentile switch latency (ms).
    pub switch_p99_ms: Option<f64>,
    /// Largest switch latency (ms).
    pub switch_max_ms: Option<f64>,
    /// Timed on-phases ended by their timer.
    pub timed_on_phases: usize,
    /// Largest |device-played time − on_s| over them (ms).
    pub on_error_max_abs_ms: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Asked to take over from the stimulus playing; switches at its cycle
    /// end.
    Switching { requested_us: u64 },
    /// Playing since `since_us` (host).
    On { since_us: u64 },
    /// Silent between on-phases until `until_us` (host).
    Off { until_us: u64 },
}

#[derive(Debug, Clone)]
struct Presentation {
    entry: usize,
    slot: u8,
    untracked: bool,
    on: Option<Duration>,
    off: Duration,
    repeat: u32,
    /// The on-phase playing or last played, 1-based.
    rep: u32,
    phase: Phase,
    /// Since when (host µs) the output is muted in this on-phase, and the
    /// muted time of this on-phase before that (µs).
    muted_since: Option<u64>,
    muted_us: u64,
}

impl Presentation {
    fn sounding_slot(&self) -> Option<u8> {
        match self.phase {
            Phase::On { .. } => Some(self.slot),
            _ => None,
        }
    }
}

/// A session over an open device.
pub struct Session {
    dev: Box<dyn Backend>,
    info: BackendInfo,
    scene: Scene,
    loaded: Vec<Loaded>,
    /// The newest presentation: its timeline runs.
    current: Option<Presentation>,
    /// The presentation still playing while `current` waits for the cycle
    /// end to take over.
    outgoing: Option<Presentation>,
    events: Vec<Event>,
    /// Mute reason last seen while on (`None`: sounding).
    mute: Option<MuteReason>,
    finger: Option<bool>,
    /// Numbers and sends the finger's centroids.
    centroids: CentroidSender,
    next_status_us: u64,
    /// Switch latencies so far (µs).
    switch_us: Vec<u64>,
    /// Timed on-phases: device-played time minus `on_s` (µs).
    on_error_us: Vec<i64>,
}

fn gate_of(untracked: bool) -> Gate {
    if untracked {
        Gate::Untracked
    } else {
        Gate::Tracked
    }
}

impl Session {
    /// Takes over `dev` with `library`'s entries planned for it (`plans`,
    /// in order; [`Library::plan_for`]) and preloads: every entry into a
    /// slot of its own when the device has enough slots, else the first.
    /// The device starts silent. Emits `preloaded` per upload and `ready`.
    pub fn new(
        mut dev: Box<dyn Backend>,
        library: &Library,
        plans: Vec<TargetPlan>,
        scene: Scene,
    ) -> anyhow::Result<Self> {
        anyhow::ensure!(
            plans.len() == library.entries.len(),
            "one plan per library entry"
        );
        let info = dev
            .info()
            .map_err(|e| e.context("reading the device info"))?;
        // The device may still play from an earlier process: start silent.
        dev.stop().map_err(|e| e.context("stopping the device"))?;
        let status = dev
            .status()
            .map_err(|e| e.context("reading the device status"))?;
        let loaded = library
            .entries
            .iter()
            .zip(plans)
            .map(|(e, planned)| Loaded {
                id: e.id.clone(),
                crc32: planned.plan.sequence.crc32(),
                stimulus: e.stimulus.clone(),
                planned,
                untracked: e.untracked,
                slot: None,
            })
            .collect::<Vec<_>>();
        let mut me = Self {
            dev,
            info,
            scene,
            loaded,
            current: None,
            outgoing: None,
            events: Vec::new(),
            mute: None,
            finger: None,
            centroids: CentroidSender::continuing(status.last_centroid_seq),
            next_status_us: 0,
            switch_us: Vec::new(),
            on_error_us: Vec::new(),
        };
        if me.loaded.len() <= usize::from(me.info.slots) {
            for i in 0..me.loaded.len() {
                me.load(i, Some(i as u8))?;
            }
        } else {
            me.load(0, None)?;
        }
        let resident = me.loaded.iter().filter(|l| l.slot.is_some()).count();
        me.emit(EventKind::Ready {
            backend: me.info.backend.clone(),
            port: me.info.port.clone(),
            stimuli: me.loaded.len(),
            resident,
            slots: me.info.slots,
        });
        Ok(me)
    }

    /// The device as it described itself at start.
    pub fn info(&self) -> &BackendInfo {
        &self.info
    }

    /// The scene (its reflector mirrors centroids into drive coordinates).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The library as planned for this device.
    pub fn loaded(&self) -> &[Loaded] {
        &self.loaded
    }

    /// The library's entries, for the `library` command.
    pub fn library(&self) -> Vec<LibraryItem> {
        self.loaded.iter().map(LibraryItem::of).collect()
    }

    /// Events since the last call, oldest first.
    pub fn drain_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// Whether a presentation runs (on, switching or between on-phases).
    pub fn presenting(&self) -> bool {
        self.current.is_some()
    }

    /// What the session measured so far: switch latencies and the timed
    /// on-phases' error by the device's counters.
    pub fn figures(&self) -> Figures {
        let pct = |p| crate::clock::percentile(self.switch_us.iter().copied(), p);
        let ms = |us: Option<u64>| us.map(|u| u as f64 / 1e3);
        Figures {
            switches: self.switch_us.len(),
            switch_p50_ms: ms(pct(50.0)),
            switch_p99_ms: ms(pct(99.0)),
            switch_max_ms: ms(self.switch_us.iter().copied().max()),
            timed_on_phases: self.on_error_us.len(),
            on_error_max_abs_ms: self
                .on_error_us
                .iter()
                .map(|e| e.unsigned_abs())
                .max()
                .map(|u| u as f64 / 1e3),
        }
    }

    /// Whether the presentation running has no end of its own (no
    /// `on_s`): it plays until `stop`.
    pub fn presenting_endless(&self) -> bool {
        self.current
            .as_ref()
            .is_some_and(|p| p.on.is_none() && matches!(p.phase, Phase::On { .. }))
    }

    pub(crate) fn emit(&mut self, kind: EventKind) {
        self.emit_at(monotonic_us(), kind);
    }

    fn emit_at(&mut self, t_host_us: u64, kind: EventKind) {
        self.events.push(Event { t_host_us, kind });
    }

    /// Uploads entry `i` into `slot` (`None`: one neither playing nor
    /// queued), evicting whatever entry that slot held.
    fn load(&mut self, i: usize, slot: Option<u8>) -> anyhow::Result<u8> {
        let t0 = monotonic_us();
        let r = self
            .dev
            .upload(&self.loaded[i].planned.plan, slot)
            .map_err(|e| e.context(format!("uploading stimulus `{}`", self.loaded[i].id)))?;
        for l in &mut self.loaded {
            if l.slot == Some(r.slot) {
                l.slot = None;
            }
        }
        self.loaded[i].slot = Some(r.slot);
        self.emit(EventKind::Preloaded {
            stimulus: self.loaded[i].id.clone(),
            slot: r.slot,
            seconds: monotonic_us().saturating_sub(t0) as f64 / 1e6,
            wire_bytes: r.wire().map(|w| w.wire_bytes_sent),
            readback_mismatches: r.readback_mismatches(),
        });
        Ok(r.slot)
    }

    fn entry(&self, id: &str) -> Result<usize, InputError> {
        self.loaded.iter().position(|l| l.id == id).ok_or_else(|| {
            let ids: Vec<&str> = self.loaded.iter().take(8).map(|l| l.id.as_str()).collect();
            InputError::new(format!(
                "no stimulus `{}` in the library (it has {}{})",
                id.escape_debug(),
                ids.join(", "),
                if self.loaded.len() > 8 { ", ..." } else { "" }
            ))
        })
    }

    /// Makes entry `i` resident (a no-op when it is), in a slot neither
    /// playing nor queued.
    fn ensure_loaded(&mut self, i: usize) -> anyhow::Result<u8> {
        if let Some(s) = self.loaded[i].slot {
            return Ok(s);
        }
        let busy: Vec<u8> = [&self.current, &self.outgoing]
            .into_iter()
            .flatten()
            .map(|p| p.slot)
            .collect();
        let free = |s: &u8| !busy.contains(s);
        let empty = (0..self.info.slots)
            .filter(free)
            .find(|s| !self.loaded.iter().any(|l| l.slot == Some(*s)));
        let slot = empty.or_else(|| (0..self.info.slots).find(free));
        let Some(slot) = slot else {
            return Err(InputError::new(format!(
                "stimulus `{}` cannot be loaded now: every slot of the device plays or is queued",
                self.loaded[i].id
            ))
            .into());
        };
        self.load(i, Some(slot))
    }

    /// Uploads `id` ahead of its `present` (into a slot that does not
    /// play), so its switch is only a slot change. Returns the slot.
    pub fn prepare(&mut self, id: &str) -> anyhow::Result<u8> {
        let i = self.entry(id)?;
        self.ensure_loaded(i)
    }

    /// Starts a presentation: from silence at once; over a playing
    /// stimulus at that stimulus's cycle end (a `switch` event then).
    pub fn present(&mut self, req: &Present) -> anyhow::Result<()> {
        let i = self.entry(&req.stimulus)?;
        let on = req
            .on_s
            .map(|s| crate::limits::duration_s("on_s", s, MAX_PHASE_S))
            .transpose()?;
        let off = match req.off_s {
            None => Duration::ZERO,
            Some(0.0) => Duration::ZERO,
            Some(s) => crate::limits::duration_s("off_s", s, MAX_PHASE_S)?,
        };
        let repeat = req.repeat.unwrap_or(1);
        if !(1..=MAX_REPEAT).contains(&repeat) {
            return Err(InputError::new(format!(
                "repeat {repeat} is out of range: allowed 1..={MAX_REPEAT}"
            ))
            .into());
        }
        if repeat > 1 && on.is_none() {
            return Err(
                InputError::new("repeat needs on_s: an endless on-phase never repeats").into(),
            );
        }
        let untracked = match req.gate {
            Some(g) => g == Gate::Untracked,
            None => self.loaded[i].untracked,
        };
        let slot = self.ensure_loaded(i)?;
        let mut p = Presentation {
            entry: i,
            slot,
            untracked,
            on,
            off,
            repeat,
            rep: 1,
            phase: Phase::On { since_us: 0 },
            muted_since: None,
            muted_us: 0,
        };
        // A presentation waiting to switch in never played: drop it.
        self.cancel_switch();
        let playing = self.current.as_ref().and_then(Presentation::sounding_slot);
        let id = self.loaded[i].id.clone();
        match playing {
            Some(old) if old != slot || on.is_some() => {
                // Another stimulus (or this one again, timed): the device
                // takes over at the playing cycle's end.
                self.start(slot, untracked, on)
                    .map_err(|e| e.context(format!("presenting `{id}`")))?;
                p.phase = Phase::Switching {
                    requested_us: monotonic_us(),
                };
                self.outgoing = self.current.replace(p);
                self.next_status_us = 0;
            }
            Some(_) => {
                // The same stimulus again: a new timeline, no device change
                // unless the gate changes.
                let old_untracked = self.current.as_ref().is_some_and(|c| c.untracked);
                self.offset(OffsetReason::Replaced, None)?;
                if old_untracked != untracked {
                    self.start(slot, untracked, None)
                        .map_err(|e| e.context(format!("presenting `{id}`")))?;
                }
                self.current = Some(p);
                self.onset();
            }
            None => {
                if let Some(c) = &self.current {
                    // Between on-phases of another presentation.
                    let name = self.loaded[c.entry].id.clone();
                    self.current = None;
                    self.emit(EventKind::Done {
                        stimulus: name,
                        reps: 0,
                    });
                }
                self.start(slot, untracked, on)
                    .map_err(|e| e.context(format!("presenting `{id}`")))?;
                self.current = Some(p);
                self.onset();
            }
        }
        Ok(())
    }

    /// Plays `slot`: for `on` (the device stops itself after that many of
    /// the slot's steps, [`Backend::play_for`]) or until stopped.
    fn start(&mut self, slot: u8, untracked: bool, on: Option<Duration>) -> anyhow::Result<()> {
        let r = match on {
            Some(on) => {
                let steps = self.steps_for(slot, on);
                self.dev.play_for(slot, untracked, steps)
            }
            None => self.dev.play(slot, untracked),
        };
        r.map_err(anyhow::Error::from)
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

    /// Marks the current presentation on from now and emits its onset.
    fn onset(&mut self) {
        self.onset_at(monotonic_us());
    }

    /// Marks the current presentation on since `now` (host µs) and emits
    /// its onset stamped then.
    fn onset_at(&mut self, now: u64) {
        let Some(p) = &mut self.current else { return };
        p.phase = Phase::On { since_us: now };
        p.muted_since = None;
        p.muted_us = 0;
        let (entry, slot, rep, untracked) = (p.entry, p.slot, p.rep, p.untracked);
        self.mute = None;
        self.next_status_us = 0;
        self.emit_at(
            now,
            EventKind::Onset {
                stimulus: self.loaded[entry].id.clone(),
                slot,
                gate: gate_of(untracked),
                rep,
            },
        );
    }

    /// Emits the offset of the current on-phase (`device`: what the device
    /// played, s) and leaves the presentation as it is.
    fn offset(&mut self, reason: OffsetReason, device: Option<f64>) -> anyhow::Result<()> {
        self.offset_at(monotonic_us(), reason, device)
    }

    /// [`Self::offset`] stamped `now` (host µs).
    fn offset_at(
        &mut self,
        now: u64,
        reason: OffsetReason,
        device: Option<f64>,
    ) -> anyhow::Result<()> {
        let Some(p) = &mut self.current else {
            return Ok(());
        };
        let Phase::On { since_us } = p.phase else {
            return Ok(());
        };
        if let Some(m) = p.muted_since.take() {
            p.muted_us += now.saturating_sub(m);
        }
        let presented = now.saturating_sub(since_us) as f64 / 1e6;
        let muted = p.muted_us as f64 / 1e6;
        let (entry, slot, rep) = (p.entry, p.slot, p.rep);
        self.emit_at(
            now,
            EventKind::Offset {
                stimulus: self.loaded[entry].id.clone(),
                slot,
                rep,
                reason,
                presented_s: presented,
                device_presented_s: device,
                muted_s: muted,
                present_fraction: if presented > 0.0 {
                    (1.0 - muted / presented).clamp(0.0, 1.0)
                } else {
                    0.0
                },
            },
        );
        Ok(())
    }

    /// Stops the device and returns the seconds it played since the
    /// on-phase began, by its own step and cycle counters.
    fn stop_device(&mut self, slot: u8) -> anyhow::Result<Option<f64>> {
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
    fn played_us(&self, slot: u8, s: &Status) -> Option<u64> {
        let l = self.loaded.iter().find(|l| l.slot == Some(slot))?;
        let h = &l.planned.plan.sequence.header;
        (s.slot == Some(slot)).then(|| {
            let steps = u64::from(h.steps.max(1));
            let played = u64::from(s.cycles) * steps + u64::from(s.step);
            played * u64::from(h.period_us) / steps
        })
    }

    /// Stops whatever plays or waits: the array is silent afterwards.
    pub fn stop(&mut self, reason: OffsetReason) -> anyhow::Result<()> {
        self.cancel_switch();
        let slot = self.current.as_ref().map(|p| p.slot);
        let device = match slot {
            Some(s) => self.stop_device(s)?,
            None => {
                self.dev
                    .stop()
                    .map_err(|e| e.context("stopping the device"))?;
                None
            }
        };
        self.offset(reason, device)?;
        if let Some(p) = self.current.take() {
            self.emit(EventKind::Done {
                stimulus: self.loaded[p.entry].id.clone(),
                reps: p.rep,
            });
        }
        Ok(())
    }

    /// A finger sample (finger space, mm; `None`: no finger): to the device
    /// as a centroid in drive coordinates; `finger` events on changes.
    pub fn finger(&mut self, pos_mm: Option<[f64; 3]>) -> anyhow::Result<()> {
        let present = pos_mm.is_some();
        if self.finger != Some(present) {
            self.finger = Some(present);
            self.emit(EventKind::Finger { present });
        }
        let pos_um = pos_mm.map(|p| self.scene.drive_point(p).map(mm_to_um));
        match self
            .centroids
            .send(self.dev.as_mut(), pos_um, monotonic_us())
        {
            Ok(CentroidOutcome::Applied | CentroidOutcome::OutOfRange) => Ok(()),
            // Not newer than the device's last (another client streamed):
            // the sender continues after it.
            Err(e) if matches!(e.kind(), ErrorKind::Refused(lm_proto::NackCode::OutOfOrder)) => {
                Ok(())
            }
            Err(e) => Err(anyhow::Error::from(e)
                .context(format!("sending centroid #{}", self.centroids.last_seq()))),
        }
    }

    /// Runs the timelines (on/off phases, switches) and the device's
    /// housekeeping; call it at least every few milliseconds.
    pub fn poll(&mut self) -> anyhow::Result<()> {
        self.dev.tick()?;
        let now = monotonic_us();
        if let Some(p) = &self.current {
            match p.phase {
                Phase::On { since_us } => {
                    // The device ends a timed on-phase itself (seen in its
                    // status); should it not have within a second more,
                    // the host stops it.
                    if let Some(on) = p.on
                        && now >= since_us + on.as_micros() as u64 + LATE_STOP.as_micros() as u64
                    {
                        self.end_on_phase(None)?;
                    }
                }
                Phase::Off { until_us } => {
                    if now >= until_us {
                        let (slot, untracked, on) = (p.slot, p.untracked, p.on);
                        if let Some(p) = &mut self.current {
                            p.rep += 1;
                        }
                        self.start(slot, untracked, on)
                            .map_err(|e| e.context("presenting the next on-phase"))?;
                        self.onset();
                    }
                }
                Phase::Switching { .. } => {}
            }
        }
        if self.current.is_some() && now >= self.next_status_us {
            self.next_status_us = now + STATUS_EVERY.as_micros() as u64;
            let s = self
                .dev
                .status()
                .map_err(|e| e.context("reading the device status"))?;
            self.observe(&s)?;
        }
        Ok(())
    }

    /// The end of a timed on-phase (`device`: what the device played when
    /// it stopped itself; `None`: the host stops it now), offset, then the
    /// next on-phase after `off`, or done.
    fn end_on_phase(&mut self, device: Option<f64>) -> anyhow::Result<()> {
        let Some(p) = &self.current else {
            return Ok(());
        };
        let (slot, on) = (p.slot, p.on);
        let device = match device {
            Some(d) => Some(d),
            None => self.stop_device(slot)?,
        };
        if let (Some(d), Some(on)) = (device, on) {
            self.on_error_us
                .push((d * 1e6).round() as i64 - on.as_micros() as i64);
        }
        self.offset(OffsetReason::Timer, device)?;
        let Some(p) = &mut self.current else {
            return Ok(());
        };
        if p.rep < p.repeat {
            p.phase = Phase::Off {
                until_us: monotonic_us() + p.off.as_micros() as u64,
            };
        } else if let Some(p) = self.current.take() {
            self.emit(EventKind::Done {
                stimulus: self.loaded[p.entry].id.clone(),
                reps: p.rep,
            });
        }
        Ok(())
    }

    /// Drops a presentation still waiting for its switch (it never
    /// played; `cancelled`): the outgoing one is current again.
    fn cancel_switch(&mut self) {
        if let Some(c) = self
            .current
            .take_if(|c| matches!(c.phase, Phase::Switching { .. }))
        {
            self.emit(EventKind::Cancelled {
                stimulus: self.loaded[c.entry].id.clone(),
            });
            self.current = self.outgoing.take();
        }
    }

    /// Ends the outgoing presentation at `at` (host µs; its offset for
    /// `reason` with what the `device` played, then `done`) and makes the
    /// one waiting for the switch current.
    fn hand_over(
        &mut self,
        at: u64,
        reason: OffsetReason,
        device: Option<f64>,
    ) -> anyhow::Result<()> {
        let incoming = self.current.take();
        self.current = self.outgoing.take();
        self.offset_at(at, reason, device)?;
        if let Some(o) = self.current.take() {
            self.emit_at(
                at,
                EventKind::Done {
                    stimulus: self.loaded[o.entry].id.clone(),
                    reps: o.rep,
                },
            );
        }
        self.current = incoming;
        Ok(())
    }

    /// Follows the device: a switch taking effect, a timed on-phase ending,
    /// mute changes.
    fn observe(&mut self, s: &Status) -> anyhow::Result<()> {
        let now = monotonic_us();
        // The outgoing stimulus was timed and the device ended it before
        // its cycle end (dropping the queued one): its offset, then the new
        // one from silence.
        if let Some(p) = &self.current
            && matches!(p.phase, Phase::Switching { .. })
            && s.state == DeviceState::Stopped
        {
            let played = self
                .outgoing
                .as_ref()
                .and_then(|o| self.played_us(o.slot, s))
                .map(|us| us as f64 / 1e6);
            self.hand_over(now, OffsetReason::Timer, played)?;
            if let Some(p) = &self.current {
                let (slot, untracked, on) = (p.slot, p.untracked, p.on);
                self.start(slot, untracked, on)?;
                self.onset();
            }
            return Ok(());
        }
        if let Some(p) = &self.current
            && let Phase::Switching { requested_us } = p.phase
            && s.slot == Some(p.slot)
            && s.queued_slot != Some(p.slot)
        {
            // The device switched before this status was read: by its own
            // counters, `played` ago.
            let played = self.played_us(p.slot, s).unwrap_or(0);
            let switched_at = now.saturating_sub(played).max(requested_us);
            let latency = switched_at - requested_us;
            let from = self
                .outgoing
                .as_ref()
                .map(|o| self.loaded[o.entry].id.clone());
            let to = self.loaded[p.entry].id.clone();
            // The outgoing one's offset, then the new one's onset.
            self.hand_over(switched_at, OffsetReason::Switch, None)?;
            self.switch_us.push(latency);
            self.emit_at(
                switched_at,
                EventKind::Switch {
                    from,
                    to,
                    latency_ms: latency as f64 / 1e3,
                    detected_ms: now.saturating_sub(requested_us) as f64 / 1e3,
                },
            );
            self.onset_at(switched_at);
            return Ok(());
        }
        let on = self
            .current
            .as_ref()
            .is_some_and(|p| matches!(p.phase, Phase::On { .. }));
        if !on {
            return Ok(());
        }
        // A timed on-phase the device ended itself: its counters say how
        // long it played.
        if let Some(p) = &self.current
            && p.on.is_some()
            && s.state == DeviceState::Stopped
            && s.slot == Some(p.slot)
        {
            let played = self.played_us(p.slot, s).map(|us| us as f64 / 1e6);
            return self.end_on_phase(played);
        }
        let mute = (s.state == DeviceState::Muted).then_some(s.mute_reason);
        if mute != self.mute {
            if let Some(p) = &mut self.current {
                match (p.muted_since, mute) {
                    (None, Some(_)) => p.muted_since = Some(now),
                    (Some(m), None) => {
                        p.muted_us += now.saturating_sub(m);
                        p.muted_since = None;
                    }
                    _ => {}
                }
            }
            self.mute = mute;
            self.emit(match mute {
                Some(reason) => EventKind::Mute {
                    reason: protocol::mute_name(reason),
                },
                None => EventKind::Unmute,
            });
        }
        Ok(())
    }

    /// What the `status` command answers.
    pub fn status(&mut self) -> anyhow::Result<protocol::StatusReply> {
        let s = self
            .dev
            .status()
            .map_err(|e| e.context("reading the device status"))?;
        let p = self.current.as_ref();
        Ok(protocol::StatusReply {
            stimulus: p.map(|p| self.loaded[p.entry].id.clone()),
            phase: p.map(|p| match p.phase {
                Phase::Switching { .. } => "switching",
                Phase::On { .. } => "on",
                Phase::Off { .. } => "off",
            }),
            rep: p.map(|p| p.rep),
            repeat: p.map(|p| p.repeat),
            gate: p.map(|p| gate_of(p.untracked)),
            finger_present: self.finger,
            state: format!("{:?}", s.state).to_lowercase(),
            slot: s.slot,
            queued_slot: s.queued_slot,
            mute_reason: (s.state == DeviceState::Muted)
                .then(|| protocol::mute_name(s.mute_reason)),
            step: s.step,
            cycles: s.cycles,
        })
    }

    /// Handles one command; `Quit` is the caller's (it answers ok here).
    pub fn handle(&mut self, cmd: &Command) -> Reply {
        let r: anyhow::Result<Reply> = match cmd {
            Command::Present(p) => self.present(p).map(|()| Reply::ok("present")),
            Command::Prepare { stimulus } => self
                .prepare(stimulus)
                .map(|slot| Reply::ok("prepare").with("slot", slot)),
            Command::Stop => self.stop(OffsetReason::Stop).map(|()| Reply::ok("stop")),
            Command::Status => self.status().map(|s| Reply::ok("status").with("status", s)),
            Command::Library => Ok(Reply::ok("library").with("stimuli", self.library())),
            Command::Subscribe => Ok(Reply::ok("subscribe")),
            Command::Quit => Ok(Reply::ok("quit")),
        };
        r.unwrap_or_else(|e| {
            let msg = crate::error::one_line(&e);
            self.emit(EventKind::Refused {
                command: cmd.name().into(),
                error: msg.clone(),
            });
            Reply::error(cmd.name(), msg)
        })
    }

    /// Ends the session: stops what plays (offset `reason`) and leaves the
    /// array silent (the backend's drop); returns the last events.
    pub fn close(mut self, reason: OffsetReason) -> Vec<Event> {
        if let Err(e) = self.stop(reason) {
            self.emit(EventKind::Refused {
                command: "stop".into(),
                error: crate::error::one_line(&e),
            });
        }
        self.emit(EventKind::Closed { reason });
        let events = self.drain_events();
        drop(self.dev);
        events
    }
}

#[cfg(test)]
mod tests;
