//! Randomised robustness run: at least 10^6 random and mutated inputs
//! through the frame decoder, the frame parser and the codec decoder.
//! Ignored by default (release mode takes seconds, debug minutes):
//!
//! ```text
//! cargo test --release -p lm-proto --test fuzz -- --ignored --nocapture
//! ```
//!
//! `LM_PROTO_FUZZ_CASES` (default 1000000) and `LM_PROTO_FUZZ_SEED` change
//! the run. Checks, beyond "never panics": every frame the decoder accepts
//! re-encodes to a frame that parses the same; every buffer `decode_frame`
//! accepts is exactly the canonical encoding of what it parsed; a valid
//! frame sent after any input is always received; the codec decoder never
//! writes past the sequence.

mod common;

use common::{Owned, Rng, decode_in_pieces, frame_of, unframed};
use lm_proto::codec;
use lm_proto::*;

fn env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn random_message(rng: &mut Rng) -> Owned {
    let x = |rng: &mut Rng| {
        [
            rng.next_u64() as i32,
            rng.next_u64() as i32,
            rng.next_u64() as i32,
        ]
    };
    let m = match rng.below(19) {
        0 => Message::GetInfo,
        1 => Message::Stop,
        2 => Message::GetStatus,
        3 => Message::Ack,
        4 => Message::Nack(NackCode::from_u8(rng.byte())),
        5 => Message::Commit(Commit {
            slot: rng.byte(),
            crc32: rng.u32(),
        }),
        6 => Message::Play(Play {
            slot: rng.byte(),
            at: if rng.below(2) == 0 {
                PlayAt::NextCycle
            } else {
                PlayAt::Immediate
            },
            untracked: rng.below(2) == 1,
            steps: if rng.below(2) == 0 { 0 } else { rng.u32() },
            lease_ms: rng.u16(),
        }),
        7 => Message::Centroid(Centroid {
            seq: rng.u32(),
            pos_um: x(rng),
            present: rng.below(2) == 1,
            host_time_us: rng.next_u64(),
        }),
        8 => Message::Info(Info {
            proto_version: rng.byte(),
            fw_version: [rng.byte(), rng.byte(), rng.byte()],
            max_transducers: rng.u16(),
            slot_bytes: rng.u32(),
            slots: rng.byte(),
            timer_hz: rng.u32(),
            min_dwell_us: rng.u32(),
            max_chunk: rng.u16(),
            rig_transducers: rng.u16(),
            rig_crc32: rng.u32(),
            library_free: rng.u32(),
            clock: ClockSource::from_u8(rng.byte() % 4).unwrap(),
        }),
        9 => Message::BeginUpload(BeginUpload {
            slot: rng.byte(),
            header: UploadHeader {
                steps: rng.u16(),
                transducers: rng.u16(),
                period_us: rng.u32(),
                center_um: x(rng),
                foci_per_step: rng.byte(),
                sound_speed_mm_s: rng.u32(),
                max_offset_um: rng.u32(),
                intensity: rng.byte(),
            },
            encoding: rng.encoding(),
            encoded_len: rng.u32(),
            rig_crc32: rng.u32(),
            intensity_table: rng.below(2) == 1,
        }),
        13 => Message::BeginRig(BeginRig {
            transducers: rng.u16(),
            crc32: rng.u32(),
        }),
        14 => Message::CommitRig,
        15 => Message::Renew,
        16 => Message::SelfTest,
        17 => Message::SelfTestResult(match rng.below(3) {
            0 => SelfTest::Unsupported,
            1 => SelfTest::Passed { bytes: rng.u32() },
            _ => SelfTest::Failed {
                bytes: rng.u32(),
                mismatches: rng.u32(),
                first_mismatch: rng.u32(),
                sent: rng.byte(),
                got: rng.byte(),
            },
        }),
        10 => Message::Status(Status {
            state: [
                DeviceState::Idle,
                DeviceState::Playing,
                DeviceState::Muted,
                DeviceState::Stopped,
            ][rng.below(4)],
            slot: if rng.below(4) == 0 {
                None
            } else {
                Some(rng.below(255) as u8)
            },
            step: rng.u16(),
            cycles: rng.u32(),
            missed_deadlines: rng.u32(),
            last_centroid_seq: rng.u32(),
            bad_frames: rng.u32(),
            crc_errors: rng.u32(),
            nacks: rng.u32(),
            correction_um: x(rng),
            queued_slot: if rng.below(2) == 0 {
                None
            } else {
                Some(rng.below(255) as u8)
            },
            mute_reason: MuteReason::from_u8(rng.below(7) as u8).unwrap(),
            lease_ms: rng.u16(),
            lease_expiries: rng.u32(),
            uptime_ms: rng.u32(),
        }),
        11 => {
            let n = 1 + rng.below(MAX_GEOMETRY_POSITIONS);
            return Owned::Geometry {
                first: rng.u16(),
                points: (0..n).map(|_| x(rng)).collect(),
            };
        }
        18 => {
            let mut data = vec![0u8; 1 + rng.below(MAX_CHUNK)];
            rng.fill(&mut data);
            return Owned::Intensity {
                slot: rng.byte(),
                offset: rng.u16(),
                data,
            };
        }
        _ => {
            let mut data = vec![0u8; 1 + rng.below(MAX_CHUNK)];
            rng.fill(&mut data);
            // Zeros are the interesting byte for COBS.
            for _ in 0..rng.below(8) {
                let i = rng.below(data.len());
                data[i] = 0;
            }
            return Owned::Chunk {
                slot: rng.byte(),
                offset: rng.u32(),
                data,
            };
        }
    };
    Owned::Plain(m)
}

fn wire_of(rng: &mut Rng) -> Vec<u8> {
    let m = random_message(rng);
    common::wire(rng.u16(), &m.msg())
}

/// Applies 1-4 random mutations.
fn mutate(rng: &mut Rng, mut v: Vec<u8>) -> Vec<u8> {
    for _ in 0..1 + rng.below(4) {
        let len = v.len();
        match rng.below(8) {
            0 if len > 0 => {
                let i = rng.below(len * 8);
                v[i / 8] ^= 1 << (i % 8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                v[i] = rng.byte();
            }
            2 if len > 0 => v.truncate(rng.below(len)),
            3 => {
                let i = rng.below(len + 1);
                let mut ins = vec![0u8; 1 + rng.below(16)];
                rng.fill(&mut ins);
                v.splice(i..i, ins);
            }
            4 if len > 0 => {
                let a = rng.below(len);
                let b = a + rng.below(len - a) + 1;
                let dup = v[a..b].to_vec();
                let i = rng.below(len + 1);
                v.splice(i..i, dup);
            }
            5 => {
                let other = wire_of(rng);
                let cut = rng.below(len + 1);
                let from = rng.below(other.len() + 1);
                v.truncate(cut);
                v.extend_from_slice(&other[from..]);
            }
            6 if len > 0 => {
                let a = rng.below(len);
                let b = a + rng.below(len - a) + 1;
                v.drain(a..b);
            }
            7 if len > 0 => {
                let i = rng.below(len);
                v[i] = 0;
            }
            _ => {}
        }
    }
    v
}

#[derive(Default)]
struct Counts {
    stream_inputs: u64,
    frames: u64,
    errors: u64,
    parse_inputs: u64,
    parse_ok: u64,
    codec_inputs: u64,
    codec_ok: u64,
}

/// Feeds `input` then a sentinel frame in random pieces; checks every
/// accepted frame and that the sentinel arrives last.
fn stream_case(rng: &mut Rng, dec: &mut FrameDecoder, input: &[u8], c: &mut Counts) {
    let sentinel_seq = rng.u16();
    let sentinel = common::wire(sentinel_seq, &Message::GetStatus);
    let mut all = input.to_vec();
    all.extend_from_slice(&sentinel);
    let mut last: Option<Result<u16, FrameError>> = None;
    let mut check = |r: Result<Frame<'_>, FrameError>, c: &mut Counts| match r {
        Ok(f) => {
            c.frames += 1;
            let bytes = unframed(&f);
            assert_eq!(
                decode_frame(&bytes),
                Ok(f),
                "accepted frame does not round-trip"
            );
            last = Some(Ok(f.seq));
        }
        Err(e) => {
            c.errors += 1;
            assert!(!e.to_string().is_empty());
            last = Some(Err(e));
        }
    };
    for piece in rng.pieces(&all, 300) {
        if rng.below(8) == 0 {
            for &b in piece {
                if let Some(r) = dec.push(b) {
                    check(r, c);
                }
            }
        } else {
            let mut rest = piece;
            loop {
                rest = match dec.feed(rest) {
                    FeedResult::Consumed => break,
                    FeedResult::Frame { frame, remaining } => {
                        check(Ok(frame), c);
                        remaining
                    }
                    FeedResult::Error { error, remaining } => {
                        check(Err(error), c);
                        remaining
                    }
                };
            }
        }
    }
    assert_eq!(
        last,
        Some(Ok(sentinel_seq)),
        "the frame after the input was lost"
    );
    assert!(dec.is_idle());
}

fn parse_case(rng: &mut Rng, c: &mut Counts) {
    // A decoded frame (header, payload, CRC), mutated, CRC fixed up half
    // the time so the payload parser sees the damage.
    let m = random_message(rng);
    let mut f = unframed(&frame_of(rng.u16(), m.msg()));
    f = mutate(rng, f);
    if rng.below(2) == 0 && f.len() >= 4 {
        if rng.below(2) == 0 {
            f[1] = rng.byte();
        }
        let n = f.len() - 4;
        let crc = crc32(&f[..n]);
        f[n..].copy_from_slice(&crc.to_le_bytes());
    }
    c.parse_inputs += 1;
    if let Ok(frame) = decode_frame(&f) {
        c.parse_ok += 1;
        assert_eq!(unframed(&frame), f, "accepted bytes are not canonical");
    }
}

fn codec_case(rng: &mut Rng, c: &mut Counts) {
    let (steps, t, enc) = rng.shape(40, 64);
    let raw_len = steps as usize * t as usize;
    let stream = if rng.below(2) == 0 {
        let mut s = vec![0u8; rng.below(2 * raw_len + 4)];
        rng.fill(&mut s);
        s
    } else {
        let mut phases = vec![0u8; raw_len];
        rng.fill(&mut phases);
        let mut s = vec![0u8; codec::encoded_len(enc, &phases, t as usize).unwrap()];
        codec::encode(enc, &phases, t as usize, &mut s).unwrap();
        if rng.below(4) == 0 { s } else { mutate(rng, s) }
    };
    let (d, out) = decode_in_pieces(rng, (steps, t, enc), &stream, 128);
    c.codec_inputs += 1;
    if d.finish().is_ok() {
        c.codec_ok += 1;
        // Whatever decoded must re-encode to a stream of the same length
        // at most (encoders use the shortest codes).
        let n = codec::encoded_len(enc, &out, t as usize).unwrap();
        assert!(n <= stream.len());
    }
}

#[test]
#[ignore = "long randomised run; use --release (see module docs)"]
fn decoder_parser_and_codec_never_panic() {
    let cases = env("LM_PROTO_FUZZ_CASES", 1_000_000);
    let seed = env("LM_PROTO_FUZZ_SEED", 0x1A2B_3C4D);
    let mut rng = Rng::new(seed);
    let mut c = Counts::default();
    let mut dec = FrameDecoder::new();
    let start = std::time::Instant::now();
    for n in 0..cases {
        // Fresh decoder now and then; usually carry state across inputs.
        if n % 64 == 0 {
            dec = FrameDecoder::new();
        }
        let input = match rng.below(4) {
            0 => {
                let zero_every = [0usize, 2, 16, 256][rng.below(4)];
                let cap = rng.below(2 * MAX_ENCODED_FRAME) + 1;
                let mut v = vec![0u8; rng.below(cap)];
                rng.fill(&mut v);
                for b in v.iter_mut() {
                    if zero_every > 0 && rng.below(zero_every) == 0 {
                        *b = 0;
                    } else if *b == 0 {
                        *b = 1;
                    }
                }
                v
            }
            _ => {
                let w = wire_of(&mut rng);
                mutate(&mut rng, w)
            }
        };
        stream_case(&mut rng, &mut dec, &input, &mut c);
        c.stream_inputs += 1;
        parse_case(&mut rng, &mut c);
        codec_case(&mut rng, &mut c);
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "lm-proto fuzz: seed {seed:#x}: {} stream inputs (+1 sentinel frame each; {} frames, {} errors reported), \
         {} decode_frame inputs ({} accepted), {} codec streams ({} complete); {:.1} s",
        c.stream_inputs,
        c.frames,
        c.errors,
        c.parse_inputs,
        c.parse_ok,
        c.codec_inputs,
        c.codec_ok,
        secs
    );
    assert!(c.stream_inputs >= cases && c.parse_inputs >= cases && c.codec_inputs >= cases);
    assert!(c.errors > cases / 2, "mutations should mostly be rejected");
}

/// The same run, small, so plain `cargo test` exercises the harness.
#[test]
fn short_fuzz_run() {
    let mut rng = Rng::new(7);
    let mut c = Counts::default();
    let mut dec = FrameDecoder::new();
    for _ in 0..300 {
        let w = wire_of(&mut rng);
        let input = mutate(&mut rng, w);
        stream_case(&mut rng, &mut dec, &input, &mut c);
        parse_case(&mut rng, &mut c);
        codec_case(&mut rng, &mut c);
    }
    assert!(c.errors > 0 && c.frames >= 300);
}
