//! Sequence codec: round trips in arbitrary pieces, named hard cases,
//! malformed streams, and the compression the Delta encoding exists for.

mod common;

use common::paper::{autd3_2x2_um, lm_phases};
use common::{Rng, decode_in_pieces};
use lm_proto::codec::{self, CodecError, Decoder, StepDecoder};
use lm_proto::{Encoding, crc32};
use proptest::prelude::*;
use std::ops::Range;

/// Encodes, then decodes in pieces of the given sizes (cycled); checks
/// length bookkeeping and returns the encoded length.
fn roundtrip(enc: Encoding, phases: &[u8], t: usize, pieces: &[usize]) -> usize {
    let n = codec::encoded_len(enc, phases, t).unwrap();
    let mut buf = vec![0u8; n];
    assert_eq!(codec::encode(enc, phases, t, &mut buf), Ok(n));
    let steps = (phases.len() / t) as u16;
    let mut d = Decoder::new(enc, steps, t as u16);
    assert_eq!(d.raw_len(), phases.len());
    let mut out = vec![0u8; phases.len()];
    let mut i = 0;
    for &p in pieces.iter().cycle() {
        if i >= n {
            break;
        }
        let j = (i + p.max(1)).min(n);
        d.feed(&buf[i..j], &mut out).unwrap();
        i = j;
        assert_eq!(d.consumed(), i);
    }
    if n == 0 {
        d.feed(&[], &mut out).unwrap();
    }
    assert_eq!(d.finish(), Ok(()));
    assert!(d.is_complete());
    assert_eq!(out, phases);
    assert_eq!(crc32(&out), crc32(phases));
    // One byte more is overlong; one byte less is truncated.
    let mut d = Decoder::new(enc, steps, t as u16);
    let mut longer = buf.clone();
    longer.push(0);
    assert_eq!(d.feed(&longer, &mut out), Err(CodecError::Overlong));
    if n > 0 {
        let mut d = Decoder::new(enc, steps, t as u16);
        d.feed(&buf[..n - 1], &mut out).unwrap();
        assert_eq!(d.finish(), Err(CodecError::Truncated));
    }
    n
}

/// Random walk per transducer: the shape of real sequences.
fn smooth(steps: usize, t: usize, max_step: i32, seed: u64) -> Vec<u8> {
    let mut rng = Rng::new(seed);
    let mut p: Vec<i32> = (0..t).map(|_| rng.below(256) as i32).collect();
    let mut v: Vec<i32> = (0..t)
        .map(|_| rng.below(2 * max_step as usize + 1) as i32 - max_step)
        .collect();
    let mut out = Vec::with_capacity(steps * t);
    for _ in 0..steps {
        for k in 0..t {
            out.push(p[k].rem_euclid(256) as u8);
            p[k] += v[k] + rng.below(3) as i32 - 1;
            v[k] = (v[k] + rng.below(3) as i32 - 1).clamp(-max_step, max_step);
        }
    }
    out
}

/// An upload to round-trip: `(steps, transducers, seed for its phases,
/// sizes of the pieces it arrives in)`, each drawn from the range given.
fn uploads(
    steps: Range<usize>,
    t: Range<usize>,
    piece: Range<usize>,
    n_pieces: Range<usize>,
) -> impl Strategy<Value = (usize, usize, u64, Vec<usize>)> {
    (
        steps,
        t,
        any::<u64>(),
        proptest::collection::vec(piece, n_pieces),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::with_cases(256) })]

    #[test]
    fn arbitrary_sequences_round_trip(
        (steps, t, seed, pieces) in uploads(0..12, 1..40, 1..50, 1..5),
        delta in any::<bool>(),
    ) {
        let mut rng = Rng::new(seed);
        let mut phases = vec![0u8; steps * t];
        rng.fill(&mut phases);
        let enc = if delta { Encoding::Delta } else { Encoding::Raw };
        roundtrip(enc, &phases, t, &pieces);
    }

    #[test]
    fn smooth_sequences_round_trip_and_shrink(
        (steps, t, seed, pieces) in uploads(3..60, 1..64, 1..300, 1..4),
    ) {
        let phases = smooth(steps, t, 7, seed);
        let n = roundtrip(Encoding::Delta, &phases, t, &pieces);
        prop_assert_eq!(roundtrip(Encoding::Raw, &phases, t, &pieces), phases.len());
        // Step 1's residuals are first differences, a speed of up to ±7
        // plus ±1 of noise: ±8 takes the 11-bit code. From step 2 on they
        // are changes of speed (±1) plus two noises (±2): at most 7 bits.
        let later = phases.len() - 2 * t;
        prop_assert!(n <= t + (t * 11 + later * 7).div_ceil(8));
    }
}

#[test]
fn named_hard_cases() {
    let t = 17;
    let cases: Vec<(&str, Vec<u8>, usize)> = vec![
        ("all zero", vec![0; 40 * t], t),
        ("all 255", vec![255; 40 * t], t),
        (
            "alternating 0/255 (wraps every step)",
            (0..40 * t)
                .map(|i| if (i / t) % 2 == 0 { 0 } else { 255 })
                .collect(),
            t,
        ),
        (
            "alternating 0/128 (residual -128 and +128)",
            (0..40 * t)
                .map(|i| if (i / t) % 2 == 0 { 0 } else { 128 })
                .collect(),
            t,
        ),
        (
            "ramp +127 per step",
            (0..40 * t).map(|i| ((i / t) * 127) as u8).collect(),
            t,
        ),
        (
            "ramp -128 per step",
            (0..40 * t).map(|i| ((i / t) * 128) as u8).collect(),
            t,
        ),
        (
            "quadratic (max residuals)",
            (0..40 * t)
                .map(|i| ((i / t) * (i / t) * 64 + i % t) as u8)
                .collect(),
            t,
        ),
        ("single step", (0..t as u8).collect(), t),
        (
            "single transducer",
            (0..200).map(|i| (i * i) as u8).collect(),
            1,
        ),
        ("one phase", vec![200], 1),
        ("empty", vec![], t),
        ("996 transducers", smooth(30, 996, 7, 1), 996),
    ];
    for (name, phases, t) in cases {
        for enc in [Encoding::Raw, Encoding::Delta] {
            for pieces in [&[1usize][..], &[3, 1, 1000], &[100_000]] {
                let n = roundtrip(enc, &phases, t, pieces);
                assert!(n > 0 || phases.is_empty(), "{name}");
            }
        }
        // Delta never costs more than 11/8 of raw.
        let d = codec::encoded_len(Encoding::Delta, &phases, t).unwrap();
        assert!(
            d <= t.min(phases.len()) + (phases.len().saturating_sub(t) * 11).div_ceil(8),
            "{name}"
        );
    }
    // Constant sequences cost one bit per phase after step 0.
    assert_eq!(
        codec::encoded_len(Encoding::Delta, &[7; 17 * 9], 17),
        Ok(17 + (17 * 8usize).div_ceil(8))
    );
}

/// The step decoder (a ring of three steps) agrees with the whole-sequence
/// decoder on random streams, fed in random pieces: the same steps, the
/// same verdict.
#[test]
fn step_decoder_agrees_with_the_decoder_on_random_streams() {
    let mut rng = Rng::new(7);
    for case in 0..3000 {
        let (steps, t, enc) = rng.shape(12, 9);
        // Half valid streams (maybe cut or extended), half noise.
        let mut stream = if case % 2 == 0 {
            let mut phases = vec![0u8; usize::from(steps) * usize::from(t)];
            rng.fill(&mut phases);
            let mut buf = vec![0u8; phases.len() * 2 + 8];
            let n = codec::encode(enc, &phases, usize::from(t), &mut buf).unwrap();
            buf.truncate(n);
            buf
        } else {
            let mut b = vec![0u8; rng.below(200)];
            rng.fill(&mut b);
            b
        };
        match rng.below(4) {
            0 => stream.truncate(stream.len().saturating_sub(1)),
            1 => stream.push(rng.below(256) as u8),
            _ => {}
        }
        let mut whole = vec![0u8; usize::from(steps) * usize::from(t)];
        let mut d = Decoder::new(enc, steps, t);
        let r1 = d.feed(&stream, &mut whole).and_then(|()| d.finish());
        let mut s = StepDecoder::new(enc, steps, t);
        let mut ring = vec![0u8; StepDecoder::ring_len(usize::from(t))];
        let mut rows = Vec::new();
        let mut r2 = Ok(());
        for piece in rng.pieces(&stream, 16) {
            match s.feed(piece, &mut ring, u16::MAX, |_, row| {
                rows.extend_from_slice(row)
            }) {
                Ok(used) => assert_eq!(used, piece.len(), "case {case}"),
                Err(e) => {
                    r2 = Err(e);
                    break;
                }
            }
        }
        let r2 = r2.and_then(|()| s.finish());
        assert_eq!(r1.is_ok(), r2.is_ok(), "case {case}: {r1:?} vs {r2:?}");
        if r1.is_ok() {
            assert_eq!(rows, whole, "case {case}");
        }
    }
}

#[test]
fn random_streams_never_panic_and_never_overrun() {
    let mut rng = Rng::new(42);
    for _ in 0..2000 {
        let shape = rng.shape(20, 30);
        let mut stream = vec![0u8; rng.below(400)];
        rng.fill(&mut stream);
        let (d, _) = decode_in_pieces(&mut rng, shape, &stream, 64);
        assert!(d.decoded() <= d.raw_len());
        let _ = d.finish();
    }
    // A too-small output is an error, not a panic.
    let mut d = Decoder::new(Encoding::Delta, 4, 4);
    assert_eq!(
        d.feed(&[1, 2, 3], &mut [0u8; 15]),
        Err(CodecError::BufferTooSmall)
    );
}

#[test]
fn delta_compresses_paper_stimuli() {
    let pos = autd3_2x2_um();
    assert_eq!(pos.len(), 996);
    for foci in [1, 4] {
        for r in [2.0, 3.0, 4.0, 5.0, 6.0] {
            // The paper's 0.23 mm steps, focus plane at 220 mm.
            let (phases, steps) = lm_phases(&pos, foci, r, 0.23, 220.0);
            let n = codec::encoded_len(Encoding::Delta, &phases, pos.len()).unwrap();
            let ratio = n as f64 / phases.len() as f64;
            // The alternative Delta was measured against: first differences
            // as 4-bit nibbles (−7..=7), escape nibble + byte otherwise.
            let t = pos.len();
            let nibble_bits: usize = (t..phases.len())
                .map(|i| {
                    if (phases[i].wrapping_sub(phases[i - t]) as i8).abs() <= 7 {
                        4
                    } else {
                        12
                    }
                })
                .sum();
            let nibble = (t + nibble_bits.div_ceil(8)) as f64 / phases.len() as f64;
            eprintln!(
                "LM-{} r={r} mm: {steps} steps, delta {n} / raw {} bytes = {ratio:.3} (first-difference nibbles: {nibble:.3})",
                if foci == 1 { "S" } else { "M" },
                phases.len()
            );
            assert!(ratio <= 0.5, "LM foci={foci} r={r}: ratio {ratio}");
            roundtrip(Encoding::Delta, &phases, pos.len(), &[1024]);
        }
    }
}
