//! Consistent Overhead Byte Stuffing: removes every 0x00 from a message so
//! that 0x00 can delimit frames on a byte stream. Encoding adds one byte per
//! started run of 254 bytes (at least one).
//!
//! The functions here work on one message without its delimiter; framing
//! (delimiters, streaming) lives in [`crate::encode_frame`] and
//! [`crate::FrameDecoder`].

use core::fmt;

/// What went wrong in a COBS operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CobsError {
    /// The output buffer is too small.
    BufferTooSmall,
    /// The encoded input contains a 0x00 byte (a delimiter inside a message).
    ZeroByte,
    /// The encoded input ends inside a block.
    Truncated,
}

impl fmt::Display for CobsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "COBS output buffer too small",
            Self::ZeroByte => "COBS data contains a zero byte",
            Self::Truncated => "COBS data ends inside a block",
        })
    }
}

/// Largest encoded size of an `n`-byte message (without delimiter).
pub const fn max_encoded_len(n: usize) -> usize {
    n + n / 254 + 1
}

/// Streaming COBS encoder writing into a caller buffer. Feed bytes with
/// [`Encoder::push`]; [`Encoder::finish`] closes the last block and returns
/// the encoded length. No look-ahead: each block's code byte is written
/// when the block closes.
#[derive(Debug)]
pub struct Encoder<'b> {
    out: &'b mut [u8],
    code_idx: usize,
    pos: usize,
    code: u8,
}

impl<'b> Encoder<'b> {
    /// Starts encoding into `out`.
    pub fn new(out: &'b mut [u8]) -> Result<Self, CobsError> {
        if out.is_empty() {
            return Err(CobsError::BufferTooSmall);
        }
        Ok(Self {
            out,
            code_idx: 0,
            pos: 1,
            code: 1,
        })
    }

    fn close_block(&mut self) -> Result<(), CobsError> {
        *self
            .out
            .get_mut(self.code_idx)
            .ok_or(CobsError::BufferTooSmall)? = self.code;
        self.code_idx = self.pos;
        self.pos += 1;
        self.code = 1;
        if self.code_idx >= self.out.len() {
            return Err(CobsError::BufferTooSmall);
        }
        Ok(())
    }

    /// Appends one message byte.
    pub fn push(&mut self, b: u8) -> Result<(), CobsError> {
        if b == 0 {
            self.close_block()
        } else {
            *self
                .out
                .get_mut(self.pos)
                .ok_or(CobsError::BufferTooSmall)? = b;
            self.pos += 1;
            self.code += 1;
            if self.code == 0xFF {
                self.close_block()?;
            }
            Ok(())
        }
    }

    /// Appends message bytes.
    pub fn extend(&mut self, bytes: &[u8]) -> Result<(), CobsError> {
        bytes.iter().try_for_each(|&b| self.push(b))
    }

    /// Closes the last block; returns the number of bytes written.
    pub fn finish(self) -> usize {
        // `close_block` and `new` guarantee `code_idx < out.len()`.
        if let Some(c) = self.out.get_mut(self.code_idx) {
            *c = self.code;
        }
        self.pos
    }
}

/// COBS-encodes `src` into `dst` (no delimiter); returns the encoded length.
pub fn encode(src: &[u8], dst: &mut [u8]) -> Result<usize, CobsError> {
    let mut e = Encoder::new(dst)?;
    e.extend(src)?;
    Ok(e.finish())
}

/// Decodes one COBS message `src` (without delimiter) into `dst`; returns
/// the decoded length. Accepts canonical and non-canonical encodings (a
/// trailing empty block after a full one).
pub fn decode(src: &[u8], dst: &mut [u8]) -> Result<usize, CobsError> {
    let mut d = Decoder::new();
    let mut n = 0;
    for &b in src {
        if b == 0 {
            return Err(CobsError::ZeroByte);
        }
        if let Some(out) = d.step(b) {
            *dst.get_mut(n).ok_or(CobsError::BufferTooSmall)? = out;
            n += 1;
        }
    }
    if d.in_block() {
        return Err(CobsError::Truncated);
    }
    Ok(n)
}

/// Byte-at-a-time COBS decoding state (shared with the frame decoder).
/// Each non-zero input byte yields at most one output byte: a data byte
/// yields itself, a code byte yields the previous block's implied zero.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Decoder {
    /// Data bytes left in the current block.
    remaining: u8,
    /// The current block is followed by an implied zero (code < 0xFF).
    zero_after: bool,
    /// A code byte has been seen.
    started: bool,
}

impl Decoder {
    pub(crate) const fn new() -> Self {
        Self {
            remaining: 0,
            zero_after: false,
            started: false,
        }
    }

    /// Feeds one non-zero encoded byte.
    pub(crate) fn step(&mut self, b: u8) -> Option<u8> {
        if self.remaining == 0 {
            let out = (self.started && self.zero_after).then_some(0);
            self.started = true;
            self.zero_after = b != 0xFF;
            self.remaining = b.wrapping_sub(1);
            out
        } else {
            self.remaining -= 1;
            Some(b)
        }
    }

    /// The input so far ends inside a block (a delimiter now is an error).
    pub(crate) fn in_block(&self) -> bool {
        self.remaining != 0
    }

    /// At least one byte has been fed since the last reset.
    pub(crate) fn started(&self) -> bool {
        self.started
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip(data: &[u8]) {
        let mut enc = [0u8; 1200];
        let n = encode(data, &mut enc).unwrap();
        assert!(n <= max_encoded_len(data.len()));
        assert!(!enc[..n].contains(&0));
        let mut dec = [0u8; 1200];
        let m = decode(&enc[..n], &mut dec).unwrap();
        assert_eq!(&dec[..m], data);
    }

    #[test]
    fn known_encodings() {
        let mut out = [0u8; 16];
        let n = encode(&[], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x01]);
        let n = encode(&[0], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x01, 0x01]);
        let n = encode(&[0x11, 0x22, 0x00, 0x33], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x03, 0x11, 0x22, 0x02, 0x33]);
        let n = encode(&[0x11, 0x00, 0x00, 0x00], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x02, 0x11, 0x01, 0x01, 0x01]);
    }

    #[test]
    fn roundtrips_around_block_boundaries() {
        for len in [0, 1, 253, 254, 255, 508, 509, 1100] {
            let nonzero: [u8; 1100] = core::array::from_fn(|i| (i % 255 + 1) as u8);
            roundtrip(&nonzero[..len]);
            let mixed: [u8; 1100] = core::array::from_fn(|i| (i % 7) as u8);
            roundtrip(&mixed[..len]);
            roundtrip(&[0u8; 1100][..len]);
        }
    }

    #[test]
    fn rejects_bad_input() {
        let mut out = [0u8; 8];
        assert_eq!(decode(&[0x03, 0x11], &mut out), Err(CobsError::Truncated));
        assert_eq!(decode(&[0x02, 0x00], &mut out), Err(CobsError::ZeroByte));
        assert_eq!(
            decode(&[0x05, 1, 2, 3, 4], &mut out[..2]),
            Err(CobsError::BufferTooSmall)
        );
        assert_eq!(
            encode(&[1, 2, 3], &mut out[..3]),
            Err(CobsError::BufferTooSmall)
        );
        assert_eq!(encode(&[1, 2, 3], &mut []), Err(CobsError::BufferTooSmall));
    }
}
