//! Shared host-side helpers: a tiny "host" that encodes requests and
//! decodes the device's responses, and sequence builders.
#![allow(dead_code)]

use lm_fw_core::{Config, Device, OutputDriver, OutputFrame, SpiOutput, memory_bytes};
use lm_proto::codec::Encoding;
use lm_proto::{
    BeginRig, BeginUpload, Chunk, Commit, FeedResult, FrameDecoder, Geometry, MAX_CHUNK,
    MAX_ENCODED_FRAME, MAX_GEOMETRY_POSITIONS, Message, NackCode, Play, PlayAt, Positions,
    UploadHeader, encode_frame,
};

/// Deterministic xorshift64* generator (no dependency, reproducible).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
    pub fn byte(&mut self) -> u8 {
        self.next() as u8
    }
    /// Below `n` seven times in eight, else any value: mostly what a
    /// device accepts, sometimes far out of range.
    pub fn mostly_below(&mut self, n: u64) -> u64 {
        if self.below(8) == 0 {
            self.next()
        } else {
            self.below(n)
        }
    }
}

/// Leaks sequence memory for a device (tests only): a library of twice
/// `slot_bytes`, so two raw sequences of that size fit (the two slots of
/// protocol version 2).
pub fn memory(slot_bytes: usize, max_t: usize) -> &'static mut [u8] {
    Box::leak(vec![0u8; memory_bytes(2 * slot_bytes, max_t)].into_boxed_slice())
}

pub fn device(cfg: Config, slot_bytes: usize) -> Device<'static> {
    let max_t = usize::from(cfg.max_transducers);
    Device::new(cfg, memory(slot_bytes, max_t)).unwrap()
}

/// Owned copy of a response (messages borrow their frame).
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    Ack,
    Nack(NackCode),
    Info(lm_proto::Info),
    Status(lm_proto::Status),
    SelfTest(lm_proto::SelfTest),
    Other,
}

/// Sends one request and returns the single response, which must carry
/// the request's seq and echo its type and CRC. A response sent to the
/// device (which it refuses) goes with a made-up echo of its own.
pub fn request(dev: &mut Device<'_>, seq: u16, msg: &Message<'_>, now: u64) -> Reply {
    let mut wire = [0u8; MAX_ENCODED_FRAME];
    let head = if msg.msg_type().is_response() {
        let made_up = lm_proto::Echo {
            request_type: 0x09,
            request_crc32: 1,
        };
        lm_proto::Head::reply(seq, made_up)
    } else {
        lm_proto::Head::from(seq)
    };
    let n = encode_frame(head, msg, &mut wire).unwrap();
    let want = match FrameDecoder::new().feed(&wire[..n]) {
        FeedResult::Frame { frame, .. } => frame.reply_head(),
        other => panic!("our own frame does not decode: {other:?}"),
    };
    let replies = feed_heads(dev, &wire[..n], now);
    assert_eq!(
        replies.len(),
        1,
        "one response per request, got {replies:?}"
    );
    assert_eq!(replies[0].0, want, "response echoes seq, type and CRC");
    replies.into_iter().next().unwrap().1
}

/// Feeds raw bytes; returns every (seq, reply) the device sent.
pub fn feed(dev: &mut Device<'_>, bytes: &[u8], now: u64) -> Vec<(u16, Reply)> {
    feed_heads(dev, bytes, now)
        .into_iter()
        .map(|(h, r)| (h.seq, r))
        .collect()
}

/// Feeds raw bytes; returns every (head, reply) the device sent.
pub fn feed_heads(dev: &mut Device<'_>, bytes: &[u8], now: u64) -> Vec<(lm_proto::Head, Reply)> {
    let mut out = Vec::new();
    let mut driver = lm_fw_core::RecordingDriver::<1>::new();
    dev.feed(bytes, now, &mut driver, &mut |b: &[u8]| {
        out.extend_from_slice(b)
    });
    let mut dec = FrameDecoder::new();
    let mut replies = Vec::new();
    let mut input: &[u8] = &out;
    loop {
        input = match dec.feed(input) {
            FeedResult::Consumed => break,
            FeedResult::Frame { frame, remaining } => {
                let r = match frame.message {
                    Message::Ack => Reply::Ack,
                    Message::Nack(c) => Reply::Nack(c),
                    Message::Info(i) => Reply::Info(i),
                    Message::Status(s) => Reply::Status(s),
                    Message::SelfTestResult(t) => Reply::SelfTest(t),
                    _ => Reply::Other,
                };
                replies.push((frame.head(), r));
                remaining
            }
            FeedResult::Error { error, .. } => panic!("device sent a bad frame: {error}"),
        };
    }
    replies
}

/// A planned sequence: raw phases and transducer positions.
#[derive(Clone)]
pub struct Seq {
    pub steps: u16,
    pub transducers: u16,
    pub period_us: u32,
    pub center_um: [i32; 3],
    /// Speed of sound the sequence was planned with, mm/s.
    pub sound_speed_mm_s: u32,
    pub phases: Vec<u8>,
    pub positions: Vec<[i32; 3]>,
}

impl Seq {
    /// A smooth pattern (so Delta compresses) distinct per `tag`.
    pub fn pattern(steps: u16, transducers: u16, period_us: u32, tag: u8) -> Self {
        let t = usize::from(transducers);
        let phases = (0..usize::from(steps) * t)
            .map(|i| {
                let (k, j) = (i / t, i % t);
                (k * 3 + j * 7 + usize::from(tag) * 31) as u8
            })
            .collect();
        let positions = (0..t)
            .map(|j| {
                let (x, y) = ((j % 18) as i32, (j / 18) as i32);
                [x * 10_160 - 86_360, y * 10_160 - 66_040, 0]
            })
            .collect();
        Self {
            steps,
            transducers,
            period_us,
            center_um: [0, 0, 200_000],
            sound_speed_mm_s: 340_000,
            phases,
            positions,
        }
    }

    pub fn step(&self, k: u16) -> &[u8] {
        let t = usize::from(self.transducers);
        &self.phases[usize::from(k) * t..(usize::from(k) + 1) * t]
    }

    pub fn encode(&self, enc: Encoding) -> Vec<u8> {
        let mut buf = vec![0u8; self.phases.len() * 2 + 64];
        let n = lm_proto::codec::encode(enc, &self.phases, usize::from(self.transducers), &mut buf)
            .unwrap();
        buf.truncate(n);
        buf
    }

    pub fn begin(&self, slot: u8, enc: Encoding) -> Message<'static> {
        Message::BeginUpload(BeginUpload {
            slot,
            header: UploadHeader {
                steps: self.steps,
                transducers: self.transducers,
                period_us: self.period_us,
                center_um: self.center_um,
                foci_per_step: 1,
                sound_speed_mm_s: self.sound_speed_mm_s,
                max_offset_um: 20_000,
                intensity: 255,
            },
            encoding: enc,
            encoded_len: self.encode(enc).len() as u32,
            rig_crc32: self.rig_crc32(),
            intensity_table: false,
        })
    }

    /// CRC-32 of the positions (the rig this sequence was planned for).
    pub fn rig_crc32(&self) -> u32 {
        lm_proto::rig_crc32(&Positions::from_points(&self.positions))
    }

    /// The rig upload: `BeginRig`, `Geometry` frames, `CommitRig` (all
    /// acked again when the device already holds this rig).
    pub fn rig_requests(&self) -> Vec<Message<'_>> {
        let mut v = vec![Message::BeginRig(BeginRig {
            transducers: self.transducers,
            crc32: self.rig_crc32(),
        })];
        for (i, ps) in self.positions.chunks(MAX_GEOMETRY_POSITIONS).enumerate() {
            v.push(Message::Geometry(Geometry {
                first: (i * MAX_GEOMETRY_POSITIONS) as u16,
                positions: Positions::from_points(ps),
            }));
        }
        v.push(Message::CommitRig);
        v
    }

    /// Every request of an upload except the commit, in order (the rig's
    /// first).
    pub fn upload_requests<'a>(
        &'a self,
        slot: u8,
        enc: Encoding,
        stream: &'a [u8],
        chunk: usize,
    ) -> Vec<Message<'a>> {
        let mut v = self.rig_requests();
        v.push(self.begin(slot, enc));
        for (i, c) in stream.chunks(chunk.min(MAX_CHUNK)).enumerate() {
            v.push(Message::Chunk(Chunk {
                slot,
                offset: (i * chunk.min(MAX_CHUNK)) as u32,
                data: c,
            }));
        }
        v
    }

    pub fn commit(&self, slot: u8) -> Message<'static> {
        Message::Commit(Commit {
            slot,
            crc32: lm_proto::crc32(&self.phases),
        })
    }

    /// Uploads and commits; panics on any nack.
    pub fn upload(&self, dev: &mut Device<'_>, slot: u8, enc: Encoding, now: u64) {
        let stream = self.encode(enc);
        for (i, m) in self
            .upload_requests(slot, enc, &stream, 700)
            .iter()
            .enumerate()
        {
            assert_eq!(
                request(dev, i as u16, m, now),
                Reply::Ack,
                "request {i}: {m:?}"
            );
        }
        assert_eq!(request(dev, 999, &self.commit(slot), now), Reply::Ack);
    }
}

pub fn play(slot: u8, at: PlayAt) -> Message<'static> {
    Message::Play(Play {
        slot,
        at,
        untracked: false,
        steps: 0,
        lease_ms: lm_proto::DEFAULT_LEASE_MS,
    })
}

/// Output driver keeping every frame (with its phases) in memory.
#[derive(Default)]
pub struct Capture {
    pub frames: Vec<(u64, u8, u16, u8, Vec<u8>)>,
}

impl OutputDriver for Capture {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, f: &OutputFrame<'_>) -> Result<(), Self::Error> {
        self.frames
            .push((f.due, f.slot, f.step, f.amplitude, f.phases.to_vec()));
        Ok(())
    }
}

/// Test configuration: 1 MHz timer, small array, tracking not required.
pub fn config(max_t: u16) -> Config {
    let mut c = Config::new(1_000_000);
    c.max_transducers = max_t;
    c.require_tracking = false;
    c
}

/// An SPI device keeping each transaction's written bytes.
#[derive(Default)]
pub struct Wire {
    pub transactions: Vec<Vec<u8>>,
}

impl embedded_hal::spi::ErrorType for Wire {
    type Error = core::convert::Infallible;
}

impl embedded_hal::spi::SpiDevice for Wire {
    fn transaction(
        &mut self,
        ops: &mut [embedded_hal::spi::Operation<'_, u8>],
    ) -> Result<(), Self::Error> {
        let mut bytes = Vec::new();
        for op in ops.iter() {
            if let embedded_hal::spi::Operation::Write(w) = op {
                bytes.extend_from_slice(w);
            }
        }
        self.transactions.push(bytes);
        Ok(())
    }
}

impl Wire {
    /// Polls a playing `dev` through [`SpiOutput`] from time 0 until the
    /// wire holds `n` transactions (those the last poll sent beyond are
    /// dropped); returns the deadline it reached.
    pub fn play(&mut self, dev: &mut Device<'_>, n: usize) -> u64 {
        let mut now = 0;
        while self.transactions.len() < n {
            now = dev
                .poll(now, &mut SpiOutput::new(&mut *self))
                .expect("a playing device has a deadline");
        }
        self.transactions.truncate(n);
        now
    }
}
