//! Frames: `[version][type][seq u16 LE][payload][CRC-32 LE]`, COBS-encoded
//! and delimited by 0x00 on the wire.

use core::fmt;

use crate::cobs;
use crate::crc::Crc32;
use crate::error::EncodeError;
use crate::field::frame::{SEQ, TYPE, VERSION};
use crate::message::{Message, PayloadError, Sink};
use crate::{CRC_LEN, HEADER_LEN, MAX_FRAME, MAX_PAYLOAD, MIN_FRAME, PROTOCOL_VERSION};

/// A bad frame. Errors that carry `seq` come from frames whose CRC was
/// valid, so the seq can be trusted and the request NACKed
/// ([`FrameError::nack`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FrameError {
    /// More than [`MAX_FRAME`] decoded bytes before a delimiter; the rest
    /// up to the next delimiter was discarded.
    TooLong,
    /// Invalid COBS (the delimiter came inside a block).
    Cobs,
    /// Fewer than [`MIN_FRAME`] bytes.
    TooShort {
        /// Decoded length.
        len: usize,
    },
    /// CRC mismatch.
    Crc {
        /// CRC in the frame.
        received: u32,
        /// CRC computed over the frame.
        computed: u32,
    },
    /// Valid CRC, but another protocol version.
    BadVersion {
        /// Version byte received.
        version: u8,
        /// Sequence number.
        seq: u16,
        /// Type byte.
        msg_type: u8,
    },
    /// Valid CRC, but a type this version does not know.
    UnknownType {
        /// Sequence number.
        seq: u16,
        /// Type byte.
        msg_type: u8,
    },
    /// Valid CRC and known type, but the payload is wrong.
    Malformed {
        /// Sequence number.
        seq: u16,
        /// Type byte.
        msg_type: u8,
        /// What was wrong.
        reason: &'static str,
    },
}

impl FrameError {
    /// The trusted seq of the bad frame, when its CRC was valid.
    pub fn seq(&self) -> Option<u16> {
        match *self {
            Self::BadVersion { seq, .. }
            | Self::UnknownType { seq, .. }
            | Self::Malformed { seq, .. } => Some(seq),
            _ => None,
        }
    }

    /// `(seq, code)` for the Nack a device should send, if any (frames
    /// with a bad CRC or framing are dropped silently: their seq is not
    /// trustworthy).
    pub fn nack(&self) -> Option<(u16, crate::NackCode)> {
        use crate::NackCode;
        match *self {
            Self::BadVersion { seq, .. } => Some((seq, NackCode::BadVersion)),
            Self::UnknownType { seq, .. } => Some((seq, NackCode::UnknownType)),
            Self::Malformed { seq, .. } => Some((seq, NackCode::Malformed)),
            _ => None,
        }
    }

    /// True for CRC errors (counted separately from other bad frames).
    pub fn is_crc(&self) -> bool {
        matches!(self, Self::Crc { .. })
    }
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::TooLong => write!(f, "frame longer than {MAX_FRAME} bytes"),
            Self::Cobs => f.write_str("invalid COBS encoding"),
            Self::TooShort { len } => write!(f, "frame of {len} bytes is shorter than {MIN_FRAME}"),
            Self::Crc { received, computed } => {
                write!(
                    f,
                    "CRC mismatch (frame {received:#010x}, computed {computed:#010x})"
                )
            }
            Self::BadVersion { version, seq, .. } => write!(
                f,
                "protocol version {version} (seq {seq}), expected {PROTOCOL_VERSION}"
            ),
            Self::UnknownType { seq, msg_type } => {
                write!(f, "unknown message type {msg_type:#04x} (seq {seq})")
            }
            Self::Malformed {
                seq,
                msg_type,
                reason,
            } => {
                write!(
                    f,
                    "malformed message type {msg_type:#04x} (seq {seq}): {reason}"
                )
            }
        }
    }
}

/// A checked frame: header fields and a parsed message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Frame<'a> {
    /// Sequence number (responses echo the request's).
    pub seq: u16,
    /// The message.
    pub message: Message<'a>,
}

impl<'a> Frame<'a> {
    /// Parses a decoded frame (COBS removed, no delimiter).
    pub fn parse(decoded: &'a [u8]) -> Result<Self, FrameError> {
        decode_frame(decoded)
    }
}

/// Parses one decoded frame (COBS already removed, no delimiter): checks
/// length, CRC, version, type and payload.
pub fn decode_frame(decoded: &[u8]) -> Result<Frame<'_>, FrameError> {
    if decoded.len() > MAX_FRAME {
        return Err(FrameError::TooLong);
    }
    if decoded.len() < MIN_FRAME {
        return Err(FrameError::TooShort { len: decoded.len() });
    }
    let (body, crc_bytes) = decoded.split_at(decoded.len() - CRC_LEN);
    let mut crc = [0u8; 4];
    crc.copy_from_slice(crc_bytes);
    let received = u32::from_le_bytes(crc);
    let computed = crate::crc32(body);
    if received != computed {
        return Err(FrameError::Crc { received, computed });
    }
    let (header, payload) = body.split_at(HEADER_LEN);
    let (version, msg_type) = (header[VERSION.start], header[TYPE.start]);
    let mut seq = [0; 2];
    seq.copy_from_slice(&header[SEQ]);
    let seq = u16::from_le_bytes(seq);
    if version != PROTOCOL_VERSION {
        return Err(FrameError::BadVersion {
            version,
            seq,
            msg_type,
        });
    }
    match Message::parse(msg_type, payload) {
        Ok(message) => Ok(Frame { seq, message }),
        Err(PayloadError::UnknownType) => Err(FrameError::UnknownType { seq, msg_type }),
        Err(PayloadError::Malformed(reason)) => Err(FrameError::Malformed {
            seq,
            msg_type,
            reason,
        }),
    }
}

/// Feeds frame bytes through the CRC and the COBS encoder.
struct FrameSink<'b> {
    crc: Crc32,
    cobs: cobs::Encoder<'b>,
}

impl Sink for FrameSink<'_> {
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        self.crc.update(bytes);
        Ok(self.cobs.extend(bytes)?)
    }
}

fn header(seq: u16, msg: &Message<'_>) -> [u8; HEADER_LEN] {
    let mut h = [0; HEADER_LEN];
    h[VERSION].copy_from_slice(&[PROTOCOL_VERSION]);
    h[TYPE].copy_from_slice(&[msg.msg_type().to_u8()]);
    h[SEQ].copy_from_slice(&seq.to_le_bytes());
    h
}

/// Encodes one frame for the wire into `buf`: `0x00`, COBS(header,
/// payload, CRC), `0x00`. Returns the number of bytes written (at most
/// [`crate::MAX_ENCODED_FRAME`]). The leading delimiter flushes any
/// garbage a receiver holds, so the frame survives line noise before it.
pub fn encode_frame(seq: u16, msg: &Message<'_>, buf: &mut [u8]) -> Result<usize, EncodeError> {
    msg.check()?;
    let (first, rest) = buf.split_first_mut().ok_or(EncodeError::BufferTooSmall)?;
    *first = crate::DELIMITER;
    // Leave room for the trailing delimiter.
    let body_room = rest
        .len()
        .checked_sub(1)
        .ok_or(EncodeError::BufferTooSmall)?;
    let mut sink = FrameSink {
        crc: Crc32::new(),
        cobs: cobs::Encoder::new(&mut rest[..body_room])?,
    };
    sink.put(&header(seq, msg))?;
    msg.emit(&mut sink)?;
    let crc = sink.crc.finish();
    sink.cobs.extend(&crc.to_le_bytes())?;
    let n = sink.cobs.finish();
    rest[n] = crate::DELIMITER;
    Ok(n + 2)
}

/// Writes the decoded frame (header, payload, CRC; no COBS, no delimiters)
/// into `buf`; returns its length (at most [`MAX_FRAME`]). For tests and
/// for transports that frame by other means.
pub fn encode_frame_unframed(
    seq: u16,
    msg: &Message<'_>,
    buf: &mut [u8],
) -> Result<usize, EncodeError> {
    msg.check()?;
    let n = HEADER_LEN + msg.payload_len();
    if buf.len() < n + CRC_LEN {
        return Err(EncodeError::BufferTooSmall);
    }
    buf[..HEADER_LEN].copy_from_slice(&header(seq, msg));
    msg.emit_payload(&mut buf[HEADER_LEN..n])?;
    let crc = crate::crc32(&buf[..n]);
    buf[n..n + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    Ok(n + CRC_LEN)
}

/// Exact on-wire length [`encode_frame`] would produce (without writing),
/// or an error if the message exceeds the limits.
pub fn encoded_frame_len(seq: u16, msg: &Message<'_>) -> Result<usize, EncodeError> {
    // Counts COBS output without a buffer.
    struct Count {
        crc: Crc32,
        run: usize,
        len: usize,
    }
    impl Count {
        fn push(&mut self, b: u8) {
            if b == 0 {
                self.len += 1 + self.run;
                self.run = 0;
            } else {
                self.run += 1;
                if self.run == 254 {
                    self.len += 255;
                    self.run = 0;
                }
            }
        }
    }
    impl Sink for Count {
        fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
            self.crc.update(bytes);
            bytes.iter().for_each(|&b| self.push(b));
            Ok(())
        }
    }
    msg.check()?;
    debug_assert!(msg.payload_len() <= MAX_PAYLOAD);
    let mut c = Count {
        crc: Crc32::new(),
        run: 0,
        len: 0,
    };
    c.put(&header(seq, msg))?;
    msg.emit(&mut c)?;
    let crc = c.crc.finish();
    crc.to_le_bytes().iter().for_each(|&b| c.push(b));
    Ok(2 + c.len + 1 + c.run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FeedResult, FrameDecoder, MAX_ENCODED_FRAME, Message, NackCode};

    #[test]
    fn encode_then_decode_and_length_agree() {
        let msgs = [
            Message::GetInfo,
            Message::Nack(NackCode::Busy),
            Message::Stop,
        ];
        for (i, m) in msgs.iter().enumerate() {
            let mut wire = [0u8; MAX_ENCODED_FRAME];
            let n = encode_frame(i as u16 * 300, m, &mut wire).unwrap();
            assert_eq!(encoded_frame_len(i as u16 * 300, m).unwrap(), n);
            assert_eq!((wire[0], wire[n - 1]), (0, 0));
            let mut raw = [0u8; MAX_FRAME];
            let r = encode_frame_unframed(i as u16 * 300, m, &mut raw).unwrap();
            let mut dec = [0u8; MAX_FRAME];
            let d = cobs::decode(&wire[1..n - 1], &mut dec).unwrap();
            assert_eq!(&dec[..d], &raw[..r]);
            let mut fd = FrameDecoder::new();
            match fd.feed(&wire[..n]) {
                FeedResult::Frame { frame, remaining } => {
                    assert_eq!(
                        frame,
                        Frame {
                            seq: i as u16 * 300,
                            message: *m
                        }
                    );
                    assert!(remaining.is_empty());
                }
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn rejects_oversized_messages() {
        let data = [1u8; crate::MAX_CHUNK + 1];
        let m = Message::Chunk(crate::Chunk {
            slot: 0,
            offset: 0,
            data: &data,
        });
        let mut wire = [0u8; 2 * MAX_ENCODED_FRAME];
        assert_eq!(encode_frame(0, &m, &mut wire), Err(EncodeError::TooLarge));
        let ok = Message::Chunk(crate::Chunk {
            slot: 0,
            offset: 0,
            data: &data[1..],
        });
        let n = encode_frame(0, &ok, &mut wire).unwrap();
        assert!(n <= MAX_ENCODED_FRAME);
        assert_eq!(
            encode_frame(0, &ok, &mut wire[..n - 1]),
            Err(EncodeError::BufferTooSmall)
        );
    }
}
