//! Sequence codecs (placeholder until the Delta codec lands).

/// Encoding of an uploaded sequence stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum Encoding {
    /// 0: the raw phase bytes, step-major.
    Raw,
    /// 1: per-transducer deltas between steps, packed (see `SPEC.md`).
    Delta,
}

impl Encoding {
    /// The wire byte.
    pub fn to_u8(self) -> u8 {
        match self {
            Self::Raw => 0,
            Self::Delta => 1,
        }
    }

    /// The encoding for a wire byte, if known.
    pub fn from_u8(b: u8) -> Option<Self> {
        match b {
            0 => Some(Self::Raw),
            1 => Some(Self::Delta),
            _ => None,
        }
    }
}
