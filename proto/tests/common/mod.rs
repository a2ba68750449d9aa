//! Shared test helpers: owned messages for proptest, a seeded PRNG, and
//! helpers that run a decoder over a byte stream.
#![allow(dead_code)]

pub mod paper;
/// One SplitMix64 for the host and these tests.
#[path = "../../../host/src/rng.rs"]
mod splitmix;

use lm_proto::*;
use proptest::prelude::*;

/// A message that owns its bulk bytes, so strategies can produce it.
#[derive(Clone, Debug)]
pub enum Owned {
    Plain(Message<'static>),
    Geometry {
        first: u16,
        points: Vec<[i32; 3]>,
    },
    Chunk {
        slot: u8,
        offset: u32,
        data: Vec<u8>,
    },
    Intensity {
        slot: u8,
        offset: u16,
        data: Vec<u8>,
    },
}

impl Owned {
    pub fn msg(&self) -> Message<'_> {
        match self {
            Owned::Plain(m) => *m,
            Owned::Geometry { first, points } => Message::Geometry(Geometry {
                first: *first,
                positions: Positions::from_points(points),
            }),
            Owned::Chunk { slot, offset, data } => Message::Chunk(Chunk {
                slot: *slot,
                offset: *offset,
                data,
            }),
            Owned::Intensity { slot, offset, data } => Message::Intensity(Intensity {
                slot: *slot,
                offset: *offset,
                data,
            }),
        }
    }
}

fn xyz() -> impl Strategy<Value = [i32; 3]> {
    any::<[i32; 3]>()
}

fn nack_code() -> impl Strategy<Value = NackCode> {
    any::<u8>().prop_map(NackCode::from_u8)
}

/// Every message type, with arbitrary field values.
pub fn any_message() -> impl Strategy<Value = Owned> {
    let plain = prop_oneof![
        Just(Message::GetInfo),
        Just(Message::Stop),
        Just(Message::GetStatus),
        Just(Message::Ack),
        Just(Message::Renew),
        Just(Message::SelfTest),
        prop_oneof![
            Just(SelfTest::Unsupported),
            any::<u32>().prop_map(|bytes| SelfTest::Passed { bytes }),
            any::<(u32, u32, u32, u8, u8)>().prop_map(
                |(bytes, mismatches, first_mismatch, sent, got)| SelfTest::Failed {
                    bytes,
                    mismatches,
                    first_mismatch,
                    sent,
                    got,
                }
            ),
        ]
        .prop_map(Message::SelfTestResult),
        nack_code().prop_map(Message::Nack),
        (any::<u8>(), any::<u32>())
            .prop_map(|(slot, crc32)| Message::Commit(Commit { slot, crc32 })),
        (
            any::<u8>(),
            any::<bool>(),
            any::<bool>(),
            any::<u32>(),
            any::<u16>()
        )
            .prop_map(|(slot, now, untracked, steps, lease_ms)| {
                Message::Play(Play {
                    slot,
                    at: if now {
                        PlayAt::Immediate
                    } else {
                        PlayAt::NextCycle
                    },
                    untracked,
                    steps,
                    lease_ms,
                })
            }),
        (any::<u32>(), xyz(), any::<bool>(), any::<u64>()).prop_map(|(seq, pos_um, present, t)| {
            Message::Centroid(Centroid {
                seq,
                pos_um,
                present,
                host_time_us: t,
            })
        }),
        (
            any::<u8>(),
            any::<[u8; 3]>(),
            any::<u16>(),
            any::<u32>(),
            any::<u8>(),
            any::<u32>(),
            any::<u32>(),
            (
                any::<u16>(),
                any::<u16>(),
                any::<u32>(),
                any::<u32>(),
                0u8..4
            )
        )
            .prop_map(
                |(p, fw, mt, sb, sl, hz, dw, (mc, rt, rc, lf, ck))| Message::Info(Info {
                    proto_version: p,
                    fw_version: fw,
                    max_transducers: mt,
                    slot_bytes: sb,
                    slots: sl,
                    timer_hz: hz,
                    min_dwell_us: dw,
                    max_chunk: mc,
                    rig_transducers: rt,
                    rig_crc32: rc,
                    library_free: lf,
                    clock: ClockSource::from_u8(ck).unwrap(),
                })
            ),
        (any::<u16>(), any::<u32>())
            .prop_map(|(transducers, crc32)| Message::BeginRig(BeginRig { transducers, crc32 })),
        Just(Message::CommitRig),
        (
            (
                any::<u8>(),
                any::<u16>(),
                any::<u16>(),
                any::<u32>(),
                any::<bool>()
            ),
            (any::<u32>(), xyz(), any::<u8>(), any::<u32>(), any::<u32>()),
            (any::<u32>(), any::<u8>(), any::<bool>())
        )
            .prop_map(
                |(
                    (slot, steps, t, period, delta),
                    (len, c, f, speed, off),
                    (rig, intensity, table),
                )| {
                    Message::BeginUpload(BeginUpload {
                        slot,
                        header: UploadHeader {
                            steps,
                            transducers: t,
                            period_us: period,
                            center_um: c,
                            foci_per_step: f,
                            sound_speed_mm_s: speed,
                            max_offset_um: off,
                            intensity,
                        },
                        encoding: if delta {
                            Encoding::Delta
                        } else {
                            Encoding::Raw
                        },
                        encoded_len: len,
                        rig_crc32: rig,
                        intensity_table: table,
                    })
                }
            ),
        (
            (
                0u8..4,
                proptest::option::of(0u8..=254),
                any::<u16>(),
                any::<[u32; 6]>()
            ),
            xyz(),
            proptest::option::of(0u8..=254),
            0u8..7,
            any::<(u16, u32, u32)>()
        )
            .prop_map(
                |(
                    (st, slot, step, c),
                    corr,
                    queued,
                    reason,
                    (lease_ms, lease_expiries, uptime_ms),
                )| {
                    Message::Status(Status {
                        state: [
                            DeviceState::Idle,
                            DeviceState::Playing,
                            DeviceState::Muted,
                            DeviceState::Stopped,
                        ][st as usize],
                        slot,
                        step,
                        cycles: c[0],
                        missed_deadlines: c[1],
                        last_centroid_seq: c[2],
                        bad_frames: c[3],
                        crc_errors: c[4],
                        nacks: c[5],
                        correction_um: corr,
                        queued_slot: queued,
                        mute_reason: MuteReason::from_u8(reason).unwrap(),
                        lease_ms,
                        lease_expiries,
                        uptime_ms,
                    })
                }
            ),
    ];
    prop_oneof![
        6 => plain.prop_map(Owned::Plain),
        1 => (any::<u16>(), proptest::collection::vec(xyz(), 1..=MAX_GEOMETRY_POSITIONS))
            .prop_map(|(first, points)| Owned::Geometry { first, points }),
        1 => (any::<u8>(), any::<u32>(), proptest::collection::vec(any::<u8>(), 1..=MAX_CHUNK))
            .prop_map(|(slot, offset, data)| Owned::Chunk { slot, offset, data }),
        1 => (any::<u8>(), any::<u16>(), proptest::collection::vec(any::<u8>(), 1..=MAX_CHUNK))
            .prop_map(|(slot, offset, data)| Owned::Intensity { slot, offset, data }),
    ]
}

/// What a decoder reported, owned.
#[derive(Clone, Debug, PartialEq)]
pub enum Out {
    Frame(u16, Vec<u8>),
    Error(FrameError),
}

/// The head the tests send `m` with: its seq, and for a response an echo
/// made up from the seq (the decoder checks an echo's length, not what it
/// says: that is the host's business).
pub fn head(seq: u16, m: &Message<'_>) -> Head {
    if m.msg_type().is_response() {
        let echo = Echo {
            request_type: 0x09,
            request_crc32: 0x5EED_0000 | u32::from(seq),
        };
        Head::reply(seq, echo)
    } else {
        Head::from(seq)
    }
}

/// The frame the tests send `m` as (see [`head`]); its CRC is not known
/// here and left 0 (nothing compares it).
pub fn frame_of<'a>(seq: u16, m: Message<'a>) -> Frame<'a> {
    Frame {
        seq,
        echo: head(seq, &m).echo,
        crc32: 0,
        message: m,
    }
}

/// Canonical bytes of a frame (for comparing frames after the decoder's
/// buffer is reused).
pub fn unframed(f: &Frame<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; MAX_FRAME];
    let n = encode_frame_unframed(f.head(), &f.message, &mut buf).expect("parsed frames re-encode");
    buf.truncate(n);
    buf
}

/// Feeds `pieces` in order to `dec`, collecting everything it reports.
pub fn run<'a>(dec: &mut FrameDecoder, pieces: impl IntoIterator<Item = &'a [u8]>) -> Vec<Out> {
    let mut outs = Vec::new();
    for piece in pieces {
        let mut input = piece;
        loop {
            input = match dec.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Frame { frame, remaining } => {
                    outs.push(Out::Frame(frame.seq, unframed(&frame)));
                    remaining
                }
                FeedResult::Error { error, remaining } => {
                    outs.push(Out::Error(error));
                    remaining
                }
            };
        }
    }
    outs
}

pub fn wire(seq: u16, m: &Message<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; MAX_ENCODED_FRAME];
    let n = encode_frame(head(seq, m), m, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// Decodes `stream` as `enc`, `steps` × `t`, fed in random pieces of up to
/// `max` bytes and stopping at the first error, into a buffer with guard
/// bytes past the sequence; asserts the decoder never wrote into them.
/// Returns the decoder (for its verdict) and the sequence.
pub fn decode_in_pieces(
    rng: &mut Rng,
    (steps, t, enc): (u16, u16, Encoding),
    stream: &[u8],
    max: usize,
) -> (codec::Decoder, Vec<u8>) {
    const GUARD: usize = 16;
    let raw_len = usize::from(steps) * usize::from(t);
    let mut out = vec![0u8; raw_len + GUARD];
    out[raw_len..].fill(0xA5);
    let mut d = codec::Decoder::new(enc, steps, t);
    for piece in rng.pieces(stream, max) {
        if d.feed(piece, &mut out).is_err() {
            break;
        }
    }
    assert!(
        out[raw_len..].iter().all(|&b| b == 0xA5),
        "decoder wrote past the sequence"
    );
    out.truncate(raw_len);
    (d, out)
}

/// The host's SplitMix64 (seeded, the same numbers on every machine),
/// with the draws the wire tests want.
pub struct Rng(splitmix::SplitMix64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(splitmix::SplitMix64::new(seed))
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// The low 16 bits of a draw.
    pub fn u16(&mut self) -> u16 {
        self.next_u64() as u16
    }
    /// The low 32 bits of a draw.
    pub fn u32(&mut self) -> u32 {
        self.next_u64() as u32
    }
    /// Uniform in `0..n` (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// Raw or Delta, evenly (one `below(2)` draw).
    pub fn encoding(&mut self) -> lm_proto::Encoding {
        if self.below(2) == 0 {
            lm_proto::Encoding::Raw
        } else {
            lm_proto::Encoding::Delta
        }
    }
    /// A random sequence shape: steps in `0..steps_below`, transducers in
    /// `1..=max_t`, and an encoding (drawn in that order).
    pub fn shape(&mut self, steps_below: usize, max_t: usize) -> (u16, u16, lm_proto::Encoding) {
        let steps = self.below(steps_below) as u16;
        let t = self.below(max_t) as u16 + 1;
        (steps, t, self.encoding())
    }
    /// `bytes` cut at random into consecutive pieces of 1..=`max` bytes, as
    /// a reader may get them.
    pub fn pieces<'a>(&mut self, bytes: &'a [u8], max: usize) -> Vec<&'a [u8]> {
        let mut v = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            let j = (i + 1 + self.below(max)).min(bytes.len());
            v.push(&bytes[i..j]);
            i = j;
        }
        v
    }
    pub fn byte(&mut self) -> u8 {
        self.next_u64() as u8
    }
    pub fn fill(&mut self, buf: &mut [u8]) {
        for c in buf.chunks_mut(8) {
            let r = self.next_u64().to_le_bytes();
            c.copy_from_slice(&r[..c.len()]);
        }
    }
}
