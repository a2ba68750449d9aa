//! Framing and decoder properties: round trips, splits, bit flips,
//! resync after garbage, limits.

mod common;

use common::{Out, Owned, Rng, any_message, frame_of, head, run, unframed, wire};
use lm_proto::*;
use proptest::prelude::*;

/// A few frames of different shapes, including one with a full chunk.
fn samples() -> Vec<(u16, Owned)> {
    let data: Vec<u8> = (0..MAX_CHUNK).map(|i| (i * 7 % 251) as u8).collect();
    vec![
        (0, Owned::Plain(Message::GetInfo)),
        (
            0x1234,
            Owned::Plain(Message::Centroid(Centroid {
                seq: 9,
                pos_um: [-1, 0, 220_000],
                present: true,
                host_time_us: 0x0102_0304_0506,
            })),
        ),
        (
            7,
            Owned::Plain(Message::Status(Status {
                state: DeviceState::Muted,
                slot: Some(3),
                step: 81,
                cycles: 12,
                missed_deadlines: 1,
                last_centroid_seq: 9,
                bad_frames: 0,
                crc_errors: 0,
                nacks: 2,
                correction_um: [5, -5, 0],
                queued_slot: Some(0),
                mute_reason: MuteReason::TrackingStale,
                lease_ms: 1000,
                lease_expiries: 3,
                uptime_ms: 4_000_000_000,
            })),
        ),
        (
            65535,
            Owned::Geometry {
                first: 85,
                points: vec![[1, -2, 3], [0, 0, 0], [-96520, 66040, 0]],
            },
        ),
        (
            3,
            Owned::Chunk {
                slot: 0,
                offset: 2048,
                data: data[..100].to_vec(),
            },
        ),
        (
            4,
            Owned::Chunk {
                slot: 1,
                offset: 0,
                data,
            },
        ),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::with_cases(512) })]

    #[test]
    fn every_message_round_trips(seq in any::<u16>(), m in any_message()) {
        let msg = m.msg();
        let w = wire(seq, &msg);
        prop_assert!(w.len() <= MAX_ENCODED_FRAME);
        let h = head(seq, &msg);
        prop_assert_eq!(encoded_frame_len(h, &msg), Ok(w.len()));
        prop_assert_eq!(w[0], 0);
        prop_assert_eq!(w[w.len() - 1], 0);
        prop_assert!(!w[1..w.len() - 1].contains(&0));
        // Through the streaming decoder.
        let mut dec = FrameDecoder::new();
        let mut got = None;
        for &b in &w {
            if let Some(r) = dec.push(b) {
                let f = r.unwrap();
                prop_assert_eq!((f.head(), f.message), (h, msg));
                got = Some(f.seq);
            }
        }
        prop_assert_eq!(got, Some(seq));
        // Through the unframed form and decode_frame.
        let mut buf = vec![0u8; MAX_FRAME];
        let n = encode_frame_unframed(h, &msg, &mut buf).unwrap();
        let echo = if h.echo.is_some() { len::ECHO } else { 0 };
        prop_assert_eq!(n, HEADER_LEN + echo + msg.payload_len() + CRC_LEN);
        let f = decode_frame(&buf[..n]).unwrap();
        prop_assert_eq!((f.head(), f.message), (h, msg));
        prop_assert_eq!(f.crc32, crc32(&buf[..n - CRC_LEN]));
        let mut payload = vec![0u8; MAX_PAYLOAD];
        let p = msg.emit_payload(&mut payload).unwrap();
        prop_assert_eq!(&payload[..p], &buf[HEADER_LEN + echo..n - CRC_LEN]);
    }

    #[test]
    fn random_splits_decode_the_same(
        msgs in proptest::collection::vec((any::<u16>(), any_message()), 1..4),
        cuts in proptest::collection::vec(any::<usize>(), 0..6),
    ) {
        let mut stream = Vec::new();
        let mut want = Vec::new();
        for (seq, m) in &msgs {
            stream.extend(wire(*seq, &m.msg()));
            want.push(Out::Frame(*seq, unframed(&frame_of(*seq, m.msg()))));
        }
        let mut cuts: Vec<usize> = cuts.iter().map(|c| c % (stream.len() + 1)).collect();
        cuts.push(0);
        cuts.push(stream.len());
        cuts.sort();
        let pieces = cuts.windows(2).map(|w| &stream[w[0]..w[1]]);
        prop_assert_eq!(run(&mut FrameDecoder::new(), pieces), want);
    }
}

#[test]
fn split_at_every_byte_boundary_decodes_the_same() {
    for (seq, m) in samples() {
        let w = wire(seq, &m.msg());
        let want = vec![Out::Frame(seq, unframed(&frame_of(seq, m.msg())))];
        for i in 0..=w.len() {
            let got = run(&mut FrameDecoder::new(), [&w[..i], &w[i..]]);
            assert_eq!(got, want, "split at {i} of {}", w.len());
        }
        // And one byte per feed.
        assert_eq!(run(&mut FrameDecoder::new(), w.chunks(1)), want);
    }
}

#[test]
fn single_bit_flip_anywhere_is_rejected_and_the_next_frame_survives() {
    let next = wire(0xAAAA, &Message::Ack);
    let next_out = Out::Frame(0xAAAA, unframed(&frame_of(0xAAAA, Message::Ack)));
    let mut flips = 0;
    for (seq, m) in samples() {
        let w = wire(seq, &m.msg());
        for bit in 0..w.len() * 8 {
            let mut bad = w.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            let mut dec = FrameDecoder::new();
            let mut outs = run(&mut dec, [&bad[..], &next[..]]);
            assert_eq!(
                outs.pop(),
                Some(next_out.clone()),
                "flip of bit {bit} lost the next frame"
            );
            assert!(
                outs.iter().all(|o| matches!(o, Out::Error(_))),
                "flip of bit {bit} of frame seq {seq} was accepted: {outs:?}"
            );
            // Only a flipped leading delimiter can merge silently into a
            // frame that then fails; every other flip reports an error.
            assert!(
                !outs.is_empty() || bit < 8 || bit >= (w.len() - 1) * 8,
                "bit {bit}"
            );
            flips += 1;
        }
    }
    assert!(flips > 8 * 1000);
}

#[test]
fn one_megabyte_of_garbage_then_a_frame_yields_that_frame() {
    let mut rng = Rng::new(0x5EED);
    let mut garbage = vec![0u8; 1 << 20];
    rng.fill(&mut garbage);
    let frame_msg = Message::Commit(Commit {
        slot: 2,
        crc32: 0xDEAD_BEEF,
    });
    let w = wire(77, &frame_msg);
    let mut dec = FrameDecoder::new();
    // Mixed piece sizes, like reads from a port.
    let mut pieces = Vec::new();
    let mut i = 0;
    while i < garbage.len() {
        let n = (1 + rng.below(4000)).min(garbage.len() - i);
        pieces.push(&garbage[i..i + n]);
        i += n;
    }
    pieces.push(&w[..]);
    let outs = run(&mut dec, pieces);
    let (last, rest) = outs.split_last().unwrap();
    assert_eq!(*last, Out::Frame(77, unframed(&frame_of(77, frame_msg))));
    assert!(
        rest.iter().all(|o| matches!(o, Out::Error(_))),
        "garbage produced a frame"
    );
    assert!(
        rest.len() > 1000,
        "each garbage frame is reported ({})",
        rest.len()
    );
    assert!(
        rest.iter()
            .any(|o| matches!(o, Out::Error(FrameError::TooLong)))
    );
}

#[test]
fn too_long_frame_is_reported_once_then_resyncs() {
    let mut long = vec![0u8];
    long.extend(std::iter::repeat_n(0x11, 3 * MAX_FRAME));
    long.push(0);
    let w = wire(5, &Message::Stop);
    let outs = run(&mut FrameDecoder::new(), [&long[..], &w[..]]);
    assert_eq!(outs.len(), 2);
    assert_eq!(outs[0], Out::Error(FrameError::TooLong));
    assert!(matches!(outs[1], Out::Frame(5, _)));
}

#[test]
fn largest_frame_fits_the_limits() {
    // A chunk of MAX_CHUNK zeros is the worst case for neither COBS nor
    // length; non-zero data is the COBS worst case.
    let data = [0xFFu8; MAX_CHUNK];
    let m = Message::Chunk(Chunk {
        slot: 0xFF,
        offset: u32::MAX,
        data: &data,
    });
    let w = wire(0xFFFF, &m);
    assert!(w.len() <= MAX_ENCODED_FRAME);
    assert_eq!(run(&mut FrameDecoder::new(), [&w[..]]).len(), 1);
    // A raw frame of exactly MAX_FRAME bytes passes the length check (and
    // fails only at the payload); one byte more is TooLong.
    let mut raw = vec![0u8; MAX_FRAME];
    raw[..4].copy_from_slice(&[PROTOCOL_VERSION, MessageType::Chunk as u8, 1, 0]);
    let crc = crc32(&raw[..MAX_FRAME - 4]);
    raw[MAX_FRAME - 4..].copy_from_slice(&crc.to_le_bytes());
    assert!(matches!(
        decode_frame(&raw),
        Err(FrameError::Malformed { seq: 1, .. })
    ));
    let mut enc = vec![0u8; MAX_ENCODED_FRAME + 10];
    let n = cobs::encode(&raw, &mut enc[1..]).unwrap();
    let outs = run(&mut FrameDecoder::new(), [&enc[..n + 2]]);
    assert!(
        matches!(outs[..], [Out::Error(FrameError::Malformed { seq: 1, .. })]),
        "{outs:?}"
    );
    raw.push(0);
    let n = cobs::encode(&raw, &mut enc[1..]).unwrap();
    enc[n + 1] = 0;
    assert_eq!(
        run(&mut FrameDecoder::new(), [&enc[..n + 2]]),
        vec![Out::Error(FrameError::TooLong)]
    );
}

/// Re-CRCs a decoded frame after editing it.
fn fix_crc(f: &mut Vec<u8>) {
    f.truncate(f.len() - CRC_LEN);
    let c = crc32(f);
    f.extend(c.to_le_bytes());
}

#[test]
fn wrong_payload_lengths_are_malformed_with_seq() {
    for (seq, m) in samples()
        .into_iter()
        .chain([(9, Owned::Plain(Message::Nack(NackCode::Busy)))])
    {
        let msg = m.msg();
        let good = unframed(&frame_of(seq, msg));
        let t = msg.msg_type() as u8;
        let mut longer = good.clone();
        longer.insert(good.len() - CRC_LEN, 0);
        fix_crc(&mut longer);
        let mut shorter = good.clone();
        if msg.payload_len() > 0 {
            shorter.remove(good.len() - CRC_LEN - 1);
            fix_crc(&mut shorter);
        }
        for (what, f) in [("longer", &longer), ("shorter", &shorter)] {
            if f == &good {
                continue;
            }
            match decode_frame(f) {
                // A chunk's data may grow or shrink by a byte.
                Ok(p) if matches!(msg, Message::Chunk(_)) => assert_eq!(p.seq, seq),
                Err(FrameError::Malformed {
                    seq: s, msg_type, ..
                }) => {
                    assert_eq!((s, msg_type), (seq, t), "{what} {msg:?}")
                }
                other => panic!("{what} {msg:?}: {other:?}"),
            }
        }
    }
}

#[test]
fn a_flags_byte_is_its_one_known_bit_or_malformed() {
    let play = Play {
        slot: 1,
        at: PlayAt::Immediate,
        untracked: true,
        steps: 0,
        lease_ms: 500,
    };
    let mut f = unframed(&frame_of(4, Message::Play(play)));
    let at = field::frame::LEN + field::play::FLAGS.start;
    assert_eq!(f[at], PLAY_FLAG_UNTRACKED);
    assert_eq!(decode_frame(&f).map(|p| p.message), Ok(Message::Play(play)));
    for (flags, want) in [(0, Some(false)), (0x02, None), (0x03, None)] {
        f[at] = flags;
        fix_crc(&mut f);
        match (decode_frame(&f), want) {
            (Ok(p), Some(untracked)) => {
                assert_eq!(p.message, Message::Play(Play { untracked, ..play }))
            }
            (Err(FrameError::Malformed { reason, .. }), None) => {
                assert_eq!(reason, "unknown play flag bits", "flags {flags:#04x}")
            }
            (got, _) => panic!("flags {flags:#04x}: {got:?}"),
        }
    }
}

#[test]
fn invalid_field_values_are_rejected_on_both_sides() {
    let m = Message::Status(Status {
        slot: Some(NO_SLOT),
        ..Status::default()
    });
    let mut buf = [0u8; MAX_ENCODED_FRAME];
    assert_eq!(
        encode_frame(1, &m, &mut buf),
        Err(EncodeError::InvalidField)
    );
    assert_eq!(
        encode_frame(1, &Message::Nack(NackCode::Other(3)), &mut buf),
        Err(EncodeError::InvalidField)
    );
    let too_many = vec![[0i32; 3]; MAX_GEOMETRY_POSITIONS + 1];
    let g = Message::Geometry(Geometry {
        first: 0,
        positions: Positions::from_points(&too_many),
    });
    assert_eq!(encoded_frame_len(1, &g), Err(EncodeError::TooLarge));
    // A parsed geometry over the limit is malformed too.
    let mut f = vec![PROTOCOL_VERSION, MessageType::Geometry as u8, 3, 0, 0, 0];
    f.extend(std::iter::repeat_n(1u8, 12 * (MAX_GEOMETRY_POSITIONS + 1)));
    f.extend([0; 4]);
    fix_crc(&mut f);
    assert!(matches!(
        decode_frame(&f),
        Err(FrameError::Malformed { seq: 3, .. })
    ));
}

#[test]
fn unknown_types_carry_seq_and_type_for_the_nack() {
    for t in 0u8..=255 {
        if MessageType::from_u8(t).is_some() {
            continue;
        }
        let mut f = vec![PROTOCOL_VERSION, t, 0x34, 0x12, 1, 2, 3, 0, 0, 0, 0];
        fix_crc(&mut f);
        let e = decode_frame(&f).unwrap_err();
        assert_eq!(
            e,
            FrameError::UnknownType {
                seq: 0x1234,
                msg_type: t,
                crc32: crc32(&f[..f.len() - CRC_LEN]),
            }
        );
        let echo = Echo {
            request_type: t,
            request_crc32: crc32(&f[..f.len() - CRC_LEN]),
        };
        assert_eq!(
            e.nack(),
            Some((Head::reply(0x1234, echo), NackCode::UnknownType))
        );
    }
}

#[test]
fn positions_read_back_from_bytes() {
    let pts = [[1, -2, 3], [i32::MIN, i32::MAX, 0]];
    let m = Message::Geometry(Geometry {
        first: 4,
        positions: Positions::from_points(&pts),
    });
    let w = wire(1, &m);
    let mut dec = FrameDecoder::new();
    let mut seen = false;
    for &b in &w {
        if let Some(Ok(Frame {
            message: Message::Geometry(g),
            ..
        })) = dec.push(b)
        {
            assert_eq!(g.positions.len(), 2);
            assert_eq!(g.positions.iter().collect::<Vec<_>>(), pts.to_vec());
            assert_eq!(g.positions.get(1), Some(pts[1]));
            assert_eq!(g.positions.get(2), None);
            seen = true;
        }
    }
    assert!(seen);
    assert!(Positions::from_le_bytes(&[0; 13]).is_none());
}

#[test]
fn display_messages_are_one_line() {
    let errs = [
        FrameError::TooLong,
        FrameError::Cobs,
        FrameError::TooShort { len: 3 },
        FrameError::Crc {
            received: 1,
            computed: 2,
        },
        FrameError::BadVersion {
            version: 2,
            seq: 1,
            msg_type: 1,
            crc32: 3,
        },
        FrameError::UnknownType {
            seq: 1,
            msg_type: 0x42,
            crc32: 3,
        },
        FrameError::Malformed {
            seq: 1,
            msg_type: 6,
            crc32: 3,
            reason: "unknown play timing",
        },
    ];
    for e in errs {
        let s = e.to_string();
        assert!(!s.is_empty() && !s.contains('\n'), "{s:?}");
    }
    assert_eq!(NackCode::Other(99).to_string(), "unknown nack code 99");
    for b in 0..=255u8 {
        assert_eq!(NackCode::from_u8(b).to_u8(), b);
    }
}
