use super::*;

fn roundtrip(enc: Encoding, phases: &[u8], t: usize, piece: usize) -> usize {
    let mut buf = [0u8; 4096];
    let n = encode(enc, phases, t, &mut buf).unwrap();
    assert_eq!(n, encoded_len(enc, phases, t).unwrap());
    let steps = (phases.len() / t) as u16;
    let mut d = Decoder::new(enc, steps, t as u16);
    let mut out = [0u8; 4096];
    for p in buf[..n].chunks(piece.max(1)) {
        d.feed(p, &mut out).unwrap();
    }
    d.finish().unwrap();
    assert_eq!(d.consumed(), n);
    assert_eq!(&out[..phases.len()], phases);
    n
}

#[test]
fn residual_codes_cover_every_value() {
    for e in i8::MIN..=i8::MAX {
        let (code, len) = residual_code(e);
        let d = Decoder {
            acc: code,
            nbits: len,
            ..Decoder::new(Encoding::Delta, 0, 0)
        };
        assert_eq!(d.peek_code(), Some((e, len)), "residual {e}");
    }
}

#[test]
fn small_roundtrips() {
    let phases: [u8; 60] = core::array::from_fn(|i| (i * i * 7) as u8);
    for enc in [Encoding::Raw, Encoding::Delta] {
        for piece in [1, 2, 5, 64] {
            roundtrip(enc, &phases, 6, piece);
            roundtrip(enc, &phases[..6], 6, piece);
            roundtrip(enc, &phases[..12], 3, piece);
            roundtrip(enc, &[], 3, piece);
        }
        // Zero steps: any byte is too many.
        let mut d = Decoder::new(enc, 0, 5);
        d.feed(&[], &mut []).unwrap();
        assert_eq!(d.feed(&[1], &mut []), Err(CodecError::Overlong));
    }
}

#[test]
fn step_decoder_matches_the_whole_sequence_step_by_step() {
    let t = 7;
    let phases: [u8; 7 * 13] = core::array::from_fn(|i| ((i / 7) * (i % 7 + 2) * 5 + i % 3) as u8);
    for enc in [Encoding::Raw, Encoding::Delta] {
        let mut buf = [0u8; 512];
        let n = encode(enc, &phases, t, &mut buf).unwrap();
        let stream = &buf[..n];
        // Fed in small pieces: every step reported once, in order.
        for piece in [1, 3, 64] {
            let mut d = StepDecoder::new(enc, 13, t as u16);
            let mut ring = [0u8; 21];
            let mut seen = 0u16;
            for p in stream.chunks(piece) {
                let used = d
                    .feed(p, &mut ring, u16::MAX, |k, row| {
                        assert_eq!(k, seen);
                        assert_eq!(row, &phases[usize::from(k) * t..][..t]);
                        seen += 1;
                    })
                    .unwrap();
                assert_eq!(used, p.len());
            }
            d.finish().unwrap();
            assert_eq!((seen, d.consumed()), (13, n));
        }
        // One step per call from the stored stream, twice round.
        let mut d = StepDecoder::new(enc, 13, t as u16);
        let mut ring = [0u8; 21];
        for _cycle in 0..2 {
            for k in 0..13u16 {
                let at = d.consumed();
                d.feed(&stream[at..], &mut ring, 1, |_, _| {}).unwrap();
                assert_eq!(d.steps_done(), k + 1);
                let row = StepDecoder::row(&ring, t, k);
                assert_eq!(row, &phases[usize::from(k) * t..][..t], "{enc:?} step {k}");
            }
            d.finish().unwrap();
            d.restart();
        }
        let mut d = StepDecoder::new(enc, 13, t as u16);
        let mut long = [0u8; 513];
        long[..n].copy_from_slice(stream);
        assert_eq!(
            d.feed(&long[..n + 1], &mut ring, u16::MAX, |_, _| {}),
            Err(CodecError::Overlong)
        );
    }
}

/// The encoder as first written, one code and one byte at a time: the
/// fast encoder must produce exactly its bytes and errors.
fn encode_bitwise(phases: &[u8], t: usize, out: &mut [u8]) -> Result<usize, CodecError> {
    check_shape(phases, t)?;
    let head = t.min(phases.len());
    out.get_mut(..head)
        .ok_or(CodecError::BufferTooSmall)?
        .copy_from_slice(&phases[..head]);
    let mut n = head;
    let (mut acc, mut nbits) = (0u32, 0u32);
    for e in residuals(phases, t) {
        let (code, len) = residual_code(e);
        acc = (acc << len) | code;
        nbits += len;
        while nbits >= 8 {
            nbits -= 8;
            *out.get_mut(n).ok_or(CodecError::BufferTooSmall)? = (acc >> nbits) as u8;
            n += 1;
        }
        acc &= (1 << nbits) - 1;
    }
    if nbits > 0 {
        *out.get_mut(n).ok_or(CodecError::BufferTooSmall)? = (acc << (8 - nbits)) as u8;
        n += 1;
    }
    Ok(n)
}

#[test]
fn encoder_matches_the_bitwise_encoder() {
    // SplitMix64: residuals from smooth (mostly 0, ±1) to random.
    let mut state = 0x5eed_u64;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let mut phases = [0u8; 2048];
    let (mut fast, mut slow) = ([0u8; 4096], [0u8; 4096]);
    for case in 0..400 {
        let t = 1 + (next() % 300) as usize;
        let steps = (next() % 7) as usize;
        let noise = [1, 3, 17, 256][case % 4];
        let phases = &mut phases[..(t * steps).min(2048) / t * t];
        for (i, p) in phases.iter_mut().enumerate() {
            let (k, j) = (i / t, i % t);
            let smooth = (k * (j % 13 + 1) + j * 7) as u64;
            *p = (smooth + next() % noise) as u8;
        }
        let want = encode_bitwise(phases, t, &mut slow);
        let len = want.unwrap();
        assert_eq!(encoded_len(Encoding::Delta, phases, t), Ok(len));
        // Roomy, exact and short buffers: same bytes, same errors.
        for size in [4096, len, len.saturating_sub(1), len / 2] {
            let got = encode(Encoding::Delta, phases, t, &mut fast[..size]);
            assert_eq!(
                got,
                encode_bitwise(phases, t, &mut slow[..size]),
                "case {case}"
            );
            if let Ok(n) = got {
                assert_eq!(fast[..n], slow[..n], "case {case} size {size}");
            }
        }
    }
}

#[test]
fn spec_example() {
    let phases = [10, 250, 12, 255, 14, 4];
    let mut out = [0u8; 8];
    let n = encode(Encoding::Delta, &phases, 2, &mut out).unwrap();
    assert_eq!(&out[..n], &[0x0a, 0xfa, 0xc5, 0x94]);
    roundtrip(Encoding::Delta, &phases, 2, 1);
}

#[test]
fn rejects_bad_streams() {
    // 2 steps × 2: step 0 raw, then residual codes `0`,`0` + 6 padding bits.
    let mut out = [0u8; 4];
    let mut d = Decoder::new(Encoding::Delta, 2, 2);
    assert_eq!(
        d.feed(&[9, 9, 0b0000_0001], &mut out),
        Err(CodecError::BadPadding)
    );
    assert_eq!(
        d.feed(&[], &mut out),
        Err(CodecError::BadPadding),
        "errors are sticky"
    );
    let mut d = Decoder::new(Encoding::Delta, 2, 2);
    assert_eq!(d.feed(&[9, 9, 0, 0], &mut out), Err(CodecError::Overlong));
    let mut d = Decoder::new(Encoding::Delta, 2, 2);
    d.feed(&[9, 9], &mut out).unwrap();
    assert_eq!(d.finish(), Err(CodecError::Truncated));
    d.feed(&[0], &mut out).unwrap();
    assert_eq!(d.finish(), Ok(()));
    assert_eq!(out, [9, 9, 9, 9]);
    let mut d = Decoder::new(Encoding::Raw, 2, 2);
    assert_eq!(d.feed(&[1], &mut out[..3]), Err(CodecError::BufferTooSmall));
    assert_eq!(
        encode(Encoding::Raw, &[1, 2, 3], 2, &mut out),
        Err(CodecError::BadShape)
    );
    assert_eq!(
        encode(Encoding::Delta, &[1, 2], 0, &mut out),
        Err(CodecError::BadShape)
    );
    assert_eq!(
        encode(Encoding::Raw, &[1, 2], 2, &mut out[..1]),
        Err(CodecError::BufferTooSmall)
    );
}
