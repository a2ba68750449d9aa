//! Sequence codecs: how the raw phase sequence (steps × transducers bytes,
//! step-major) travels in `Chunk` frames.
//!
//! - [`Encoding::Raw`]: the raw bytes.
//! - [`Encoding::Delta`]: step 0 raw, then each phase as a residual against
//!   a per-transducer prediction, in a bit-packed prefix code. Step 1 is
//!   predicted by step 0 (a first difference); step k ≥ 2 by linear
//!   extrapolation `2·p[k−1] − p[k−2]` (a delta of deltas), because an LM
//!   focus moves at constant speed, so each transducer's phase changes by
//!   nearly the same amount every step. The paper's LM-S and LM-M at
//!   0.23 mm steps encode to 19-29 % of raw (first differences alone
//!   cannot go below 50 %: they need ~3.3 bits each). Layout in `SPEC.md`.
//!
//! The host encodes with [`encode`] (size it with [`encoded_len`]); the
//! device decodes chunk by chunk with the no-heap streaming [`Decoder`]
//! (into the whole raw sequence), or keeps the encoded stream and decodes it
//! one step at a time with [`StepDecoder`] (over a ring of three steps:
//! checking an upload it keeps encoded, and playing it).

use core::fmt;

use crate::wire::wire_enum;

wire_enum! {
    /// Encoding of an uploaded sequence stream.
    pub enum Encoding {
        /// 0: the raw phase bytes, step-major.
        Raw = 0,
        /// 1: step 0 raw, then prediction residuals, bit-packed (see module docs).
        Delta = 1,
    }
}

/// What went wrong in encoding or decoding a sequence stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CodecError {
    /// `transducers` is zero or the phase count is not a multiple of it.
    BadShape,
    /// The output buffer is smaller than the encoded (or raw) size.
    BufferTooSmall,
    /// The stream has bytes past the end of the sequence.
    Overlong,
    /// The stream ended before the whole sequence was decoded.
    Truncated,
    /// The padding bits after the last Delta code are not zero.
    BadPadding,
}

impl fmt::Display for CodecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::BadShape => "phase count is not steps × transducers",
            Self::BufferTooSmall => "sequence buffer too small",
            Self::Overlong => "encoded stream longer than the sequence",
            Self::Truncated => "encoded stream ends before the sequence does",
            Self::BadPadding => "nonzero padding after the last code",
        })
    }
}

impl core::error::Error for CodecError {}

/// Prediction of step `k`'s phase from earlier steps (k ≥ 1).
#[inline]
fn predict(prev: u8, prev2: Option<u8>) -> u8 {
    match prev2 {
        None => prev,
        Some(p2) => prev.wrapping_mul(2).wrapping_sub(p2),
    }
}

/// Prefix code of one residual: `(bits, length)`.
#[inline]
const fn residual_code(e: i8) -> (u32, u32) {
    match e {
        0 => (0b0, 1),
        1 => (0b100, 3),
        -1 => (0b101, 3),
        -8..=7 => ((0b110 << 4) | (e as u8 & 0xF) as u32, 7),
        _ => ((0b111 << 8) | e as u8 as u32, 11),
    }
}

/// [`residual_code`] of every residual byte, split into its bits and its
/// length: the encoder's two lookups.
const CODE_BITS: [u16; 256] = code_table().0;
const CODE_LEN: [u8; 256] = code_table().1;

const fn code_table() -> ([u16; 256], [u8; 256]) {
    let (mut bits, mut len) = ([0u16; 256], [0u8; 256]);
    let mut i = 0;
    while i < 256 {
        let (b, l) = residual_code(i as u8 as i8);
        bits[i] = b as u16;
        len[i] = l as u8;
        i += 1;
    }
    (bits, len)
}

/// Residuals of one step (`cur` against its prediction from `prev` and
/// `prev2`; `prev2 = prev` predicts step 1 by step 0) into `res`, all four
/// the same length. Byte-wise wrapping arithmetic, which compilers
/// vectorise.
#[inline]
fn step_residuals(cur: &[u8], prev: &[u8], prev2: &[u8], res: &mut [u8]) {
    let n = res.len();
    let (cur, prev, prev2) = (&cur[..n], &prev[..n], &prev2[..n]);
    for i in 0..n {
        res[i] = cur[i].wrapping_sub(prev[i].wrapping_mul(2).wrapping_sub(prev2[i]));
    }
}

/// Residuals per [`step_residuals`] call: a stack buffer, step by step.
const RESIDUAL_CHUNK: usize = 256;

/// The Delta bit stream: codes appended MSB first into a 64-bit
/// accumulator, whole bytes written out after each group of codes.
struct BitWriter<'a> {
    out: &'a mut [u8],
    /// Bytes written.
    n: usize,
    /// Pending bits: the low `nbits` bits (higher bits are stale).
    acc: u64,
    nbits: u32,
}

impl BitWriter<'_> {
    /// Appends the low `len` bits of `code` (`len ≤ 56`, `len ≥ 1`).
    #[inline(always)]
    fn put(&mut self, code: u64, len: u32) -> Result<(), CodecError> {
        self.acc = (self.acc << len) | code;
        self.nbits += len;
        if let Some(dst) = self.out.get_mut(self.n..self.n + 8) {
            // The pending bits at the top, zeros below: writing all eight
            // bytes is harmless (the next write starts at the partial byte).
            dst.copy_from_slice(&(self.acc << (64 - self.nbits)).to_be_bytes());
            self.n += (self.nbits / 8) as usize;
            self.nbits %= 8;
            Ok(())
        } else {
            self.put_bytes()
        }
    }

    /// Writes the whole pending bytes one at a time (the end of `out`).
    #[cold]
    fn put_bytes(&mut self) -> Result<(), CodecError> {
        while self.nbits >= 8 {
            self.nbits -= 8;
            *self.out.get_mut(self.n).ok_or(CodecError::BufferTooSmall)? =
                (self.acc >> self.nbits) as u8;
            self.n += 1;
        }
        Ok(())
    }

    /// Appends the codes of `res`, four at a time (at most 44 bits).
    #[inline]
    fn put_residuals(&mut self, res: &[u8]) -> Result<(), CodecError> {
        let code = |e: u8| {
            (
                u64::from(CODE_BITS[usize::from(e)]),
                u32::from(CODE_LEN[usize::from(e)]),
            )
        };
        let mut quads = res.chunks_exact(4);
        for q in &mut quads {
            let ((c0, l0), (c1, l1)) = (code(q[0]), code(q[1]));
            let ((c2, l2), (c3, l3)) = (code(q[2]), code(q[3]));
            let (a, b) = ((c0 << l1) | c1, (c2 << l3) | c3);
            self.put((a << (l2 + l3)) | b, l0 + l1 + l2 + l3)?;
        }
        for &e in quads.remainder() {
            let (c, l) = code(e);
            self.put(c, l)?;
        }
        Ok(())
    }

    /// Pads the last byte with zeros; returns the bytes written.
    fn finish(mut self) -> Result<usize, CodecError> {
        if self.nbits > 0 {
            *self.out.get_mut(self.n).ok_or(CodecError::BufferTooSmall)? =
                (self.acc << (8 - self.nbits)) as u8;
            self.n += 1;
        }
        Ok(self.n)
    }
}

fn check_shape(phases: &[u8], transducers: usize) -> Result<(), CodecError> {
    if phases.len().checked_rem(transducers) != Some(0) {
        return Err(CodecError::BadShape);
    }
    Ok(())
}

/// Residuals of steps 1.. in stream order, one at a time (the
/// definition the chunked encoder is checked against).
#[cfg(test)]
fn residuals(phases: &[u8], t: usize) -> impl Iterator<Item = i8> + '_ {
    (t..phases.len()).map(move |i| {
        let prev2 = i.checked_sub(2 * t).map(|j| phases[j]);
        phases[i].wrapping_sub(predict(phases[i - t], prev2)) as i8
    })
}

/// Exact encoded size of `phases` (steps × `transducers`, step-major).
pub fn encoded_len(
    encoding: Encoding,
    phases: &[u8],
    transducers: usize,
) -> Result<usize, CodecError> {
    check_shape(phases, transducers)?;
    Ok(match encoding {
        Encoding::Raw => phases.len(),
        Encoding::Delta => {
            let head = transducers.min(phases.len());
            let mut bits = 0usize;
            for_each_residual_chunk(phases, transducers, |res| {
                bits += res
                    .iter()
                    .map(|&e| usize::from(CODE_LEN[usize::from(e)]))
                    .sum::<usize>();
                Ok::<(), CodecError>(())
            })?;
            head + bits.div_ceil(8)
        }
    })
}

/// Encoded stream lengths a sequence of `steps × transducers` can have in
/// `encoding` (`BeginUpload::encoded_len` outside it is `OutOfRange`):
/// Raw exactly `steps × transducers`; Delta from step 0 plus one bit per
/// residual up to step 0 plus eleven bits per residual (the longest code).
/// Empty for zero steps or transducers.
pub fn encoded_len_range(
    encoding: Encoding,
    steps: u16,
    transducers: u16,
) -> core::ops::RangeInclusive<u64> {
    let (n, t) = (u64::from(steps), u64::from(transducers));
    if n == 0 || t == 0 {
        #[allow(clippy::reversed_empty_ranges)]
        return 1..=0;
    }
    let residuals = (n - 1) * t;
    match encoding {
        Encoding::Raw => n * t..=n * t,
        Encoding::Delta => t + residuals.div_ceil(8)..=t + (residuals * 11).div_ceil(8),
    }
}

/// Encodes `phases` (steps × `transducers`, step-major) into `out`;
/// returns the encoded length (= [`encoded_len`]). Up to 7 bytes of `out`
/// past that length may be overwritten (with zeros).
pub fn encode(
    encoding: Encoding,
    phases: &[u8],
    transducers: usize,
    out: &mut [u8],
) -> Result<usize, CodecError> {
    check_shape(phases, transducers)?;
    let head = match encoding {
        Encoding::Raw => phases.len(),
        Encoding::Delta => transducers.min(phases.len()),
    };
    out.get_mut(..head)
        .ok_or(CodecError::BufferTooSmall)?
        .copy_from_slice(&phases[..head]);
    if encoding == Encoding::Raw {
        return Ok(head);
    }
    let t = transducers;
    let mut w = BitWriter {
        out,
        n: head,
        acc: 0,
        nbits: 0,
    };
    for_each_residual_chunk(phases, t, |res| w.put_residuals(res))?;
    w.finish()
}

/// The residuals of steps 1.. of `phases` (`t > 0` transducers) in stream
/// order, handed to `f` a chunk at a time.
#[inline(always)]
fn for_each_residual_chunk<E>(
    phases: &[u8],
    t: usize,
    mut f: impl FnMut(&[u8]) -> Result<(), E>,
) -> Result<(), E> {
    let mut res = [0u8; RESIDUAL_CHUNK];
    for k in 1..phases.len() / t {
        let prev = &phases[(k - 1) * t..k * t];
        // Step 1: prediction 2·p − p = p, the first difference.
        let prev2 = if k >= 2 {
            &phases[(k - 2) * t..(k - 1) * t]
        } else {
            prev
        };
        let cur = &phases[k * t..(k + 1) * t];
        for i in (0..t).step_by(RESIDUAL_CHUNK) {
            let j = (i + RESIDUAL_CHUNK).min(t);
            let res = &mut res[..j - i];
            step_residuals(&cur[i..j], &prev[i..j], &prev2[i..j], res);
            f(res)?;
        }
    }
    Ok(())
}

/// Streaming no-heap decoder for the device: feed the encoded stream in
/// order, in pieces of any size, with the same `out` slice each time (the
/// slot's raw sequence memory, at least steps × transducers bytes; Delta
/// reads back the two previous steps from it). Never panics; after an
/// error it keeps returning that error.
#[derive(Clone, Debug)]
pub struct Decoder {
    encoding: Encoding,
    transducers: usize,
    total: usize,
    written: usize,
    consumed: usize,
    acc: u32,
    nbits: u32,
    failed: Option<CodecError>,
}

impl Decoder {
    /// A decoder for a sequence of `steps` × `transducers` phases.
    pub fn new(encoding: Encoding, steps: u16, transducers: u16) -> Self {
        Self {
            encoding,
            transducers: transducers as usize,
            total: steps as usize * transducers as usize,
            written: 0,
            consumed: 0,
            acc: 0,
            nbits: 0,
            failed: None,
        }
    }

    /// Raw sequence length (steps × transducers).
    pub fn raw_len(&self) -> usize {
        self.total
    }

    /// Phases decoded so far.
    pub fn decoded(&self) -> usize {
        self.written
    }

    /// Encoded bytes accepted so far (the offset the next piece starts at).
    pub fn consumed(&self) -> usize {
        self.consumed
    }

    /// Every phase has been decoded.
    pub fn is_complete(&self) -> bool {
        self.failed.is_none() && self.written == self.total
    }

    /// Checks the stream ended exactly at the end of the sequence.
    pub fn finish(&self) -> Result<(), CodecError> {
        match self.failed {
            Some(e) => Err(e),
            None if self.written < self.total => Err(CodecError::Truncated),
            None => Ok(()),
        }
    }

    /// Decodes the next piece of the stream into `out`.
    pub fn feed(&mut self, data: &[u8], out: &mut [u8]) -> Result<(), CodecError> {
        if let Some(e) = self.failed {
            return Err(e);
        }
        let r = self.feed_inner(data, out);
        if let Err(e) = r {
            self.failed = Some(e);
        }
        r
    }

    fn feed_inner(&mut self, data: &[u8], out: &mut [u8]) -> Result<(), CodecError> {
        if out.len() < self.total {
            return Err(CodecError::BufferTooSmall);
        }
        let out = &mut out[..self.total];
        let t = self.transducers;
        let head = match self.encoding {
            Encoding::Raw => self.total,
            Encoding::Delta => t.min(self.total),
        };
        let mut input = data;
        // Raw bytes: all of Raw, step 0 of Delta.
        if self.written < head {
            let n = (head - self.written).min(input.len());
            out[self.written..self.written + n].copy_from_slice(&input[..n]);
            self.written += n;
            self.consumed += n;
            input = &input[n..];
        }
        while self.written < self.total {
            let e = loop {
                if let Some((e, used)) = self.peek_code() {
                    self.nbits -= used;
                    self.acc &= (1u32 << self.nbits) - 1;
                    break e;
                }
                let Some((&b, rest)) = input.split_first() else {
                    return Ok(());
                };
                input = rest;
                self.acc = (self.acc << 8) | b as u32;
                self.nbits += 8;
                self.consumed += 1;
            };
            let i = self.written;
            // i ≥ t here (step 0 is raw), so i - t is in bounds.
            let prev2 = i.checked_sub(2 * t).map(|j| out[j]);
            out[i] = predict(out[i - t], prev2).wrapping_add(e as u8);
            self.written += 1;
        }
        // Complete: only zero padding (< 8 bits) may remain.
        if !input.is_empty() {
            return Err(CodecError::Overlong);
        }
        if self.nbits >= 8 {
            return Err(CodecError::Overlong);
        }
        if self.acc != 0 {
            return Err(CodecError::BadPadding);
        }
        Ok(())
    }

    /// The next residual and its code length, if enough bits are buffered.
    fn peek_code(&self) -> Option<(i8, u32)> {
        peek_code(self.acc, self.nbits)
    }
}

/// The residual at the top of the `n` buffered bits of `acc` and its code
/// length, if enough bits are buffered.
#[inline]
fn peek_code(acc: u32, n: u32) -> Option<(i8, u32)> {
    {
        let top = |k: u32| (acc >> (n - k)) & ((1 << k) - 1);
        if n < 1 {
            return None;
        }
        if top(1) == 0 {
            return Some((0, 1));
        }
        if n < 3 {
            return None;
        }
        match top(3) {
            0b100 => Some((1, 3)),
            0b101 => Some((-1, 3)),
            0b110 if n >= 7 => Some((((top(7) as u8) << 4) as i8 >> 4, 7)),
            0b111 if n >= 11 => Some((top(11) as u8 as i8, 11)),
            _ => None,
        }
    }
}

/// Streaming decoder over a **ring of three steps** instead of the whole
/// sequence (no heap, no sequence-sized buffer): each completed step is
/// handed to a callback and stays readable in the ring until two more
/// steps complete ([`StepDecoder::row`]). A device uses it to check the CRC
/// of an upload it keeps encoded (fed chunk by chunk) and to play such an
/// entry (fed the stored stream from [`consumed`](Self::consumed), one step
/// per call; a new cycle [`restart`](Self::restart)s it). Same stream rules
/// and errors as [`Decoder`]; after an error it keeps returning it.
#[derive(Clone, Debug)]
pub struct StepDecoder {
    encoding: Encoding,
    transducers: usize,
    steps: u16,
    /// The step being decoded (`steps` once complete).
    step: u16,
    /// Phases of `step` decoded so far.
    idx: usize,
    consumed: usize,
    acc: u32,
    nbits: u32,
    failed: Option<CodecError>,
}

impl StepDecoder {
    /// A decoder for `steps` × `transducers` phases.
    pub fn new(encoding: Encoding, steps: u16, transducers: u16) -> Self {
        Self {
            encoding,
            transducers: usize::from(transducers),
            steps,
            step: 0,
            idx: 0,
            consumed: 0,
            acc: 0,
            nbits: 0,
            failed: None,
        }
    }

    /// Ring bytes the decoder needs for `transducers`: three steps.
    pub const fn ring_len(transducers: usize) -> usize {
        3 * transducers
    }

    /// Back to step 0 (the caller feeds the stream from its start again).
    pub fn restart(&mut self) {
        *self = Self::new(self.encoding, self.steps, self.transducers as u16);
    }

    /// Steps completed so far (the next one to complete is this index).
    pub fn steps_done(&self) -> u16 {
        self.step
    }

    /// Encoded bytes taken so far (the stream offset the next feed starts at).
    pub fn consumed(&self) -> usize {
        self.consumed
    }

    /// Checks the stream ended exactly at the end of the sequence.
    pub fn finish(&self) -> Result<(), CodecError> {
        match self.failed {
            Some(e) => Err(e),
            None if self.step < self.steps => Err(CodecError::Truncated),
            None => Ok(()),
        }
    }

    /// Phases of completed step `step` in `ring` (valid until two more
    /// steps complete); empty if `ring` is too short.
    pub fn row(ring: &[u8], transducers: usize, step: u16) -> &[u8] {
        let at = usize::from(step % 3) * transducers;
        ring.get(at..at + transducers).unwrap_or(&[])
    }

    /// Decodes from `data`, the stream continuing at
    /// [`consumed`](Self::consumed), until `data` runs out or `max_steps`
    /// more steps complete; `on_step(k, phases)` sees each completed step.
    /// Returns the bytes of `data` taken (bits of a partly used byte are
    /// kept). Once the last step completes, `data` must hold nothing more
    /// (`Overlong`) and the padding must be zero (`BadPadding`).
    pub fn feed(
        &mut self,
        data: &[u8],
        ring: &mut [u8],
        max_steps: u16,
        mut on_step: impl FnMut(u16, &[u8]),
    ) -> Result<usize, CodecError> {
        if let Some(e) = self.failed {
            return Err(e);
        }
        let r = self.feed_inner(data, ring, max_steps, &mut on_step);
        if let Err(e) = r {
            self.failed = Some(e);
        }
        r
    }

    fn feed_inner(
        &mut self,
        data: &[u8],
        ring: &mut [u8],
        max_steps: u16,
        on_step: &mut impl FnMut(u16, &[u8]),
    ) -> Result<usize, CodecError> {
        let t = self.transducers;
        if ring.len() < Self::ring_len(t) {
            return Err(CodecError::BufferTooSmall);
        }
        let mut used = 0;
        let mut done = 0u16;
        while self.step < self.steps && done < max_steps {
            let used_before = used;
            let k = usize::from(self.step);
            let (head, rest) = ring.split_at_mut((k % 3) * t);
            let (cur, tail) = rest.split_at_mut(t);
            if self.encoding == Encoding::Raw || k == 0 {
                let n = (t - self.idx).min(data.len() - used);
                cur[self.idx..self.idx + n].copy_from_slice(&data[used..used + n]);
                self.idx += n;
                used += n;
                self.consumed += n;
            } else {
                // The two previous steps, wherever the ring holds them.
                let row = |j: usize| -> &[u8] {
                    match (j % 3).cmp(&(k % 3)) {
                        core::cmp::Ordering::Less => &head[(j % 3) * t..(j % 3 + 1) * t],
                        _ => &tail[(j % 3 - k % 3 - 1) * t..(j % 3 - k % 3) * t],
                    }
                };
                let prev = &row(k - 1)[..t];
                let prev2 = if k >= 2 { row(k - 2) } else { prev };
                let prev2 = &prev2[..t];
                let cur = &mut cur[..t];
                let (mut acc, mut nbits) = (self.acc, self.nbits);
                let mut i = self.idx;
                while i < t {
                    // Keep at least 11 bits (the longest code) buffered
                    // while input lasts: then a code always decodes.
                    while nbits <= 16 {
                        let Some(&b) = data.get(used) else { break };
                        used += 1;
                        acc = (acc << 8) | u32::from(b);
                        nbits += 8;
                    }
                    let (e, len) = if nbits >= 11 {
                        // Fast path: every code is complete (`acc` holds
                        // exactly `nbits` bits).
                        if acc >> (nbits - 1) == 0 {
                            (0, 1)
                        } else {
                            match (acc >> (nbits - 3)) & 0b111 {
                                0b100 => (1, 3),
                                0b101 => (-1, 3),
                                0b110 => ((((acc >> (nbits - 7)) as u8) << 4) as i8 >> 4, 7),
                                _ => ((acc >> (nbits - 11)) as u8 as i8, 11),
                            }
                        }
                    } else {
                        match peek_code(acc, nbits) {
                            Some(c) => c,
                            None => break,
                        }
                    };
                    nbits -= len;
                    acc &= (1u32 << nbits) - 1;
                    // Step 1 is predicted by step 0 alone (prev2 = prev
                    // makes 2·p − p = p).
                    let pred = prev[i].wrapping_mul(2).wrapping_sub(prev2[i]);
                    cur[i] = pred.wrapping_add(e as u8);
                    i += 1;
                }
                self.consumed += used - used_before;
                self.idx = i;
                self.acc = acc;
                self.nbits = nbits;
            }
            if self.idx < t {
                return Ok(used);
            }
            on_step(self.step, cur);
            self.step += 1;
            self.idx = 0;
            done += 1;
        }
        if self.step == self.steps {
            if used < data.len() || self.nbits >= 8 {
                return Err(CodecError::Overlong);
            }
            if self.acc != 0 {
                return Err(CodecError::BadPadding);
            }
        }
        Ok(used)
    }
}

#[cfg(test)]
#[path = "codec_tests.rs"]
mod tests;
