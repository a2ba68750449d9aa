//! Reader for the exact-byte test vectors ([`crate::TEST_VECTORS`],
//! `proto/vectors/frames.txt`), so host and firmware tests need no parser
//! of their own.

/// One record of the vector file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Vector<'a> {
    /// Unique name.
    pub name: &'a str,
    /// Message type byte (absent for framing errors).
    pub msg_type: Option<u8>,
    /// Sequence number (absent for framing errors).
    pub seq: Option<u16>,
    /// Human description of the fields.
    pub fields: &'a str,
    /// Hex of the decoded frame (absent for framing errors).
    pub decoded: Option<&'a str>,
    /// Hex of the on-wire bytes.
    pub wire: &'a str,
    /// `None` for a good frame, else the error kind the decoder must
    /// report: `crc`, `unknown_type`, `bad_version`, `malformed`, `cobs`,
    /// `too_short`.
    pub error: Option<&'a str>,
    /// Device behaviour records (names `dev_*`) only: the response a fresh
    /// device fed every record in file order gives: `ack`,
    /// `nack <NackCode>` or `status <DeviceState> <MuteReason>` (Debug names).
    pub expect: Option<&'a str>,
}

/// Records of a vector file (use [`crate::TEST_VECTORS`]); lines with
/// unknown keys are ignored, records without a name are skipped.
pub fn parse(text: &str) -> impl Iterator<Item = Vector<'_>> {
    text.split("\n\n").filter_map(|block| {
        let mut v = Vector::default();
        for line in block.lines() {
            let line = line.trim();
            if line.starts_with('#') {
                continue;
            }
            let (key, value) = line.split_once(' ').unwrap_or((line, ""));
            match key {
                "name" => v.name = value,
                "type" => v.msg_type = u8::from_str_radix(value, 16).ok(),
                "seq" => v.seq = value.parse().ok(),
                "fields" => v.fields = value,
                "decoded" => v.decoded = Some(value),
                "wire" => v.wire = value,
                "error" => v.error = Some(value),
                "expect" => v.expect = Some(value),
                _ => {}
            }
        }
        (!v.name.is_empty()).then_some(v)
    })
}

/// Decodes space-separated hex bytes into `out`; returns the count, or
/// `None` on a bad byte or a too-small `out`.
pub fn hex_decode(hex: &str, out: &mut [u8]) -> Option<usize> {
    let mut n = 0;
    for tok in hex.split_ascii_whitespace() {
        *out.get_mut(n)? = u8::from_str_radix(tok, 16).ok()?;
        n += 1;
    }
    Some(n)
}

/// Name of the error kind a decoder reports for `e`, as used in the file.
pub fn error_kind(e: &crate::FrameError) -> &'static str {
    use crate::FrameError as E;
    match e {
        E::TooLong => "too_long",
        E::Cobs => "cobs",
        E::TooShort { .. } => "too_short",
        E::Crc { .. } => "crc",
        E::BadVersion { .. } => "bad_version",
        E::UnknownType { .. } => "unknown_type",
        E::Malformed { .. } => "malformed",
    }
}

/// Why a vector's wire bytes did not replay as its record says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Mismatch {
    /// The wire hex is not hex, or does not fit the buffer.
    Hex,
    /// The decoder reported this many outcomes (frames and errors), not one.
    Outcomes(usize),
    /// A good frame decoded with another seq than the record's.
    Seq {
        /// What the decoder read.
        got: u16,
    },
    /// Encoding the decoded frame again did not give the wire bytes.
    Reencode,
    /// The decoder reported an error the record does not have, or another
    /// kind than the record's.
    Error {
        /// The kind the decoder reported.
        got: &'static str,
    },
    /// An error from a valid-CRC frame did not carry the record's seq (the
    /// seq a device needs for its Nack).
    ErrorSeq {
        /// What the error carried.
        got: Option<u16>,
    },
    /// The record wants an error but the decoder read a good frame.
    Decoded,
}

impl core::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Hex => write!(f, "wire hex is bad or does not fit"),
            Self::Outcomes(n) => write!(f, "{n} decoder outcomes, expected 1"),
            Self::Seq { got } => write!(f, "decoded seq {got} differs from the record"),
            Self::Reencode => write!(f, "re-encoding differs from the wire bytes"),
            Self::Error { got } => write!(f, "decoder reported {got}, not the record's error"),
            Self::ErrorSeq { got } => write!(f, "error carries seq {got:?}, not the record's"),
            Self::Decoded => write!(f, "decoded a frame where the record wants an error"),
        }
    }
}

/// Replays one record's wire bytes through a fresh [`crate::FrameDecoder`]
/// and checks them against the record: exactly one outcome; for a good
/// frame its seq, and encoding it again gives the wire bytes (`on_frame`
/// sees the frame first); for a bad one the error kind, and the seq a Nack
/// needs when the CRC was valid. `wire` holds the decoded hex,
/// `again` the re-encoding (each at least [`crate::MAX_ENCODED_FRAME`]).
/// No allocation: host tests and the on-target self-test share it.
pub fn replay(
    v: &Vector<'_>,
    wire: &mut [u8],
    again: &mut [u8],
    mut on_frame: impl FnMut(&crate::Frame<'_>),
) -> Result<(), Mismatch> {
    use crate::FeedResult;
    let n = hex_decode(v.wire, wire).ok_or(Mismatch::Hex)?;
    let wire = &wire[..n];
    let mut dec = crate::FrameDecoder::new();
    let mut input = wire;
    let mut outcomes = 0;
    let mut first: Result<(), Mismatch> = Err(Mismatch::Outcomes(0));
    loop {
        input = match dec.feed(input) {
            FeedResult::Consumed => break,
            FeedResult::Frame { frame, remaining } => {
                outcomes += 1;
                if outcomes == 1 {
                    on_frame(&frame);
                    let same = crate::encode_frame(frame.head(), &frame.message, again)
                        .is_ok_and(|m| again[..m] == *wire);
                    first = match v.error {
                        Some(_) => Err(Mismatch::Decoded),
                        None if v.seq != Some(frame.seq) => Err(Mismatch::Seq { got: frame.seq }),
                        None if !same => Err(Mismatch::Reencode),
                        None => Ok(()),
                    };
                }
                remaining
            }
            FeedResult::Error { error, remaining } => {
                outcomes += 1;
                if outcomes == 1 {
                    let kind = error_kind(&error);
                    let want_seq = v.seq.filter(|_| kind != "crc");
                    first = match v.error {
                        Some(want) if want != kind => Err(Mismatch::Error { got: kind }),
                        Some(_) if error.seq() != want_seq => {
                            Err(Mismatch::ErrorSeq { got: error.seq() })
                        }
                        Some(_) => Ok(()),
                        None => Err(Mismatch::Error { got: kind }),
                    };
                }
                remaining
            }
        };
    }
    if outcomes != 1 {
        return Err(Mismatch::Outcomes(outcomes));
    }
    first
}
