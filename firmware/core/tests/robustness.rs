//! Random and mutated frames fed to the device: it never panics, answers
//! at most once per frame with a well-formed response, and never sounds a
//! slot whose commit was not acknowledged.
//!
//! Quick run in `cargo test`; the 10^6-frame run is ignored:
//! `cargo test --release -p lm-fw-core --test robustness -- --ignored --nocapture`

mod common;

use common::*;
use lm_fw_core::{Device, OutputDriver, OutputFrame};
use lm_proto::codec::Encoding;
use lm_proto::{
    BeginRig, BeginUpload, Centroid, Chunk, Commit, Geometry, Intensity, MAX_ENCODED_FRAME,
    MAX_FRAME, Message, PROTOCOL_VERSION, Play, PlayAt, Positions, UploadHeader, cobs,
    encode_frame,
};

/// Fails the test if a sounding frame comes from a slot that is not
/// known-committed.
struct Guard {
    committed: [bool; lm_fw_core::SLOTS],
    sounding: u64,
    frames: u64,
}

impl OutputDriver for Guard {
    type Error = ();
    fn write_frame(&mut self, f: &OutputFrame<'_>) -> Result<(), ()> {
        self.frames += 1;
        if f.amplitude > 0 {
            self.sounding += 1;
            assert!(
                self.committed
                    .get(usize::from(f.slot))
                    .copied()
                    .unwrap_or(false),
                "sounding uncommitted slot {}",
                f.slot
            );
        }
        Ok(())
    }
}

const POINTS: [[i32; 3]; 16] = [[1_000, -2_000, 0]; 16];

/// A random request, biased towards values the small device accepts.
fn random_message(r: &mut Rng, data: &'static [u8], seqs: &mut u32) -> Message<'static> {
    let slot = r.below(3) as u8;
    let t = 1 + r.below(18) as u16;
    match r.below(12) {
        0 => Message::GetInfo,
        10 => {
            let t = 1 + r.below(18) as u16;
            Message::BeginRig(BeginRig {
                transducers: t,
                crc32: Seq::pattern(1, t, 1000, 0).rig_crc32(),
            })
        }
        11 => Message::CommitRig,
        1 => Message::GetStatus,
        2 => Message::BeginUpload(BeginUpload {
            slot,
            header: UploadHeader {
                steps: 1 + r.below(40) as u16,
                transducers: t,
                period_us: (r.below(200) as u32 + 1) * 1000,
                center_um: [r.next() as i32 % 50_000, 0, 200_000],
                foci_per_step: r.byte(),
                // Mostly valid, sometimes 0 or far out of range.
                sound_speed_mm_s: match r.below(8) {
                    0 => 0,
                    1 => r.next() as u32,
                    _ => 300_000 + r.below(100_000) as u32,
                },
                max_offset_um: match r.below(8) {
                    0 => 0,
                    1 => r.next() as u32,
                    _ => 1 + r.below(30_000) as u32,
                },
                intensity: r.byte(),
            },
            // Mostly the rig of the scripted uploads' sequences.
            rig_crc32: if r.below(8) == 0 {
                r.next() as u32
            } else {
                Seq::pattern(1, t, 1000, 0).rig_crc32()
            },
            encoding: if r.below(2) == 0 {
                Encoding::Raw
            } else {
                Encoding::Delta
            },
            encoded_len: r.below(700) as u32,
            intensity_table: r.below(2) == 0,
        }),
        3 => {
            // 1 ..: a list of no elements cannot be encoded (SPEC, Lists).
            let n = 1 + r.below(16) as usize;
            Message::Geometry(Geometry {
                first: r.below(20) as u16,
                positions: Positions::from_points(&POINTS[..n]),
            })
        }
        4 if r.below(2) == 0 => {
            // Intensity levels: mostly in range of a small table.
            let n = 1 + r.below(data.len().min(48) as u64) as usize;
            Message::Intensity(Intensity {
                slot,
                offset: r.mostly_below(40) as u16,
                data: &data[..n],
            })
        }
        4 | 5 => {
            let n = 1 + r.below(data.len() as u64) as usize;
            Message::Chunk(Chunk {
                slot,
                offset: r.mostly_below(700) as u32,
                data: &data[..n],
            })
        }
        6 => Message::Commit(Commit {
            slot,
            crc32: if r.below(2) == 0 {
                lm_proto::crc32(&data[..r.below(64) as usize])
            } else {
                r.next() as u32
            },
        }),
        7 => Message::Play(Play {
            slot,
            at: if r.below(2) == 0 {
                PlayAt::NextCycle
            } else {
                PlayAt::Immediate
            },
            untracked: r.below(4) == 0,
            steps: if r.below(3) == 0 {
                r.below(40) as u32
            } else {
                0
            },
            // Mostly valid leases, short ones (so they expire within the
            // run), and some out of range.
            lease_ms: match r.below(8) {
                0 => r.next() as u16,
                1..=3 => 100 + r.below(200) as u16,
                _ => lm_proto::DEFAULT_LEASE_MS,
            },
        }),
        8 => {
            *seqs = seqs.wrapping_add(r.below(3) as u32).wrapping_sub(1);
            Message::Centroid(Centroid {
                seq: *seqs,
                // Mostly near the centre, sometimes anywhere (the work
                // volume must refuse those).
                pos_um: if r.below(8) == 0 {
                    [r.next() as i32, r.next() as i32, r.next() as i32]
                } else {
                    [r.next() as i32 % 20_000, r.next() as i32 % 20_000, 200_000]
                },
                present: r.below(4) != 0,
                host_time_us: r.next(),
            })
        }
        _ => Message::Stop,
    }
}

/// Encodes `decoded` (header + payload, CRC appended here) for the wire.
fn wire_with_valid_crc(body: &[u8], out: &mut Vec<u8>) {
    let mut frame = body.to_vec();
    frame.extend_from_slice(&lm_proto::crc32(body).to_le_bytes());
    let mut enc = vec![0u8; cobs::max_encoded_len(frame.len())];
    let n = cobs::encode(&frame, &mut enc).unwrap();
    out.push(0);
    out.extend_from_slice(&enc[..n]);
    out.push(0);
}

fn mutate(r: &mut Rng, bytes: &mut Vec<u8>) {
    for _ in 0..1 + r.below(4) {
        if bytes.is_empty() {
            bytes.push(r.byte());
        }
        let i = r.below(bytes.len() as u64) as usize;
        match r.below(5) {
            0 => bytes[i] ^= 1 << r.below(8),
            1 => bytes[i] = r.byte(),
            2 => bytes.insert(i, r.byte()),
            3 => {
                bytes.remove(i);
            }
            _ => bytes.truncate(i),
        }
    }
}

/// Runs `frames` random frames; returns (frames fed, replies, sounding frames out).
fn run(seed: u64, frames: u64) -> (u64, u64, u64) {
    let mut r = Rng(seed);
    let mut dev: Device<'static> = device(config(16), 512);
    let mut guard = Guard {
        committed: [false; lm_fw_core::SLOTS],
        sounding: 0,
        frames: 0,
    };
    let data: &'static [u8] = Box::leak((0..1024).map(|i| (i * 13 % 251) as u8).collect());
    let mut now = 0u64;
    let mut seqs = 0u32;
    let mut replies = 0u64;
    let mut wire = [0u8; MAX_ENCODED_FRAME];
    let mut bytes = Vec::with_capacity(2 * MAX_ENCODED_FRAME);
    let mut fed = 0u64;
    let mut script: Vec<Message<'static>> = Vec::new();
    while fed < frames {
        bytes.clear();
        let mut known = None;
        if script.is_empty() && r.below(200) == 0 {
            // Now and then a complete, valid upload (and a play), so the
            // random frames also hit playing and queued slots.
            let seq = Seq::pattern(
                1 + r.below(30) as u16,
                1 + r.below(16) as u16,
                40_000,
                r.byte(),
            );
            let seq: &'static Seq = Box::leak(Box::new(seq));
            let enc = if r.below(2) == 0 {
                Encoding::Raw
            } else {
                Encoding::Delta
            };
            let stream: &'static [u8] = Box::leak(seq.encode(enc).into_boxed_slice());
            let slot = r.below(2) as u8;
            script.extend(seq.upload_requests(slot, enc, stream, 1 + r.below(200) as usize));
            script.push(seq.commit(slot));
            script.push(play(
                slot,
                if r.below(2) == 0 {
                    PlayAt::NextCycle
                } else {
                    PlayAt::Immediate
                },
            ));
            script.reverse();
        }
        let kind = if script.is_empty() { r.below(10) } else { 0 };
        match kind {
            // Valid frames (40 %): the handler logic with random fields.
            0..=3 => {
                let msg = match script.pop() {
                    Some(m) => m,
                    None => random_message(&mut r, data, &mut seqs),
                };
                let seq = r.next() as u16;
                let n = encode_frame(seq, &msg, &mut wire).unwrap();
                bytes.extend_from_slice(&wire[..n]);
                known = Some((seq, msg));
            }
            // Mutated valid frames.
            4..=6 => {
                let msg = random_message(&mut r, data, &mut seqs);
                let n = encode_frame(r.next() as u16, &msg, &mut wire).unwrap();
                bytes.extend_from_slice(&wire[..n]);
                mutate(&mut r, &mut bytes);
            }
            // Valid CRC, random type and payload (reaches payload parsing).
            7 | 8 => {
                let cap = if r.below(20) == 0 {
                    MAX_FRAME as u64 + 8
                } else {
                    48
                };
                let len = r.below(cap) as usize;
                let mut body = vec![
                    if r.below(16) == 0 {
                        r.byte()
                    } else {
                        PROTOCOL_VERSION
                    },
                    if r.below(4) == 0 {
                        r.byte()
                    } else {
                        1 + r.below(10) as u8
                    },
                    r.byte(),
                    r.byte(),
                ];
                body.extend((0..len).map(|_| {
                    if r.below(3) == 0 {
                        r.below(3) as u8
                    } else {
                        r.byte()
                    }
                }));
                wire_with_valid_crc(&body, &mut bytes);
            }
            // Line noise.
            _ => {
                let len = r.below(300) as usize;
                bytes.extend((0..len).map(|_| if r.below(40) == 0 { 0 } else { r.byte() }));
            }
        }
        // Feed in random pieces.
        let mut rest: &[u8] = &bytes;
        let mut got = Vec::new();
        while !rest.is_empty() {
            let n = 1 + r.below(rest.len() as u64) as usize;
            let (piece, tail) = rest.split_at(n);
            got.extend(feed(&mut dev, piece, now));
            rest = tail;
        }
        replies += got.len() as u64;
        // Track which slots are known-committed from acknowledged requests.
        if let Some((seq, msg)) = known {
            // A partial frame left by earlier noise may be completed (and
            // answered) by this frame's leading delimiter; ours comes last.
            let (rseq, reply) = got.last().expect("a valid request gets a response");
            assert_eq!(*rseq, seq);
            if *reply == Reply::Ack {
                match msg {
                    Message::BeginUpload(b) => guard.committed[usize::from(b.slot)] = false,
                    Message::Commit(c) => guard.committed[usize::from(c.slot)] = true,
                    _ => {}
                }
            }
        }
        assert!(got.len() <= 2, "at most one reply per frame");
        // Never steered outside a work volume: an applied correction is at
        // most the largest work volume a slot can have.
        let c = dev
            .status(now)
            .correction_um
            .map(|v| i128::from(v) * i128::from(v));
        let max = i128::from(*lm_proto::MAX_OFFSET_UM.end());
        assert!(c.iter().sum::<i128>() <= max * max, "{c:?}");
        let step = if r.below(50) == 0 { 10_000_000 } else { 3000 };
        now += r.below(step);
        dev.poll(now, &mut guard);
        fed += 1;
    }
    let s = dev.status(now);
    assert_eq!(s.nacks, dev.counters().nacks);
    (fed, replies, guard.sounding)
}

#[test]
fn random_frames_quick() {
    let (fed, replies, sounding) = run(0x5EED, 20_000);
    assert_eq!(fed, 20_000);
    assert!(replies > 8_000, "{replies} replies");
    assert!(sounding > 0, "the run should reach playing states");
}

#[test]
#[ignore = "long: run in release with --ignored"]
fn random_frames_million() {
    let mut total = 0;
    let mut replies = 0;
    let mut sounding = 0;
    let per_seed = (250_000.0 * long_scale()).round() as u64;
    for seed in 1..=4u64 {
        let (f, rep, s) = run(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15), per_seed);
        total += f;
        replies += rep;
        sounding += s;
    }
    println!(
        "robustness: {total} random/mutated frames fed, {replies} responses, {sounding} sounding frames, 0 panics"
    );
    assert!(total >= 4 * per_seed);
    assert!(sounding > 0, "the run should reach playing states");
}

/// The long run's share of its full size: `LM_LONG_SCALE` in (0, 1] (the
/// CI's everyday run), 1 when unset (`cargo xtask ci --full`).
fn long_scale() -> f64 {
    let s = std::env::var("LM_LONG_SCALE")
        .ok()
        .and_then(|s| s.parse().ok());
    s.filter(|s: &f64| *s > 0.0 && *s <= 1.0).unwrap_or(1.0)
}
