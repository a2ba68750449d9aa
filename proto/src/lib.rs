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
mod error;
pub mod field;
mod frame;
mod header;
mod message;
mod nack;
pub mod vectors;
mod wire;

pub use codec::Encoding;
pub use crc::{Crc32, crc32};
pub use decoder::{FeedResult, FrameDecoder};
pub use error::EncodeError;
pub use frame::{
    Echo, Frame, FrameError, Head, decode_frame, encode_frame, encode_frame_unframed,
    encoded_frame_len,
};
pub use header::{DeviceLimits, HeaderError, UploadHeader};
pub use message::{
    BeginRig, BeginUpload, Centroid, Chunk, ClockSource, Commit, DeviceState, Geometry, Info,
    Intensity, Message, MessageType, MuteReason, PLAY_FLAG_UNTRACKED, Play, PlayAt, Positions,
    SelfTest, Status, UPLOAD_FLAG_INTENSITY_TABLE, rig_crc32,
};
pub use nack::NackCode;

/// Protocol version carried in every frame header.
pub const PROTOCOL_VERSION: u8 = 7;
/// Carrier frequency of the transducers, Hz (the wavenumber of a slot is
/// 2π · `CARRIER_HZ` / its speed of sound).
pub const CARRIER_HZ: u32 = 40_000;
/// Phase levels of one phase byte: u8 = round(φ / 2π · 256) mod 256.
pub const PHASE_LEVELS: u32 = 256;
/// Bytes of one transducer position record: `[i32; 3]` µm, little-endian.
pub const POSITION_LEN: usize = 12;
/// Largest `Chunk` data (bytes of the encoded sequence stream) per frame.
pub const MAX_CHUNK: usize = 1024;
/// Largest number of transducer positions in one `Geometry` frame.
pub const MAX_GEOMETRY_POSITIONS: usize = MAX_CHUNK / POSITION_LEN;
/// Largest message payload (the largest message, `Chunk`, needs
/// `MAX_CHUNK + len::CHUNK_HEAD`; the rest is headroom for future fields).
pub const MAX_PAYLOAD: usize = MAX_CHUNK + 16;
/// Frame header length: version, type, seq (u16 LE) ([`field::frame`]).
pub const HEADER_LEN: usize = field::frame::LEN;
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

/// `UploadHeader::foci_per_step` a device accepts: 1 (LM-S) ..= 32 foci a
/// step, the most a host plans; others (0 included: a step with no focus)
/// are refused with `OutOfRange`.
pub const FOCI_PER_STEP: core::ops::RangeInclusive<u8> = 1..=32;

/// `UploadHeader::max_offset_um` a device accepts: a work volume of
/// 1 µm ..= 100 mm around the planned centre; others are `OutOfRange`.
pub const MAX_OFFSET_UM: core::ops::RangeInclusive<u32> = 1..=100_000;

/// `Play::lease_ms` a device accepts: 100 ms ..= 60 s; others (0
/// included: there is no "forever") are refused with `OutOfRange`. A play
/// ends within its lease of the last request the device accepted (SPEC
/// section 3, the host lease).
pub const LEASE_MS: core::ops::RangeInclusive<u16> = 100..=60_000;

/// `Info::min_dwell_us` a host accepts: 0 ..= 1 s. The slowest LM cycle
/// (5 Hz, 200 ms) of even one step needs no longer step than that; the
/// firmware's 1 kHz update limit gives 1000 µs. A device saying more
/// (`u32::MAX`) is not LM firmware of this protocol, not a limit the
/// user's sequence failed to meet.
pub const MIN_DWELL_US: core::ops::RangeInclusive<u32> = 0..=1_000_000;

/// The lease hosts ask for unless told otherwise, ms (1 s).
pub const DEFAULT_LEASE_MS: u16 = 1000;

/// Payload length of each fixed-size message, and the fixed heads of the
/// variable ones (SPEC section 3): the end of the last of its [`field`]s.
pub mod len {
    use crate::field;

    /// The echo every response carries before its payload.
    pub const ECHO: usize = field::echo::LEN;
    /// `BeginUpload`.
    pub const BEGIN_UPLOAD: usize = field::begin_upload::LEN;
    /// `BeginRig`.
    pub const BEGIN_RIG: usize = field::begin_rig::LEN;
    /// `Geometry` before its positions (first).
    pub const GEOMETRY_HEAD: usize = field::geometry::LEN;
    /// `Chunk` before its data (slot, offset).
    pub const CHUNK_HEAD: usize = field::chunk::LEN;
    /// `Intensity` before its table bytes (slot, offset).
    pub const INTENSITY_HEAD: usize = field::intensity::LEN;
    /// `Commit`.
    pub const COMMIT: usize = field::commit::LEN;
    /// `Play`.
    pub const PLAY: usize = field::play::LEN;
    /// `Centroid`.
    pub const CENTROID: usize = field::centroid::LEN;
    /// `Nack`.
    pub const NACK: usize = field::nack::LEN;
    /// `Info`.
    pub const INFO: usize = field::info::LEN;
    /// `Status`.
    pub const STATUS: usize = field::status::LEN;
    /// `SelfTestResult`.
    pub const SELF_TEST_RESULT: usize = field::self_test::LEN;
}

/// Exact-byte test vectors (`proto/vectors/frames.txt`), format described
/// at the top of the file; read them with [`vectors::parse`].
pub const TEST_VECTORS: &str = include_str!("../vectors/frames.txt");
