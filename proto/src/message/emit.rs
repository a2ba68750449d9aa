//! Writing a message's payload, field by field.

use super::{Message, PLAY_FLAG_UNTRACKED, SelfTest, UPLOAD_FLAG_INTENSITY_TABLE, xyz_le};
use crate::error::EncodeError;
use crate::field::{self, Field};
use crate::nack::NackCode;
use crate::{MAX_CHUNK, MAX_GEOMETRY_POSITIONS, NO_SLOT};

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

/// Writes `bytes` into field `f` of a payload being built (the widths are
/// the layout's, checked by every round-trip test).
fn set(p: &mut [u8], f: Field, bytes: &[u8]) {
    p[f].copy_from_slice(bytes);
}

/// A flags byte with one known bit `bit`, set when `on`.
fn flag(on: bool, bit: u8) -> u8 {
    if on { bit } else { 0 }
}

/// Writes a bulk message (`Chunk`, `Intensity`): a head of its slot and
/// the offset of its bytes (whose width is the layout's), then the bytes.
fn put_bulk<const LEN: usize>(
    s: &mut impl Sink,
    [slot_f, offset_f]: [Field; 2],
    slot: u8,
    offset: &[u8],
    data: &[u8],
) -> Result<(), EncodeError> {
    let mut p = [0; LEN];
    set(&mut p, slot_f, &[slot]);
    set(&mut p, offset_f, offset);
    s.put(&p)?;
    s.put(data)
}

impl Message<'_> {
    /// Writes the payload (no header, no CRC) into `buf`; returns its length.
    pub fn emit_payload(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let mut s = SliceSink { buf, len: 0 };
        self.emit(&mut s)?;
        Ok(s.len)
    }

    /// Checks limits the type system does not enforce: whether the wire
    /// can carry this message at all (what [`crate::encode_frame`] checks
    /// first, and a device handed a message built in process checks as it
    /// checks a parsed one).
    pub fn check(&self) -> Result<(), EncodeError> {
        // A list's elements: the parser's one rule (`parse::elements`),
        // too many `TooLarge`, none `InvalidField`.
        let list = match self {
            Self::Geometry(g) => Some((g.positions.len(), MAX_GEOMETRY_POSITIONS)),
            Self::Chunk(c) => Some((c.data.len(), MAX_CHUNK)),
            Self::Intensity(c) => Some((c.data.len(), MAX_CHUNK)),
            _ => None,
        };
        match list {
            Some((n, max)) if n > max => return Err(EncodeError::TooLarge),
            Some((0, _)) => return Err(EncodeError::InvalidField),
            _ => {}
        }
        match self {
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
            payload_less!(Self) => Ok(()),
            Self::BeginRig(r) => {
                use field::begin_rig as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::TRANSDUCERS, &r.transducers.to_le_bytes());
                set(&mut p, f::CRC32, &r.crc32.to_le_bytes());
                s.put(&p)
            }
            Self::BeginUpload(b) => {
                use field::begin_upload as f;
                let h = &b.header;
                let mut p = [0; f::LEN];
                set(&mut p, f::SLOT, &[b.slot]);
                set(&mut p, f::STEPS, &h.steps.to_le_bytes());
                set(&mut p, f::TRANSDUCERS, &h.transducers.to_le_bytes());
                set(&mut p, f::PERIOD_US, &h.period_us.to_le_bytes());
                set(&mut p, f::ENCODING, &[b.encoding.to_u8()]);
                set(&mut p, f::ENCODED_LEN, &b.encoded_len.to_le_bytes());
                set(&mut p, f::CENTER_UM, &xyz_le(&h.center_um));
                set(&mut p, f::FOCI_PER_STEP, &[h.foci_per_step]);
                set(
                    &mut p,
                    f::SOUND_SPEED_MM_S,
                    &h.sound_speed_mm_s.to_le_bytes(),
                );
                set(&mut p, f::MAX_OFFSET_UM, &h.max_offset_um.to_le_bytes());
                set(&mut p, f::RIG_CRC32, &b.rig_crc32.to_le_bytes());
                set(&mut p, f::INTENSITY, &[h.intensity]);
                set(
                    &mut p,
                    f::FLAGS,
                    &[flag(b.intensity_table, UPLOAD_FLAG_INTENSITY_TABLE)],
                );
                s.put(&p)
            }
            Self::Geometry(g) => {
                use field::geometry as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::FIRST, &g.first.to_le_bytes());
                s.put(&p)?;
                g.positions.iter().try_for_each(|q| s.put(&xyz_le(&q)))
            }
            Self::Chunk(c) => {
                use field::chunk as f;
                let offset = c.offset.to_le_bytes();
                put_bulk::<{ f::LEN }>(s, [f::SLOT, f::OFFSET], c.slot, &offset, c.data)
            }
            Self::Intensity(c) => {
                use field::intensity as f;
                let offset = c.offset.to_le_bytes();
                put_bulk::<{ f::LEN }>(s, [f::SLOT, f::OFFSET], c.slot, &offset, c.data)
            }
            Self::Commit(c) => {
                use field::commit as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::SLOT, &[c.slot]);
                set(&mut p, f::CRC32, &c.crc32.to_le_bytes());
                s.put(&p)
            }
            Self::Play(q) => {
                use field::play as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::SLOT, &[q.slot]);
                set(&mut p, f::AT, &[q.at.to_u8()]);
                set(&mut p, f::FLAGS, &[flag(q.untracked, PLAY_FLAG_UNTRACKED)]);
                set(&mut p, f::STEPS, &q.steps.to_le_bytes());
                set(&mut p, f::LEASE_MS, &q.lease_ms.to_le_bytes());
                s.put(&p)
            }
            Self::Centroid(c) => {
                use field::centroid as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::SEQ, &c.seq.to_le_bytes());
                set(&mut p, f::POS_UM, &xyz_le(&c.pos_um));
                set(&mut p, f::PRESENT, &[u8::from(c.present)]);
                set(&mut p, f::HOST_TIME_US, &c.host_time_us.to_le_bytes());
                s.put(&p)
            }
            Self::Nack(code) => {
                use field::nack as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::CODE, &[code.to_u8()]);
                s.put(&p)
            }
            Self::Info(i) => {
                use field::info as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::PROTO_VERSION, &[i.proto_version]);
                set(&mut p, f::FW_VERSION, &i.fw_version);
                set(&mut p, f::MAX_TRANSDUCERS, &i.max_transducers.to_le_bytes());
                set(&mut p, f::SLOT_BYTES, &i.slot_bytes.to_le_bytes());
                set(&mut p, f::SLOTS, &[i.slots]);
                set(&mut p, f::TIMER_HZ, &i.timer_hz.to_le_bytes());
                set(&mut p, f::MIN_DWELL_US, &i.min_dwell_us.to_le_bytes());
                set(&mut p, f::MAX_CHUNK, &i.max_chunk.to_le_bytes());
                set(&mut p, f::RIG_TRANSDUCERS, &i.rig_transducers.to_le_bytes());
                set(&mut p, f::RIG_CRC32, &i.rig_crc32.to_le_bytes());
                set(&mut p, f::LIBRARY_FREE, &i.library_free.to_le_bytes());
                set(&mut p, f::CLOCK, &[i.clock.to_u8()]);
                s.put(&p)
            }
            Self::Status(st) => {
                use field::status as f;
                let mut p = [0; f::LEN];
                set(&mut p, f::STATE, &[st.state.to_u8()]);
                set(&mut p, f::SLOT, &[st.slot.unwrap_or(NO_SLOT)]);
                set(&mut p, f::STEP, &st.step.to_le_bytes());
                set(&mut p, f::CYCLES, &st.cycles.to_le_bytes());
                set(
                    &mut p,
                    f::MISSED_DEADLINES,
                    &st.missed_deadlines.to_le_bytes(),
                );
                set(
                    &mut p,
                    f::LAST_CENTROID_SEQ,
                    &st.last_centroid_seq.to_le_bytes(),
                );
                set(&mut p, f::BAD_FRAMES, &st.bad_frames.to_le_bytes());
                set(&mut p, f::CRC_ERRORS, &st.crc_errors.to_le_bytes());
                set(&mut p, f::NACKS, &st.nacks.to_le_bytes());
                set(&mut p, f::CORRECTION_UM, &xyz_le(&st.correction_um));
                set(&mut p, f::QUEUED_SLOT, &[st.queued_slot.unwrap_or(NO_SLOT)]);
                set(&mut p, f::MUTE_REASON, &[st.mute_reason.to_u8()]);
                set(&mut p, f::LEASE_MS, &st.lease_ms.to_le_bytes());
                set(&mut p, f::LEASE_EXPIRIES, &st.lease_expiries.to_le_bytes());
                set(&mut p, f::UPTIME_MS, &st.uptime_ms.to_le_bytes());
                s.put(&p)
            }
            Self::SelfTestResult(t) => {
                use field::self_test as f;
                let mut p = [0; f::LEN];
                let (outcome, bytes, mismatches, first, sent, got) = match *t {
                    SelfTest::Unsupported => (0u8, 0, 0, 0, 0, 0),
                    SelfTest::Passed { bytes } => (1, bytes, 0, 0, 0, 0),
                    SelfTest::Failed {
                        bytes,
                        mismatches,
                        first_mismatch,
                        sent,
                        got,
                    } => (2, bytes, mismatches, first_mismatch, sent, got),
                };
                set(&mut p, f::OUTCOME, &[outcome]);
                set(&mut p, f::BYTES, &bytes.to_le_bytes());
                set(&mut p, f::MISMATCHES, &mismatches.to_le_bytes());
                set(&mut p, f::FIRST_MISMATCH, &first.to_le_bytes());
                set(&mut p, f::SENT, &[sent]);
                set(&mut p, f::GOT, &[got]);
                s.put(&p)
            }
        }
    }
}
