//! [`Autd3Backend`]: an AUTD3 rig as a [`Backend`].
//!
//! Slots are the two STM segments. `upload` writes a GainSTM of the planned
//! phases (phase-only packing, full intensity) into a segment without
//! switching to it; `play` switches with `SyncIdx`, i.e. when the new
//! segment's index wraps to 0 on the devices' shared clock, which is the end
//! of the playing loop when both have the same period (autd3 firmware only
//! allows `SyncIdx` for a finite loop count, so a segment is written with the
//! largest count and set to loop forever, `Immediate` on the same segment,
//! once the switch is seen). A failed upload leaves the playing segment alone.

use std::num::NonZeroU16;
use std::time::Duration;

use anyhow::{Context, bail};
use autd3::Controller;
use autd3::core::firmware::transition_mode::{Immediate, Later, SyncIdx};
use autd3::core::geometry::{Device, Transducer};
use autd3::core::link::Link;
use autd3::gain::Custom;
use autd3::prelude::{
    Drive, GainSTM, GainSTMMode, GainSTMOption, Intensity, Null, ParallelMode, Phase,
    PhaseCorrection, ReadsFPGAState, SamplingConfig, Segment, SenderOption, Silencer, Static,
    SwapSegmentGainSTM, WithFiniteLoop, WithSegment,
};
use lm_fw_core::policy::{Policy, Session};

use super::emulator::{EmulatorHandle, EmulatorLink};
use super::port::Autd3Port;
use super::{correction, geometry, safety};
use crate::clock::Clock;
use crate::device::backend::{
    Backend, BackendError, BackendInfo, CentroidOutcome, Kind, Result as BResult, Transfer,
    UploadReport,
};
use crate::error::InputError;
use crate::plan::array::AUTD3_TRANSDUCERS;
use crate::plan::grid as timing;
use crate::plan::scene::Scene;
use crate::plan::sequence::Plan;
use lm_proto::{Centroid, MuteReason, NackCode, PlayAt, Status, UploadHeader};

/// What a segment holds.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Slot {
    steps: usize,
    divide: u16,
    header: UploadHeader,
}

/// An AUTD3 rig driven through the autd3 crates.
pub struct Autd3Backend {
    ctl: Controller<Box<dyn Link>>,
    port: Autd3Port,
    emulator: Option<EmulatorHandle>,
    clock: Clock,
    positions: Vec<u8>,
    slots: [Option<Slot>; 2],
    /// Slot whose segment plays (or starts from silence at its next loop
    /// boundary, see `rearm`).
    playing: Option<u8>,
    /// Slot that takes over from `playing` at the end of its loop (the
    /// firmware's queued slot).
    queued: Option<u8>,
    /// Segment switched to with `SyncIdx`, still to be set to loop forever.
    rearm: Option<u8>,
    /// When the playing slot's loop began on the devices' clock (µs), and
    /// the time it had played when stopped: the status's step and cycles.
    started_us: Option<u64>,
    played_us: Option<u64>,
    /// Steps the playing slot plays before the host stops it (0 = until
    /// `stop`), counted from `started_us`; and the queued slot's, counted
    /// from its takeover.
    limit: u32,
    queued_limit: u32,
    /// The firmware's safety rules (session, gate, untracked, work volume).
    policy: Policy,
    /// Modulation intensity last sent.
    output: u8,
    offsets: Vec<u8>,
    closed: bool,
}

fn segment(slot: u8) -> Segment {
    if slot == 0 { Segment::S0 } else { Segment::S1 }
}

/// The emulator answers at once, so frames go back to back; real links keep
/// autd3's pacing (one frame per 1 ms, ack polled every 1 ms).
fn sender_option(emulated: bool) -> SenderOption {
    if emulated {
        SenderOption {
            send_interval: None,
            receive_interval: None,
            timeout: Some(Duration::from_millis(200)),
            parallel: ParallelMode::Off,
        }
    } else {
        SenderOption::default()
    }
}

impl Autd3Backend {
    /// Opens `port` for `scene`. The emulator gets as many devices as the
    /// scene; a real link must report the same number.
    pub fn open(port: &Autd3Port, scene: &Scene) -> anyhow::Result<Self> {
        match port {
            Autd3Port::Emulator => Ok(Self::open_emulator(scene, Clock::real(), None)?.0),
            Autd3Port::EmulatorRig { devices } => {
                Ok(Self::open_emulator(scene, Clock::real(), Some(*devices))?.0)
            }
            Autd3Port::Remote { host, port: tcp } => {
                use std::net::ToSocketAddrs;
                let addr = (host.as_str(), *tcp)
                    .to_socket_addrs()
                    .with_context(|| format!("resolving {port}"))?
                    .next()
                    .with_context(|| format!("{port}: the host has no address"))?;
                let link = autd3_link_remote::Remote::new(
                    addr,
                    autd3_link_remote::RemoteOption {
                        timeout: Some(Duration::from_secs(2)),
                    },
                );
                Self::open_link(Box::new(link), port.clone(), scene, Clock::real(), None)
            }
            #[cfg(feature = "autd3-soem")]
            Autd3Port::Soem { ifname } => {
                super::ethercat::preflight(&port.to_string(), ifname.as_deref())?;
                let link = autd3_link_soem::SOEM::new(
                    |slave: u16, status: autd3_link_soem::Status| {
                        crate::errln!("lmhost: AUTD3 device {slave}: EtherCAT {status:?}");
                    },
                    autd3_link_soem::SOEMOption {
                        ifname: ifname.clone(),
                        ..Default::default()
                    },
                );
                Self::open_link(Box::new(link), port.clone(), scene, Clock::real(), None)
            }
            #[cfg(feature = "autd3-ethercrab")]
            Autd3Port::EtherCrab { ifname } => {
                super::ethercat::preflight(&port.to_string(), ifname.as_deref())?;
                let open = |ifname: &str| {
                    let link = autd3_link_ethercrab::EtherCrab::new(
                        |dev: usize, status: autd3_link_ethercrab::Status| {
                            crate::errln!("lmhost: AUTD3 device {dev}: EtherCAT {status:?}");
                        },
                        autd3_link_ethercrab::EtherCrabOption {
                            ifname: Some(ifname.to_string()),
                            ..Default::default()
                        },
                    );
                    Self::open_link(Box::new(link), port.clone(), scene, Clock::real(), None)
                };
                match ifname {
                    Some(i) => open(i),
                    // ethercrab's own search walks libpcap's device list,
                    // whose pseudo-devices (names of 16+ bytes such as
                    // `bluetooth-monitor`) panic it: walk the kernel's
                    // network interfaces instead, first answer wins.
                    None => {
                        let tried =
                            super::ethercat::candidates(std::path::Path::new("/sys/class/net"));
                        for i in &tried {
                            if let Ok(me) = open(i) {
                                return Ok(me);
                            }
                        }
                        bail!(
                            "opening {port}: no AUTD3 device answered on any interface (tried {})",
                            if tried.is_empty() {
                                "none".to_string()
                            } else {
                                tried.join(", ")
                            }
                        )
                    }
                }
            }
            #[allow(unreachable_patterns)]
            other => bail!(
                "{other}: this lmhost was built without the `{}` feature (EtherCAT links are opt-in: they need system libraries and raw-socket privileges)",
                other.feature().unwrap_or("?")
            ),
        }
    }

    /// Opens an emulated rig of `rig_devices` boards (`None`: the scene's
    /// count) on `clock`, returning the handle to its emulated devices.
    pub fn open_emulator(
        scene: &Scene,
        clock: Clock,
        rig_devices: Option<usize>,
    ) -> anyhow::Result<(Self, EmulatorHandle)> {
        if let Some(n) = rig_devices.filter(|&n| n != scene.devices.len()) {
            return Err(InputError::new(format!(
                "scene `{}` has {} devices but the AUTD3 rig has {n}",
                scene.name,
                scene.devices.len()
            ))
            .into());
        }
        let (link, handle) = EmulatorLink::new(clock.clone());
        let me = Self::open_link(
            Box::new(link),
            Autd3Port::Emulator,
            scene,
            clock,
            Some(handle.clone()),
        )?;
        Ok((me, handle))
    }

    /// Opens `link` (already built for `port`) for `scene`.
    pub fn open_link(
        link: Box<dyn Link>,
        port: Autd3Port,
        scene: &Scene,
        clock: Clock,
        emulator: Option<EmulatorHandle>,
    ) -> anyhow::Result<Self> {
        geometry::check_no_overlap(scene)?;
        let positions = correction::packed_positions_um(scene)?;
        let mut ctl = Controller::open_with(
            geometry::devices(scene),
            link,
            sender_option(emulator.is_some()),
            autd3::core::sleep::StdSleeper,
        )
        .map_err(|e| {
            if emulator.is_none() && port.feature().is_some() {
                // EtherCAT: the link's bare "timeout" made specific.
                anyhow::anyhow!(super::ethercat::explain(&format!("opening {port}"), &e))
            } else {
                anyhow::Error::new(e).context(format!("opening {port}"))
            }
        })?;
        // autd3 lengths are mm, so its sound speed is mm/s.
        ctl.environment.sound_speed = scene.sound_speed_m_s as f32 * 1000.0;
        geometry::check_positions(scene, ctl.geometry())?;
        let n = ctl.num_transducers();
        let mut me = Self {
            ctl,
            port,
            emulator,
            clock,
            positions,
            slots: [None; 2],
            playing: None,
            queued: None,
            rearm: None,
            started_us: None,
            played_us: None,
            limit: 0,
            queued_limit: 0,
            policy: safety::policy(),
            output: safety::FULL,
            offsets: vec![0; n],
            closed: false,
        };
        me.ctl.send(Silencer::default())?;
        me.ctl.send(ReadsFPGAState::new(|_| true))?;
        me.set_output(safety::MUTED)?;
        me.send_offsets()?;
        Ok(me)
    }

    /// autd3's geometry of the rig (same device order as the scene).
    pub fn geometry(&self) -> &autd3::core::geometry::Geometry {
        self.ctl.geometry()
    }

    /// The emulated devices, when the link is the emulator.
    pub fn emulator(&self) -> Option<&EmulatorHandle> {
        self.emulator.as_ref()
    }

    fn now_us(&self) -> u64 {
        self.clock.now().as_micros() as u64
    }

    fn set_output(&mut self, intensity: u8) -> anyhow::Result<()> {
        self.ctl
            .send(Static::new(intensity))
            .context("setting the output level")?;
        self.output = intensity;
        Ok(())
    }

    fn send_offsets(&mut self) -> anyhow::Result<()> {
        let off = &self.offsets;
        self.ctl
            .send(PhaseCorrection::new(|dev: &Device| {
                let base = dev.idx() * AUTD3_TRANSDUCERS;
                move |tr: &Transducer| Phase(off[base + tr.idx()])
            }))
            .context("sending the phase correction")?;
        Ok(())
    }

    /// Recomputes the offsets for the slot that plays (or will) and sends them.
    fn update_correction(&mut self) -> anyhow::Result<()> {
        let slot = self.playing.and_then(|s| self.slots[usize::from(s)]);
        match slot.and_then(|s| Some((s, self.policy.steer_for(&s.header)?))) {
            Some((s, c)) => correction::offsets_into(
                &self.positions,
                s.header.center_um,
                c,
                s.header.sound_speed_mm_s,
                &mut self.offsets,
            ),
            None => self.offsets.fill(0),
        }
        self.send_offsets()
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

    /// Mutes or unmutes as the policy says; finishes a pending switch. A
    /// start from silence stays muted until the devices play the new
    /// segment (the old one must not sound meanwhile).
    fn apply_gate(&mut self) -> anyhow::Result<()> {
        self.finish_switch(false)?;
        self.stop_at_limit()?;
        let starting = self.rearm.is_some() && self.queued.is_none();
        let want = if self.policy.sounding(self.now_us()) && !starting {
            self.level()
        } else {
            safety::MUTED
        };
        if want != self.output {
            self.set_output(want)?;
        }
        Ok(())
    }

    /// Stops (as `stop`) once the devices' clock says the playing slot has
    /// played its `limit` steps; `played_us` keeps the real stop time, so
    /// the status shows how late the host was. A limit on the loop end
    /// with a slot queued waits for the takeover instead (as the firmware).
    fn stop_at_limit(&mut self) -> anyhow::Result<()> {
        let starting = self.rearm.is_some() && self.queued.is_none();
        if self.limit == 0 || starting || self.policy.session() != Session::Playing {
            return Ok(());
        }
        let (Some(t0), Some(s)) = (
            self.started_us,
            self.playing.and_then(|p| self.slots[usize::from(p)]),
        ) else {
            return Ok(());
        };
        let dwell = u64::from(timing::dwell_us(u32::from(s.divide))).max(1);
        let played = self.now_us().saturating_sub(t0) / dwell;
        let limit = u64::from(self.limit);
        let n = s.steps.max(1) as u64;
        let awaits_takeover = self.queued.is_some() && limit % n == 0 && played < limit + n;
        if played >= limit && !awaits_takeover {
            self.mute_and_stop()?;
        }
        Ok(())
    }

    /// The firmware's `Stop`: freezes the counters at now, drops a queued
    /// slot and the limits, mutes at once.
    fn mute_and_stop(&mut self) -> anyhow::Result<()> {
        if self.policy.session() == Session::Playing
            && let Some(t0) = self.started_us
        {
            self.played_us = Some(self.now_us().saturating_sub(t0));
        }
        self.policy.stop();
        // As the firmware's Stop, a queued slot is dropped (the devices may
        // still switch; a later play checks which segment plays).
        self.queued = None;
        self.limit = 0;
        self.queued_limit = 0;
        self.set_output(safety::MUTED)
    }

    /// The output level while sounding: the playing slot's intensity (its
    /// header's `intensity`, 255 = full) as the modulation level.
    fn level(&self) -> u8 {
        self.playing
            .and_then(|p| self.slots[usize::from(p)])
            .map_or(safety::FULL, |s| s.header.intensity)
    }

    /// Step within the cycle and cycles completed of the playing slot,
    /// from the time it has played (frozen at `stop`, as the firmware's
    /// counters).
    fn counters(&self, now: u64) -> (u16, u32) {
        let Some(s) = self.playing.and_then(|p| self.slots[usize::from(p)]) else {
            return (0, 0);
        };
        let Some(played) = self
            .played_us
            .or_else(|| self.started_us.map(|t0| now.saturating_sub(t0)))
        else {
            return (0, 0);
        };
        let dwell = u64::from(timing::dwell_us(u32::from(s.divide))).max(1);
        let steps = (played / dwell) as usize;
        let n = s.steps.max(1);
        (
            (steps % n) as u16,
            (steps / n).min(u32::MAX as usize) as u32,
        )
    }

    /// The STM segment the devices play, from their FPGA state.
    fn current_segment(&mut self) -> anyhow::Result<Option<u8>> {
        let states = self.ctl.fpga_state().context("reading the FPGA state")?;
        let mut seg = None;
        for s in states {
            let s = s.and_then(|s| s.current_stm_segment()).map(|s| s as u8);
            if seg.is_some() && seg != Some(s) {
                bail!("the devices play different STM segments");
            }
            seg = Some(s);
        }
        Ok(seg.flatten())
    }

    /// After a `SyncIdx` switch: once the devices play the new segment, make
    /// it loop forever. With `wait`, waits up to one loop period + 100 ms.
    fn finish_switch(&mut self, wait: bool) -> anyhow::Result<()> {
        let Some(slot) = self.rearm else {
            return Ok(());
        };
        let s = self.slots[usize::from(slot)].context("switching to an empty slot")?;
        let period = Duration::from_micros(
            s.steps as u64 * u64::from(timing::dwell_us(u32::from(s.divide))),
        );
        let deadline = self.clock.now() + period + Duration::from_millis(100);
        loop {
            if self.current_segment()? == Some(slot) {
                self.ctl
                    .send(SwapSegmentGainSTM(segment(slot), Immediate))
                    .context("setting the new segment to loop")?;
                self.rearm = None;
                // SyncIdx switched at the new segment's index 0, on a
                // boundary of its period on the devices' shared clock.
                let now = self.now_us();
                let period_us = period.as_micros() as u64;
                self.started_us = Some(now - now % period_us.max(1));
                self.played_us = None;
                if self.queued.take().is_some() {
                    self.limit = std::mem::take(&mut self.queued_limit);
                    // The queued slot took over: its own centre and work
                    // volume from now on.
                    self.playing = Some(slot);
                    self.update_correction()?;
                }
                return Ok(());
            }
            if !wait {
                return Ok(());
            }
            if self.clock.now() > deadline {
                bail!("the devices did not switch to slot {slot} within one loop");
            }
            self.clock.sleep(Duration::from_millis(1));
        }
    }

    /// Starts the switch to `slot` at the end of the playing loop without
    /// waiting for it (tests step the clock in between).
    pub fn request_play(&mut self, slot: u8, untracked: bool) -> anyhow::Result<()> {
        self.request_play_at(slot, PlayAt::NextCycle, untracked)
    }

    /// [`Self::request_play`] at `at`. As on the firmware, a slot played
    /// while another plays takes over at the end of its loop (`queued`
    /// until then) and one played from silence starts at once (it sounds
    /// from the new segment's first loop boundary). `Immediate` is refused
    /// while another slot plays: autd3 firmware switches a segment uploaded
    /// for a loop-end switch only at a loop end.
    pub fn request_play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> anyhow::Result<()> {
        self.request(slot, at, untracked, 0)
    }

    /// [`Self::request_play`] for `steps` steps (0 = until `stop`), counted
    /// from the start (or the takeover) on the devices' clock; `tick`,
    /// `status` and `centroid` stop it once they have played.
    pub fn request_play_for(
        &mut self,
        slot: u8,
        untracked: bool,
        steps: u32,
    ) -> anyhow::Result<()> {
        self.request(slot, PlayAt::NextCycle, untracked, steps)
    }

    fn request(&mut self, slot: u8, at: PlayAt, untracked: bool, steps: u32) -> anyhow::Result<()> {
        if slot > 1 {
            return Err(InputError::new(format!("AUTD3 has slots 0 and 1, got {slot}")).into());
        }
        if self.slots[usize::from(slot)].is_none() {
            bail!(
                "slot {slot} of {} is empty: an AUTD3 holds a sequence only while lmhost holds the link; \
                 `lmhost upload --port {}` uploads and plays",
                self.port,
                self.port
            );
        }
        self.finish_switch(true)?;
        let playing = self.policy.session() == Session::Playing;
        if playing && at == PlayAt::Immediate && self.playing != Some(slot) {
            return Err(InputError::new(
                "an AUTD3 switches sequences at the end of a loop only; play without --immediate",
            )
            .into());
        }
        if self.current_segment()? != Some(slot) {
            self.ctl
                .send(SwapSegmentGainSTM(segment(slot), SyncIdx))
                .with_context(|| format!("switching to slot {slot}"))?;
            self.rearm = Some(slot);
            if playing {
                self.queued = Some(slot);
                self.queued_limit = steps;
            } else {
                self.playing = Some(slot);
                self.limit = steps;
            }
        } else {
            let now = self.now_us();
            if !playing {
                self.started_us = Some(now);
                self.played_us = None;
            } else if steps != 0 {
                // The same slot again: no switch on the devices, so the
                // count begins at its next loop boundary, as a firmware
                // restart queued for the cycle end.
                if let (Some(t0), Some(s)) = (self.started_us, self.slots[usize::from(slot)]) {
                    let period =
                        (s.steps as u64 * u64::from(timing::dwell_us(u32::from(s.divide)))).max(1);
                    let loops = now.saturating_sub(t0).div_ceil(period);
                    self.started_us = Some(t0 + loops * period);
                }
            }
            self.playing = Some(slot);
            self.limit = steps;
        }
        self.policy.play(untracked);
        self.update_correction()?;
        self.apply_gate()
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
        self.policy.stop();
        self.set_output(safety::MUTED)?;
        let seg = match self.playing {
            Some(s) => s,
            None => self.current_segment()?.unwrap_or(0),
        };
        self.ctl
            .send(WithSegment::new(Null::new(), segment(seg), Immediate))
            .context("sending the null gain")?;
        self.slots[usize::from(seg)] = None;
        self.playing = None;
        self.queued = None;
        self.rearm = None;
        Ok(())
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
        self.apply_gate()?;
        let now = self.now_us();
        // Until the devices take over a `SyncIdx` switch, the old segment
        // plays and the new one is queued, as on the firmware.
        let (slot, queued_slot) = (self.playing, self.queued);
        let correction_um = slot
            .and_then(|s| self.slots[usize::from(s)])
            .map_or([0; 3], |s| self.policy.correction_um(s.header.center_um));
        let (step, cycles) = self.counters(now);
        Ok(Status {
            state: self.policy.state(now),
            slot,
            step,
            cycles,
            missed_deadlines: 0,
            last_centroid_seq: self.policy.last_seq(),
            bad_frames: 0,
            crc_errors: 0,
            nacks: 0,
            correction_um,
            queued_slot,
            mute_reason: self.policy.mute_reason(now),
            // The array plays only while lmhost holds the link: no lease.
            lease_ms: 0,
            lease_expiries: self.policy.lease_expiries(),
        })
    }

    fn upload(&mut self, plan: &Plan, slot: Option<u8>) -> BResult<UploadReport> {
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
        self.finish_switch(true)?;
        let slot = match slot {
            Some(s) if s > 1 => {
                return Err(InputError::new(format!("AUTD3 has slots 0 and 1, got {s}")).into());
            }
            Some(s)
                if Some(s) == self.queued
                    || (Some(s) == self.playing && self.policy.session() == Session::Playing) =>
            {
                return Err(BackendError::refused(
                    NackCode::SlotPlaying,
                    format!("slot {s} is playing; upload into the idle slot"),
                ));
            }
            Some(s) => s,
            None if self.queued.is_some() => {
                return Err(BackendError::refused(
                    NackCode::SlotPlaying,
                    "no free slot: one plays and the other is queued",
                ));
            }
            None => match self.playing {
                Some(p) => 1 - p,
                None => 1 - self.current_segment()?.unwrap_or(0),
            },
        };
        // The segment is being overwritten: until it arrives whole it is empty.
        self.slots[usize::from(slot)] = None;
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
            .send(WithFiniteLoop::new(
                stm,
                NonZeroU16::MAX,
                segment(slot),
                Later,
            ))
            .with_context(|| format!("uploading to slot {slot} on {}", self.port))?;
        let frames = self.emulator.as_ref().map_or(0, |e| e.frames()) - frames0;
        self.slots[usize::from(slot)] = Some(Slot {
            steps,
            divide,
            header: *h,
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
                readback_mismatches: self.readback_mismatches(slot, phases),
            },
        })
    }

    fn play_at(&mut self, slot: u8, at: PlayAt, untracked: bool) -> BResult<()> {
        // A start from silence returns once the new segment plays (within
        // one loop); a slot queued behind a playing one returns at once, as
        // on the firmware, and `tick` / `status` see the switch through.
        self.request_play_at(slot, at, untracked)?;
        if self.queued.is_none() {
            self.finish_switch(true)?;
        }
        Ok(self.apply_gate()?)
    }

    /// Timed by the host on the devices' clock (`stop_at_limit`): an AUTD3
    /// cannot stop itself.
    fn play_for(&mut self, slot: u8, untracked: bool, steps: u32) -> BResult<()> {
        self.request_play_for(slot, untracked, steps)?;
        if self.queued.is_none() {
            self.finish_switch(true)?;
        }
        Ok(self.apply_gate()?)
    }

    /// Mutes at once, as the firmware's `Stop`; the segments stay, so a
    /// later `play` resumes without an upload (drop writes the null gain).
    fn stop(&mut self) -> BResult<()> {
        Ok(self.mute_and_stop()?)
    }

    fn centroid(&mut self, c: &Centroid) -> BResult<CentroidOutcome> {
        // A play whose steps have played is stopped before the update.
        self.finish_switch(false)?;
        self.stop_at_limit()?;
        let header = self
            .playing
            .and_then(|s| self.slots[usize::from(s)])
            .map(|s| s.header);
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
        self.apply_gate()?;
        Ok(outcome)
    }

    fn tick(&mut self) -> BResult<()> {
        Ok(self.apply_gate()?)
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
