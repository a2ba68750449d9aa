//! Reading an untrusted payload into a message.

use super::{
    BeginRig, BeginUpload, Centroid, Chunk, ClockSource, Commit, DeviceState, Geometry, Info,
    Intensity, Message, MessageType, MuteReason, PLAY_FLAG_UNTRACKED, Play, PlayAt, Positions,
    SelfTest, Status, UPLOAD_FLAG_INTENSITY_TABLE, xyz_from_le,
};
use crate::codec::Encoding;
use crate::field::{self, Field};
use crate::header::UploadHeader;
use crate::nack::NackCode;
use crate::{MAX_CHUNK, MAX_GEOMETRY_POSITIONS, NO_SLOT};

/// An untrusted payload, read field by field. Reads never panic: a field
/// outside the payload is an error (which [`Fields::exact`] and
/// [`Fields::head`] rule out before any field is read).
struct Fields<'a>(&'a [u8]);

impl<'a> Fields<'a> {
    /// A payload of exactly `len` bytes.
    fn exact(payload: &'a [u8], len: usize) -> Result<Self, &'static str> {
        match payload.len().cmp(&len) {
            core::cmp::Ordering::Less => Err("payload too short"),
            core::cmp::Ordering::Greater => Err("payload too long"),
            core::cmp::Ordering::Equal => Ok(Self(payload)),
        }
    }
    /// A head of `len` bytes and the rest of the payload.
    fn head(payload: &'a [u8], len: usize) -> Result<(Self, &'a [u8]), &'static str> {
        if payload.len() < len {
            return Err("payload too short");
        }
        let (head, rest) = payload.split_at(len);
        Ok((Self(head), rest))
    }
    /// A head of `len` bytes and the bulk bytes after it (`Chunk`,
    /// `Intensity`): 1 ..= [`MAX_CHUNK`] of them ([`elements`]).
    fn bulk(payload: &'a [u8], len: usize) -> Result<(Self, &'a [u8]), &'static str> {
        let (head, data) = Self::head(payload, len)?;
        elements(data.len(), MAX_CHUNK)?;
        Ok((head, data))
    }
    fn array<const N: usize>(&self, f: Field) -> Result<[u8; N], &'static str> {
        let b = self.0.get(f).ok_or("payload too short")?;
        b.try_into()
            .map_err(|_| "field width differs from its type")
    }
    fn u8(&self, f: Field) -> Result<u8, &'static str> {
        Ok(self.array::<1>(f)?[0])
    }
    fn u16(&self, f: Field) -> Result<u16, &'static str> {
        Ok(u16::from_le_bytes(self.array(f)?))
    }
    fn u32(&self, f: Field) -> Result<u32, &'static str> {
        Ok(u32::from_le_bytes(self.array(f)?))
    }
    fn u64(&self, f: Field) -> Result<u64, &'static str> {
        Ok(u64::from_le_bytes(self.array(f)?))
    }
    fn xyz(&self, f: Field) -> Result<[i32; 3], &'static str> {
        Ok(xyz_from_le(self.array(f)?))
    }
    fn bool(&self, f: Field) -> Result<bool, &'static str> {
        self.flag(f, 1, "bool field not 0 or 1")
    }
    /// A flags byte with one known bit `bit`: set or not; any other bit
    /// is `unknown`.
    fn flag(&self, f: Field, bit: u8, unknown: &'static str) -> Result<bool, &'static str> {
        match self.u8(f)? {
            0 => Ok(false),
            b if b == bit => Ok(true),
            _ => Err(unknown),
        }
    }
    /// A slot byte, [`NO_SLOT`] meaning none.
    fn slot(&self, f: Field) -> Result<Option<u8>, &'static str> {
        Ok(Some(self.u8(f)?).filter(|s| *s != NO_SLOT))
    }
}

/// The one rule for the elements a message carries in a list (`Chunk`'s
/// data bytes, `Geometry`'s positions, `Intensity`'s levels; SPEC section
/// 3): 1 ..= `max` of them. An empty list asks for nothing (an empty chunk
/// completes no stream, a geometry with no transducer fills no position,
/// an intensity frame with no value sets no level), so a sender that
/// writes one has lost track of what it sends: malformed, as a longer one
/// is, never acked as a no-op. The encoder refuses both as well.
pub(crate) fn elements(n: usize, max: usize) -> Result<(), &'static str> {
    match n {
        0 => Err("a list of no elements (needs at least one)"),
        n if n > max => Err("more elements than the message's maximum"),
        _ => Ok(()),
    }
}

/// Why a payload did not parse (mapped to [`crate::FrameError`]).
pub(crate) enum PayloadError {
    UnknownType,
    Malformed(&'static str),
}

impl<'a> Message<'a> {
    /// Parses an untrusted payload of type `msg_type`.
    pub(crate) fn parse(msg_type: u8, payload: &'a [u8]) -> Result<Self, PayloadError> {
        let t = MessageType::from_u8(msg_type).ok_or(PayloadError::UnknownType)?;
        Self::parse_known(t, payload).map_err(PayloadError::Malformed)
    }

    fn parse_known(t: MessageType, payload: &'a [u8]) -> Result<Self, &'static str> {
        Ok(match t {
            MessageType::GetInfo => Fields::exact(payload, 0).map(|_| Self::GetInfo)?,
            MessageType::Stop => Fields::exact(payload, 0).map(|_| Self::Stop)?,
            MessageType::GetStatus => Fields::exact(payload, 0).map(|_| Self::GetStatus)?,
            MessageType::Ack => Fields::exact(payload, 0).map(|_| Self::Ack)?,
            MessageType::CommitRig => Fields::exact(payload, 0).map(|_| Self::CommitRig)?,
            MessageType::Renew => Fields::exact(payload, 0).map(|_| Self::Renew)?,
            MessageType::SelfTest => Fields::exact(payload, 0).map(|_| Self::SelfTest)?,
            MessageType::BeginRig => {
                use field::begin_rig as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::BeginRig(BeginRig {
                    transducers: p.u16(f::TRANSDUCERS)?,
                    crc32: p.u32(f::CRC32)?,
                })
            }
            MessageType::BeginUpload => {
                use field::begin_upload as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::BeginUpload(BeginUpload {
                    slot: p.u8(f::SLOT)?,
                    encoding: Encoding::from_u8(p.u8(f::ENCODING)?).ok_or("unknown encoding")?,
                    encoded_len: p.u32(f::ENCODED_LEN)?,
                    rig_crc32: p.u32(f::RIG_CRC32)?,
                    intensity_table: p.flag(
                        f::FLAGS,
                        UPLOAD_FLAG_INTENSITY_TABLE,
                        "unknown upload flag bits",
                    )?,
                    header: UploadHeader {
                        steps: p.u16(f::STEPS)?,
                        transducers: p.u16(f::TRANSDUCERS)?,
                        period_us: p.u32(f::PERIOD_US)?,
                        center_um: p.xyz(f::CENTER_UM)?,
                        foci_per_step: p.u8(f::FOCI_PER_STEP)?,
                        sound_speed_mm_s: p.u32(f::SOUND_SPEED_MM_S)?,
                        max_offset_um: p.u32(f::MAX_OFFSET_UM)?,
                        intensity: p.u8(f::INTENSITY)?,
                    },
                })
            }
            MessageType::Geometry => {
                use field::geometry as f;
                let (p, bytes) = Fields::head(payload, f::LEN)?;
                let positions = Positions::from_le_bytes(bytes)
                    .ok_or("positions not a multiple of POSITION_LEN bytes")?;
                elements(positions.len(), MAX_GEOMETRY_POSITIONS)?;
                Self::Geometry(Geometry {
                    first: p.u16(f::FIRST)?,
                    positions,
                })
            }
            MessageType::Chunk => {
                use field::chunk as f;
                let (p, data) = Fields::bulk(payload, f::LEN)?;
                Self::Chunk(Chunk {
                    slot: p.u8(f::SLOT)?,
                    offset: p.u32(f::OFFSET)?,
                    data,
                })
            }
            MessageType::Intensity => {
                use field::intensity as f;
                let (p, data) = Fields::bulk(payload, f::LEN)?;
                Self::Intensity(Intensity {
                    slot: p.u8(f::SLOT)?,
                    offset: p.u16(f::OFFSET)?,
                    data,
                })
            }
            MessageType::Commit => {
                use field::commit as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::Commit(Commit {
                    slot: p.u8(f::SLOT)?,
                    crc32: p.u32(f::CRC32)?,
                })
            }
            MessageType::Play => {
                use field::play as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::Play(Play {
                    slot: p.u8(f::SLOT)?,
                    at: PlayAt::from_u8(p.u8(f::AT)?).ok_or("unknown play timing")?,
                    untracked: p.flag(f::FLAGS, PLAY_FLAG_UNTRACKED, "unknown play flag bits")?,
                    steps: p.u32(f::STEPS)?,
                    lease_ms: p.u16(f::LEASE_MS)?,
                })
            }
            MessageType::Centroid => {
                use field::centroid as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::Centroid(Centroid {
                    seq: p.u32(f::SEQ)?,
                    pos_um: p.xyz(f::POS_UM)?,
                    present: p.bool(f::PRESENT)?,
                    host_time_us: p.u64(f::HOST_TIME_US)?,
                })
            }
            MessageType::Nack => {
                use field::nack as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::Nack(NackCode::from_u8(p.u8(f::CODE)?))
            }
            MessageType::Info => {
                use field::info as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::Info(Info {
                    proto_version: p.u8(f::PROTO_VERSION)?,
                    fw_version: p.array(f::FW_VERSION)?,
                    max_transducers: p.u16(f::MAX_TRANSDUCERS)?,
                    slot_bytes: p.u32(f::SLOT_BYTES)?,
                    slots: p.u8(f::SLOTS)?,
                    timer_hz: p.u32(f::TIMER_HZ)?,
                    min_dwell_us: p.u32(f::MIN_DWELL_US)?,
                    max_chunk: p.u16(f::MAX_CHUNK)?,
                    rig_transducers: p.u16(f::RIG_TRANSDUCERS)?,
                    rig_crc32: p.u32(f::RIG_CRC32)?,
                    library_free: p.u32(f::LIBRARY_FREE)?,
                    clock: ClockSource::from_u8(p.u8(f::CLOCK)?).ok_or("unknown clock source")?,
                })
            }
            MessageType::Status => {
                use field::status as f;
                let p = Fields::exact(payload, f::LEN)?;
                Self::Status(Status {
                    state: DeviceState::from_u8(p.u8(f::STATE)?).ok_or("unknown device state")?,
                    slot: p.slot(f::SLOT)?,
                    step: p.u16(f::STEP)?,
                    cycles: p.u32(f::CYCLES)?,
                    missed_deadlines: p.u32(f::MISSED_DEADLINES)?,
                    last_centroid_seq: p.u32(f::LAST_CENTROID_SEQ)?,
                    bad_frames: p.u32(f::BAD_FRAMES)?,
                    crc_errors: p.u32(f::CRC_ERRORS)?,
                    nacks: p.u32(f::NACKS)?,
                    correction_um: p.xyz(f::CORRECTION_UM)?,
                    queued_slot: p.slot(f::QUEUED_SLOT)?,
                    mute_reason: MuteReason::from_u8(p.u8(f::MUTE_REASON)?)
                        .ok_or("unknown mute reason")?,
                    lease_ms: p.u16(f::LEASE_MS)?,
                    lease_expiries: p.u32(f::LEASE_EXPIRIES)?,
                    uptime_ms: p.u32(f::UPTIME_MS)?,
                })
            }
            MessageType::SelfTestResult => {
                use field::self_test as f;
                let p = Fields::exact(payload, f::LEN)?;
                let bytes = p.u32(f::BYTES)?;
                let rest = (
                    p.u32(f::MISMATCHES)?,
                    p.u32(f::FIRST_MISMATCH)?,
                    p.u8(f::SENT)?,
                    p.u8(f::GOT)?,
                );
                Self::SelfTestResult(match p.u8(f::OUTCOME)? {
                    0 if bytes == 0 && rest == (0, 0, 0, 0) => SelfTest::Unsupported,
                    1 if rest == (0, 0, 0, 0) => SelfTest::Passed { bytes },
                    2 => SelfTest::Failed {
                        bytes,
                        mismatches: rest.0,
                        first_mismatch: rest.1,
                        sent: rest.2,
                        got: rest.3,
                    },
                    0 | 1 => return Err("self-test field set that its outcome does not have"),
                    _ => return Err("unknown self-test outcome"),
                })
            }
        })
    }
}
