//! Wire protocol shared by the host (`lmhost`) and the firmware.
//!
//! This crate is the one place where the wire format lives: COBS framing,
//! the frame header, CRC-32, every message's byte layout, limits, nack codes
//! and the sequence codec ([`codec`]). It parses untrusted bytes once into
//! checked types; after parsing no accessor can panic. The full written
//! spec is `proto/SPEC.md`; exact-byte vectors are in
//! `proto/vectors/frames.txt` ([`TEST_VECTORS`]).
//!
//! It never does I/O, timing or policy (what a device does with a request
//! is the firmware's business), never allocates and contains no `unsafe`.
//!
//! Sending: [`encode_frame`] writes `0x00, COBS(frame), 0x00` into a caller
//! buffer of at least [`MAX_ENCODED_FRAME`] bytes. Receiving: feed bytes to
//! a [`FrameDecoder`] in any pieces (see its docs for the loops).
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod cobs;
pub mod codec;
mod crc;
mod decoder;
mod frame;
mod message;
pub mod vectors;

pub use codec::Encoding;
pub use crc::{Crc32, crc32};
pub use decoder::{FeedResult, FrameDecoder};
pub use frame::{
    EncodeError, Frame, FrameError, decode_frame, encode_frame, encode_frame_unframed,
    encoded_frame_len,
};
pub use message::{
    BeginUpload, Centroid, Chunk, Commit, DeviceState, Geometry, Info, Message, MessageType,
    NackCode, Play, PlayAt, Positions, Status,
};

/// Protocol version carried in every frame header.
pub const PROTOCOL_VERSION: u8 = 1;
/// Largest `Chunk` data (bytes of the encoded sequence stream) per frame.
pub const MAX_CHUNK: usize = 1024;
/// Largest number of transducer positions in one `Geometry` frame.
pub const MAX_GEOMETRY_POSITIONS: usize = MAX_CHUNK / 12;
/// Largest message payload (the largest message, `Chunk`, needs
/// `MAX_CHUNK + 5`; the rest is headroom for future fields).
pub const MAX_PAYLOAD: usize = MAX_CHUNK + 16;
/// Frame header length: version, type, seq (u16 LE).
pub const HEADER_LEN: usize = 4;
/// Frame check length (CRC-32 LE).
pub const CRC_LEN: usize = 4;
/// Largest decoded frame: header, payload, CRC.
pub const MAX_FRAME: usize = HEADER_LEN + MAX_PAYLOAD + CRC_LEN;
/// Smallest decoded frame (empty payload).
pub const MIN_FRAME: usize = HEADER_LEN + CRC_LEN;
/// Largest frame on the wire: leading 0x00, COBS of [`MAX_FRAME`] bytes,
/// trailing 0x00. Size send buffers with this.
pub const MAX_ENCODED_FRAME: usize = 1 + cobs::max_encoded_len(MAX_FRAME) + 1;
/// The frame delimiter.
pub const DELIMITER: u8 = 0x00;
/// `Status::slot` on the wire when no slot is selected.
pub const NO_SLOT: u8 = 0xFF;
/// `BeginUpload::sound_speed_mm_s` a device accepts (100 m/s ..= 2000 m/s,
/// air to water with margin); others are refused with `OutOfRange`.
pub const SOUND_SPEED_MM_S: core::ops::RangeInclusive<u32> = 100_000..=2_000_000;

/// Exact-byte test vectors (`proto/vectors/frames.txt`), format described
/// at the top of the file; read them with [`vectors::parse`].
pub const TEST_VECTORS: &str = include_str!("../vectors/frames.txt");
