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
