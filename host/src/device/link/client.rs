//! Request/response client: one request in flight, matched by seq, with
//! timeouts and retries; chunked upload with acks and a whole-sequence CRC.
//!
//! Retries resend the same frame with the same seq. Where a lost ack makes
//! the device's state ambiguous (a chunk that may or may not have landed),
//! the client restarts the whole upload from `BeginUpload` rather than
//! guess: the device only ever plays a slot whose CRC it checked itself.
//!
//! The rig (the transducer positions) goes to the device once: before an
//! upload the client makes sure the device holds the rig the sequence was
//! planned for (its CRC-32, from the device's `Info` the first time, then
//! remembered), and sends `BeginRig`, `Geometry`, `CommitRig` only when it
//! does not; later uploads carry phases only. A device that lost the rig
//! (reset) answers `NoRig` / `RigMismatch`, and the client sends it again.
//!
//! Every play carries the client's host lease ([`Client::lease_ms`]); the
//! client notes when the device last accepted a request (each one renews
//! the lease) and [`Client::renew_due`] says when a `Renew` is due: after a
//! quarter lease without one (SPEC section 2).

use std::time::{Duration, Instant};

use lm_proto::codec::CodecError;
use lm_proto::{
    BeginRig, Centroid, Chunk, Commit, Echo, FeedResult, FrameDecoder, Geometry, Info, Intensity,
    MAX_CHUNK, MAX_ENCODED_FRAME, MAX_GEOMETRY_POSITIONS, Message, NackCode, POSITION_LEN, Play,
    PlayAt, Positions, SelfTest, Status, encode_frame,
};

pub use super::error::{Heard, LinkError};
pub use super::spec::{UploadReport, UploadSpec};
use super::transport::Transport;

/// A response, owned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reply {
    /// Done.
    Ack,
    /// Refused.
    Nack(NackCode),
    /// Device info.
    Info(Info),
    /// Device status.
    Status(Status),
    /// Outcome of a self-test.
    SelfTest(SelfTest),
}

impl Reply {
    /// The reply's kind, with its article.
    fn name(&self) -> &'static str {
        match self {
            Reply::Ack => "an ack",
            Reply::Nack(_) => "a nack",
            Reply::Info(_) => "an info",
            Reply::Status(_) => "a status",
            Reply::SelfTest(_) => "a self-test result",
        }
    }

    /// The reply's kind, without its article.
    fn kind(&self) -> &'static str {
        let name = self.name();
        name.split_once(' ').map_or(name, |(_, kind)| kind)
    }
}

mod adapt;

/// Byte and event counts of one client.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct LinkStats {
    /// Bytes written to the transport.
    pub bytes_sent: u64,
    /// Bytes read from the transport.
    pub bytes_received: u64,
    /// Requests sent (first attempts).
    pub requests: u64,
    /// Resends after a timeout.
    pub retries: u64,
    /// Received frames that failed to decode (CRC, framing).
    pub bad_frames: u64,
    /// Whole-upload restarts.
    pub upload_restarts: u64,
}

/// Smallest chunk the adaptive upload shrinks to on a noisy link (bytes).
pub const MIN_ADAPTIVE_CHUNK: usize = 64;

/// The client.
pub struct Client<T> {
    transport: T,
    decoder: FrameDecoder,
    seq: u16,
    rx: Vec<u8>,
    tx: Vec<u8>,
    /// Per-attempt response timeout.
    pub timeout: Duration,
    /// Attempts per request (first try included).
    pub tries: u32,
    /// Whole-upload attempts.
    pub upload_attempts: u32,
    /// Counters.
    pub stats: LinkStats,
    /// The rig (transducers, CRC-32) the device is known to hold.
    rig: Option<(u16, u32)>,
    /// Host lease every `Play` carries, ms (within [`lm_proto::LEASE_MS`]).
    pub lease_ms: u16,
    /// When the request the device last accepted was sent (the device
    /// renewed the lease no earlier).
    last_accepted: Option<Instant>,
    /// The device's `Info`, checked ([`super::reply::check_info`]), once
    /// asked.
    info: Option<Info>,
    /// Steps per cycle of the slots this client committed (a `Status`
    /// step beyond them is impossible).
    committed: std::collections::HashMap<u8, u16>,
    /// The last `Status` read and when it had arrived (the transport's
    /// clock): the next one is held to it ([`super::reply::restarted`]).
    last_status: Option<(Status, Duration)>,
    /// When the last request was first written (the transport's clock).
    first_sent: Duration,
}

impl<T: Transport> Client<T> {
    /// A client on `transport` with defaults for a local link.
    pub fn new(transport: T) -> Self {
        Self {
            transport,
            decoder: FrameDecoder::new(),
            seq: 0,
            rx: vec![0; 4096],
            tx: vec![0; MAX_ENCODED_FRAME],
            timeout: Duration::from_millis(300),
            tries: 8,
            upload_attempts: 4,
            stats: LinkStats::default(),
            rig: None,
            lease_ms: lm_proto::DEFAULT_LEASE_MS,
            last_accepted: None,
            info: None,
            committed: std::collections::HashMap::new(),
            last_status: None,
            first_sent: Duration::ZERO,
        }
    }

    /// What the transport says it is (errors name it).
    fn port(&self) -> String {
        self.transport.describe()
    }

    /// The transport.
    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// Numbers the next request `seq + 1` (replies are matched by seq).
    pub fn start_seq(&mut self, seq: u16) {
        self.seq = seq;
    }

    /// The transport, mutably.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Send `msg` and wait for the response with the same seq that echoes
    /// it (SPEC section 2, Binding), resending on timeout.
    pub fn request(&mut self, what: &'static str, msg: &Message<'_>) -> Result<Reply, LinkError> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        let unencodable = |port, e: lm_proto::EncodeError| LinkError::Io {
            port,
            what,
            source: std::io::Error::new(std::io::ErrorKind::InvalidInput, e.to_string()),
        };
        let n = encode_frame(seq, msg, &mut self.tx).map_err(|e| unencodable(self.port(), e))?;
        let echo = Echo::of_request(seq, msg).map_err(|e| unencodable(self.port(), e))?;
        // What came before this request cannot be its reply: a late
        // answer to an earlier one, or a frame made up ahead of it.
        self.decoder.reset();
        if let Err(source) = self.transport.discard_input() {
            return Err(LinkError::Io {
                port: self.port(),
                what,
                source,
            });
        }
        self.stats.requests += 1;
        let mut heard = Heard::default();
        for attempt in 0..self.tries {
            if attempt > 0 {
                self.stats.retries += 1;
            } else {
                self.first_sent = self.transport.now();
            }
            let sent = Instant::now();
            if let Err(source) = self.transport.send(&self.tx[..n]) {
                return Err(LinkError::Io {
                    port: self.port(),
                    what,
                    source,
                });
            }
            self.stats.bytes_sent += n as u64;
            if let Some(r) = self.wait_for(seq, echo, what, &mut heard)? {
                if !matches!(r, Reply::Nack(_)) {
                    self.last_accepted = Some(sent);
                }
                return Ok(r);
            }
        }
        Err(LinkError::Timeout {
            port: self.port(),
            what,
            tries: self.tries,
            timeout_ms: self.timeout.as_millis() as u64,
            heard,
        })
    }

    /// Read until a response with `seq` arrives or the timeout passes,
    /// counting in `heard` what came instead. A response with `seq` that
    /// does not carry `echo` answers another request than the one written
    /// (replayed, or made up before it): refused.
    fn wait_for(
        &mut self,
        seq: u16,
        echo: Echo,
        what: &'static str,
        heard: &mut Heard,
    ) -> Result<Option<Reply>, LinkError> {
        let deadline = Instant::now() + self.timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            let got = match self.transport.recv(&mut self.rx, left) {
                Ok(n) => n,
                Err(source) => {
                    return Err(LinkError::Io {
                        port: self.port(),
                        what,
                        source,
                    });
                }
            };
            if got == 0 {
                // Transports return 0 only once the timeout has passed (on
                // their own clock, which may be virtual).
                return Ok(None);
            }
            self.stats.bytes_received += got as u64;
            heard.bytes += got as u64;
            let mut input: &[u8] = &self.rx[..got];
            let mut found = None;
            loop {
                input = match self.decoder.feed(input) {
                    FeedResult::Consumed => break,
                    FeedResult::Frame { frame, remaining } => {
                        heard.frames += 1;
                        let reply = match frame.message {
                            Message::Ack => Some(Reply::Ack),
                            Message::Nack(c) => Some(Reply::Nack(c)),
                            Message::Info(i) => Some(Reply::Info(i)),
                            Message::Status(s) => Some(Reply::Status(s)),
                            Message::SelfTestResult(t) => Some(Reply::SelfTest(t)),
                            // A request: our own frame echoed back (or
                            // noise that decoded); never an answer.
                            _ => None,
                        };
                        match reply {
                            None => heard.echoes += 1,
                            Some(_) if frame.seq != seq => heard.other_seq += 1,
                            Some(r) if frame.echo != Some(echo) => {
                                let why = unbound(frame.echo, echo, what);
                                return Err(self.bad_reply(r.kind(), why));
                            }
                            Some(r) => {
                                // The first answer counts; a repeat of it
                                // in the same read is dropped.
                                found = found.or(Some(r));
                            }
                        }
                        remaining
                    }
                    FeedResult::Error { remaining, .. } => {
                        self.stats.bad_frames += 1;
                        heard.bad_frames += 1;
                        remaining
                    }
                };
            }
            if found.is_some() {
                return Ok(found);
            }
        }
    }

    fn expect_ack(&mut self, what: &'static str, msg: &Message<'_>) -> Result<(), LinkError> {
        match self.request(what, msg)? {
            Reply::Ack => Ok(()),
            other => Err(self.refused(what, other)),
        }
    }

    /// The error for `reply`, which is not what `what` asked for.
    fn refused(&self, what: &'static str, reply: Reply) -> LinkError {
        match reply {
            Reply::Nack(code) => LinkError::Nack {
                port: self.port(),
                what,
                code,
            },
            other => LinkError::Unexpected {
                port: self.port(),
                what,
                got: other.name(),
            },
        }
    }

    /// A reply of the right kind that no LM firmware sends.
    fn bad_reply(&self, reply: &'static str, why: String) -> LinkError {
        LinkError::BadReply {
            port: self.port(),
            reply,
            why,
        }
    }

    /// Device info, checked ([`super::reply::check_info`]): a device
    /// whose `Info` no LM firmware of this lmhost sends is refused here,
    /// before any number of it is used.
    pub fn info(&mut self) -> Result<Info, LinkError> {
        let i = match self.request("info", &Message::GetInfo)? {
            Reply::Info(i) => i,
            other => return Err(self.refused("info", other)),
        };
        super::reply::check_info(&i).map_err(|why| self.bad_reply("info", why))?;
        self.info = Some(i);
        Ok(i)
    }

    /// Device status, checked against the device's `Info` (asked first
    /// when not yet known) and the slots this client committed
    /// ([`super::reply::check_status`]).
    pub fn status(&mut self) -> Result<Status, LinkError> {
        let info = match self.info {
            Some(i) => i,
            None => self.info()?,
        };
        let s = match self.request("status", &Message::GetStatus)? {
            Reply::Status(s) => s,
            other => return Err(self.refused("status", other)),
        };
        // The device stamped this reply before now, and stamps the next
        // one after that request's first write: the host's time from here
        // to that write is at most what passes on the device.
        let arrived = self.transport.now();
        super::reply::check_status(&s, &info, |slot| self.committed.get(&slot).copied())
            .map_err(|why| self.bad_reply("status", why))?;
        // A device that restarted lost what this client uploaded: a loop
        // that went on would play nothing, or fail later on a slot it
        // takes for resident.
        if let Some(why) = self.last_status.as_ref().and_then(|(before, at)| {
            let elapsed = self.first_sent.saturating_sub(*at);
            super::reply::restarted(before, &s, elapsed, self.timeout, info.clock)
        }) {
            self.last_status = None;
            return Err(LinkError::Restarted {
                port: self.port(),
                why,
            });
        }
        self.last_status = Some((s, arrived));
        Ok(s)
    }

    /// Play a committed slot until `Stop` (or until the host lease runs
    /// out: keep [`renew`](Self::renew)ing); `untracked` plays without
    /// tracking (the device does not gate or correct the output).
    pub fn play(&mut self, slot: u8, at: PlayAt, untracked: bool) -> Result<(), LinkError> {
        self.play_steps(slot, at, untracked, 0)
    }

    /// Play a committed slot for `steps` steps, counted and stopped by the
    /// device's own timer (`Play.steps`, SPEC section 3); 0 = until `Stop`.
    pub fn play_steps(
        &mut self,
        slot: u8,
        at: PlayAt,
        untracked: bool,
        steps: u32,
    ) -> Result<(), LinkError> {
        self.expect_ack(
            "play",
            &Message::Play(Play {
                slot,
                at,
                untracked,
                steps,
                lease_ms: self.lease_ms,
            }),
        )
    }

    /// Renews the host lease (any accepted request does; this one does
    /// nothing else).
    pub fn renew(&mut self) -> Result<(), LinkError> {
        self.expect_ack("renew", &Message::Renew)
    }

    /// Whether a renewal is due: a quarter of [`lease_ms`](Self::lease_ms)
    /// has passed since the device last accepted a request (or none was).
    pub fn renew_due(&self) -> bool {
        let quarter = std::time::Duration::from_millis(u64::from(self.lease_ms) / 4);
        self.last_accepted.is_none_or(|t| t.elapsed() >= quarter)
    }

    /// Runs the device's output self-test (its SPI loopback); `Busy` while
    /// a slot plays.
    pub fn self_test(&mut self) -> Result<SelfTest, LinkError> {
        let what = "self test";
        match self.request(what, &Message::SelfTest)? {
            Reply::SelfTest(t) => {
                super::reply::check_self_test(&t).map_err(|why| self.bad_reply(what, why))?;
                Ok(t)
            }
            other => Err(self.refused(what, other)),
        }
    }

    /// Stop (mutes at once).
    pub fn stop(&mut self) -> Result<(), LinkError> {
        self.expect_ack("stop", &Message::Stop)
    }

    /// Send one centroid update and wait for its ack.
    pub fn centroid(&mut self, c: Centroid) -> Result<(), LinkError> {
        let retries = self.stats.retries;
        match self.expect_ack("centroid", &Message::Centroid(c)) {
            // A resend whose first copy the device took (its ack was lost):
            // the device keeps only newer updates, so it refuses the copy
            // of the one it holds. One update is in flight at a time, so
            // it holds this one.
            Err(LinkError::Nack {
                code: NackCode::OutOfOrder,
                ..
            }) if self.stats.retries > retries => Ok(()),
            r => r,
        }
    }

    /// Ends a transfer of many requests (an upload, a rig) once a stop
    /// was requested: a device that answers slowly would otherwise hold
    /// Ctrl-C up for as long as the rest takes.
    fn check_stop(&self, what: &'static str) -> Result<(), LinkError> {
        if crate::stop::requested() {
            return Err(LinkError::Stopped {
                port: self.port(),
                what,
            });
        }
        Ok(())
    }

    /// Makes sure the device holds the rig of `positions_um` (CRC `crc`):
    /// asks its `Info` the first time, then remembers; sends the positions
    /// (`BeginRig`, `Geometry` frames, `CommitRig`) only when the device
    /// does not hold them. Returns the position bytes sent (0: none).
    pub fn ensure_rig(&mut self, positions_um: &[[i32; 3]], crc: u32) -> Result<u64, LinkError> {
        let t = u16::try_from(positions_um.len())
            .map_err(|_| LinkError::Codec(CodecError::BadShape))?;
        if self.rig == Some((t, crc)) {
            return Ok(0);
        }
        let info = self.info()?;
        if (info.rig_transducers, info.rig_crc32) == (t, crc) {
            self.rig = Some((t, crc));
            return Ok(0);
        }
        self.rig = None;
        // Another rig drops every library entry.
        self.committed.clear();
        let begin = Message::BeginRig(BeginRig {
            transducers: t,
            crc32: crc,
        });
        self.expect_ack("begin rig", &begin)?;
        // Groups adapt like chunks ([`adapt`]): writes at fixed indices are
        // idempotent, so only the group size changes.
        let min_group = MIN_ADAPTIVE_CHUNK / POSITION_LEN;
        let mut group = adapt::Sizer::new(MAX_GEOMETRY_POSITIONS, min_group, 1);
        let mut first = 0usize;
        while first < positions_um.len() {
            let pts = &positions_um[first..(first + group.size()).min(positions_um.len())];
            let g = Geometry {
                first: first as u16,
                positions: Positions::from_points(pts),
            };
            let retries_before = self.stats.retries;
            self.check_stop("the rig")?;
            self.expect_ack("geometry", &Message::Geometry(g))?;
            first += pts.len();
            group.record(self.stats.retries - retries_before);
        }
        self.expect_ack("commit rig", &Message::CommitRig)?;
        self.rig = Some((t, crc));
        Ok((POSITION_LEN * positions_um.len()) as u64)
    }

    /// Upload `spec` into `slot` (call [`UploadSpec::check_fits`] first)
    /// and commit it, after the rig if the device does not hold it
    /// ([`ensure_rig`](Self::ensure_rig)). `progress(done, total)` is
    /// called after each acked chunk.
    pub fn upload(
        &mut self,
        spec: &UploadSpec,
        slot: u8,
        chunk: usize,
        mut progress: impl FnMut(u64, u64),
    ) -> Result<UploadReport, LinkError> {
        let start = Instant::now();
        let before = self.stats;
        let crc32 = spec.crc32;
        let chunk = chunk.clamp(1, MAX_CHUNK);
        let mut rig_bytes = self.ensure_rig(&spec.positions_um, spec.rig_crc32)?;
        // A begun upload drops the slot's old entry.
        self.committed.remove(&slot);
        let mut last = None;
        for attempt in 0..self.upload_attempts {
            if attempt > 0 {
                self.stats.upload_restarts += 1;
            }
            // A restart after a chunk that never got through starts with
            // frames a quarter the size (down to the adaptive minimum).
            let size = (chunk >> (2 * attempt.min(8))).max(MIN_ADAPTIVE_CHUNK.min(chunk));
            match self.upload_once(spec, slot, size, &mut rig_bytes, &mut progress) {
                Ok(()) => {
                    self.committed.insert(slot, spec.header.steps);
                    let s = self.stats;
                    return Ok(UploadReport {
                        slot,
                        raw_bytes: spec.header.raw_len(),
                        sequence_bytes: spec.encoded.len() as u64,
                        rig_bytes,
                        payload_bytes: (spec.encoded.len()
                            + spec.intensity_table.as_ref().map_or(0, Vec::len))
                            as u64
                            + rig_bytes,
                        wire_bytes_sent: s.bytes_sent - before.bytes_sent,
                        wire_bytes_received: s.bytes_received - before.bytes_received,
                        seconds: start.elapsed().as_secs_f64(),
                        crc32,
                        retries: s.retries - before.retries,
                        restarts: s.upload_restarts - before.upload_restarts,
                    });
                }
                // Refusals that a restart cannot mend end the upload at once.
                Err(
                    e @ LinkError::Nack {
                        code:
                            NackCode::BadSlot
                            | NackCode::SlotPlaying
                            | NackCode::TooLarge
                            | NackCode::DwellTooShort
                            | NackCode::LibraryFull
                            | NackCode::NoRig
                            | NackCode::RigMismatch
                            | NackCode::BadVersion
                            | NackCode::UnknownType,
                        ..
                    },
                ) => return Err(e),
                Err(e @ (LinkError::Io { .. } | LinkError::Stopped { .. })) => return Err(e),
                Err(e) => last = Some(e),
            }
        }
        Err(LinkError::UploadGaveUp {
            attempts: self.upload_attempts,
            last: Box::new(last.expect("at least one attempt")),
        })
    }

    fn upload_once(
        &mut self,
        spec: &UploadSpec,
        slot: u8,
        chunk: usize,
        rig_bytes: &mut u64,
        progress: &mut impl FnMut(u64, u64),
    ) -> Result<(), LinkError> {
        let (encoded, crc32) = (&spec.encoded[..], spec.crc32);
        let begin = Message::BeginUpload(spec.begin(slot));
        match self.expect_ack("begin upload", &begin) {
            // The device lost the rig (a reset) or holds another: send
            // ours again, once, and begin again.
            Err(LinkError::Nack {
                code: NackCode::NoRig | NackCode::RigMismatch,
                ..
            }) => {
                self.rig = None;
                *rig_bytes += self.ensure_rig(&spec.positions_um, spec.rig_crc32)?;
                self.expect_ack("begin upload", &begin)?;
            }
            r => r?,
        }
        let total = encoded.len() as u64;
        // Adaptive chunk size ([`adapt`]): shorter chunks after a resend
        // while they lose less (a noisy link loses fewer short frames),
        // longer again when they do not (a lost reply costs a resend at any
        // length) or after a run of clean ones, never below the floor. A
        // frame is never changed while it may have landed, so resends stay
        // idempotent.
        let mut size = adapt::Sizer::new(chunk, MIN_ADAPTIVE_CHUNK, 16);
        let mut offset = 0usize;
        while offset < encoded.len() {
            let data = &encoded[offset..(offset + size.size()).min(encoded.len())];
            let retries_before = self.stats.retries;
            self.check_stop("the upload")?;
            let msg = Message::Chunk(Chunk {
                slot,
                offset: offset as u32,
                data,
            });
            self.expect_ack("chunk", &msg)?;
            offset += data.len();
            size.record(self.stats.retries - retries_before);
            progress(offset as u64, total);
        }
        // The levels (a few hundred bytes at most per stimulus) in frames of
        // the chunk size; a resend of one is idempotent like a chunk's.
        let levels = spec.intensity_table.as_deref().unwrap_or_default();
        for (i, data) in levels.chunks(chunk.clamp(1, MAX_CHUNK)).enumerate() {
            let offset = u16::try_from(i * chunk.clamp(1, MAX_CHUNK))
                .map_err(|_| LinkError::Codec(CodecError::BadShape))?;
            let msg = Message::Intensity(Intensity { slot, offset, data });
            self.expect_ack("intensity", &msg)?;
        }
        self.expect_ack("commit", &Message::Commit(Commit { slot, crc32 }))
    }
}

/// Why a reply echoing `got` does not answer the request `what` (whose
/// echo is `want`).
fn unbound(got: Option<Echo>, want: Echo, what: &str) -> String {
    match got {
        None => "it carries no echo of a request".into(),
        Some(got) => format!(
            "it answers a request of type {:#04x} with CRC {:#010x}, and the {what} request \
             lmhost wrote has type {:#04x}, CRC {:#010x} (a reply replayed, or made up before \
             the request)",
            got.request_type, got.request_crc32, want.request_type, want.request_crc32
        ),
    }
}

#[cfg(test)]
#[path = "client_tests.rs"]
pub(crate) mod tests;
