//! Why a message could not be encoded (decode errors are
//! [`crate::FrameError`], next to the frame they describe). Its own module,
//! as postcard keeps its errors, so the message and frame code both use it
//! without importing each other for it.

use core::fmt;

use crate::cobs;

/// Why a frame could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is too small (use [`crate::MAX_ENCODED_FRAME`]).
    BufferTooSmall,
    /// Chunk data over [`crate::MAX_CHUNK`] or positions over
    /// [`crate::MAX_GEOMETRY_POSITIONS`].
    TooLarge,
    /// A field holds a value the wire cannot carry (`Status::slot ==
    /// Some(NO_SLOT)`, `NackCode::Other` with a known code, a `Chunk`,
    /// `Geometry` or `Intensity` of no elements).
    InvalidField,
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "frame buffer too small",
            Self::TooLarge => "message exceeds the frame size limits",
            Self::InvalidField => "message field not representable on the wire",
        })
    }
}

impl From<cobs::CobsError> for EncodeError {
    fn from(_: cobs::CobsError) -> Self {
        Self::BufferTooSmall
    }
}
