//! What a board chooses ([`Config`] and its defaults), why a [`Device`]
//! could not be built, and the counters it reports.
//!
//! [`Device`]: super::Device

use crate::store::StoreError;

/// Device configuration, chosen by the board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// Frequency of the free-running timer whose counts `now` is in (≥ 1 MHz recommended).
    pub timer_hz: u32,
    /// Firmware version reported in `Info`.
    pub fw_version: [u8; 3],
    /// Most transducers a sequence may drive (≤ [`MAX_TRANSDUCERS`](crate::MAX_TRANSDUCERS)).
    pub max_transducers: u16,
    /// Shortest step dwell accepted, µs (default 1000: the 1 kHz limit).
    pub min_dwell_us: u32,
    /// Mute when no centroid update came for this long, µs (default 100 ms).
    pub centroid_timeout_us: u32,
    /// Mute from `Play` until the first centroid update (default on).
    pub require_tracking: bool,
    /// Amplitude of unmuted frames (default 255).
    pub amplitude: u8,
    /// While a step lasts longer than this (µs), its frame is sent again
    /// this often, so the transducer driver's 100 ms silence timeout
    /// (`firmware/DRIVER.md`) never cuts a long dwell; 0 = never.
    pub frame_repeat_us: u32,
    /// What the timer counts, reported in `Info` (the board knows).
    pub clock: lm_proto::ClockSource,
}

impl Config {
    /// Defaults for a timer at `timer_hz`: 996 transducers, 1 ms minimum
    /// dwell, 100 ms centroid timeout, tracking required, full amplitude,
    /// the crate's version. (The speed of sound is not configured here: each
    /// slot's `BeginUpload` carries the one its sequence was planned with.)
    pub const fn new(timer_hz: u32) -> Self {
        Self {
            timer_hz,
            fw_version: FW_VERSION,
            max_transducers: DEFAULT_TRANSDUCERS,
            min_dwell_us: 1000,
            centroid_timeout_us: DEFAULT_CENTROID_TIMEOUT_US,
            require_tracking: true,
            amplitude: 255,
            frame_repeat_us: 50_000,
            clock: lm_proto::ClockSource::Unknown,
        }
    }
}

/// Transducers of the rig the defaults are for: four AUTD3 boards of 249,
/// the array every board crate and the simulated device drive.
pub const DEFAULT_TRANSDUCERS: u16 = 996;

/// Default centroid timeout (µs): the output mutes after this long without
/// a centroid update, on the firmware and (held by the host) on an AUTD3.
pub const DEFAULT_CENTROID_TIMEOUT_US: u32 = 100_000;

/// This crate's version as `[major, minor, patch]`.
pub const FW_VERSION: [u8; 3] = [
    parse_u8(env!("CARGO_PKG_VERSION_MAJOR")),
    parse_u8(env!("CARGO_PKG_VERSION_MINOR")),
    parse_u8(env!("CARGO_PKG_VERSION_PATCH")),
];

const fn parse_u8(s: &str) -> u8 {
    let b = s.as_bytes();
    let mut v: u32 = 0;
    let mut i = 0;
    while i < b.len() {
        v = v * 10 + (b[i] - b'0') as u32;
        i += 1;
    }
    if v > 255 { 255 } else { v as u8 }
}

/// Why a [`Device`](super::Device) could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DeviceError {
    /// The sequence memory or transducer count does not work.
    Store(StoreError),
    /// `timer_hz` is zero.
    BadTimer,
}

impl core::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Store(e) => write!(f, "sequence store: {e}"),
            Self::BadTimer => f.write_str("timer_hz must be above zero"),
        }
    }
}

/// Counters reported in `Status` (all since reset, wrapping).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Frames dropped: framing, COBS, length, plus valid-CRC frames with a
    /// bad version, unknown type or malformed payload (those are also nacked).
    pub bad_frames: u32,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u32,
    /// Nacks sent.
    pub nacks: u32,
    /// Requests answered (acks, nacks, info, status).
    pub responses: u32,
    /// Frames the output driver refused.
    pub output_errors: u32,
    /// Frames written to the output driver.
    pub frames_out: u32,
    /// Plays stopped because their host lease expired (the policy's count,
    /// as `Status` reports it).
    pub lease_expiries: u32,
}
