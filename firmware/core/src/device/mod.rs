//! [`Device`]: the protocol handler, store, player, gate and correction
//! wired together. Boards and the host simulator drive only this.

use lm_proto::{
    BeginUpload, Centroid, DeviceLimits, FeedResult, FrameDecoder, Head, Info, LEASE_MS, MAX_CHUNK,
    MAX_ENCODED_FRAME, Message, NackCode, PROTOCOL_VERSION, Play, PlayAt, Status, encode_frame,
};

use crate::MAX_TRANSDUCERS;
use crate::correction::{apply_offsets, compute_offsets, sound_speed_m_s};
use crate::output::{OutputDriver, OutputFrame};
use crate::player::{PlayState, Player, Timing};
use crate::policy::{Policy, Session};
use crate::status::Mechanics;
use crate::store::{SLOTS, Store};

mod config;

pub use config::{
    Config, Counters, DEFAULT_CENTROID_TIMEOUT_US, DEFAULT_TRANSDUCERS, DeviceError, FW_VERSION,
};

/// Everything but the receive decoder (split so a parsed frame can borrow
/// the decoder while the handler mutates the rest).
#[derive(Debug)]
struct Handler<'m> {
    cfg: Config,
    store: Store<'m>,
    player: Player,
    /// Session, gate, untracked play, work volume: the safety rules.
    policy: Policy,
    counters: Counters,
    /// Slot the offsets were computed for (None: offsets are zero).
    offsets_for: Option<u8>,
    offsets: [u8; MAX_TRANSDUCERS],
    frame: [u8; MAX_TRANSDUCERS],
    /// Re-send the current step at once (Stop, presence lost).
    refresh: bool,
    /// When the last frame went out (timer counts), for repeats.
    last_frame: Option<u64>,
    /// [`Config::frame_repeat_us`] in timer counts (0 = never).
    repeat_every: u64,
    /// The play session's host lease as its `Play` gave it, ms (0: none yet).
    lease_ms: u16,
    /// The timer count at reset, from which `Status::uptime_ms` counts.
    epoch: u64,
}

/// The output of [`Device::handle`]: writes nothing and has no self-test.
struct NoOutput;

impl OutputDriver for NoOutput {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, _: &OutputFrame<'_>) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// The whole device core.
///
/// Drive it with [`feed`](Self::feed) (received bytes, any piece size)
/// and [`poll`](Self::poll) (call after every feed and whenever the
/// returned deadline is reached). `now` is the free-running timer count in
/// [`Config::timer_hz`] counts, never decreasing (see
/// [`TimeExtender`](crate::TimeExtender) for 32-bit timers).
#[derive(Debug)]
pub struct Device<'m> {
    rx: FrameDecoder,
    tx: [u8; MAX_ENCODED_FRAME],
    handler: Handler<'m>,
}

impl<'m> Device<'m> {
    /// A device over `mem`, the sequence memory: the rig's positions and the
    /// stimulus library's arena (see [`memory_bytes`](crate::memory_bytes)
    /// for the size a library needs).
    pub fn new(cfg: Config, mem: &'m mut [u8]) -> Result<Self, DeviceError> {
        if cfg.timer_hz == 0 {
            return Err(DeviceError::BadTimer);
        }
        let store = Store::new(mem, cfg.max_transducers).map_err(DeviceError::Store)?;
        let timeout = u64::from(cfg.centroid_timeout_us) * u64::from(cfg.timer_hz) / 1_000_000;
        // Timer counts between repeats of a long step's frame (0 = never).
        let repeat_every = match cfg.frame_repeat_us {
            0 => 0,
            us => (u64::from(us) * u64::from(cfg.timer_hz) / 1_000_000).max(1),
        };
        Ok(Self {
            rx: FrameDecoder::new(),
            tx: [0; MAX_ENCODED_FRAME],
            handler: Handler {
                cfg,
                store,
                player: Player::new(cfg.timer_hz),
                policy: Policy::new(timeout, cfg.require_tracking),
                counters: Counters::default(),
                offsets_for: None,
                offsets: [0; MAX_TRANSDUCERS],
                frame: [0; MAX_TRANSDUCERS],
                refresh: false,
                last_frame: None,
                repeat_every,
                lease_ms: 0,
                epoch: 0,
            },
        })
    }

    /// Feeds received bytes. Each complete request is handled at `now` and
    /// its encoded response frame (delimiters included) is passed to
    /// `send`; `out` is the output [`poll`](Self::poll) writes to, which a
    /// `SelfTest` request tests ([`OutputDriver::self_test`]). Never
    /// panics, whatever the bytes.
    pub fn feed<D: OutputDriver>(
        &mut self,
        bytes: &[u8],
        now: u64,
        out: &mut D,
        send: &mut impl FnMut(&[u8]),
    ) {
        let mut input = bytes;
        while !input.is_empty() {
            let (reply, rest) = match self.rx.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Frame { frame, remaining } => {
                    // One line per request, by kind (a chunk's bytes are not
                    // logged): the board's link traffic at `debug`.
                    #[cfg(feature = "defmt")]
                    defmt::debug!("request {}", frame.message.msg_type());
                    // The reply echoes this frame's type and CRC: it
                    // answers this request and no other.
                    (
                        Some((
                            frame.reply_head(),
                            self.handler.handle(&frame.message, now, out),
                        )),
                        remaining,
                    )
                }
                FeedResult::Error { error, remaining } => {
                    if error.is_crc() {
                        self.handler.counters.crc_errors =
                            self.handler.counters.crc_errors.wrapping_add(1);
                    } else {
                        self.handler.counters.bad_frames =
                            self.handler.counters.bad_frames.wrapping_add(1);
                    }
                    #[cfg(feature = "defmt")]
                    defmt::debug!("bad frame: {}", error);
                    (
                        error.nack().map(|(head, code)| (head, Message::Nack(code))),
                        remaining,
                    )
                }
            };
            if let Some((head, msg)) = reply {
                self.send(head, &msg, send);
            }
            input = rest;
        }
    }

    fn send(&mut self, head: Head, msg: &Message<'_>, send: &mut impl FnMut(&[u8])) {
        let c = &mut self.handler.counters;
        c.responses = c.responses.wrapping_add(1);
        if matches!(msg, Message::Nack(_)) {
            c.nacks = c.nacks.wrapping_add(1);
        }
        // Responses are small and well-formed; encoding cannot fail with a
        // MAX_ENCODED_FRAME buffer.
        if let Ok(n) = encode_frame(head, msg, &mut self.tx) {
            send(&self.tx[..n]);
        }
    }

    /// Handles one parsed request at `now` and returns the response
    /// (without encoding it or touching the counters). For tests and
    /// transports that parse frames themselves. Without an output, a
    /// `SelfTest` is answered `Unsupported`
    /// ([`handle_with_output`](Self::handle_with_output) runs it).
    pub fn handle(&mut self, msg: &Message<'_>, now: u64) -> Message<'static> {
        self.handler.handle(msg, now, &mut NoOutput)
    }

    /// [`handle`](Self::handle), with the output a `SelfTest` tests.
    pub fn handle_with_output<D: OutputDriver>(
        &mut self,
        msg: &Message<'_>,
        now: u64,
        out: &mut D,
    ) -> Message<'static> {
        self.handler.handle(msg, now, out)
    }

    /// Runs the player at `now`: writes the frame of a newly due step (or a
    /// muted frame after Stop / loss of presence) to `out`, and returns the
    /// time of the next step boundary (`None` while nothing plays). Call it
    /// at (or soon after) that time; a late call counts missed deadlines.
    pub fn poll<D: OutputDriver>(&mut self, now: u64, out: &mut D) -> Option<u64> {
        self.handler.poll(now, out)
    }

    /// The next time [`poll`](Self::poll) has work, without doing it.
    pub fn next_deadline(&self) -> Option<u64> {
        if self.handler.refresh {
            return Some(0);
        }
        self.handler.deadline()
    }

    /// The `Info` response.
    pub fn info(&self) -> Info {
        self.handler.info()
    }

    /// The `Status` response at `now`.
    pub fn status(&self, now: u64) -> Status {
        self.handler.status(now)
    }

    /// Sets the timer count the device was reset at, from which
    /// `Status::uptime_ms` counts: 0 on the boards (their timer starts
    /// with them, the default); a device on a shared clock (the host's
    /// simulated device) gives the time it started.
    pub fn set_epoch(&mut self, now: u64) {
        self.handler.epoch = now;
    }

    /// Counters.
    pub fn counters(&self) -> Counters {
        Counters {
            lease_expiries: self.handler.policy.lease_expiries(),
            ..self.handler.counters
        }
    }

    /// Configuration.
    pub fn config(&self) -> &Config {
        &self.handler.cfg
    }

    /// Changes the centroid timeout (µs).
    pub fn set_centroid_timeout_us(&mut self, us: u32) {
        self.handler.cfg.centroid_timeout_us = us;
        self.handler
            .policy
            .set_timeout(u64::from(us) * u64::from(self.handler.cfg.timer_hz) / 1_000_000);
    }

    /// Changes the minimum step dwell (µs), checked at `BeginUpload` and `Play`.
    pub fn set_min_dwell_us(&mut self, us: u32) {
        self.handler.cfg.min_dwell_us = us;
    }

    /// Turns muting before the first centroid update on or off.
    pub fn set_require_tracking(&mut self, on: bool) {
        self.handler.cfg.require_tracking = on;
        self.handler.policy.set_require_tracking(on);
    }

    /// Per-transducer correction offsets (u8 phase LSB) being added to the
    /// playing slot's frames; empty while no correction applies (no
    /// centroid yet, or nothing playing).
    pub fn offsets(&self) -> &[u8] {
        let c = &self.handler;
        if !c.policy.correcting() {
            return &[];
        }
        match c.player.slot().filter(|s| c.offsets_for == Some(*s)) {
            Some(slot) => {
                let t = c
                    .store
                    .header(slot)
                    .map_or(0, |h| usize::from(h.transducers));
                &c.offsets[..t]
            }
            None => &[],
        }
    }

    /// Whether the output sounds at `now` (playing and the gate is open).
    pub fn is_sounding(&self, now: u64) -> bool {
        self.handler.sounding(now)
    }
}

impl Handler<'_> {
    fn info(&self) -> Info {
        Info {
            proto_version: PROTOCOL_VERSION,
            fw_version: self.cfg.fw_version,
            max_transducers: self.store.max_transducers(),
            slot_bytes: self.store.slot_bytes(),
            slots: SLOTS as u8,
            timer_hz: self.cfg.timer_hz,
            min_dwell_us: self.cfg.min_dwell_us,
            max_chunk: MAX_CHUNK as u16,
            rig_transducers: self.store.rig().map_or(0, |r| r.0),
            rig_crc32: self.store.rig().map_or(0, |r| r.1),
            library_free: self.store.free_bytes(),
            clock: self.cfg.clock,
        }
    }

    /// The limits `BeginUpload` is checked against (`Info`'s).
    fn limits(&self) -> DeviceLimits {
        DeviceLimits::from_info(&self.info())
    }

    /// Playing and not muted at `now`.
    fn sounding(&self, now: u64) -> bool {
        self.policy.sounding(now)
    }

    fn status(&self, now: u64) -> Status {
        let playing = self.player.slot().and_then(|s| self.store.header(s));
        let m = Mechanics {
            missed_deadlines: self.player.missed(),
            bad_frames: self.counters.bad_frames,
            crc_errors: self.counters.crc_errors,
            nacks: self.counters.nacks,
            lease_ms: self.lease_ms,
            uptime_ms: crate::status::uptime_ms(now.saturating_sub(self.epoch), self.cfg.timer_hz),
        };
        crate::status::status(&self.player, &self.policy, playing, m, now)
    }

    fn result(r: Result<(), NackCode>) -> Message<'static> {
        match r {
            Ok(()) => Message::Ack,
            Err(code) => {
                #[cfg(feature = "defmt")]
                defmt::debug!("nack: {}", code);
                Message::Nack(code)
            }
        }
    }

    /// Handles a request: first ends a play whose host lease has run out
    /// (a late request never revives it), then answers; a request it
    /// accepts (anything but a `Nack`) renews the lease.
    fn handle<D: OutputDriver>(
        &mut self,
        msg: &Message<'_>,
        now: u64,
        out: &mut D,
    ) -> Message<'static> {
        self.expire_lease(now);
        // A message built in process ([`Device::handle`]) that the wire
        // could not carry (an empty list, SPEC section 3) is malformed, as
        // its frame would be.
        let reply = match msg.check() {
            Ok(()) => self.answer(msg, now, out),
            Err(_) => Message::Nack(NackCode::Malformed),
        };
        if !matches!(reply, Message::Nack(_)) {
            self.policy.renew(now);
        }
        reply
    }

    /// Ends the play if its host lease has run out at `now`: as `Stop`
    /// (the player stops, the output mutes on the next poll), the reason
    /// and the count kept by the policy.
    fn expire_lease(&mut self, now: u64) {
        if self.policy.expire_lease(now) {
            #[cfg(feature = "defmt")]
            defmt::warn!("host lease expired: stop");
            self.player.stop();
            self.refresh = true;
        }
    }

    /// Whether a slot plays or is queued.
    fn busy(&self) -> bool {
        self.player.state() == PlayState::Playing || self.player.pending().is_some()
    }

    fn answer<D: OutputDriver>(
        &mut self,
        msg: &Message<'_>,
        now: u64,
        out: &mut D,
    ) -> Message<'static> {
        match msg {
            Message::GetInfo => Message::Info(self.info()),
            Message::GetStatus => Message::Status(self.status(now)),
            Message::BeginUpload(b) => Self::result(self.begin_upload(b)),
            Message::BeginRig(r) => Self::result(self.begin_rig(r.transducers, r.crc32)),
            Message::Geometry(g) => Self::result(self.store.geometry(g.first, &g.positions)),
            Message::CommitRig => Self::result(self.store.commit_rig()),
            Message::Chunk(c) => Self::result(
                self.writable(c.slot)
                    .and_then(|()| self.store.chunk(c.slot, c.offset, c.data)),
            ),
            Message::Intensity(c) => Self::result(
                self.writable(c.slot)
                    .and_then(|()| self.store.intensity_levels(c.slot, c.offset, c.data)),
            ),
            // A repeated commit (same CRC) changes nothing, so it is acked
            // even while the slot plays.
            Message::Commit(c) if self.store.committed_crc(c.slot) == Some(c.crc32) => Message::Ack,
            Message::Commit(c) => {
                let r = self
                    .writable(c.slot)
                    .and_then(|()| self.store.commit(c.slot, c.crc32));
                #[cfg(feature = "defmt")]
                if r.is_ok() {
                    defmt::info!("slot {} committed", c.slot);
                }
                Self::result(r)
            }
            Message::Play(p) => Self::result(self.play(p, now)),
            Message::Stop => {
                #[cfg(feature = "defmt")]
                defmt::info!("stop");
                self.player.stop();
                self.policy.stop();
                self.refresh = true;
                Message::Ack
            }
            Message::Centroid(c) => Self::result(self.centroid(c, now)),
            // Its only effect, the renewal, is `handle`'s.
            Message::Renew => Message::Ack,
            // The test uses the output's bus: never while a slot plays.
            Message::SelfTest if self.busy() => Message::Nack(NackCode::Busy),
            Message::SelfTest => Message::SelfTestResult(out.self_test()),
            // Responses (or anything newer) sent to the device.
            _ => Message::Nack(NackCode::UnknownType),
        }
    }

    fn writable(&self, slot: u8) -> Result<(), NackCode> {
        if usize::from(slot) >= SLOTS {
            Err(NackCode::BadSlot)
        } else if self.player.busy(slot) {
            Err(NackCode::SlotPlaying)
        } else {
            Ok(())
        }
    }

    /// A rig upload; one that would change the rig (and so drop every
    /// entry) is refused with `Busy` while an entry plays or is queued.
    fn begin_rig(&mut self, transducers: u16, crc32: u32) -> Result<(), NackCode> {
        let change = self.store.rig_would_change(transducers, crc32);
        if change && self.busy() {
            return Err(NackCode::Busy);
        }
        if change {
            self.offsets_for = None;
        }
        self.store.begin_rig(transducers, crc32)
    }

    fn dwell_ok(&self, t: Timing) -> bool {
        u64::from(t.period_us) >= u64::from(self.cfg.min_dwell_us) * u64::from(t.steps)
            && self.player.schedulable(t)
    }

    fn begin_upload(&mut self, b: &BeginUpload) -> Result<(), NackCode> {
        self.writable(b.slot)?;
        b.validate(&self.limits())?;
        let t = Timing {
            steps: b.header.steps,
            period_us: b.header.period_us,
        };
        if !self.dwell_ok(t) {
            return Err(NackCode::DwellTooShort);
        }
        if self.offsets_for == Some(b.slot) {
            self.offsets_for = None;
        }
        #[cfg(feature = "defmt")]
        defmt::info!(
            "upload slot {}: {} steps x {} transducers",
            b.slot,
            b.header.steps,
            b.header.transducers
        );
        self.store.begin(b)
    }

    fn play(&mut self, p: &Play, now: u64) -> Result<(), NackCode> {
        if usize::from(p.slot) >= SLOTS {
            return Err(NackCode::BadSlot);
        }
        if !LEASE_MS.contains(&p.lease_ms) {
            return Err(NackCode::OutOfRange);
        }
        let h = *self.store.header(p.slot).ok_or(NackCode::NotCommitted)?;
        let t = Timing {
            steps: h.steps,
            period_us: h.period_us,
        };
        if !self.dwell_ok(t) {
            return Err(NackCode::DwellTooShort);
        }
        let ok = match p.at {
            PlayAt::Immediate => self.player.start(p.slot, t, now, p.steps),
            _ => self.player.queue(p.slot, t, now, p.steps),
        };
        if !ok {
            return Err(NackCode::DwellTooShort);
        }
        if self.policy.session() != Session::Playing {
            // A new session: fresh tracking, no offsets.
            self.offsets_for = None;
        }
        self.policy.play(p.untracked);
        let lease = u64::from(p.lease_ms) * u64::from(self.cfg.timer_hz) / 1000;
        self.policy.set_lease(lease.max(1), now);
        self.lease_ms = p.lease_ms;
        self.refresh = true;
        #[cfg(feature = "defmt")]
        defmt::info!(
            "play slot {} ({} steps, {} us)",
            p.slot,
            h.steps,
            h.period_us
        );
        Ok(())
    }

    fn centroid(&mut self, c: &Centroid, now: u64) -> Result<(), NackCode> {
        let playing = self.player.slot().and_then(|s| self.store.header(s));
        match self.policy.centroid(c, playing, now) {
            Ok(Some(_)) => {
                if let Some(slot) = self.player.slot() {
                    self.recompute(slot);
                }
                Ok(())
            }
            Ok(None) => {
                self.refresh = true;
                Ok(())
            }
            Err(NackCode::OutOfRange) => {
                // Never steer outside the work volume: muted until a
                // present centroid inside it arrives.
                self.offsets_for = None;
                self.refresh = true;
                Err(NackCode::OutOfRange)
            }
            Err(e) => Err(e),
        }
    }

    /// Recomputes the offsets for `slot` from the last centroid, as far as
    /// the policy lets it steer (a slot taking over with another centre or
    /// volume is re-checked).
    fn recompute(&mut self, slot: u8) {
        let (Some(h), Some(pos)) = (self.store.header(slot).copied(), self.store.positions(slot))
        else {
            self.offsets_for = None;
            return;
        };
        let Some(c) = self.policy.steer_for(&h) else {
            self.offsets_for = None;
            return;
        };
        let t = usize::from(h.transducers);
        compute_offsets(
            pos,
            h.center_um,
            c,
            sound_speed_m_s(h.sound_speed_mm_s),
            &mut self.offsets[..t],
        );
        self.offsets_for = Some(slot);
    }

    /// When the current frame must go out again ([`Config::frame_repeat_us`]
    /// after the last one), while something plays.
    fn repeat_at(&self) -> Option<u64> {
        if self.repeat_every == 0 {
            return None;
        }
        self.player.deadline()?;
        self.last_frame.map(|t| t.saturating_add(self.repeat_every))
    }

    /// The next time `poll` has work: a step boundary, a repeat or the
    /// host lease's end.
    fn deadline(&self) -> Option<u64> {
        [
            self.player.deadline(),
            self.repeat_at(),
            self.policy.lease_deadline(),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    fn poll<D: OutputDriver>(&mut self, now: u64, out: &mut D) -> Option<u64> {
        // A lease that ran out stops the play before any step is due: no
        // frame due after it sounds, however late this poll.
        self.expire_lease(now);
        #[cfg(feature = "defmt")]
        let missed_before = self.player.missed();
        let due = self.player.tick(now);
        #[cfg(feature = "defmt")]
        if self.player.missed() != missed_before {
            defmt::warn!(
                "missed {} step deadlines",
                self.player.missed() - missed_before
            );
        }
        let (slot, step, at) = match due {
            Some(d) => {
                if d.stop {
                    // The play's steps have played: stop as `Stop` does,
                    // and the frame for this boundary goes out muted.
                    #[cfg(feature = "defmt")]
                    defmt::info!("slot {} played its steps: stop", d.slot);
                    self.policy.stop();
                }
                (d.slot, d.step, d.at)
            }
            None if self.refresh || self.repeat_at().is_some_and(|t| now >= t) => {
                let Some(slot) = self.player.slot() else {
                    self.refresh = false;
                    return self.deadline();
                };
                (slot, self.player.step(), now)
            }
            None => return self.deadline(),
        };
        self.refresh = false;
        if self.offsets_for != Some(slot) && self.policy.correcting() {
            self.recompute(slot);
        }
        let amplitude = if self.sounding(now) {
            self.cfg.amplitude
        } else {
            0
        };
        // The entry's intensity, or its table's level for this step.
        let intensity = self.store.intensity(slot, step).unwrap_or(0);
        let phases: &[u8] = match self.store.step(slot, step) {
            Some(p) => {
                let t = p.len();
                if self.offsets_for == Some(slot) && self.policy.correcting() {
                    apply_offsets(p, &self.offsets[..t], &mut self.frame[..t]);
                } else {
                    self.frame[..t].copy_from_slice(p);
                }
                &self.frame[..t]
            }
            None => &[],
        };
        let frame = OutputFrame {
            due: at,
            slot,
            step,
            amplitude,
            intensity,
            phases,
        };
        match out.write_frame(&frame) {
            Ok(()) => self.counters.frames_out = self.counters.frames_out.wrapping_add(1),
            Err(_) => self.counters.output_errors = self.counters.output_errors.wrapping_add(1),
        }
        self.last_frame = Some(now);
        self.deadline()
    }
}
