//! [`Autd3Backend`]: an AUTD3 rig as a [`Backend`].
//!
//! The decisions are the firmware's own: an `lm_fw_core` [`Player`] on a
//! 1 MHz clock (the host's µs) says which slot plays, which is queued, when
//! a queued one takes over (the playing slot's cycle end, counted from its
//! start), when a play's steps are done and what `Status` counts; a
//! [`Policy`] says when the array may sound and where it steers. This file
//! only makes the devices follow them (`Autd3Backend::sync`, run on every
//! call): the STM segment the player's slot sits in plays, the output
//! ([`super::output`]) sounds at the slot's intensity while the policy
//! allows and its lease is renewed, and the correction follows the slot.
//!
//! Slots are the two STM segments. `upload` writes a GainSTM of the planned
//! phases (phase-only packing, full intensity) into a segment, looping
//! forever, without switching to it, and reads it back where it can: a
//! mismatch fails the upload. A slot starts with an `Immediate` switch
//! (autd3 firmware allows it into an endless loop only), so a play from
//! silence sounds at once wherever the slot sits; a queued slot is switched
//! to the same way when the player's cycle end comes, on the first call at
//! or after it, which is why the host keeps ticking while a slot is queued
//! (steps that sound late are counted in `missed_deadlines`). The devices'
//! STM index runs on their synchronised clock, so a slot starts at some
//! point of its cycle: a phase offset the player's count does not see.

use anyhow::{Context, bail};
use autd3::Controller;
use autd3::core::ethercat::DcSysTime;
use autd3::core::firmware::transition_mode::{Immediate, Later};
use autd3::core::geometry::{Device, Transducer};
use autd3::core::link::Link;
use autd3::gain::Custom;
use autd3::prelude::{
    Drive, GainSTM, GainSTMMode, GainSTMOption, Intensity, Null, Phase, PhaseCorrection,
    SamplingConfig, Segment, SwapSegmentGainSTM, WithSegment,
};
use lm_fw_core::correction::{compute_offsets, sound_speed_m_s};
use lm_fw_core::player::{PlayState, Player, Timing};
use lm_fw_core::policy::Policy;
use lm_fw_core::status::Mechanics;
use std::num::NonZeroU16;
use std::time::Duration;

use super::emulator::EmulatorHandle;
use super::output::Output;
use super::port::Autd3Port;
use crate::clock::Clock;
use crate::device::backend::{
    Backend, BackendError, BackendInfo, CentroidOutcome, Kind, Result as BResult, Transfer,
    UploadReport, check_shape, free_slot,
};
use crate::error::InputError;
use crate::plan::array::AUTD3_TRANSDUCERS;
use crate::plan::grid as timing;
use crate::plan::sequence::Plan;
use lm_proto::{Centroid, MuteReason, NackCode, PlayAt, Status, UploadHeader};

/// The player's clock: the host's microseconds.
pub(super) const TIMER_HZ: u32 = 1_000_000;

/// What a segment holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Slot {
    steps: usize,
    divide: u16,
    header: UploadHeader,
    /// The plan's amplitude modulation, played through the output.
    am: Option<crate::plan::modulation::Am>,
}

impl Slot {
    fn dwell_us(&self) -> u64 {
        u64::from(timing::dwell_us(u32::from(self.divide)))
    }

    /// The player's view: steps and period on its µs clock.
    fn timing(&self) -> Timing {
        Timing {
            // ≤ GainSTM's 1024 patterns, checked at upload.
            steps: self.steps as u16,
            period_us: (self.steps as u64 * self.dwell_us()).min(u64::from(u32::MAX)) as u32,
        }
    }
}

/// An AUTD3 rig driven through the autd3 crates.
pub struct Autd3Backend {
    pub(super) ctl: Controller<Box<dyn Link>>,
    pub(super) port: Autd3Port,
    pub(super) emulator: Option<EmulatorHandle>,
    pub(super) clock: Clock,
    /// When the backend opened the rig (µs of `clock`): its `Status`
    /// counts `uptime_ms` from here, as a board counts from reset.
    pub(super) opened_us: u64,
    pub(super) positions: Vec<u8>,
    pub(super) slots: [Option<Slot>; 2],
    /// The STM segment the devices play, as last switched to (`None`: none
    /// yet, or its data was rewritten since, so the next start switches
    /// again and the devices take its new length).
    pub(super) stm_segment: Option<u8>,
    /// The firmware's player: the slot that plays, the queued one, limits
    /// and counters.
    pub(super) player: Player,
    /// The firmware's safety rules (session, gate, untracked, work volume).
    pub(super) policy: Policy,
    /// The modulation: level and lease.
    pub(super) output: Output,
    pub(super) offsets: Vec<u8>,
    /// Slot the offsets were computed for.
    pub(super) offsets_for: Option<u8>,
    /// Steps that sounded past a stop or a switch because the host made it
    /// late (`Status::missed_deadlines`).
    pub(super) late_steps: u32,
    pub(super) closed: bool,
}

fn segment(slot: u8) -> Segment {
    if slot == 0 { Segment::S0 } else { Segment::S1 }
}

impl Autd3Backend {
    /// autd3's geometry of the rig (same device order as the scene).
    pub fn geometry(&self) -> &autd3::core::geometry::Geometry {
        self.ctl.geometry()
    }

    /// The emulated devices, when the link is the emulator.
    pub fn emulator(&self) -> Option<&EmulatorHandle> {
        self.emulator.as_ref()
    }

    /// How long the array sounds without the host (see [`super::output`]).
    pub fn lease(&self) -> Duration {
        self.output.lease()
    }

    /// Changes the lease (from the next renewal on); out of range is bad
    /// input.
    pub fn set_lease(&mut self, lease: Duration) -> Result<(), InputError> {
        self.output.set_lease(lease)
    }

    fn now_us(&self) -> u64 {
        self.clock.now().as_micros() as u64
    }

    /// The devices' clock: the emulator runs on ours; a real rig's
    /// EtherCAT clock is the system time since 2000-01-01 UTC (autd3's
    /// `DcSysTime::now`, which needs a feature this build leaves out). A
    /// reading that outlives the borrow of `self`, so a switch that missed
    /// its time can read it again.
    fn dc_clock(&self) -> impl Fn() -> DcSysTime + 'static {
        /// 1970-01-01 to 2000-01-01, s.
        const EPOCH_2000_S: u64 = 946_684_800;
        let emulated = self.emulator.is_some().then(|| self.clock.clone());
        move || match &emulated {
            Some(clock) => super::emulator::sys_time(clock.now()),
            None => {
                let unix = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .unwrap_or_default();
                let since_2000 = unix.saturating_sub(Duration::from_secs(EPOCH_2000_S));
                DcSysTime::new(since_2000.as_nanos() as u64)
            }
        }
    }

    pub(super) fn send_offsets(&mut self) -> anyhow::Result<()> {
        self.switch_and_correct(None, true)
    }

    /// Sends a switch to `slot`'s segment (`None`: none) and the offsets
    /// (if `offsets`) in one frame: a start from silence takes one frame
    /// for them and one for the output, whatever changed.
    fn switch_and_correct(&mut self, slot: Option<u8>, offsets: bool) -> anyhow::Result<()> {
        let off = &self.offsets;
        let correction = || {
            PhaseCorrection::new(|dev: &Device| {
                let base = dev.idx() * AUTD3_TRANSDUCERS;
                move |tr: &Transducer| Phase(off[base + tr.idx()])
            })
        };
        let sent = match (slot, offsets) {
            (Some(s), true) => self
                .ctl
                .send((SwapSegmentGainSTM(segment(s), Immediate), correction())),
            (Some(s), false) => self.ctl.send(SwapSegmentGainSTM(segment(s), Immediate)),
            (None, true) => self.ctl.send(correction()),
            (None, false) => return Ok(()),
        };
        match slot {
            Some(s) => sent.with_context(|| format!("switching to slot {s}"))?,
            None => sent.context("sending the phase correction")?,
        }
        if slot.is_some() {
            self.stm_segment = slot;
        }
        Ok(())
    }

    /// The header of the slot the player holds (playing or last played).
    fn playing_header(&self) -> Option<UploadHeader> {
        let s = self.player.slot()?;
        self.slots[usize::from(s)].map(|s| s.header)
    }

    /// Recomputes the offsets for the player's slot, as far as the policy
    /// lets it steer (a slot taking over re-checks the last centroid
    /// against its own work volume), and sends them if they changed.
    fn update_correction(&mut self) -> anyhow::Result<()> {
        let changed = self.recompute_offsets();
        self.switch_and_correct(None, changed)
    }

    /// [`Self::update_correction`] without sending: whether they changed.
    fn recompute_offsets(&mut self) -> bool {
        let mut next = vec![0u8; self.offsets.len()];
        if let Some(h) = self.playing_header()
            && let Some(c) = self.policy.steer_for(&h)
        {
            compute_offsets(
                &self.positions,
                h.center_um,
                c,
                sound_speed_m_s(h.sound_speed_mm_s),
                &mut next,
            );
        }
        self.offsets_for = self.player.slot();
        if next == self.offsets {
            return false;
        }
        self.offsets = next;
        true
    }

    /// Steps held by `slot` (`None`: empty or half-written).
    pub fn slot_steps(&self, slot: u8) -> Option<usize> {
        self.slots
            .get(usize::from(slot))
            .copied()
            .flatten()
            .map(|s| s.steps)
    }

    /// Why the output is silent now, by the firmware's rules.
    pub fn mute_reason(&self) -> MuteReason {
        self.policy.mute_reason(self.now_us())
    }

    /// Makes the devices follow the player and the policy at the host's
    /// now: a play whose steps are done stops, a queued slot whose time has
    /// come is switched to, a lapsed lease ends the play, and the output
    /// sounds exactly while the policy allows (its lease renewed).
    pub(super) fn sync(&mut self) -> anyhow::Result<()> {
        let now = self.now_us();
        let before = self.player.slot();
        if let Some(d) = self.player.tick(now)
            && d.stop
        {
            // Its steps have played: stopped as `Stop`; the steps that
            // sounded after the boundary are the host's lateness.
            self.policy.stop();
            let dwell = self.slots[usize::from(d.slot)].map_or(1, |s| s.dwell_us().max(1));
            self.add_late(now.saturating_sub(d.at) / dwell);
        }
        if self.output.lapsed(now) {
            // Nobody renewed the lease: the array fell silent on its own,
            // and the play is over, as when the LM firmware's lease ends.
            self.player.stop();
            self.policy.stop();
        }
        let switch = self
            .player
            .slot()
            .filter(|&s| self.player.state() == PlayState::Playing && Some(s) != self.stm_segment);
        if let Some(slot) = switch
            && before.is_some_and(|b| b != slot)
        {
            // A takeover at the cycle end, switched now: the steps the new
            // slot has counted played on the old one.
            let st = (self.player.cycles(), self.player.step());
            let n = self.slots[usize::from(slot)].map_or(0, |s| s.steps as u64);
            self.add_late(u64::from(st.0) * n + u64::from(st.1));
        }
        let offsets = self.player.slot() != self.offsets_for && self.recompute_offsets();
        self.switch_and_correct(switch, offsets)?;
        let playing = self.player.slot().and_then(|s| self.slots[usize::from(s)]);
        let (level, am) = match playing {
            Some(s) if self.player.state() == PlayState::Playing && self.policy.sounding(now) => {
                (s.header.intensity, s.am)
            }
            _ => (0, None),
        };
        let dc = self.dc_clock();
        self.output.set(&mut self.ctl, level, am, now, &dc)
    }

    fn add_late(&mut self, steps: u64) {
        self.late_steps = self
            .late_steps
            .saturating_add(steps.min(u64::from(u32::MAX)) as u32);
    }

    fn resident(&self, slot: u8) -> anyhow::Result<Slot> {
        if slot > 1 {
            return Err(InputError::new(format!("AUTD3 has slots 0 and 1, got {slot}")).into());
        }
        match self.slots[usize::from(slot)] {
            Some(s) => Ok(s),
            // Refused as the firmware refuses a `Play` of a slot without
            // a committed sequence (`NotCommitted`), so every backend
            // answers it alike (the conformance table checks it).
            None => Err(BackendError::refused(
                NackCode::NotCommitted,
                format!(
                    "slot {slot} of {} is empty: an AUTD3 holds a sequence only while lmhost holds the link; \
                     `lmhost upload --port {}` uploads and plays",
                    self.port, self.port
                ),
            )
            .into()),
        }
    }

    /// The firmware's `Play`: at once (`Immediate`, or from silence) or
    /// queued for the playing slot's cycle end, for `steps` steps (0 =
    /// until `stop`).
    fn request(&mut self, slot: u8, at: PlayAt, untracked: bool, steps: u32) -> anyhow::Result<()> {
        let s = self.resident(slot)?;
        self.sync()?;
        let now = self.now_us();
        let ok = match at {
            PlayAt::Immediate => self.player.start(slot, s.timing(), now, steps),
            _ => self.player.queue(slot, s.timing(), now, steps),
        };
        if !ok {
            bail!("slot {slot}'s timing cannot be played");
        }
        let new_session = self.policy.session() != lm_fw_core::policy::Session::Playing;
        self.policy.play(untracked);
        if new_session {
            // Fresh tracking: no offsets until a centroid says where.
            self.offsets_for = None;
        }
        self.sync()
    }

    /// Phases read back from the emulated FPGA that differ from `phases`
    /// (step-major) in `slot`, plus intensities that are not full; `None`
    /// on a real link.
    pub fn readback_mismatches(&self, slot: u8, phases: &[u8]) -> Option<u64> {
        let emu = self.emulator.as_ref()?;
        let seg = segment(slot);
        let t = self.ctl.num_transducers();
        let steps = phases.len() / t.max(1);
        Some(emu.with_cpus(|cpus| {
            let mut bad = 0u64;
            for cpu in cpus {
                let fpga = cpu.fpga();
                if !fpga.is_stm_gain_mode(seg) || fpga.stm_cycle(seg) != steps {
                    return (steps * t) as u64;
                }
                let corr = fpga.phase_correction();
                let base = cpu.idx() * AUTD3_TRANSDUCERS;
                for j in 0..steps {
                    for (i, d) in fpga.drives_at(seg, j).iter().enumerate() {
                        let raw = d.phase.0.wrapping_sub(corr[i].0);
                        if raw != phases[j * t + base + i] || d.intensity != Intensity::MAX {
                            bad += 1;
                        }
                    }
                }
            }
            bad
        }))
    }

    /// Leaves the array silent for good: mute, then a null gain in the
    /// playing segment (on drop; `stop` only mutes).
    fn silence(&mut self) -> anyhow::Result<()> {
        self.player.stop();
        self.policy.stop();
        self.output.mute(&mut self.ctl)?;
        let seg = self.stm_segment.unwrap_or(0);
        self.ctl
            .send(WithSegment::new(Null::new(), segment(seg), Immediate))
            .context("sending the null gain")?;
        self.slots[usize::from(seg)] = None;
        Ok(())
    }

    fn status_now(&self) -> Status {
        let m = Mechanics {
            missed_deadlines: self.late_steps,
            lease_ms: u16::try_from(self.lease().as_millis()).unwrap_or(u16::MAX),
            uptime_ms: lm_fw_core::status::uptime_ms(
                self.now_us().saturating_sub(self.opened_us),
                TIMER_HZ,
            ),
            ..Mechanics::default()
        };
        let h = self.playing_header();
        lm_fw_core::status::status(&self.player, &self.policy, h.as_ref(), m, self.now_us())
    }

    /// Writes `plan`'s phases into `slot`'s segment (looping forever, no
    /// switch) and reads them back; a mismatch leaves the slot empty.
    fn write_segment(&mut self, plan: &Plan, slot: u8, divide: u16) -> anyhow::Result<u64> {
        let t = self.ctl.num_transducers();
        let steps = usize::from(plan.sequence.header.steps);
        let phases = &plan.sequence.phases;
        let gains: Vec<_> = (0..steps)
            .map(|j| {
                Custom::new(move |dev: &Device| {
                    let base = j * t + dev.idx() * AUTD3_TRANSDUCERS;
                    move |tr: &Transducer| Drive {
                        phase: Phase(phases[base + tr.idx()]),
                        intensity: Intensity::MAX,
                    }
                })
            })
            .collect();
        let stm = GainSTM::new(
            gains,
            SamplingConfig::new(NonZeroU16::new(divide).context("zero divide")?),
            GainSTMOption {
                mode: GainSTMMode::PhaseFull,
            },
        );
        let frames0 = self.emulator.as_ref().map_or(0, |e| e.frames());
        self.ctl
            .send(WithSegment::new(stm, segment(slot), Later))
            .with_context(|| format!("uploading to slot {slot} on {}", self.port))?;
        Ok(self.emulator.as_ref().map_or(0, |e| e.frames()) - frames0)
    }
}

impl Backend for Autd3Backend {
    fn describe(&self) -> String {
        self.port.to_string()
    }

    fn needs_host(&self) -> bool {
        true
    }

    fn info(&mut self) -> BResult<BackendInfo> {
        let firmware = self
            .ctl
            .firmware_version()
            .context("reading the firmware versions")?
            .iter()
            .map(|v| v.to_string())
            .collect();
        Ok(BackendInfo {
            backend: "autd3".into(),
            port: self.port.to_string(),
            devices: self.ctl.num_devices(),
            transducers: self.ctl.num_transducers(),
            slots: 2,
            firmware,
            kind: Kind::Autd3 {
                dwell_grid_us: timing::SAMPLING_PERIOD_US,
            },
        })
    }

    fn counters_source(&self) -> &'static str {
        "host clock"
    }

    fn status(&mut self) -> BResult<Status> {
        self.sync()?;
        Ok(self.status_now())
    }

    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> BResult<UploadReport> {
        check_shape(plan)?;
        let h = &plan.sequence.header;
        let t = self.ctl.num_transducers();
        let steps = usize::from(h.steps);
        if usize::from(h.transducers) != t || plan.sequence.phases.len() != steps * t {
            return Err(InputError::new(format!(
                "the plan has {} transducers per step; this AUTD3 rig has {t}",
                h.transducers
            ))
            .into());
        }
        if !(timing::MIN_PATTERNS..=timing::MAX_PATTERNS).contains(&steps) {
            return Err(InputError::new(format!(
                "AUTD3 GainSTM holds {}..={} patterns, the plan has {steps}",
                timing::MIN_PATTERNS,
                timing::MAX_PATTERNS
            ))
            .into());
        }
        let divide = timing::divide_for_dwell(plan.trajectory.dwell_s)
            .filter(|&d| u32::from(d) >= timing::SILENCER_MIN_DIVIDE)
            .ok_or_else(|| {
                InputError::new(format!(
                    "dwell {:.3} µs is not a multiple of 25 µs ≥ 1000 µs; plan for the AUTD3 port so the planner picks the grid",
                    plan.sequence.dwell_us()
                ))
            })?;
        self.sync()?;
        let slot = match slot {
            Some(s) if s > 1 => {
                return Err(InputError::new(format!("AUTD3 has slots 0 and 1, got {s}")).into());
            }
            Some(s) if self.player.busy(s) => {
                return Err(BackendError::refused(
                    NackCode::SlotPlaying,
                    format!("slot {s} is playing; upload into the idle slot"),
                ));
            }
            Some(s) => s,
            None => free_slot(2, &self.status_now()).ok_or_else(|| {
                BackendError::refused(
                    NackCode::SlotPlaying,
                    "no free slot: one plays and the other is queued",
                )
            })?,
        };
        // An upload sends nothing else for a while: start it on a fresh lease.
        let (now, dc) = (self.now_us(), self.dc_clock());
        self.output.refresh(&mut self.ctl, now, &dc)?;
        // The segment is being overwritten: until it arrives whole it is
        // empty, and a start switches to it anew.
        self.slots[usize::from(slot)] = None;
        if self.stm_segment == Some(slot) {
            self.stm_segment = None;
        }
        let frames = self.write_segment(plan, slot, divide)?;
        let readback = self.readback_mismatches(slot, &plan.sequence.phases);
        if let Some(n) = readback.filter(|&n| n > 0) {
            return Err(BackendError::failed(format!(
                "{} holds {n} phases in slot {slot} that differ from the plan; the slot is left empty",
                self.port
            )));
        }
        self.slots[usize::from(slot)] = Some(Slot {
            steps,
            divide,
            header: *h,
            am: plan.am,
        });
        let dwell_us = f64::from(timing::dwell_us(u32::from(divide)));
        Ok(UploadReport {
            slot,
            steps,
            transducers: t,
            dwell_us,
            freq_hz: 1e6 / (steps as f64 * dwell_us),
            transfer: Transfer::Autd3 {
                frames,
                readback_mismatches: readback,
            },
        })
    }

    /// As the firmware: from silence (or `Immediate`) at once, sounding
    /// within one frame; while another slot plays, queued for its cycle end.
    fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> BResult<()> {
        Ok(self.request(slot, at, untracked, 0)?)
    }

    /// Timed by the firmware's player on the host's clock: `tick`, `status`
    /// and `centroid` stop it once its steps have played (late by as much
    /// as those calls are, counted in `missed_deadlines`).
    fn play_for(&mut self, slot: u8, untracked: bool, steps: u32) -> BResult<()> {
        Ok(self.request(slot, PlayAt::NextCycle, untracked, steps)?)
    }

    /// Mutes at once, as the firmware's `Stop` (a queued slot is dropped);
    /// the segments stay, so a later `play` resumes without an upload
    /// (drop writes the null gain).
    fn stop(&mut self) -> BResult<()> {
        self.sync()?;
        self.player.stop();
        self.policy.stop();
        Ok(self.sync()?)
    }

    fn centroid(&mut self, c: &Centroid) -> BResult<CentroidOutcome> {
        // A play whose steps have played is stopped before the update.
        self.sync()?;
        let header = self.playing_header();
        let last = self.policy.last_seq();
        let outcome = match self.policy.centroid(c, header.as_ref(), self.now_us()) {
            Ok(Some(_)) => {
                self.update_correction()?;
                CentroidOutcome::Applied
            }
            Ok(None) => CentroidOutcome::Applied,
            // Never steered outside the work volume: muted until a present
            // centroid inside it arrives.
            Err(NackCode::OutOfRange) => CentroidOutcome::OutOfRange,
            Err(code) => {
                return Err(BackendError::refused(
                    code,
                    format!("centroid {} is not newer than {last}; ignored", c.seq),
                ));
            }
        };
        self.sync()?;
        Ok(outcome)
    }

    fn tick(&mut self) -> BResult<()> {
        Ok(self.sync()?)
    }

    fn set_lease(&mut self, lease: Duration) -> BResult<()> {
        Ok(Autd3Backend::set_lease(self, lease)?)
    }
}

impl Drop for Autd3Backend {
    /// Leaves the array silent: mute, null gain, close the link.
    fn drop(&mut self) {
        if self.closed {
            return;
        }
        self.closed = true;
        let _ = self.silence();
    }
}
