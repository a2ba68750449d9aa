//! Message types and their payload layouts (all integers little-endian).
//! Byte layouts are listed in `proto/SPEC.md`.

use crate::codec::Encoding;
use crate::error::EncodeError;
use crate::header::{DeviceLimits, HeaderError, UploadHeader};
use crate::nack::NackCode;
use crate::wire::wire_enum;
use crate::{MAX_CHUNK, MAX_GEOMETRY_POSITIONS, NO_SLOT, POSITION_LEN, len};

wire_enum! {
    /// Message type byte (second header byte). Requests are `0x01..=0x7F`,
    /// responses `0x80..=0xFF`.
    pub enum MessageType {
        /// Request device info; answered by `Info`.
        GetInfo = 0x01,
        /// Start uploading a sequence into a slot.
        BeginUpload = 0x02,
        /// Transducer positions for centroid correction.
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
        /// Request done.
        Ack = 0x80,
        /// Request refused, with a code.
        Nack = 0x81,
        /// Device info.
        Info = 0x82,
        /// Device status.
        Status = 0x83,
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
    /// Largest chunk the device accepts (≤ [`MAX_CHUNK`]).
    pub max_chunk: u16,
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
}

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
            limits,
        )
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
    /// Positions to send. At most [`MAX_GEOMETRY_POSITIONS`] fit a frame
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
                Some(core::array::from_fn(|k| {
                    i32::from_le_bytes([r[4 * k], r[4 * k + 1], r[4 * k + 2], r[4 * k + 3]])
                }))
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

/// Transducer positions for centroid correction, `first..first+len`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Geometry<'a> {
    /// Slot of the upload in progress.
    pub slot: u8,
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
    /// Stream bytes (at most [`MAX_CHUNK`]).
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
    /// (steps × transducers phase bytes, step-major).
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
    /// sounds until `Stop`. Off by default.
    pub untracked: bool,
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
        /// 3: stopped by `Stop`.
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
        /// 5: stopped by `Stop`.
        Stopped = 5 => "stopped",
    }
}

/// Device status (response to `GetStatus`). The default is a device fresh
/// from reset: idle, no slot, every counter zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Status {
    /// Player state.
    pub state: DeviceState,
    /// Slot playing or last played (`None` on the wire as [`NO_SLOT`]).
    pub slot: Option<u8>,
    /// Current step within the cycle.
    pub step: u16,
    /// Cycles completed since `Play`.
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
    /// wire as [`NO_SLOT`]).
    pub queued_slot: Option<u8>,
    /// Why the output is silent ([`MuteReason::None`] while it sounds).
    pub mute_reason: MuteReason,
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
    /// Request done.
    Ack,
    /// Request refused.
    Nack(NackCode),
    /// Device info.
    Info(Info),
    /// Device status.
    Status(Status),
}

/// Output of payload emission: a plain buffer or the frame encoder.
pub(crate) trait Sink {
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError>;
}

/// Payload bytes into a slice.
pub(crate) struct SliceSink<'b> {
    pub(crate) buf: &'b mut [u8],
    pub(crate) len: usize,
}

impl Sink for SliceSink<'_> {
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        let end = self.len + bytes.len();
        self.buf
            .get_mut(self.len..end)
            .ok_or(EncodeError::BufferTooSmall)?
            .copy_from_slice(bytes);
        self.len = end;
        Ok(())
    }
}

fn put_xyz(s: &mut impl Sink, v: &[i32; 3]) -> Result<(), EncodeError> {
    v.iter().try_for_each(|c| s.put(&c.to_le_bytes()))
}

/// Bounds-checked little-endian reader over an untrusted payload.
struct Reader<'a> {
    buf: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], &'static str> {
        if self.buf.len() < n {
            return Err("payload too short");
        }
        let (head, rest) = self.buf.split_at(n);
        self.buf = rest;
        Ok(head)
    }
    fn array<const N: usize>(&mut self) -> Result<[u8; N], &'static str> {
        let b = self.take(N)?;
        let mut a = [0u8; N];
        a.copy_from_slice(b);
        Ok(a)
    }
    fn u8(&mut self) -> Result<u8, &'static str> {
        Ok(self.array::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, &'static str> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    fn u32(&mut self) -> Result<u32, &'static str> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    fn u64(&mut self) -> Result<u64, &'static str> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    fn i32(&mut self) -> Result<i32, &'static str> {
        Ok(i32::from_le_bytes(self.array()?))
    }
    fn xyz(&mut self) -> Result<[i32; 3], &'static str> {
        Ok([self.i32()?, self.i32()?, self.i32()?])
    }
    fn bool(&mut self) -> Result<bool, &'static str> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err("bool field not 0 or 1"),
        }
    }
    fn rest(&mut self) -> &'a [u8] {
        core::mem::take(&mut self.buf)
    }
    fn end(&self) -> Result<(), &'static str> {
        if self.buf.is_empty() {
            Ok(())
        } else {
            Err("payload too long")
        }
    }
}

/// Why a payload did not parse (mapped to [`crate::FrameError`]).
pub(crate) enum PayloadError {
    UnknownType,
    Malformed(&'static str),
}

impl<'a> Message<'a> {
    /// The message's type byte.
    pub fn msg_type(&self) -> MessageType {
        match self {
            Self::GetInfo => MessageType::GetInfo,
            Self::BeginUpload(_) => MessageType::BeginUpload,
            Self::Geometry(_) => MessageType::Geometry,
            Self::Chunk(_) => MessageType::Chunk,
            Self::Commit(_) => MessageType::Commit,
            Self::Play(_) => MessageType::Play,
            Self::Stop => MessageType::Stop,
            Self::Centroid(_) => MessageType::Centroid,
            Self::GetStatus => MessageType::GetStatus,
            Self::Ack => MessageType::Ack,
            Self::Nack(_) => MessageType::Nack,
            Self::Info(_) => MessageType::Info,
            Self::Status(_) => MessageType::Status,
        }
    }

    /// Payload length on the wire (before framing).
    pub fn payload_len(&self) -> usize {
        match self {
            Self::GetInfo | Self::Stop | Self::GetStatus | Self::Ack => 0,
            Self::BeginUpload(_) => len::BEGIN_UPLOAD,
            Self::Geometry(g) => len::GEOMETRY_HEAD + POSITION_LEN * g.positions.len(),
            Self::Chunk(c) => len::CHUNK_HEAD + c.data.len(),
            Self::Commit(_) => len::COMMIT,
            Self::Play(_) => len::PLAY,
            Self::Centroid(_) => len::CENTROID,
            Self::Nack(_) => len::NACK,
            Self::Info(_) => len::INFO,
            Self::Status(_) => len::STATUS,
        }
    }

    /// Writes the payload (no header, no CRC) into `buf`; returns its length.
    pub fn emit_payload(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let mut s = SliceSink { buf, len: 0 };
        self.emit(&mut s)?;
        Ok(s.len)
    }

    /// Checks limits the type system does not enforce.
    pub(crate) fn check(&self) -> Result<(), EncodeError> {
        match self {
            Self::Geometry(g) if g.positions.len() > MAX_GEOMETRY_POSITIONS => {
                Err(EncodeError::TooLarge)
            }
            Self::Chunk(c) if c.data.len() > MAX_CHUNK => Err(EncodeError::TooLarge),
            Self::Status(s) if s.slot == Some(NO_SLOT) || s.queued_slot == Some(NO_SLOT) => {
                Err(EncodeError::InvalidField)
            }
            // `Other` must hold a value this version does not know, or it
            // would not survive a round trip.
            Self::Nack(NackCode::Other(b))
                if !matches!(NackCode::from_u8(*b), NackCode::Other(_)) =>
            {
                Err(EncodeError::InvalidField)
            }
            _ => Ok(()),
        }
    }

    pub(crate) fn emit(&self, s: &mut impl Sink) -> Result<(), EncodeError> {
        self.check()?;
        match self {
            Self::GetInfo | Self::Stop | Self::GetStatus | Self::Ack => Ok(()),
            Self::BeginUpload(b) => {
                let h = &b.header;
                s.put(&[b.slot])?;
                s.put(&h.steps.to_le_bytes())?;
                s.put(&h.transducers.to_le_bytes())?;
                s.put(&h.period_us.to_le_bytes())?;
                s.put(&[b.encoding.to_u8()])?;
                s.put(&b.encoded_len.to_le_bytes())?;
                put_xyz(s, &h.center_um)?;
                s.put(&[h.foci_per_step])?;
                s.put(&h.sound_speed_mm_s.to_le_bytes())?;
                s.put(&h.max_offset_um.to_le_bytes())
            }
            Self::Geometry(g) => {
                s.put(&[g.slot])?;
                s.put(&g.first.to_le_bytes())?;
                g.positions.iter().try_for_each(|p| put_xyz(s, &p))
            }
            Self::Chunk(c) => {
                s.put(&[c.slot])?;
                s.put(&c.offset.to_le_bytes())?;
                s.put(c.data)
            }
            Self::Commit(c) => {
                s.put(&[c.slot])?;
                s.put(&c.crc32.to_le_bytes())
            }
            Self::Play(p) => s.put(&[
                p.slot,
                p.at.to_u8(),
                if p.untracked { PLAY_FLAG_UNTRACKED } else { 0 },
            ]),
            Self::Centroid(c) => {
                s.put(&c.seq.to_le_bytes())?;
                put_xyz(s, &c.pos_um)?;
                s.put(&[c.present as u8])?;
                s.put(&c.host_time_us.to_le_bytes())
            }
            Self::Nack(code) => s.put(&[code.to_u8()]),
            Self::Info(i) => {
                s.put(&[i.proto_version])?;
                s.put(&i.fw_version)?;
                s.put(&i.max_transducers.to_le_bytes())?;
                s.put(&i.slot_bytes.to_le_bytes())?;
                s.put(&[i.slots])?;
                s.put(&i.timer_hz.to_le_bytes())?;
                s.put(&i.min_dwell_us.to_le_bytes())?;
                s.put(&i.max_chunk.to_le_bytes())
            }
            Self::Status(st) => {
                s.put(&[st.state.to_u8(), st.slot.unwrap_or(NO_SLOT)])?;
                s.put(&st.step.to_le_bytes())?;
                for v in [
                    st.cycles,
                    st.missed_deadlines,
                    st.last_centroid_seq,
                    st.bad_frames,
                    st.crc_errors,
                    st.nacks,
                ] {
                    s.put(&v.to_le_bytes())?;
                }
                put_xyz(s, &st.correction_um)?;
                s.put(&[st.queued_slot.unwrap_or(NO_SLOT), st.mute_reason.to_u8()])
            }
        }
    }

    /// Parses an untrusted payload of type `msg_type`.
    pub(crate) fn parse(msg_type: u8, payload: &'a [u8]) -> Result<Self, PayloadError> {
        let t = MessageType::from_u8(msg_type).ok_or(PayloadError::UnknownType)?;
        let mut r = Reader { buf: payload };
        let m = Self::parse_known(t, &mut r).map_err(PayloadError::Malformed)?;
        r.end().map_err(PayloadError::Malformed)?;
        Ok(m)
    }

    fn parse_known(t: MessageType, r: &mut Reader<'a>) -> Result<Self, &'static str> {
        Ok(match t {
            MessageType::GetInfo => Self::GetInfo,
            MessageType::Stop => Self::Stop,
            MessageType::GetStatus => Self::GetStatus,
            MessageType::Ack => Self::Ack,
            MessageType::BeginUpload => {
                let slot = r.u8()?;
                let steps = r.u16()?;
                let transducers = r.u16()?;
                let period_us = r.u32()?;
                let encoding = Encoding::from_u8(r.u8()?).ok_or("unknown encoding")?;
                let encoded_len = r.u32()?;
                Self::BeginUpload(BeginUpload {
                    slot,
                    encoding,
                    encoded_len,
                    header: UploadHeader {
                        steps,
                        transducers,
                        period_us,
                        center_um: r.xyz()?,
                        foci_per_step: r.u8()?,
                        sound_speed_mm_s: r.u32()?,
                        max_offset_um: r.u32()?,
                    },
                })
            }
            MessageType::Geometry => {
                let slot = r.u8()?;
                let first = r.u16()?;
                let bytes = r.rest();
                let positions = Positions::from_le_bytes(bytes)
                    .ok_or("positions not a multiple of POSITION_LEN bytes")?;
                if positions.len() > MAX_GEOMETRY_POSITIONS {
                    return Err("too many positions");
                }
                Self::Geometry(Geometry {
                    slot,
                    first,
                    positions,
                })
            }
            MessageType::Chunk => {
                let slot = r.u8()?;
                let offset = r.u32()?;
                let data = r.rest();
                if data.len() > MAX_CHUNK {
                    return Err("chunk longer than MAX_CHUNK");
                }
                Self::Chunk(Chunk { slot, offset, data })
            }
            MessageType::Commit => Self::Commit(Commit {
                slot: r.u8()?,
                crc32: r.u32()?,
            }),
            MessageType::Play => Self::Play(Play {
                slot: r.u8()?,
                at: PlayAt::from_u8(r.u8()?).ok_or("unknown play timing")?,
                untracked: match r.u8()? {
                    0 => false,
                    PLAY_FLAG_UNTRACKED => true,
                    _ => return Err("unknown play flag bits"),
                },
            }),
            MessageType::Centroid => Self::Centroid(Centroid {
                seq: r.u32()?,
                pos_um: r.xyz()?,
                present: r.bool()?,
                host_time_us: r.u64()?,
            }),
            MessageType::Nack => Self::Nack(NackCode::from_u8(r.u8()?)),
            MessageType::Info => Self::Info(Info {
                proto_version: r.u8()?,
                fw_version: r.array()?,
                max_transducers: r.u16()?,
                slot_bytes: r.u32()?,
                slots: r.u8()?,
                timer_hz: r.u32()?,
                min_dwell_us: r.u32()?,
                max_chunk: r.u16()?,
            }),
            MessageType::Status => Self::Status(Status {
                state: DeviceState::from_u8(r.u8()?).ok_or("unknown device state")?,
                slot: match r.u8()? {
                    NO_SLOT => None,
                    s => Some(s),
                },
                step: r.u16()?,
                cycles: r.u32()?,
                missed_deadlines: r.u32()?,
                last_centroid_seq: r.u32()?,
                bad_frames: r.u32()?,
                crc_errors: r.u32()?,
                nacks: r.u32()?,
                correction_um: r.xyz()?,
                queued_slot: match r.u8()? {
                    NO_SLOT => None,
                    s => Some(s),
                },
                mute_reason: MuteReason::from_u8(r.u8()?).ok_or("unknown mute reason")?,
            }),
        })
    }
}
