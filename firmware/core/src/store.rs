//! Sequence store: [`SLOTS`] slots over caller-provided memory.
//!
//! Each slot's memory is `[positions: max_transducers × 12 B][raw phases]`.
//! An upload is `BeginUpload`, `Geometry` frames (any order of whole
//! frames, each at its index), `Chunk`s in stream order, then `Commit`.
//! The store never decides whether a slot is playing: the caller refuses
//! writes to the playing slot before calling in here. Every write path
//! starts by marking the slot uncommitted, so a slot that is not
//! [`committed`](Store::is_committed) is never played, and a failed upload
//! cannot reach any other slot.
//!
//! Repeats are idempotent (SPEC section 2): a chunk lying wholly in the
//! received part of the stream with identical bytes is acked without
//! effect (Raw: compared with the stored bytes at any offset; Delta, whose
//! stream bytes are not kept: any of the last [`CHUNK_LOG`] accepted chunks,
//! by offset, length and CRC-32); a `Commit` of a committed slot with its
//! CRC is acked again.

use lm_proto::codec::{Decoder, Encoding};
use lm_proto::{
    BeginUpload, Crc32, DeviceLimits, NackCode, POSITION_LEN as POSITION_BYTES, Positions,
    UploadHeader,
};

/// Number of slots.
pub const SLOTS: usize = 2;

/// Accepted Delta chunks remembered per upload to recognise repeats.
pub const CHUNK_LOG: usize = 16;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Empty,
    Uploading,
    Committed,
}

/// An accepted chunk, to recognise a re-sent duplicate.
#[derive(Debug, Clone, Copy, Default)]
struct LoggedChunk {
    offset: u32,
    len: u32,
    crc: u32,
}

/// Upload bookkeeping of one slot.
#[derive(Debug, Clone)]
struct Upload {
    encoded_len: u32,
    decoder: Decoder,
    /// CRC over the raw phases decoded so far (updated per chunk).
    crc: Crc32,
    encoding: Encoding,
    /// Ring of the last accepted chunks (Delta repeats).
    log: [LoggedChunk; CHUNK_LOG],
    logged: usize,
    /// Number of positions received; positions arrive in whole frames.
    geometry_mask_words: [u32; GEOMETRY_WORDS],
    failed: bool,
}

/// Bitmap words for received positions (one bit per transducer).
const GEOMETRY_WORDS: usize = crate::MAX_TRANSDUCERS.div_ceil(32);

/// One slot: memory plus state.
#[derive(Debug)]
struct Slot<'m> {
    positions: &'m mut [u8],
    phases: &'m mut [u8],
    state: State,
    header: Option<UploadHeader>,
    upload: Option<Upload>,
    /// Raw CRC-32 of the committed sequence (repeated commits).
    committed_crc: u32,
}

/// Why the store could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StoreError {
    /// `max_transducers` is zero or above [`crate::MAX_TRANSDUCERS`].
    BadTransducerCount,
    /// The memory does not leave one raw step per slot after the positions.
    TooSmall,
}

impl core::fmt::Display for StoreError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BadTransducerCount => "max_transducers must be 1..=MAX_TRANSDUCERS",
            Self::TooSmall => "sequence memory too small for the positions and one step per slot",
        })
    }
}

/// Bytes of memory a board must give for `slot_bytes` raw phase bytes per
/// slot and `max_transducers` positions per slot.
pub const fn memory_bytes(slot_bytes: usize, max_transducers: usize) -> usize {
    SLOTS * (slot_bytes + max_transducers * POSITION_BYTES)
}

/// The sequence store.
#[derive(Debug)]
pub struct Store<'m> {
    slots: [Slot<'m>; SLOTS],
    max_transducers: u16,
    slot_bytes: u32,
}

impl<'m> Store<'m> {
    /// Splits `mem` into [`SLOTS`] equal slots, each with room for
    /// `max_transducers` positions; the rest of each slot holds phases.
    pub fn new(mem: &'m mut [u8], max_transducers: u16) -> Result<Self, StoreError> {
        let t = usize::from(max_transducers);
        if t == 0 || t > crate::MAX_TRANSDUCERS {
            return Err(StoreError::BadTransducerCount);
        }
        let per_slot = (mem.len() / SLOTS).min(u32::MAX as usize);
        let pos_len = t * POSITION_BYTES;
        if per_slot < pos_len + 1 {
            return Err(StoreError::TooSmall);
        }
        let (a, rest) = mem.split_at_mut(per_slot);
        let (b, _) = rest.split_at_mut(per_slot);
        let make = |m: &'m mut [u8]| {
            let (positions, phases) = m.split_at_mut(pos_len);
            Slot {
                positions,
                phases,
                state: State::Empty,
                header: None,
                upload: None,
                committed_crc: 0,
            }
        };
        Ok(Self {
            slots: [make(a), make(b)],
            max_transducers,
            slot_bytes: (per_slot - pos_len) as u32,
        })
    }

    /// Raw phase bytes one slot holds (`Info::slot_bytes`).
    pub fn slot_bytes(&self) -> u32 {
        self.slot_bytes
    }

    /// Most transducers a sequence may have.
    pub fn max_transducers(&self) -> u16 {
        self.max_transducers
    }

    fn slot(&mut self, slot: u8) -> Result<&mut Slot<'m>, NackCode> {
        self.slots
            .get_mut(usize::from(slot))
            .ok_or(NackCode::BadSlot)
    }

    /// Whether `slot` holds a committed sequence.
    pub fn is_committed(&self, slot: u8) -> bool {
        self.slots
            .get(usize::from(slot))
            .is_some_and(|s| s.state == State::Committed)
    }

    /// Header of a committed slot.
    pub fn header(&self, slot: u8) -> Option<&UploadHeader> {
        let s = self.slots.get(usize::from(slot))?;
        if s.state == State::Committed {
            s.header.as_ref()
        } else {
            None
        }
    }

    /// Phases of step `step` of a committed slot.
    pub fn step(&self, slot: u8, step: u16) -> Option<&[u8]> {
        let s = self.slots.get(usize::from(slot))?;
        let h = s.header.as_ref().filter(|_| s.state == State::Committed)?;
        if step >= h.steps {
            return None;
        }
        let t = usize::from(h.transducers);
        let start = usize::from(step) * t;
        s.phases.get(start..start + t)
    }

    /// Positions (packed `[i32; 3]` µm LE) of a committed slot.
    pub fn positions(&self, slot: u8) -> Option<&[u8]> {
        let s = self.slots.get(usize::from(slot))?;
        let h = s.header.as_ref().filter(|_| s.state == State::Committed)?;
        s.positions
            .get(..usize::from(h.transducers) * POSITION_BYTES)
    }

    /// CRC-32 of a committed slot's raw sequence.
    pub fn committed_crc(&self, slot: u8) -> Option<u32> {
        let s = self.slots.get(usize::from(slot))?;
        (s.state == State::Committed).then_some(s.committed_crc)
    }

    /// What the store itself can hold (no dwell limit: that is the
    /// player's business).
    pub fn limits(&self) -> DeviceLimits {
        DeviceLimits {
            slots: SLOTS as u8,
            max_transducers: self.max_transducers,
            slot_bytes: self.slot_bytes,
            min_dwell_us: 0,
        }
    }

    /// Starts an upload (the caller has checked the slot is not playing
    /// and the dwell). Any previous content of the slot is invalidated.
    /// The header is checked with [`BeginUpload::validate`] against the
    /// store's [`limits`](Self::limits).
    pub fn begin(&mut self, b: &BeginUpload) -> Result<(), NackCode> {
        b.validate(&self.limits())?;
        let s = self.slot(b.slot)?;
        let h = b.header;
        s.state = State::Uploading;
        s.header = Some(h);
        s.upload = Some(Upload {
            encoded_len: b.encoded_len,
            decoder: Decoder::new(b.encoding, h.steps, h.transducers),
            crc: Crc32::new(),
            encoding: b.encoding,
            log: [LoggedChunk::default(); CHUNK_LOG],
            logged: 0,
            geometry_mask_words: [0; GEOMETRY_WORDS],
            failed: false,
        });
        Ok(())
    }

    fn uploading(&mut self, slot: u8) -> Result<(&mut Slot<'m>, UploadHeader), NackCode> {
        let s = self.slot(slot)?;
        match (s.state, s.header) {
            (State::Uploading, Some(h)) if s.upload.is_some() => Ok((s, h)),
            _ => Err(NackCode::NoUpload),
        }
    }

    /// Stores positions `first..first + positions.len()`.
    pub fn geometry(
        &mut self,
        slot: u8,
        first: u16,
        positions: &Positions<'_>,
    ) -> Result<(), NackCode> {
        let (s, h) = self.uploading(slot)?;
        let first = usize::from(first);
        let n = positions.len();
        if first + n > usize::from(h.transducers) {
            return Err(NackCode::OutOfRange);
        }
        let Some(up) = s.upload.as_mut() else {
            return Err(NackCode::NoUpload);
        };
        for i in 0..n {
            let Some(p) = positions.get(i) else {
                return Err(NackCode::Malformed);
            };
            let k = first + i;
            let dst = &mut s.positions[k * POSITION_BYTES..(k + 1) * POSITION_BYTES];
            for (c, v) in p.iter().enumerate() {
                dst[c * 4..c * 4 + 4].copy_from_slice(&v.to_le_bytes());
            }
            up.geometry_mask_words[k / 32] |= 1 << (k % 32);
        }
        Ok(())
    }

    /// Stores a chunk of the encoded stream at `offset`.
    ///
    /// Chunks must arrive in order; a repeat of received data with the
    /// same bytes is acknowledged without effect (see the module docs).
    pub fn chunk(&mut self, slot: u8, offset: u32, data: &[u8]) -> Result<(), NackCode> {
        let (s, _) = self.uploading(slot)?;
        let Some(up) = s.upload.as_mut() else {
            return Err(NackCode::NoUpload);
        };
        if up.failed {
            return Err(NackCode::BadStream);
        }
        let len = data.len() as u32;
        let end = u64::from(offset) + u64::from(len);
        if end > u64::from(up.encoded_len) {
            return Err(NackCode::OutOfRange);
        }
        let consumed = up.decoder.consumed() as u64;
        if u64::from(offset) < consumed && end <= consumed {
            let same = match up.encoding {
                // Raw: the stream is the phases; compare what is stored.
                Encoding::Raw => s.phases.get(offset as usize..end as usize) == Some(data),
                _ => {
                    let crc = lm_proto::crc32(data);
                    up.log[..up.logged.min(CHUNK_LOG)]
                        .iter()
                        .any(|l| l.offset == offset && l.len == len && l.crc == crc)
                }
            };
            return if same {
                Ok(())
            } else {
                Err(NackCode::OutOfOrder)
            };
        }
        if offset as usize != up.decoder.consumed() {
            return Err(NackCode::OutOfOrder);
        }
        let before = up.decoder.decoded();
        if up.decoder.feed(data, s.phases).is_err() {
            up.failed = true;
            return Err(NackCode::BadStream);
        }
        let after = up.decoder.decoded();
        up.crc.update(&s.phases[before..after]);
        up.log[up.logged % CHUNK_LOG] = LoggedChunk {
            offset,
            len,
            crc: lm_proto::crc32(data),
        };
        up.logged = up.logged.wrapping_add(1);
        Ok(())
    }

    /// Finishes an upload: the whole stream and every position must have
    /// arrived and the raw sequence CRC must match `crc32`. On success the
    /// slot becomes playable; on a CRC mismatch the upload is dropped. A
    /// repeat of the commit that succeeded (same CRC) is acked again.
    pub fn commit(&mut self, slot: u8, crc32: u32) -> Result<(), NackCode> {
        if self.committed_crc(slot) == Some(crc32) {
            return Ok(());
        }
        let (s, h) = self.uploading(slot)?;
        let Some(up) = s.upload.as_ref() else {
            return Err(NackCode::NoUpload);
        };
        if up.failed {
            return Err(NackCode::BadStream);
        }
        if up.decoder.consumed() as u64 != u64::from(up.encoded_len) {
            return Err(NackCode::Incomplete);
        }
        if up.decoder.finish().is_err() {
            return Err(NackCode::BadStream);
        }
        let t = usize::from(h.transducers);
        let all_positions = (0..t).all(|k| up.geometry_mask_words[k / 32] & (1 << (k % 32)) != 0);
        if !all_positions {
            return Err(NackCode::Incomplete);
        }
        if up.crc.finish() != crc32 {
            s.state = State::Empty;
            s.upload = None;
            return Err(NackCode::CrcMismatch);
        }
        s.state = State::Committed;
        s.committed_crc = crc32;
        s.upload = None;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn begin(slot: u8, steps: u16, t: u16) -> BeginUpload {
        BeginUpload {
            slot,
            header: UploadHeader {
                steps,
                transducers: t,
                period_us: 200_000,
                center_um: [0, 0, 150_000],
                foci_per_step: 1,
                sound_speed_mm_s: 340_000,
                max_offset_um: 20_000,
            },
            encoding: Encoding::Raw,
            encoded_len: u32::from(steps) * u32::from(t),
        }
    }

    fn geometry(store: &mut Store<'_>, slot: u8, t: u16) {
        let pts: [[i32; 3]; 4] = [
            [0, 0, 0],
            [10_000, 0, 0],
            [0, 10_000, 0],
            [10_000, 10_000, 0],
        ];
        for first in 0..t {
            let i = usize::from(first) % 4;
            store
                .geometry(slot, first, &Positions::from_points(&pts[i..i + 1]))
                .unwrap();
        }
    }

    #[test]
    fn raw_upload_commit_and_read_back() {
        let mut mem = [0u8; memory_bytes(64, 4)];
        let mut st = Store::new(&mut mem, 4).unwrap();
        assert_eq!(st.slot_bytes(), 64);
        let data: [u8; 12] = core::array::from_fn(|i| i as u8 * 7);
        st.begin(&begin(1, 3, 4)).unwrap();
        geometry(&mut st, 1, 4);
        assert_eq!(st.chunk(1, 0, &data[..5]), Ok(()));
        assert_eq!(
            st.chunk(1, 0, &data[..5]),
            Ok(()),
            "duplicate of last chunk"
        );
        assert_eq!(st.chunk(1, 0, &data[1..6]), Err(NackCode::OutOfOrder));
        assert_eq!(st.chunk(1, 1, &data[1..4]), Ok(()), "identical inner range");
        assert_eq!(
            st.chunk(1, 3, &data[3..7]),
            Err(NackCode::OutOfOrder),
            "overlap"
        );
        assert_eq!(st.chunk(1, 6, &data[6..]), Err(NackCode::OutOfOrder), "gap");
        assert_eq!(st.chunk(1, 5, &data[5..]), Ok(()));
        assert_eq!(st.chunk(1, 12, &[1]), Err(NackCode::OutOfRange));
        assert_eq!(st.commit(1, 1), Err(NackCode::CrcMismatch));
        assert!(!st.is_committed(1));
        assert_eq!(
            st.commit(1, lm_proto::crc32(&data)),
            Err(NackCode::NoUpload)
        );
        st.begin(&begin(1, 3, 4)).unwrap();
        geometry(&mut st, 1, 4);
        assert_eq!(
            st.commit(1, lm_proto::crc32(&data)),
            Err(NackCode::Incomplete)
        );
        st.chunk(1, 0, &data).unwrap();
        st.commit(1, lm_proto::crc32(&data)).unwrap();
        assert!(st.is_committed(1));
        assert_eq!(st.commit(1, lm_proto::crc32(&data)), Ok(()), "repeat");
        assert_eq!(st.commit(1, 0), Err(NackCode::NoUpload), "other CRC");
        assert!(st.is_committed(1));
        assert_eq!(st.step(1, 2), Some(&data[8..12]));
        assert_eq!(st.step(1, 3), None);
        assert_eq!(&st.positions(1).unwrap()[12..16], &10_000i32.to_le_bytes());
    }

    #[test]
    fn refuses_bad_headers() {
        let mut mem = [0u8; memory_bytes(64, 4)];
        let mut st = Store::new(&mut mem, 4).unwrap();
        assert_eq!(st.begin(&begin(2, 1, 1)), Err(NackCode::BadSlot));
        assert_eq!(st.begin(&begin(0, 17, 4)), Err(NackCode::TooLarge));
        assert_eq!(st.begin(&begin(0, 1, 5)), Err(NackCode::TooLarge));
        assert_eq!(st.begin(&begin(0, 0, 4)), Err(NackCode::OutOfRange));
        for speed in [0, 99_999, 2_000_001, u32::MAX] {
            let mut b = begin(0, 1, 4);
            b.header.sound_speed_mm_s = speed;
            assert_eq!(st.begin(&b), Err(NackCode::OutOfRange), "{speed} mm/s");
        }
        let mut b = begin(0, 2, 4);
        b.encoded_len = 7;
        assert_eq!(st.begin(&b), Err(NackCode::OutOfRange));
        b.encoding = Encoding::Delta;
        b.encoded_len = 0;
        assert_eq!(st.begin(&b), Err(NackCode::OutOfRange));
        let mut b = begin(0, 2, 4);
        b.header.max_offset_um = 0;
        assert_eq!(st.begin(&b), Err(NackCode::OutOfRange));
        assert_eq!(st.chunk(0, 0, &[0]), Err(NackCode::NoUpload));
        assert!(Store::new(&mut [0u8; 10], 4).is_err());
    }

    #[test]
    fn commit_needs_every_position() {
        let mut mem = [0u8; memory_bytes(64, 4)];
        let mut st = Store::new(&mut mem, 4).unwrap();
        st.begin(&begin(0, 1, 4)).unwrap();
        st.chunk(0, 0, &[1, 2, 3, 4]).unwrap();
        let p = [[1, 2, 3]; 3];
        st.geometry(0, 0, &Positions::from_points(&p)).unwrap();
        assert_eq!(
            st.geometry(0, 2, &Positions::from_points(&p)),
            Err(NackCode::OutOfRange)
        );
        assert_eq!(
            st.commit(0, lm_proto::crc32(&[1, 2, 3, 4])),
            Err(NackCode::Incomplete)
        );
        st.geometry(0, 3, &Positions::from_points(&p[..1])).unwrap();
        st.commit(0, lm_proto::crc32(&[1, 2, 3, 4])).unwrap();
    }

    #[test]
    fn delta_stream_decodes_into_slot() {
        let t = 5u16;
        let steps = 9u16;
        let raw: [u8; 45] = core::array::from_fn(|i| ((i / 5) * (i % 5 + 1) * 3) as u8);
        let mut enc = [0u8; 256];
        let n = lm_proto::codec::encode(Encoding::Delta, &raw, usize::from(t), &mut enc).unwrap();
        let mut mem = [0u8; memory_bytes(64, 5)];
        let mut st = Store::new(&mut mem, 5).unwrap();
        let mut b = begin(0, steps, t);
        b.encoding = Encoding::Delta;
        b.encoded_len = n as u32;
        st.begin(&b).unwrap();
        assert!(n <= 3 * CHUNK_LOG, "every chunk stays logged");
        let p = [[0, 0, 0]; 5];
        st.geometry(0, 0, &Positions::from_points(&p)).unwrap();
        let mut off = 0;
        for piece in enc[..n].chunks(3) {
            st.chunk(0, off as u32, piece).unwrap();
            off += piece.len();
        }
        // Repeats of any logged chunk are acked; other bytes are not.
        assert_eq!(st.chunk(0, 0, &enc[..3]), Ok(()));
        assert_eq!(st.chunk(0, 3, &enc[3..6]), Ok(()));
        assert_eq!(st.chunk(0, 3, &[0xAA; 3]), Err(NackCode::OutOfOrder));
        assert_eq!(
            st.chunk(0, 1, &enc[1..4]),
            Err(NackCode::OutOfOrder),
            "unlogged"
        );
        st.commit(0, lm_proto::crc32(&raw)).unwrap();
        for k in 0..steps {
            let s = usize::from(k) * 5;
            assert_eq!(st.step(0, k).unwrap(), &raw[s..s + 5]);
        }
    }
}
