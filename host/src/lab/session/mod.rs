//! The rig session: one process holds the device and the finger source for
//! its whole life, presents stimuli from a [`Library`] on command and logs
//! what was actually played as [`Event`]s.
//!
//! [`Session`] is a polled state machine, as smoltcp's interface is: it
//! has no I/O of its own besides the device and no time but the
//! [`Clock`] it is given. It takes [`Command`]s and finger samples, moves
//! its one `stage` (idle, on, off, switching from one stimulus to the
//! next) in [`Session::poll`], says in [`Session::poll_at`] when it next
//! has work, and queues events the caller drains
//! ([`Session::drain_events`]). [`driver::Driver`] runs it (the finger
//! source, the loop's deadlines) for both `lmhost session`
//! ([`serve::serve`], behind a control socket) and `lmhost study`. Tests
//! run it on a manual clock shared with the simulated device or the AUTD3
//! emulator, without sleeping. The protocol is specified in
//! `host/src/lab/session/PROTOCOL.md`.
//!
//! Stimuli are planned for the device at start and preloaded as far as the
//! device's slots and library memory go (`resident`); the rest load when
//! presented or, ahead of time, on `prepare`, in place of the least
//! recently used idle entry when the memory is full. A stimulus presented
//! while another plays takes over at the playing cycle's end (`switch`
//! event with its latency); one presented from silence starts at once.
//!
//! Time stamps: `t_host_us` is the session's clock (the host's monotonic
//! clock, [`crate::clock::monotonic_us`], outside tests); what the device
//! played is read from its own step and cycle counters at the offset
//! (`device_presented_s`).

pub(crate) mod conn;
pub mod driver;
mod endpoint;
mod eventlog;
mod handover;
pub mod protocol;
mod resident;
pub mod serve;
mod stage;

use std::time::Duration;

use lm_proto::{DeviceState, MuteReason};

use crate::clock::{Clock, Spread};
use crate::device::backend::{Backend, BackendInfo, CentroidOutcome, ErrorKind};
use crate::device::centroids::CentroidSender;
use crate::error::InputError;
use crate::plan::library::Library;
use crate::plan::scene::Scene;
use crate::plan::stimulus::TargetPlan;
use crate::units::mm_to_um;

pub use eventlog::{EventLog, PendingEventLog};
pub use protocol::{Command, Event, EventKind, Gate, LibraryItem, OffsetReason, Present, Reply};
pub use resident::Loaded;
pub use stage::{IN_PROCESS, LATE_STOP, Owner, STATUS_EVERY, TICK_EVERY};

use stage::{OnPhase, Presentation, Stage};

/// Longest `on_s` / `off_s`, seconds.
pub const MAX_PHASE_S: f64 = 3_600.0;

/// Whether an on-phase of `on_s` plays at least one step of a stimulus
/// whose steps last `dwell_us`: the device plays the whole number of steps
/// nearest to it, so one under half a step would play none (and is played
/// as one, longer than asked).
pub fn plays_a_step(on_s: f64, dwell_us: f64) -> bool {
    (on_s * 1e6 / dwell_us).round() >= 1.0
}

/// Most on-phases one `present` asks for.
pub const MAX_REPEAT: u32 = 10_000;

/// The one rule for an `off_s` beside its on-phases, for a control line's
/// `present` and a protocol's `[timeline]` alike: the silence between
/// on-phases needs two of them (`repeat` 2 or more, or a procedure's trial,
/// which repeats until answered); with one, an `off_s` would change
/// nothing, so it is refused rather than dropped. `Err` says what to give.
pub fn check_off_s(
    off_given: bool,
    on_phases: u32,
    repeats_until_answered: bool,
) -> Result<(), &'static str> {
    if off_given && on_phases < 2 && !repeats_until_answered {
        return Err("`off_s` is the silence between on-phases: give `repeat` 2 or more");
    }
    Ok(())
}

/// What a session measured (from its events).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Figures {
    /// On-phases begun from silence whose start the device's counters
    /// showed.
    pub onsets: usize,
    /// Onset latency: from the ideal start (the `present`, or the end of
    /// the off-phase before) to the device playing (ms).
    pub onset_ms: Option<Spread<f64>>,
    /// Switches between stimuli at a cycle end.
    pub switches: usize,
    /// Switch latency, request to the device playing the new one (ms).
    pub switch_ms: Option<Spread<f64>>,
    /// Timed on-phases ended by their timer.
    pub timed_on_phases: usize,
    /// Largest |device-played time − on_s| over them (ms).
    pub on_error_max_abs_ms: Option<f64>,
}

/// A session over an open device.
pub struct Session {
    dev: Box<dyn Backend>,
    info: BackendInfo,
    scene: Scene,
    clock: Clock,
    loaded: Vec<Loaded>,
    stage: Stage,
    events: Vec<Event>,
    /// Mute reason last seen while on (`None`: sounding).
    mute: Option<MuteReason>,
    finger: Option<bool>,
    /// Whether anything feeds finger samples (else tracked presentations
    /// are refused: they would stay muted).
    finger_source: bool,
    /// Numbers and sends the finger's centroids.
    centroids: CentroidSender,
    next_status_us: u64,
    next_tick_us: u64,
    /// Onset latencies from silence (µs), switch latencies (µs), timed
    /// on-phases' device-played time minus `on_s` (µs).
    onset_us: Vec<u64>,
    switch_us: Vec<u64>,
    on_error_us: Vec<i64>,
    /// Entries shrunk to make room for the load under way.
    shrunk: Vec<String>,
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
    /// in order; [`Library::plan_for`]) on `clock` (the device's own, in
    /// tests) and preloads what fits. The device starts silent. Emits
    /// `preloaded` per upload and `ready`. A session has a finger source
    /// unless told otherwise ([`Session::set_finger_source`]).
    pub fn new(
        mut dev: Box<dyn Backend>,
        library: &Library,
        plans: Vec<TargetPlan>,
        scene: Scene,
        clock: Clock,
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
        // A stop asked while the device was being opened ends the set-up
        // here, the device silent.
        crate::stop::check_set_up(&format!("connecting to {}", info.port))?;
        let mut me = Self {
            dev,
            info,
            scene,
            clock,
            loaded: resident::entries(library, plans),
            stage: Stage::Idle,
            events: Vec::new(),
            mute: None,
            finger: None,
            finger_source: true,
            centroids: CentroidSender::continuing(status.last_centroid_seq),
            next_status_us: 0,
            next_tick_us: 0,
            onset_us: Vec::new(),
            switch_us: Vec::new(),
            on_error_us: Vec::new(),
            shrunk: Vec::new(),
        };
        me.preload()?;
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

    /// Says whether anything feeds finger samples: without, a tracked
    /// presentation is refused (it would stay muted throughout).
    pub fn set_finger_source(&mut self, present: bool) {
        self.finger_source = present;
    }

    /// The device as it described itself at start.
    pub fn info(&self) -> &BackendInfo {
        &self.info
    }

    /// The scene (its reflector mirrors centroids into drive coordinates).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The session's clock.
    pub fn clock(&self) -> &Clock {
        &self.clock
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
        !matches!(self.stage, Stage::Idle)
    }

    /// Whether the presentation running has no end of its own (no
    /// `on_s`): it plays until `stop`.
    pub fn presenting_endless(&self) -> bool {
        matches!(&self.stage, Stage::On(p, _) if p.on.is_none())
    }

    /// What the session measured so far: onset and switch latencies and
    /// the timed on-phases' error by the device's counters.
    pub fn figures(&self) -> Figures {
        let ms = |us: &[u64]| Spread::of(us.iter().copied()).map(Spread::ms);
        Figures {
            onsets: self.onset_us.len(),
            onset_ms: ms(&self.onset_us),
            switches: self.switch_us.len(),
            switch_ms: ms(&self.switch_us),
            timed_on_phases: self.on_error_us.len(),
            on_error_max_abs_ms: self
                .on_error_us
                .iter()
                .map(|e| e.unsigned_abs())
                .max()
                .map(|u| u as f64 / 1e3),
        }
    }

    /// Each onset latency from silence so far (ms), in order.
    pub fn onset_latencies_ms(&self) -> Vec<f64> {
        self.onset_us.iter().map(|&u| u as f64 / 1e3).collect()
    }

    pub(crate) fn emit(&mut self, kind: EventKind) {
        let now = self.clock.now_us();
        self.emit_at(now, kind);
    }

    fn emit_at(&mut self, t_host_us: u64, kind: EventKind) {
        self.events.push(Event { t_host_us, kind });
    }

    fn entry(&self, id: &str) -> Result<usize, InputError> {
        self.loaded.iter().position(|l| l.id == id).ok_or_else(|| {
            InputError::new(format!(
                "no stimulus `{}` in the library (it has {})",
                protocol::clip(id),
                crate::error::some_of(self.loaded.iter().map(|l| protocol::clip(&l.id)), ", ")
            ))
        })
    }

    /// Uploads `id` ahead of its `present` (into a slot that does not
    /// play), so its switch is only a slot change. Returns the slot.
    pub fn prepare(&mut self, id: &str) -> anyhow::Result<u8> {
        let i = self.entry(id)?;
        self.touch(i);
        self.ensure_loaded(i)
    }

    /// Starts a presentation asked for in process ([`IN_PROCESS`]); see
    /// [`Session::present_for`].
    pub fn present(&mut self, req: &Present) -> anyhow::Result<()> {
        self.present_for(req, IN_PROCESS)
    }

    /// Starts a presentation for `owner`: from silence at once; over a
    /// playing stimulus at that stimulus's cycle end (a `switch` event
    /// then); one waiting for its switch is replaced (`cancelled`). A
    /// refused present changes nothing.
    pub fn present_for(&mut self, req: &Present, owner: Owner) -> anyhow::Result<()> {
        let now = self.clock.now_us();
        let i = self.entry(&req.stimulus)?;
        // The device plays whole steps: an on-phase that rounds to none
        // would be played as one step longer than asked, without a word
        // (checked first: it names the least on_s that plays).
        if let Some(s) = req.on_s.filter(|s| s.is_finite() && *s > 0.0) {
            let dwell_us = self.loaded[i].planned.plan.sequence.dwell_us();
            if !plays_a_step(s, dwell_us) {
                return Err(InputError::new(format!(
                    "on_s {} s is shorter than half a step of `{}` ({} µs): the device plays whole steps; give at least {} s",
                    crate::limits::show(s),
                    protocol::clip(&self.loaded[i].id),
                    crate::limits::show(dwell_us),
                    crate::limits::show(dwell_us / 2e6)
                ))
                .into());
            }
        }
        let on_s = |s| crate::limits::duration_s("on_s", s, MAX_PHASE_S);
        let on = req.on_s.map(on_s).transpose()?;
        let off = req.off_s.map_or(Ok(Duration::ZERO), |s| {
            crate::limits::pause_s("off_s", s, MAX_PHASE_S)
        })?;
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
        let id = protocol::clip(&self.loaded[i].id);
        if !untracked && !self.finger_source {
            return Err(InputError::new(format!(
                "stimulus `{id}` is tracked, but this session has no finger source: it would stay muted; present it with \"gate\":\"untracked\", or give the session a finger source"
            ))
            .into());
        }
        if let Stage::Switching { to, .. } = &self.stage
            && !self.dev.replaces_queued()
        {
            return Err(anyhow::anyhow!(
                "stimulus `{id}` cannot replace `{}` before its switch: this device cannot take a queued switch back; present it once `{}` plays",
                protocol::clip(&self.loaded[to.entry].id),
                protocol::clip(&self.loaded[to.entry].id),
            ));
        }
        self.touch(i);
        let slot = self.ensure_loaded(i)?;
        let p = Presentation {
            entry: i,
            slot,
            untracked,
            on,
            off,
            repeat,
            rep: 1,
            owner,
        };
        let context = |e: anyhow::Error| e.context(format!("presenting `{id}`"));
        match std::mem::take(&mut self.stage) {
            Stage::Idle => {
                if let Err(e) = self.start(slot, untracked, on) {
                    return Err(context(e));
                }
                let at = self.clock.now_us();
                self.begin_on(p, OnPhase::new(at, now));
            }
            Stage::Off(old, until) => {
                if let Err(e) = self.start(slot, untracked, on) {
                    self.stage = Stage::Off(old, until);
                    return Err(context(e));
                }
                let at = self.clock.now_us();
                self.done_at(at, &old);
                self.begin_on(p, OnPhase::new(at, now));
            }
            Stage::On(old, phase) => self.over(old, phase, p, None, now).map_err(context)?,
            Stage::Switching { from, on, to, .. } => {
                self.over(from, on, p, Some(to), now).map_err(context)?
            }
        }
        Ok(())
    }

    /// Stops whatever plays or waits: the array is silent afterwards.
    pub fn stop(&mut self, reason: OffsetReason) -> anyhow::Result<()> {
        match std::mem::take(&mut self.stage) {
            Stage::Idle => {
                self.dev
                    .stop()
                    .map_err(|e| e.context("stopping the device"))?;
            }
            Stage::Off(p, _) => {
                self.dev
                    .stop()
                    .map_err(|e| e.context("stopping the device"))?;
                let now = self.clock.now_us();
                self.done_at(now, &p);
            }
            Stage::On(p, mut on) => {
                let device = self.stop_device(p.slot)?;
                let now = self.clock.now_us();
                self.offset_at(now, &p, &mut on, reason, device);
                self.done_at(now, &p);
            }
            Stage::Switching {
                from, mut on, to, ..
            } => {
                let device = self.stop_device(from.slot)?;
                let now = self.clock.now_us();
                self.emit(EventKind::Cancelled {
                    stimulus: self.loaded[to.entry].id.clone(),
                });
                self.offset_at(now, &from, &mut on, reason, device);
                self.done_at(now, &from);
            }
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
            .send(self.dev.as_mut(), pos_um, self.clock.now_us())
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

    /// The device's missed deadlines and lease expiries so far (from its
    /// status): a study records their change over each trial.
    pub fn device_counters(&mut self) -> anyhow::Result<(u32, u32)> {
        let s = self
            .dev
            .status()
            .map_err(|e| e.context("reading the device status"))?;
        Ok((s.missed_deadlines, s.lease_expiries))
    }

    /// What the `status` command answers.
    pub fn status(&mut self) -> anyhow::Result<protocol::StatusReply> {
        let s = self
            .dev
            .status()
            .map_err(|e| e.context("reading the device status"))?;
        let p = self.stage.newest();
        Ok(protocol::StatusReply {
            stimulus: p.map(|p| self.loaded[p.entry].id.clone()),
            phase: self.stage.name(),
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

    /// Handles one command from `client`; `Quit`, `Subscribe` and `Auth`
    /// are the caller's (they answer ok here).
    pub fn handle(&mut self, cmd: &Command, client: Owner) -> Reply {
        let r: anyhow::Result<Reply> = match cmd {
            Command::Present(p) => self.present_for(p, client).map(|()| Reply::ok("present")),
            Command::Prepare { stimulus } => self
                .prepare(stimulus)
                .map(|slot| Reply::ok("prepare").with("slot", slot)),
            Command::Stop => self.stop(OffsetReason::Stop).map(|()| Reply::ok("stop")),
            Command::Status => self.status().map(|s| Reply::ok("status").with("status", s)),
            Command::Library => Ok(Reply::ok("library").with("stimuli", self.library())),
            Command::Subscribe | Command::Quit | Command::Auth { .. } => Ok(Reply::ok(cmd.name())),
        };
        r.unwrap_or_else(|e| {
            let msg = crate::error::one_line(&e);
            self.refused(cmd.name(), &msg);
            Reply::error(cmd.name(), msg)
        })
    }

    /// Emits `refused` for `command` (`""`: the line was not a command).
    pub fn refused(&mut self, command: &str, error: &str) {
        self.emit(EventKind::Refused {
            command: command.into(),
            error: error.into(),
        });
    }

    /// Ends the session: stops what plays (offset `reason`) and leaves the
    /// array silent (the backend's drop); returns the last events.
    pub fn close(self, reason: OffsetReason) -> Vec<Event> {
        self.close_counted(reason, None)
    }

    /// [`close`](Self::close), its `closed` event with what the finger
    /// source's gate counted.
    pub fn close_counted(
        mut self,
        reason: OffsetReason,
        finger: Option<crate::sense::stream::intake::GateCounts>,
    ) -> Vec<Event> {
        if let Err(e) = self.stop(reason) {
            self.refused("stop", &crate::error::one_line(&e));
        }
        self.emit(EventKind::Closed { reason, finger });
        let events = self.drain_events();
        drop(self.dev);
        events
    }
}

#[cfg(test)]
mod tests;
