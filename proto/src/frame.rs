//! Frames: `[version][type][seq u16 LE][payload][CRC-32 LE]`, COBS-encoded
//! and delimited by 0x00 on the wire.

use core::fmt;

use crate::cobs;
use crate::crc::Crc32;
use crate::error::EncodeError;
use crate::field::echo::{REQUEST_CRC32, REQUEST_TYPE};
use crate::field::frame::{SEQ, TYPE, VERSION};
use crate::message::{Message, MessageType, PayloadError, Sink};
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
        /// The frame's (valid) CRC-32, which the `Nack` echoes.
        crc32: u32,
    },
    /// Valid CRC, but a type this version does not know.
    UnknownType {
        /// Sequence number.
        seq: u16,
        /// Type byte.
        msg_type: u8,
        /// The frame's (valid) CRC-32, which the `Nack` echoes.
        crc32: u32,
    },
    /// Valid CRC and known type, but the payload (or a response's echo)
    /// is wrong.
    Malformed {
        /// Sequence number.
        seq: u16,
        /// Type byte.
        msg_type: u8,
        /// The frame's (valid) CRC-32, which the `Nack` echoes.
        crc32: u32,
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

    /// `(head, code)` for the Nack a device should send, if any: the bad
    /// frame's seq and the echo of its type and CRC. Frames with a bad CRC
    /// or framing are dropped silently: their seq is not trustworthy.
    pub fn nack(&self) -> Option<(Head, crate::NackCode)> {
        use crate::NackCode;
        let (seq, request_type, request_crc32, code) = match *self {
            Self::BadVersion {
                seq,
                msg_type,
                crc32,
                ..
            } => (seq, msg_type, crc32, NackCode::BadVersion),
            Self::UnknownType {
                seq,
                msg_type,
                crc32,
            } => (seq, msg_type, crc32, NackCode::UnknownType),
            Self::Malformed {
                seq,
                msg_type,
                crc32,
                ..
            } => (seq, msg_type, crc32, NackCode::Malformed),
            _ => return None,
        };
        let echo = Echo {
            request_type,
            request_crc32,
        };
        Some((Head::reply(seq, echo), code))
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
            Self::UnknownType { seq, msg_type, .. } => {
                write!(f, "unknown message type {msg_type:#04x} (seq {seq})")
            }
            Self::Malformed {
                seq,
                msg_type,
                reason,
                ..
            } => {
                write!(
                    f,
                    "malformed message type {msg_type:#04x} (seq {seq}): {reason}"
                )
            }
        }
    }
}

/// What a response echoes of the request it answers (SPEC section 2,
/// "Binding"): the request's type byte and its frame's CRC-32. A reply
/// that does not echo the request the host wrote answers another one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Echo {
    /// The request's type byte (as received: it may be one this version
    /// does not know).
    pub request_type: u8,
    /// The CRC-32 of the request's decoded frame (its last four bytes).
    pub request_crc32: u32,
}

impl Echo {
    /// The echo a reply to `msg`, sent with `seq`, must carry: what the
    /// host checks replies against.
    pub fn of_request(seq: u16, msg: &Message<'_>) -> Result<Self, EncodeError> {
        struct CrcOnly(Crc32);
        impl Sink for CrcOnly {
            fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
                self.0.update(bytes);
                Ok(())
            }
        }
        let head = Head::from(seq);
        head.check(msg)?;
        let mut c = CrcOnly(Crc32::new());
        c.put(&header(seq, msg))?;
        msg.emit(&mut c)?;
        Ok(Self {
            request_type: msg.msg_type().to_u8(),
            request_crc32: c.0.finish(),
        })
    }
}

/// What precedes a payload besides its type: the seq, and for a response
/// the [`Echo`] of its request. A request's head is its seq
/// (`Head::from(seq)`; every encoder takes `impl Into<Head>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Head {
    /// Sequence number (a response carries its request's).
    pub seq: u16,
    /// A response's echo of its request; `None` for a request.
    pub echo: Option<Echo>,
}

impl Head {
    /// The head of a response answering the request `echo` describes.
    pub const fn reply(seq: u16, echo: Echo) -> Self {
        Self {
            seq,
            echo: Some(echo),
        }
    }

    /// A response needs an echo and a request has none.
    fn check(&self, msg: &Message<'_>) -> Result<(), EncodeError> {
        msg.check()?;
        if msg.msg_type().is_response() != self.echo.is_some() {
            return Err(EncodeError::InvalidField);
        }
        Ok(())
    }
}

impl From<u16> for Head {
    fn from(seq: u16) -> Self {
        Self { seq, echo: None }
    }
}

/// A checked frame: header fields and a parsed message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Frame<'a> {
    /// Sequence number (responses carry the request's).
    pub seq: u16,
    /// A response's echo of the request it answers (`None` for requests).
    pub echo: Option<Echo>,
    /// The frame's CRC-32 (checked): a reply to it echoes it.
    pub crc32: u32,
    /// The message.
    pub message: Message<'a>,
}

impl<'a> Frame<'a> {
    /// Parses a decoded frame (COBS removed, no delimiter).
    pub fn parse(decoded: &'a [u8]) -> Result<Self, FrameError> {
        decode_frame(decoded)
    }

    /// The frame's seq and echo: re-encoding it with this head gives the
    /// same bytes.
    pub fn head(&self) -> Head {
        Head {
            seq: self.seq,
            echo: self.echo,
        }
    }

    /// The head of a reply to this frame (a request): its seq, and the
    /// echo of its type and CRC.
    pub fn reply_head(&self) -> Head {
        Head::reply(
            self.seq,
            Echo {
                request_type: self.message.msg_type().to_u8(),
                request_crc32: self.crc32,
            },
        )
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
            crc32: received,
        });
    }
    let malformed = |reason| FrameError::Malformed {
        seq,
        msg_type,
        crc32: received,
        reason,
    };
    // A response (of a type this version knows) opens with its echo.
    let (echo, payload) = match MessageType::from_u8(msg_type) {
        Some(t) if t.is_response() => {
            if payload.len() < crate::len::ECHO {
                return Err(malformed("response without the echo of its request"));
            }
            let (e, rest) = payload.split_at(crate::len::ECHO);
            let mut crc = [0; 4];
            crc.copy_from_slice(&e[REQUEST_CRC32]);
            let echo = Echo {
                request_type: e[REQUEST_TYPE.start],
                request_crc32: u32::from_le_bytes(crc),
            };
            (Some(echo), rest)
        }
        _ => (None, payload),
    };
    match Message::parse(msg_type, payload) {
        Ok(message) => Ok(Frame {
            seq,
            echo,
            crc32: received,
            message,
        }),
        Err(PayloadError::UnknownType) => Err(FrameError::UnknownType {
            seq,
            msg_type,
            crc32: received,
        }),
        Err(PayloadError::Malformed(reason)) => Err(malformed(reason)),
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

/// The header and, for a response, its echo, once [`Head::check`] has
/// found them right for `msg`.
fn put_head(s: &mut impl Sink, head: &Head, msg: &Message<'_>) -> Result<(), EncodeError> {
    head.check(msg)?;
    s.put(&header(head.seq, msg))?;
    if let Some(e) = head.echo {
        let mut b = [0; crate::len::ECHO];
        b[REQUEST_TYPE].copy_from_slice(&[e.request_type]);
        b[REQUEST_CRC32].copy_from_slice(&e.request_crc32.to_le_bytes());
        s.put(&b)?;
    }
    Ok(())
}

/// Encodes one frame for the wire into `buf`: `0x00`, COBS(header,
/// echo, payload, CRC), `0x00`. Returns the number of bytes written (at
/// most [`crate::MAX_ENCODED_FRAME`]). The leading delimiter flushes any
/// garbage a receiver holds, so the frame survives line noise before it.
/// `head` is a request's seq, or a response's [`Head::reply`]; a response
/// without an echo, or a request with one, is `InvalidField`.
pub fn encode_frame(
    head: impl Into<Head>,
    msg: &Message<'_>,
    buf: &mut [u8],
) -> Result<usize, EncodeError> {
    let head = head.into();
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
    put_head(&mut sink, &head, msg)?;
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
    head: impl Into<Head>,
    msg: &Message<'_>,
    buf: &mut [u8],
) -> Result<usize, EncodeError> {
    let head = head.into();
    let echo_len = if head.echo.is_some() {
        crate::len::ECHO
    } else {
        0
    };
    let n = HEADER_LEN + echo_len + msg.payload_len();
    if buf.len() < n + CRC_LEN {
        return Err(EncodeError::BufferTooSmall);
    }
    let mut s = crate::message::SliceSink {
        buf: &mut buf[..n],
        len: 0,
    };
    put_head(&mut s, &head, msg)?;
    msg.emit(&mut s)?;
    let crc = crate::crc32(&buf[..n]);
    buf[n..n + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    Ok(n + CRC_LEN)
}

/// Exact on-wire length [`encode_frame`] would produce (without writing),
/// or an error if the message exceeds the limits.
pub fn encoded_frame_len(head: impl Into<Head>, msg: &Message<'_>) -> Result<usize, EncodeError> {
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
    let head = head.into();
    head.check(msg)?;
    debug_assert!(msg.payload_len() <= MAX_PAYLOAD);
    let mut c = Count {
        crc: Crc32::new(),
        run: 0,
        len: 0,
    };
    put_head(&mut c, &head, msg)?;
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
        let echo = Echo {
            request_type: 0x05,
            request_crc32: 0xDEAD_BEEF,
        };
        let msgs = [
            (Message::GetInfo, None),
            (Message::Nack(NackCode::Busy), Some(echo)),
            (Message::Stop, None),
        ];
        for (i, (m, echo)) in msgs.iter().enumerate() {
            let head = Head {
                seq: i as u16 * 300,
                echo: *echo,
            };
            let mut wire = [0u8; MAX_ENCODED_FRAME];
            let n = encode_frame(head, m, &mut wire).unwrap();
            assert_eq!(encoded_frame_len(head, m).unwrap(), n);
            assert_eq!((wire[0], wire[n - 1]), (0, 0));
            let mut raw = [0u8; MAX_FRAME];
            let r = encode_frame_unframed(head, m, &mut raw).unwrap();
            let mut dec = [0u8; MAX_FRAME];
            let d = cobs::decode(&wire[1..n - 1], &mut dec).unwrap();
            assert_eq!(&dec[..d], &raw[..r]);
            let mut fd = FrameDecoder::new();
            match fd.feed(&wire[..n]) {
                FeedResult::Frame { frame, remaining } => {
                    assert_eq!((frame.head(), frame.message), (head, *m));
                    assert_eq!(frame.crc32, crate::crc32(&raw[..r - CRC_LEN]));
                    assert!(remaining.is_empty());
                }
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn a_response_needs_an_echo_and_a_request_has_none() {
        let echo = Echo::of_request(7, &Message::GetStatus).unwrap();
        let mut wire = [0u8; MAX_ENCODED_FRAME];
        let n = encode_frame(7, &Message::GetStatus, &mut wire).unwrap();
        let mut dec = [0u8; MAX_FRAME];
        let d = cobs::decode(&wire[1..n - 1], &mut dec).unwrap();
        let req = decode_frame(&dec[..d]).unwrap();
        assert_eq!(req.echo, None);
        assert_eq!(
            req.reply_head(),
            Head::reply(7, echo),
            "the echo a reply needs"
        );
        assert_eq!(echo.request_type, 0x09);
        assert_eq!(
            encode_frame(7, &Message::Ack, &mut wire),
            Err(EncodeError::InvalidField)
        );
        assert_eq!(
            encode_frame(Head::reply(7, echo), &Message::GetStatus, &mut wire),
            Err(EncodeError::InvalidField)
        );
        // An Ack of version 6 (no echo) is malformed in version 7.
        let mut old = [PROTOCOL_VERSION, 0x80, 7, 0, 0, 0, 0, 0];
        let crc = crate::crc32(&old[..4]);
        old[4..].copy_from_slice(&crc.to_le_bytes());
        assert!(matches!(
            decode_frame(&old),
            Err(FrameError::Malformed { seq: 7, reason, .. }) if reason.contains("echo")
        ));
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
