//! An entry's per-step intensity table (protocol v6): one level per step,
//! stored after the entry's phases (or Delta stream) in its arena range,
//! so it moves, is freed and is accounted with the entry. Step `j` plays
//! at `intensity × level[j] / 255` ([`scale`]); an entry without a table
//! plays its `intensity` at every step, as before.
//!
//! Levels arrive in `Intensity` frames in step order, with `Chunk`'s
//! repeat rule (the levels are kept, so identical repeats at any offset
//! are acked); `Commit` needs all of them and its CRC covers them as
//! stored, after the phases.

use lm_proto::NackCode;

use super::{Entry, SLOTS, Store, Upload};

impl Entry {
    /// Bytes of the table (`steps`, or 0 without one).
    pub(super) fn table_len(&self) -> usize {
        if self.table {
            usize::from(self.header.steps)
        } else {
            0
        }
    }

    /// Bytes of the stored form before the table (raw phases or the
    /// Delta stream).
    pub(super) fn phases_len(&self) -> usize {
        self.len - self.table_len()
    }
}

/// Whether every level of `e`'s table arrived (true without a table).
pub(super) fn complete(e: &Entry, up: &Upload) -> bool {
    !e.table || up.levels == e.header.steps
}

/// The output intensity of a step at `level` in an entry of `intensity`:
/// `intensity × level / 255` rounded to nearest, in integers (the player
/// has no floating point per step). 255 is odd, so no product lies
/// half-way and `+ 127` rounds every value exactly.
pub const fn scale(intensity: u8, level: u8) -> u8 {
    ((intensity as u16 * level as u16 + 127) / 255) as u8
}

impl Store<'_> {
    /// Stores intensity levels `offset..offset + levels.len()` of the
    /// upload into `slot`: `NoUpload` without that upload, `OutOfRange`
    /// past its last step (every level of an upload without a table),
    /// `OutOfOrder` for a gap or different levels over received ones; an
    /// identical repeat is acked without effect.
    pub fn intensity_levels(
        &mut self,
        slot: u8,
        offset: u16,
        levels: &[u8],
    ) -> Result<(), NackCode> {
        let e = self.entries[usize::from(slot).min(SLOTS - 1)];
        let up = Upload::live(&mut self.upload, slot)?;
        let table = &mut self.arena[e.off + e.phases_len()..e.off + e.len];
        let start = usize::from(offset);
        let end = start + levels.len();
        if end > table.len() {
            return Err(NackCode::OutOfRange);
        }
        let received = usize::from(up.levels);
        if end <= received {
            return if &table[start..end] == levels {
                Ok(())
            } else {
                Err(NackCode::OutOfOrder)
            };
        }
        if start != received {
            return Err(NackCode::OutOfOrder);
        }
        table[start..end].copy_from_slice(levels);
        // end ≤ steps, a u16.
        up.levels = end as u16;
        Ok(())
    }

    /// The intensity step `step` of a committed slot plays at: its
    /// `intensity`, scaled by the step's level when it has a table.
    pub fn intensity(&self, slot: u8, step: u16) -> Option<u8> {
        let e = self.committed(slot)?;
        if step >= e.header.steps {
            return None;
        }
        if !e.table {
            return Some(e.header.intensity);
        }
        let level = self.arena[e.off + e.phases_len() + usize::from(step)];
        Some(scale(e.header.intensity, level))
    }

    /// Whether a committed slot has an intensity table.
    pub fn has_table(&self, slot: u8) -> Option<bool> {
        self.committed(slot).map(|e| e.table)
    }
}

#[cfg(test)]
mod tests {
    use super::scale;

    #[test]
    fn scale_rounds_to_nearest_without_floats() {
        for i in 0..=255u16 {
            for l in 0..=255u16 {
                let exact = f64::from(i) * f64::from(l) / 255.0;
                assert_eq!(
                    f64::from(scale(i as u8, l as u8)),
                    exact.round(),
                    "{i} × {l}"
                );
            }
        }
        assert_eq!(
            (scale(255, 255), scale(200, 128), scale(200, 0)),
            (255, 100, 0)
        );
    }
}
