//! The resident stimulus library: [`SLOTS`] entries in one arena of
//! caller-provided memory, plus the rig (the one transducer positions
//! table every entry's centroid correction uses).
//!
//! Memory is `[rig: max_transducers × 12 B][arena]` ([`memory_bytes`]).
//! An entry takes a variable range of the arena, in one of two forms:
//!
//! - **Raw**: the steps × transducers phases, as before (a step is a slice).
//! - **Delta**: the Delta stream as uploaded, decoded step by step while it
//!   plays ([`lm_proto::codec::StepDecoder`] over a three-step ring; a new
//!   cycle, or a step before the last decoded one, re-decodes from step 0).
//!
//! **The storage rule**, decided at `BeginUpload` with the space the upload
//! would have (free bytes plus the slot's old entry and any unfinished
//! upload, which it replaces): a Raw upload is stored Raw; a Delta upload
//! is expanded to Raw when its raw form is no larger than its stream (a
//! few big steps, e.g. 4 mm at 25 Hz), or when after expanding at least
//! three quarters of the arena would still be free ([`Store::raw_fits`]:
//! the first, small entries of a library play from raw frames); otherwise
//! it is kept as Delta. Greedy, in upload order. What does not fit even so
//! is refused with `LibraryFull`, and the old entry stays as it was.
//!
//! **Space**: an entry is placed first-fit in the gaps between entries; when
//! no gap is large enough but the free bytes are, the entries are
//! compacted towards the arena's start first (the playing entry included:
//! its bytes move, its decoding position is relative to the entry, so it
//! plays on). Overwriting an entry (a `BeginUpload` into its slot) frees
//! its space; so does a `BeginRig` for another rig (every entry is
//! dropped: its phases were planned for the old positions).
//!
//! **Uploads**: one at a time. `BeginUpload`, `Chunk`s in stream order,
//! `Commit`. A `BeginUpload` abandons an unfinished upload (its entry is
//! dropped). Every write path starts by marking the slot uncommitted, so a
//! slot that is not [`committed`](Store::is_committed) is never played, and
//! a failed upload cannot reach any other entry. The store never decides
//! whether a slot is playing: the caller refuses writes to the playing or
//! queued slot before calling in here.
//!
//! Repeats are idempotent (SPEC section 2): a chunk lying wholly in the
//! received part of the stream with identical bytes is acked without
//! effect (Raw uploads, and Delta uploads kept as Delta: compared with the
//! stored bytes at any offset; Delta expanded to Raw, whose stream bytes are
//! not kept: any of the last [`CHUNK_LOG`] accepted chunks, by offset,
//! length and CRC-32); a `Commit` of a committed slot with its CRC is
//! acked again, and so is a `BeginRig` of the rig the device holds.

use lm_proto::codec::{Decoder, Encoding, StepDecoder};
use lm_proto::{
    BeginUpload, Crc32, DeviceLimits, NackCode, POSITION_LEN as POSITION_BYTES, Positions,
    UploadHeader,
};

use crate::MAX_TRANSDUCERS;

mod cursor;
mod table;

use cursor::Cursor;
pub use table::scale as scale_intensity;

/// Library entries (slot numbers `0..SLOTS`).
pub const SLOTS: usize = 32;

/// Accepted chunks remembered per upload to recognise repeats (Delta
/// streams expanded to Raw).
pub const CHUNK_LOG: usize = 16;

/// Ring bytes of one step decoder (three steps).
const RING: usize = StepDecoder::ring_len(MAX_TRANSDUCERS);

/// Bitmap words for received rig positions (one bit per transducer).
const GEOMETRY_WORDS: usize = MAX_TRANSDUCERS.div_ceil(32);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Empty,
    Uploading,
    Committed,
}

/// How an entry is kept in the arena.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Form {
    /// Steps × transducers phase bytes.
    Raw,
    /// The Delta stream, decoded while playing.
    Delta,
}

/// One library entry: where it lies and what it plays.
#[derive(Debug, Clone, Copy)]
struct Entry {
    state: State,
    form: Form,
    header: UploadHeader,
    /// Arena range `off..off + len` (len 0 while empty): the stored form,
    /// then the intensity table when it has one (`steps` bytes).
    off: usize,
    len: usize,
    /// The entry has a per-step intensity table ([`table`] module).
    table: bool,
    /// Raw CRC-32 of the committed sequence (repeated commits).
    crc: u32,
}

const EMPTY: Entry = Entry {
    state: State::Empty,
    form: Form::Raw,
    header: UploadHeader {
        steps: 0,
        transducers: 0,
        period_us: 0,
        center_um: [0; 3],
        foci_per_step: 0,
        sound_speed_mm_s: 0,
        max_offset_um: 0,
        intensity: 0,
    },
    off: 0,
    len: 0,
    table: false,
    crc: 0,
};

/// An accepted chunk, to recognise a re-sent duplicate.
#[derive(Debug, Clone, Copy, Default)]
struct LoggedChunk {
    offset: u32,
    len: u32,
    crc: u32,
}

/// The upload in progress.
#[derive(Debug, Clone)]
struct Upload {
    slot: u8,
    encoding: Encoding,
    encoded_len: u32,
    /// Raw form: decodes into the entry's arena range.
    decoder: Decoder,
    /// Delta form: checks the stream kept in the arena, step by step.
    check: StepDecoder,
    /// CRC over the raw phases decoded so far (updated per chunk).
    crc: Crc32,
    /// Ring of the last accepted chunks (Delta expanded to Raw).
    log: [LoggedChunk; CHUNK_LOG],
    logged: usize,
    failed: bool,
    /// Intensity levels received (steps `0..levels`).
    levels: u16,
}

impl Upload {
    /// The upload into `slot` (`NoUpload` if there is none, `BadStream` if
    /// its stream failed).
    fn live(upload: &mut Option<Upload>, slot: u8) -> Result<&mut Upload, NackCode> {
        match upload.as_mut() {
            Some(u) if u.slot == slot && u.failed => Err(NackCode::BadStream),
            Some(u) if u.slot == slot => Ok(u),
            _ => Err(NackCode::NoUpload),
        }
    }
}

/// The rig: the positions table's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rig {
    None,
    Uploading {
        transducers: u16,
        crc: u32,
        mask: [u32; GEOMETRY_WORDS],
    },
    Ready {
        transducers: u16,
        crc: u32,
    },
}

/// Why the store could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StoreError {
    /// `max_transducers` is zero or above [`crate::MAX_TRANSDUCERS`].
    BadTransducerCount,
    /// The memory does not leave one raw step after the rig's positions.
    TooSmall,
}

impl core::fmt::Display for StoreError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BadTransducerCount => "max_transducers must be 1..=MAX_TRANSDUCERS",
            Self::TooSmall => "sequence memory too small for the rig and one step",
        })
    }
}

/// Bytes of memory a board must give for a library arena of
/// `library_bytes` and a rig of up to `max_transducers` positions.
pub const fn memory_bytes(library_bytes: usize, max_transducers: usize) -> usize {
    library_bytes + max_transducers * POSITION_BYTES
}

/// The library arena the boards give: 448 KiB, which with the rig and the
/// core's state fits the Nucleo-H743's 512 KiB AXI SRAM (QEMU gives the
/// same, so its tests show what the Nucleo holds).
pub const BOARD_LIBRARY_BYTES: usize = 448 * 1024;

/// The library.
#[derive(Debug)]
pub struct Store<'m> {
    rig_mem: &'m mut [u8],
    arena: &'m mut [u8],
    entries: [Entry; SLOTS],
    upload: Option<Upload>,
    rig: Rig,
    /// Upload check ring (Delta entries).
    ring: [u8; RING],
    cursor: Cursor,
    max_transducers: u16,
}

impl<'m> Store<'m> {
    /// Splits `mem` into the rig's positions (`max_transducers` × 12 B) and
    /// the arena (the rest).
    pub fn new(mem: &'m mut [u8], max_transducers: u16) -> Result<Self, StoreError> {
        let t = usize::from(max_transducers);
        if t == 0 || t > MAX_TRANSDUCERS {
            return Err(StoreError::BadTransducerCount);
        }
        let pos_len = t * POSITION_BYTES;
        if mem.len() < pos_len + t || mem.len() - pos_len > u32::MAX as usize {
            return Err(StoreError::TooSmall);
        }
        let (rig_mem, arena) = mem.split_at_mut(pos_len);
        Ok(Self {
            rig_mem,
            arena,
            entries: [EMPTY; SLOTS],
            upload: None,
            rig: Rig::None,
            ring: [0; RING],
            cursor: Cursor::new(),
            max_transducers,
        })
    }

    /// Largest raw sequence one entry may have: the arena (`Info::slot_bytes`).
    pub fn slot_bytes(&self) -> u32 {
        self.arena.len() as u32
    }

    /// Arena bytes not taken by an entry or an upload (`Info::library_free`).
    pub fn free_bytes(&self) -> u32 {
        let used: usize = self.entries.iter().map(|e| e.len).sum();
        (self.arena.len() - used) as u32
    }

    /// Most transducers a sequence may have.
    pub fn max_transducers(&self) -> u16 {
        self.max_transducers
    }

    fn committed(&self, slot: u8) -> Option<&Entry> {
        self.entries
            .get(usize::from(slot))
            .filter(|e| e.state == State::Committed)
    }

    /// Whether `slot` holds a committed sequence.
    pub fn is_committed(&self, slot: u8) -> bool {
        self.committed(slot).is_some()
    }

    /// Header of a committed slot.
    pub fn header(&self, slot: u8) -> Option<&UploadHeader> {
        self.committed(slot).map(|e| &e.header)
    }

    /// How a committed slot is stored.
    pub fn form(&self, slot: u8) -> Option<Form> {
        self.committed(slot).map(|e| e.form)
    }

    /// Arena bytes a committed slot takes.
    pub fn stored_bytes(&self, slot: u8) -> Option<u32> {
        self.committed(slot).map(|e| e.len as u32)
    }

    /// Phases of step `step` of a committed slot. Raw entries: a slice of
    /// the arena. Delta entries: decoded into the play ring, from the last
    /// step decoded for this slot (the next step costs one step of
    /// decoding; an earlier one, e.g. step 0 of a new cycle, restarts at
    /// step 0).
    pub fn step(&mut self, slot: u8, step: u16) -> Option<&[u8]> {
        let e = *self.committed(slot)?;
        let h = e.header;
        if step >= h.steps {
            return None;
        }
        let t = usize::from(h.transducers);
        let data = &self.arena[e.off..e.off + e.phases_len()];
        if e.form == Form::Raw {
            let start = usize::from(step) * t;
            return data.get(start..start + t);
        }
        self.cursor.step(slot, &h, data, step)
    }

    /// The rig's positions (packed `[i32; 3]` µm LE) for a committed slot
    /// (planned for that rig, so as many as its transducers).
    pub fn positions(&self, slot: u8) -> Option<&[u8]> {
        let h = self.header(slot)?;
        match self.rig {
            Rig::Ready { transducers, .. } if transducers == h.transducers => self
                .rig_mem
                .get(..usize::from(transducers) * POSITION_BYTES),
            _ => None,
        }
    }

    /// CRC-32 of a committed slot's raw sequence.
    pub fn committed_crc(&self, slot: u8) -> Option<u32> {
        self.committed(slot).map(|e| e.crc)
    }

    /// The rig the device holds: transducers and CRC-32.
    pub fn rig(&self) -> Option<(u16, u32)> {
        match self.rig {
            Rig::Ready { transducers, crc } => Some((transducers, crc)),
            _ => None,
        }
    }

    /// What the store itself can hold (no dwell limit: that is the
    /// player's business).
    pub fn limits(&self) -> DeviceLimits {
        DeviceLimits {
            slots: SLOTS as u8,
            max_transducers: self.max_transducers,
            slot_bytes: self.slot_bytes(),
            min_dwell_us: 0,
        }
    }

    /// The storage rule for a Delta upload of `raw` raw bytes and
    /// `encoded` stream bytes with `free` bytes available: expand to Raw
    /// when raw is no larger, or when it leaves at least three quarters of
    /// the arena free (see the module docs).
    pub fn raw_fits(&self, raw: u64, encoded: u64, free: u64) -> bool {
        raw <= encoded || (raw <= free && free - raw >= self.arena.len() as u64 / 4 * 3)
    }

    /// Drops `slot`'s entry (and the play cursor on it).
    fn drop_entry(&mut self, slot: usize) {
        self.entries[slot] = EMPTY;
        self.cursor.forget(slot as u8);
    }

    /// Starts an upload (the caller has checked the slot is not playing
    /// and the dwell). Checked with [`BeginUpload::validate`] against the
    /// store's [`limits`](Self::limits), then the rig (`NoRig`,
    /// `RigMismatch`), then the space (`LibraryFull`); on any refusal
    /// nothing changes. On success the slot's old entry and any unfinished
    /// upload are dropped.
    pub fn begin(&mut self, b: &BeginUpload) -> Result<(), NackCode> {
        b.validate(&self.limits())?;
        let slot = usize::from(b.slot);
        let h = b.header;
        match self.rig {
            Rig::Ready { transducers, crc } => {
                if crc != b.rig_crc32 || transducers != h.transducers {
                    return Err(NackCode::RigMismatch);
                }
            }
            _ => return Err(NackCode::NoRig),
        }
        let abandoned = self
            .upload
            .as_ref()
            .map(|u| usize::from(u.slot))
            .filter(|&s| s != slot);
        let reclaim = self.entries[slot].len + abandoned.map_or(0, |s| self.entries[s].len);
        let free = u64::from(self.free_bytes()) + reclaim as u64;
        let raw = h.raw_len();
        // The table goes with the phases in either form.
        let table = u64::from(b.table_len());
        let form = match b.encoding {
            Encoding::Delta
                if !self.raw_fits(raw, u64::from(b.encoded_len), free.saturating_sub(table)) =>
            {
                Form::Delta
            }
            _ => Form::Raw,
        };
        let need = table
            + match form {
                Form::Raw => raw,
                Form::Delta => u64::from(b.encoded_len),
            };
        if need > free {
            return Err(NackCode::LibraryFull);
        }
        self.drop_entry(slot);
        if let Some(s) = abandoned {
            self.drop_entry(s);
        }
        let need = need as usize;
        let off = match self.first_fit(need) {
            Some(off) => off,
            None => {
                self.compact();
                self.arena.len() - self.free_bytes() as usize
            }
        };
        self.entries[slot] = Entry {
            state: State::Uploading,
            form,
            header: h,
            off,
            len: need,
            table: b.intensity_table,
            crc: 0,
        };
        self.upload = Some(Upload {
            slot: b.slot,
            encoding: b.encoding,
            encoded_len: b.encoded_len,
            decoder: Decoder::new(b.encoding, h.steps, h.transducers),
            check: StepDecoder::new(b.encoding, h.steps, h.transducers),
            crc: Crc32::new(),
            log: [LoggedChunk::default(); CHUNK_LOG],
            logged: 0,
            failed: false,
            levels: 0,
        });
        Ok(())
    }

    /// Slots of the entries holding space, in arena order.
    fn by_offset(&self) -> ([u8; SLOTS], usize) {
        let mut order = [0u8; SLOTS];
        let mut n = 0;
        for (i, e) in self.entries.iter().enumerate() {
            if e.len > 0 {
                order[n] = i as u8;
                n += 1;
            }
        }
        // Insertion sort: at most SLOTS entries.
        for i in 1..n {
            let mut j = i;
            while j > 0
                && self.entries[usize::from(order[j - 1])].off
                    > self.entries[usize::from(order[j])].off
            {
                order.swap(j - 1, j);
                j -= 1;
            }
        }
        (order, n)
    }

    /// The start of the first gap of at least `need` bytes.
    fn first_fit(&self, need: usize) -> Option<usize> {
        let (order, n) = self.by_offset();
        let mut at = 0;
        for &s in &order[..n] {
            let e = &self.entries[usize::from(s)];
            if e.off - at >= need {
                return Some(at);
            }
            at = e.off + e.len;
        }
        (self.arena.len() - at >= need).then_some(at)
    }

    /// Moves every entry towards the arena's start, closing the gaps.
    fn compact(&mut self) {
        let (order, n) = self.by_offset();
        let mut at = 0;
        for &s in &order[..n] {
            let e = &mut self.entries[usize::from(s)];
            if e.off != at {
                self.arena.copy_within(e.off..e.off + e.len, at);
                e.off = at;
            }
            at += e.len;
        }
    }

    /// Stores a chunk of the encoded stream at `offset`.
    ///
    /// Chunks must arrive in order; a repeat of received data with the
    /// same bytes is acknowledged without effect (see the module docs).
    pub fn chunk(&mut self, slot: u8, offset: u32, data: &[u8]) -> Result<(), NackCode> {
        let e = self.entries[usize::from(slot).min(SLOTS - 1)];
        let up = Upload::live(&mut self.upload, slot)?;
        let len = data.len() as u32;
        let end = u64::from(offset) + u64::from(len);
        if end > u64::from(up.encoded_len) {
            return Err(NackCode::OutOfRange);
        }
        let mem = &mut self.arena[e.off..e.off + e.phases_len()];
        let consumed = match e.form {
            Form::Raw => up.decoder.consumed(),
            Form::Delta => up.check.consumed(),
        } as u64;
        if u64::from(offset) < consumed && end <= consumed {
            let same = match (e.form, up.encoding) {
                // The stream is in the arena: compare what is stored.
                (Form::Delta, _) | (Form::Raw, Encoding::Raw) => {
                    mem.get(offset as usize..end as usize) == Some(data)
                }
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
        if u64::from(offset) != consumed {
            return Err(NackCode::OutOfOrder);
        }
        let ok = match e.form {
            Form::Raw => {
                let before = up.decoder.decoded();
                let ok = up.decoder.feed(data, mem).is_ok();
                up.crc.update(&mem[before..up.decoder.decoded()]);
                ok
            }
            Form::Delta => {
                mem[offset as usize..end as usize].copy_from_slice(data);
                let crc = &mut up.crc;
                up.check
                    .feed(data, &mut self.ring, u16::MAX, |_, row| crc.update(row))
                    .is_ok()
            }
        };
        if !ok {
            up.failed = true;
            return Err(NackCode::BadStream);
        }
        up.log[up.logged % CHUNK_LOG] = LoggedChunk {
            offset,
            len,
            crc: lm_proto::crc32(data),
        };
        up.logged = up.logged.wrapping_add(1);
        Ok(())
    }

    /// Finishes an upload: the whole stream must have arrived and the raw
    /// sequence CRC must match `crc32`. On success the slot becomes
    /// playable; on a CRC mismatch the upload and its entry are dropped. A
    /// repeat of the commit that succeeded (same CRC) is acked again.
    pub fn commit(&mut self, slot: u8, crc32: u32) -> Result<(), NackCode> {
        if self.committed_crc(slot) == Some(crc32) {
            return Ok(());
        }
        let e = self.entries[usize::from(slot).min(SLOTS - 1)];
        let up = Upload::live(&mut self.upload, slot)?;
        let (consumed, finished) = match e.form {
            Form::Raw => (up.decoder.consumed(), up.decoder.finish()),
            Form::Delta => (up.check.consumed(), up.check.finish()),
        };
        if consumed as u64 != u64::from(up.encoded_len) || !table::complete(&e, up) {
            return Err(NackCode::Incomplete);
        }
        if finished.is_err() {
            return Err(NackCode::BadStream);
        }
        // The phases' CRC, then the table as stored: what plays is checked.
        let mut crc = up.crc;
        crc.update(&self.arena[e.off + e.phases_len()..e.off + e.len]);
        let good = crc.finish() == crc32;
        self.upload = None;
        let s = usize::from(slot);
        if !good {
            self.drop_entry(s);
            return Err(NackCode::CrcMismatch);
        }
        self.entries[s].state = State::Committed;
        self.entries[s].crc = crc32;
        Ok(())
    }

    /// Starts a rig upload of `transducers` positions whose table has CRC
    /// `crc32` (the caller has checked that nothing plays). The rig the
    /// device holds already: acked, nothing changes. Another: every entry
    /// and any upload are dropped (planned for the old positions).
    pub fn begin_rig(&mut self, transducers: u16, crc32: u32) -> Result<(), NackCode> {
        if self.rig() == Some((transducers, crc32)) {
            return Ok(());
        }
        if transducers == 0 {
            return Err(NackCode::OutOfRange);
        }
        if transducers > self.max_transducers {
            return Err(NackCode::TooLarge);
        }
        for s in 0..SLOTS {
            self.drop_entry(s);
        }
        self.upload = None;
        self.rig = Rig::Uploading {
            transducers,
            crc: crc32,
            mask: [0; GEOMETRY_WORDS],
        };
        Ok(())
    }

    /// Whether a rig upload is under way (the caller refuses it while
    /// anything plays only when it would change the rig).
    pub fn rig_would_change(&self, transducers: u16, crc32: u32) -> bool {
        self.rig() != Some((transducers, crc32))
    }

    /// Stores rig positions `first..first + positions.len()`. On a rig
    /// already committed, positions identical to the stored ones are acked
    /// (a repeat), others are `NoUpload`.
    pub fn geometry(&mut self, first: u16, positions: &Positions<'_>) -> Result<(), NackCode> {
        if let Rig::Ready { transducers, .. } = self.rig {
            let first = usize::from(first);
            let same = first + positions.len() <= usize::from(transducers)
                && positions.iter().enumerate().all(|(i, p)| {
                    let k = (first + i) * POSITION_BYTES;
                    let r = &self.rig_mem[k..k + POSITION_BYTES];
                    (0..3).all(|c| r[c * 4..c * 4 + 4] == p[c].to_le_bytes())
                });
            return if same {
                Ok(())
            } else {
                Err(NackCode::NoUpload)
            };
        }
        let Rig::Uploading {
            transducers, mask, ..
        } = &mut self.rig
        else {
            return Err(NackCode::NoUpload);
        };
        let first = usize::from(first);
        let n = positions.len();
        if first + n > usize::from(*transducers) {
            return Err(NackCode::OutOfRange);
        }
        for (i, p) in positions.iter().enumerate() {
            let k = first + i;
            let dst = &mut self.rig_mem[k * POSITION_BYTES..(k + 1) * POSITION_BYTES];
            for (c, v) in p.iter().enumerate() {
                dst[c * 4..c * 4 + 4].copy_from_slice(&v.to_le_bytes());
            }
            mask[k / 32] |= 1 << (k % 32);
        }
        Ok(())
    }

    /// Finishes the rig upload: every position must have arrived and the
    /// table's CRC-32 must be `BeginRig`'s (else the rig is dropped,
    /// `CrcMismatch`). A repeat after success is acked again.
    pub fn commit_rig(&mut self) -> Result<(), NackCode> {
        let (transducers, crc, mask) = match self.rig {
            Rig::Ready { .. } => return Ok(()),
            Rig::None => return Err(NackCode::NoUpload),
            Rig::Uploading {
                transducers,
                crc,
                mask,
            } => (transducers, crc, mask),
        };
        let t = usize::from(transducers);
        if !(0..t).all(|k| mask[k / 32] & (1 << (k % 32)) != 0) {
            return Err(NackCode::Incomplete);
        }
        if lm_proto::crc32(&self.rig_mem[..t * POSITION_BYTES]) != crc {
            self.rig = Rig::None;
            return Err(NackCode::CrcMismatch);
        }
        self.rig = Rig::Ready { transducers, crc };
        Ok(())
    }
}

#[cfg(test)]
mod tests;
