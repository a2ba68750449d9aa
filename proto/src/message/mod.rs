//! Message types and their payload layouts (all integers little-endian).
//! Byte layouts are listed in `proto/SPEC.md`; writing a payload is in
//! `emit`, reading an untrusted one in `parse`.

use crate::POSITION_LEN;
use crate::codec::Encoding;
use crate::field;
use crate::header::{DeviceLimits, HeaderError, UploadHeader};
use crate::nack::NackCode;
use crate::wire::wire_enum;

/// The messages without a payload, as a pattern: the one list that
/// `payload_len` and `emit` match on. Over `Message` or `MessageType`,
/// whose variants share these names. (`parse` names each of them, as it
/// builds each message from its type; its match over `MessageType` is
/// exhaustive, so none can be missed there.)
macro_rules! payload_less {
    ($e:ident) => {
        $e::GetInfo | $e::Stop | $e::GetStatus | $e::Ack | $e::CommitRig | $e::Renew | $e::SelfTest
    };
}

mod emit;
mod parse;

pub(crate) use emit::{Sink, SliceSink};
pub(crate) use parse::PayloadError;

wire_enum! {
    /// Message type byte (second header byte). Requests are `0x01..=0x7F`,
    /// responses `0x80..=0xFF`.
    pub enum MessageType {
        /// Request device info; answered by `Info`.
        GetInfo = 0x01,
        /// Start uploading a sequence into a slot.
        BeginUpload = 0x02,
        /// Transducer positions of the rig being uploaded.
        Geometry = 0x03,
        /// A piece of the encoded sequence stream.
        Chunk = 0x04,
        /// Finish an upload, check the raw sequence CRC.
        Commit = 0x05,
        /// Start playing a slot.
        Play = 0x06,
        /// Stop playing.
        Stop = 0x07,
        /// Centroid (LM centre) update.
        Centroid = 0x08,
        /// Request status; answered by `Status`.
        GetStatus = 0x09,
        /// Start uploading the rig's transducer positions.
        BeginRig = 0x0A,
        /// Finish the rig upload, check the positions' CRC.
        CommitRig = 0x0B,
        /// Renew the host lease of what plays (nothing else).
        Renew = 0x0C,
        /// Run the output's self-test; answered by `SelfTestResult`.
        SelfTest = 0x0D,
        /// A piece of the upload's per-step intensity table.
        Intensity = 0x0E,
        /// Request done.
        Ack = 0x80,
        /// Request refused, with a code.
        Nack = 0x81,
        /// Device info.
        Info = 0x82,
        /// Device status.
        Status = 0x83,
        /// Outcome of a `SelfTest`.
        SelfTestResult = 0x84,
    }
}

impl MessageType {
    /// True for device-to-host messages (`0x80..`).
    pub fn is_response(self) -> bool {
        self.to_u8() >= 0x80
    }
}

/// Device info (response to `GetInfo`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Info {
    /// Protocol version the device speaks.
    pub proto_version: u8,
    /// Firmware version, major.minor.patch.
    pub fw_version: [u8; 3],
    /// Most transducers a sequence may drive.
    pub max_transducers: u16,
    /// Raw sequence bytes (steps × transducers) one slot holds.
    pub slot_bytes: u32,
    /// Number of slots (slot numbers `0..slots`).
    pub slots: u8,
    /// Player timer frequency in Hz.
    pub timer_hz: u32,
    /// Shortest step dwell the device plays, µs.
    pub min_dwell_us: u32,
    /// Largest chunk the device accepts (≤ [`MAX_CHUNK`](crate::MAX_CHUNK)).
    pub max_chunk: u16,
    /// Transducers of the rig the device holds; 0: none yet.
    pub rig_transducers: u16,
    /// CRC-32 of the rig's positions table ([`rig_crc32`]); 0 when none.
    pub rig_crc32: u32,
    /// Library bytes free now (an entry takes its raw or its Delta size).
    pub library_free: u32,
    /// What the player's timer counts: how accurate a dwell is.
    pub clock: ClockSource,
}

/// CRC-32 of a rig's positions table: every position as its 12-byte
/// record (`[i32; 3]` µm LE), in transducer order. `BeginRig`,
/// `BeginUpload::rig_crc32` and `Info::rig_crc32` carry it.
pub fn rig_crc32(positions: &Positions<'_>) -> u32 {
    let mut c = crate::Crc32::new();
    for p in positions.iter() {
        c.update(&xyz_le(&p));
    }
    c.finish()
}

// Here rather than in `header`, so that `header` needs nothing from the
// messages (they import it).
impl DeviceLimits {
    /// The limits a device reported in its `Info`.
    pub fn from_info(info: &Info) -> Self {
        Self {
            slots: info.slots,
            max_transducers: info.max_transducers,
            slot_bytes: info.slot_bytes,
            min_dwell_us: info.min_dwell_us,
        }
    }
}

/// Start of an upload into a slot: the slot, the [`UploadHeader`] and how
/// the chunk stream is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct BeginUpload {
    /// Target slot.
    pub slot: u8,
    /// What the slot will play.
    pub header: UploadHeader,
    /// Encoding of the chunk stream.
    pub encoding: Encoding,
    /// Total bytes of the encoded stream (sum of chunk lengths), within
    /// [`encoded_len_range`](crate::codec::encoded_len_range).
    pub encoded_len: u32,
    /// CRC-32 of the rig the phases were planned for ([`rig_crc32`]); the
    /// device refuses the upload unless it holds that rig.
    pub rig_crc32: u32,
    /// The upload carries a per-step intensity table (`steps` bytes, sent
    /// in `Intensity` frames; flags bit 0, [`UPLOAD_FLAG_INTENSITY_TABLE`]):
    /// step `j` plays at `intensity × table[j] / 255`.
    pub intensity_table: bool,
}

/// `BeginUpload` flags bit: the upload carries a per-step intensity table.
pub const UPLOAD_FLAG_INTENSITY_TABLE: u8 = 0x01;

impl BeginUpload {
    /// The one check of an upload against a device (host before sending,
    /// device on receipt): slot number, [`UploadHeader::validate`], then
    /// `encoded_len` for the encoding.
    pub fn validate(&self, limits: &DeviceLimits) -> Result<(), HeaderError> {
        crate::header::validate_begin(
            self.slot,
            &self.header,
            self.encoding,
            self.encoded_len,
            self.intensity_table,
            limits,
        )
    }

    /// Bytes the entry takes besides its phases: its intensity table
    /// (`steps` bytes), or nothing.
    pub fn table_len(&self) -> u32 {
        if self.intensity_table {
            u32::from(self.header.steps)
        } else {
            0
        }
    }
}

/// Transducer positions of a `Geometry` frame: `[x, y, z]` µm, each i32 LE.
/// Built from points on the sending side ([`Positions::from_points`]) or
/// borrowed from a parsed frame; both compare and iterate the same.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Positions<'a>(PosRepr<'a>);

#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum PosRepr<'a> {
    /// Length is a multiple of 12 (checked by the constructor).
    Bytes(&'a [u8]),
    Points(&'a [[i32; 3]]),
}

impl<'a> Positions<'a> {
    /// Positions to send. At most [`MAX_GEOMETRY_POSITIONS`](crate::MAX_GEOMETRY_POSITIONS) fit a frame
    /// ([`crate::encode_frame`] returns `TooLarge` otherwise).
    pub const fn from_points(points: &'a [[i32; 3]]) -> Self {
        Self(PosRepr::Points(points))
    }

    /// Positions packed as 12-byte little-endian records; `None` if the
    /// length is not a multiple of 12.
    pub fn from_le_bytes(bytes: &'a [u8]) -> Option<Self> {
        bytes
            .chunks_exact(POSITION_LEN)
            .remainder()
            .is_empty()
            .then_some(Self(PosRepr::Bytes(bytes)))
    }

    /// Number of positions.
    pub fn len(&self) -> usize {
        match self.0 {
            PosRepr::Bytes(b) => b.len() / POSITION_LEN,
            PosRepr::Points(p) => p.len(),
        }
    }

    /// No positions.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Position `i`, if present.
    pub fn get(&self, i: usize) -> Option<[i32; 3]> {
        match self.0 {
            PosRepr::Bytes(b) => {
                let r = b.get(i.checked_mul(POSITION_LEN)?..)?.get(..POSITION_LEN)?;
                Some(xyz_from_le(r.try_into().ok()?))
            }
            PosRepr::Points(p) => p.get(i).copied(),
        }
    }

    /// All positions in order.
    pub fn iter(&self) -> impl Iterator<Item = [i32; 3]> + '_ {
        (0..self.len()).filter_map(|i| self.get(i))
    }
}

impl PartialEq for Positions<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

impl Eq for Positions<'_> {}

#[cfg(feature = "serde")]
impl serde::Serialize for Positions<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.iter())
    }
}

/// Start of a rig upload: the device's one positions table, which every
/// library entry's centroid correction uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct BeginRig {
    /// Transducers (positions) of the rig.
    pub transducers: u16,
    /// CRC-32 of the whole positions table ([`rig_crc32`]).
    pub crc32: u32,
}

/// Transducer positions of the rig being uploaded, `first..first+len`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Geometry<'a> {
    /// Index of the first transducer in this frame.
    pub first: u16,
    /// Positions, µm, drive coordinates.
    pub positions: Positions<'a>,
}

/// A piece of the encoded sequence stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Chunk<'a> {
    /// Slot of the upload in progress.
    pub slot: u8,
    /// Offset of `data` in the encoded stream.
    pub offset: u32,
    /// Stream bytes (at most [`MAX_CHUNK`](crate::MAX_CHUNK)).
    pub data: &'a [u8],
}

/// A piece of the upload's per-step intensity table: `data[i]` is step
/// `offset + i`'s level, 0-255 (255 = the entry's `intensity`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Intensity<'a> {
    /// Slot of the upload in progress.
    pub slot: u8,
    /// The step `data[0]` is for.
    pub offset: u16,
    /// One level per step (1 ..= [`MAX_CHUNK`](crate::MAX_CHUNK) bytes).
    pub data: &'a [u8],
}

/// End of an upload.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Commit {
    /// Slot of the upload in progress.
    pub slot: u8,
    /// CRC-32 ([`crate::crc32`]) of the whole raw sequence
    /// (steps × transducers phase bytes, step-major), followed by its
    /// intensity table when it has one.
    pub crc32: u32,
}

wire_enum! {
    /// When `Play` takes effect.
    pub enum PlayAt {
        /// 0: at the end of the current cycle (seamless switch); at once when idle.
        NextCycle = 0,
        /// 1: at once, from step 0.
        Immediate = 1,
    }
}

/// Start playing a committed slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Play {
    /// Slot to play.
    pub slot: u8,
    /// When to switch.
    pub at: PlayAt,
    /// Play without tracking (flags bit 0, [`PLAY_FLAG_UNTRACKED`]): the
    /// output is not gated by centroids and no correction is applied; it
    /// sounds until `Stop` (or the lease ends). Off by default.
    pub untracked: bool,
    /// Steps to play, counted from the slot's start (from the takeover for
    /// a queued `NextCycle` play), after which the device stops by itself
    /// as `Stop` does, at that step boundary by its own timer; `Status`
    /// then shows `Stopped` with `cycles × N + step == steps`. 0 = play
    /// until `Stop`.
    pub steps: u32,
    /// Host lease, ms, within [`LEASE_MS`](crate::LEASE_MS) (else
    /// `OutOfRange`): the device stops the play, as `Stop` does, once this
    /// long has passed without a request it accepted (every accepted
    /// request renews it; `Renew` does nothing else).
    pub lease_ms: u16,
}

/// `Play` flags bit: play without tracking.
pub const PLAY_FLAG_UNTRACKED: u8 = 0x01;

/// Centroid update: where the LM centre is now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Centroid {
    /// Host's update counter (the device ignores updates not newer than the last).
    pub seq: u32,
    /// Centre, µm, drive coordinates.
    pub pos_um: [i32; 3],
    /// A finger is present (false mutes the output).
    pub present: bool,
    /// Host clock when the position was measured, µs.
    pub host_time_us: u64,
}

wire_enum! {
    /// The oscillator the player's timer runs from, in `Info`.
    #[derive(Default)]
    pub enum ClockSource {
        /// 0: not said.
        #[default]
        Unknown = 0,
        /// 1: an internal RC oscillator (the Nucleo's HSI fallback: ~1 %).
        InternalRc = 1,
        /// 2: a crystal (the Nucleo on HSE: ±50 ppm or better).
        Crystal = 2,
        /// 3: emulated on a host machine (QEMU, the simulated device): the
        /// host's clock.
        Emulated = 3,
    }
}

wire_enum! {
    /// Player state in `Status`.
    #[derive(Default)]
    pub enum DeviceState {
        /// 0: nothing played since reset.
        #[default]
        Idle = 0,
        /// 1: playing a slot.
        Playing = 1,
        /// 2: playing but the output is gated (no presence, stale centroid, ...).
        Muted = 2,
        /// 3: stopped by `Stop`, or by itself after a `Play`'s `steps`.
        Stopped = 3,
    }
}

wire_enum! {
    /// Why the output is silent (`Status::mute_reason`).
    #[derive(Default)]
    #[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
    pub enum MuteReason {
        /// 0: not muted (playing, or idle: nothing was ever played).
        #[default]
        None = 0 => "none",
        /// 1: playing, no centroid since `Play` (tracked play needs one).
        WaitingForTracking = 1 => "waiting for tracking",
        /// 2: the last centroid said no finger is present.
        FingerAbsent = 2 => "finger absent",
        /// 3: no centroid within the device's timeout.
        TrackingStale = 3 => "tracking stale",
        /// 4: the last centroid lay outside the slot's work volume.
        CentroidOutOfRange = 4 => "centroid out of range",
        /// 5: stopped by `Stop`, or by itself after a `Play`'s `steps`.
        Stopped = 5 => "stopped",
        /// 6: stopped by the device because no request came from the host
        /// within the play's lease (`Play::lease_ms`).
        LeaseExpired = 6 => "host lease expired",
    }
}

/// What an output self-test found (`SelfTestResult`): on the boards, an
/// SPI loopback (MOSI jumpered to MISO, chip select inactive) of a known
/// pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case", tag = "outcome"))]
pub enum SelfTest {
    /// 0: the board has no self-test.
    Unsupported,
    /// 1: every byte came back as sent.
    Passed {
        /// Bytes sent and read back.
        bytes: u32,
    },
    /// 2: some bytes came back different (no jumper, a broken line).
    Failed {
        /// Bytes sent and read back.
        bytes: u32,
        /// Bytes read back that differ from those sent.
        mismatches: u32,
        /// Index of the first of them.
        first_mismatch: u32,
        /// The byte sent there.
        sent: u8,
        /// The byte read back there.
        got: u8,
    },
}

/// Device status (response to `GetStatus`). The default is a device fresh
/// from reset: idle, no slot, every counter zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Status {
    /// Player state.
    pub state: DeviceState,
    /// Slot playing or last played (`None` on the wire as [`NO_SLOT`](crate::NO_SLOT)).
    pub slot: Option<u8>,
    /// Current step within the cycle.
    pub step: u16,
    /// Cycles completed since the playing slot began (its `Play`, or the
    /// cycle boundary where a queued slot took over).
    pub cycles: u32,
    /// Step deadlines missed since reset.
    pub missed_deadlines: u32,
    /// `seq` of the last accepted `Centroid` (0 if none).
    pub last_centroid_seq: u32,
    /// Bad frames other than CRC errors (framing, length, COBS, version,
    /// type, payload) since reset.
    pub bad_frames: u32,
    /// Frames dropped for CRC errors since reset.
    pub crc_errors: u32,
    /// Nacks sent since reset.
    pub nacks: u32,
    /// Correction offset currently applied (centroid − planned centre), µm.
    pub correction_um: [i32; 3],
    /// Slot queued to take over at the next cycle boundary (`None` on the
    /// wire as [`NO_SLOT`](crate::NO_SLOT)).
    pub queued_slot: Option<u8>,
    /// Why the output is silent ([`MuteReason::None`] while it sounds).
    pub mute_reason: MuteReason,
    /// Host lease of the play session (its last `Play`), ms; 0 before any.
    pub lease_ms: u16,
    /// Plays the device stopped because their lease expired, since reset.
    pub lease_expiries: u32,
    /// Milliseconds since reset, wrapping at `u32::MAX` (49.7 days): with
    /// the host's own clock it tells a restart that left every counter at
    /// 0 (SPEC section 3, `Status`).
    pub uptime_ms: u32,
}

/// One protocol message, borrowing bulk bytes (chunk data, positions) from
/// the frame it was parsed from or from the caller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[non_exhaustive]
pub enum Message<'a> {
    /// Request device info.
    GetInfo,
    /// Start an upload.
    BeginUpload(BeginUpload),
    /// Transducer positions.
    Geometry(Geometry<'a>),
    /// Encoded sequence bytes.
    Chunk(Chunk<'a>),
    /// Intensity table bytes.
    Intensity(Intensity<'a>),
    /// Finish an upload.
    Commit(Commit),
    /// Play a slot.
    Play(Play),
    /// Stop playing.
    Stop,
    /// Centroid update.
    Centroid(Centroid),
    /// Request status.
    GetStatus,
    /// Start a rig upload.
    BeginRig(BeginRig),
    /// Finish a rig upload.
    CommitRig,
    /// Renew the host lease.
    Renew,
    /// Run the output's self-test.
    SelfTest,
    /// Request done.
    Ack,
    /// Request refused.
    Nack(NackCode),
    /// Device info.
    Info(Info),
    /// Device status.
    Status(Status),
    /// Outcome of a self-test.
    SelfTestResult(SelfTest),
}

/// `[x, y, z]` from a 12-byte record (`POSITION_LEN`, `i32` LE each).
fn xyz_from_le(b: [u8; POSITION_LEN]) -> [i32; 3] {
    core::array::from_fn(|k| {
        i32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]])
    })
}

/// `[x, y, z]` as a 12-byte record.
fn xyz_le(v: &[i32; 3]) -> [u8; POSITION_LEN] {
    let mut b = [0; 12];
    for (d, c) in b.chunks_exact_mut(4).zip(v) {
        d.copy_from_slice(&c.to_le_bytes());
    }
    b
}

impl<'a> Message<'a> {
    /// The message's type byte.
    pub fn msg_type(&self) -> MessageType {
        match self {
            Self::GetInfo => MessageType::GetInfo,
            Self::BeginUpload(_) => MessageType::BeginUpload,
            Self::Geometry(_) => MessageType::Geometry,
            Self::Chunk(_) => MessageType::Chunk,
            Self::Intensity(_) => MessageType::Intensity,
            Self::Commit(_) => MessageType::Commit,
            Self::Play(_) => MessageType::Play,
            Self::Stop => MessageType::Stop,
            Self::Centroid(_) => MessageType::Centroid,
            Self::GetStatus => MessageType::GetStatus,
            Self::BeginRig(_) => MessageType::BeginRig,
            Self::CommitRig => MessageType::CommitRig,
            Self::Renew => MessageType::Renew,
            Self::SelfTest => MessageType::SelfTest,
            Self::Ack => MessageType::Ack,
            Self::Nack(_) => MessageType::Nack,
            Self::Info(_) => MessageType::Info,
            Self::Status(_) => MessageType::Status,
            Self::SelfTestResult(_) => MessageType::SelfTestResult,
        }
    }

    /// Payload length on the wire (before framing).
    pub fn payload_len(&self) -> usize {
        match self {
            payload_less!(Self) => 0,
            Self::BeginRig(_) => field::begin_rig::LEN,
            Self::BeginUpload(_) => field::begin_upload::LEN,
            Self::Geometry(g) => field::geometry::LEN + POSITION_LEN * g.positions.len(),
            Self::Chunk(c) => field::chunk::LEN + c.data.len(),
            Self::Intensity(c) => field::intensity::LEN + c.data.len(),
            Self::Commit(_) => field::commit::LEN,
            Self::Play(_) => field::play::LEN,
            Self::Centroid(_) => field::centroid::LEN,
            Self::Nack(_) => field::nack::LEN,
            Self::Info(_) => field::info::LEN,
            Self::Status(_) => field::status::LEN,
            Self::SelfTestResult(_) => field::self_test::LEN,
        }
    }
}
