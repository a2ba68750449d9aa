//! The upload header: what a slot plays, written once. The host checks it
//! against the device's [`Info`](crate::Info) before sending ([`UploadHeader::validate`]
//! with [`DeviceLimits::from_info`]); the device runs the same check on
//! receipt with its own limits. One type, one check, both ends.

use core::fmt;

use crate::codec::{Encoding, encoded_len_range};
use crate::nack::NackCode;
use crate::{FOCI_PER_STEP, MAX_OFFSET_UM, SOUND_SPEED_MM_S};

/// What a slot plays, as planned: shape, timing, planned centre, the speed
/// of sound the phases assume and the work volume the device may steer in.
/// Carried by `BeginUpload` (SPEC section 3), kept by the device per slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct UploadHeader {
    /// Steps per cycle (≥ 1).
    pub steps: u16,
    /// Transducers per step (1 ..= `max_transducers`).
    pub transducers: u16,
    /// Cycle period, µs (dwell per step = `period_us / steps`).
    pub period_us: u32,
    /// Centre the sequence was planned for, µm, drive coordinates.
    pub center_um: [i32; 3],
    /// Foci per step (1 for LM-S, more for LM-M), within
    /// [`FOCI_PER_STEP`]: the device refuses others, 0 included.
    pub foci_per_step: u8,
    /// Speed of sound the sequence was planned with, mm/s (340 m/s =
    /// `340_000`), within [`SOUND_SPEED_MM_S`]. The device derives the
    /// slot's wavenumber for centroid correction from it.
    pub sound_speed_mm_s: u32,
    /// Work volume, µm: the largest distance of a tracked centroid from
    /// `center_um` the device steers to, within [`MAX_OFFSET_UM`]. A
    /// centroid farther away is refused (`OutOfRange`) and mutes the output.
    pub max_offset_um: u32,
    /// Output intensity, 0-255 (255 = full): the device puts it in every
    /// output frame of the entry so the transducer driver scales its duty.
    pub intensity: u8,
}

/// What a device can hold and play: the part of [`Info`](crate::Info) an upload is
/// checked against.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DeviceLimits {
    /// Number of slots (slot numbers `0..slots`).
    pub slots: u8,
    /// Most transducers a sequence may drive.
    pub max_transducers: u16,
    /// Largest raw sequence (steps × transducers bytes) one library entry
    /// may have.
    pub slot_bytes: u32,
    /// Shortest step dwell the device plays, µs.
    pub min_dwell_us: u32,
}

/// Why an upload header (or a `BeginUpload`) is refused; each maps to the
/// one [`NackCode`] a device answers with ([`HeaderError::nack`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum HeaderError {
    /// `slot` ≥ `slots` (`BadSlot`).
    BadSlot {
        /// The slot asked for.
        slot: u8,
        /// Slots the device has.
        slots: u8,
    },
    /// Zero steps or zero transducers (`OutOfRange`).
    Empty,
    /// `sound_speed_mm_s` outside [`SOUND_SPEED_MM_S`] (`OutOfRange`).
    SoundSpeed(u32),
    /// `max_offset_um` outside [`MAX_OFFSET_UM`] (`OutOfRange`).
    MaxOffset(u32),
    /// `foci_per_step` outside [`FOCI_PER_STEP`] (`OutOfRange`).
    FociPerStep(u8),
    /// More transducers than the device drives (`TooLarge`).
    TooManyTransducers {
        /// Transducers in the header.
        transducers: u16,
        /// The device's maximum.
        max: u16,
    },
    /// steps × transducers exceeds the slot (`TooLarge`).
    TooLarge {
        /// Raw bytes of the sequence.
        raw: u64,
        /// The device's slot size.
        slot_bytes: u32,
    },
    /// `period_us / steps` is below the device's minimum dwell
    /// (`DwellTooShort`).
    DwellTooShort {
        /// The header's period.
        period_us: u32,
        /// Its steps.
        steps: u16,
        /// The device's minimum dwell.
        min_dwell_us: u32,
    },
    /// `encoded_len` impossible for the encoding (`OutOfRange`).
    EncodedLen {
        /// The length given.
        encoded_len: u32,
        /// The encoding.
        encoding: Encoding,
    },
}

impl HeaderError {
    /// The code a device answers this with.
    pub fn nack(&self) -> NackCode {
        match self {
            Self::BadSlot { .. } => NackCode::BadSlot,
            Self::Empty
            | Self::SoundSpeed(_)
            | Self::MaxOffset(_)
            | Self::FociPerStep(_)
            | Self::EncodedLen { .. } => NackCode::OutOfRange,
            Self::TooManyTransducers { .. } | Self::TooLarge { .. } => NackCode::TooLarge,
            Self::DwellTooShort { .. } => NackCode::DwellTooShort,
        }
    }
}

impl From<HeaderError> for NackCode {
    fn from(e: HeaderError) -> Self {
        e.nack()
    }
}

impl fmt::Display for HeaderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BadSlot { slot, slots } => {
                write!(
                    f,
                    "slot {slot} does not exist (the device has {slots} slots)"
                )
            }
            Self::Empty => f.write_str("a sequence needs at least one step and one transducer"),
            Self::SoundSpeed(v) => write!(
                f,
                "speed of sound {v} mm/s is outside the {}-{} mm/s a device accepts",
                SOUND_SPEED_MM_S.start(),
                SOUND_SPEED_MM_S.end()
            ),
            Self::MaxOffset(v) => write!(
                f,
                "work volume {v} µm is outside the {}-{} µm a device accepts",
                MAX_OFFSET_UM.start(),
                MAX_OFFSET_UM.end()
            ),
            Self::FociPerStep(v) => write!(
                f,
                "{v} foci per step is outside the {}-{} a device accepts",
                FOCI_PER_STEP.start(),
                FOCI_PER_STEP.end()
            ),
            Self::TooManyTransducers { transducers, max } => {
                write!(
                    f,
                    "{transducers} transducers, the device drives at most {max}"
                )
            }
            Self::TooLarge { raw, slot_bytes } => write!(
                f,
                "{raw} bytes exceed the device's {slot_bytes}-byte slot; use fewer steps"
            ),
            Self::DwellTooShort {
                period_us,
                steps,
                min_dwell_us,
            } => write!(
                f,
                "dwell {} µs per step is below the device's minimum {min_dwell_us} µs; \
                 use fewer steps or a lower frequency",
                period_us / u32::from(steps.max(1))
            ),
            Self::EncodedLen {
                encoded_len,
                encoding,
            } => write!(
                f,
                "encoded length {encoded_len} is impossible for {encoding:?} encoding"
            ),
        }
    }
}

impl core::error::Error for HeaderError {}

impl UploadHeader {
    /// Raw sequence bytes: steps × transducers.
    pub fn raw_len(&self) -> u64 {
        u64::from(self.steps) * u64::from(self.transducers)
    }

    /// The one check of a header against a device, in this order (the
    /// first failure is reported): zero steps or transducers, speed of
    /// sound, work volume (`OutOfRange`); transducers, slot size
    /// (`TooLarge`); dwell (`DwellTooShort`).
    pub fn validate(&self, limits: &DeviceLimits) -> Result<(), HeaderError> {
        if self.steps == 0 || self.transducers == 0 {
            return Err(HeaderError::Empty);
        }
        if !SOUND_SPEED_MM_S.contains(&self.sound_speed_mm_s) {
            return Err(HeaderError::SoundSpeed(self.sound_speed_mm_s));
        }
        if !MAX_OFFSET_UM.contains(&self.max_offset_um) {
            return Err(HeaderError::MaxOffset(self.max_offset_um));
        }
        if !FOCI_PER_STEP.contains(&self.foci_per_step) {
            return Err(HeaderError::FociPerStep(self.foci_per_step));
        }
        if self.transducers > limits.max_transducers {
            return Err(HeaderError::TooManyTransducers {
                transducers: self.transducers,
                max: limits.max_transducers,
            });
        }
        if self.raw_len() > u64::from(limits.slot_bytes) {
            return Err(HeaderError::TooLarge {
                raw: self.raw_len(),
                slot_bytes: limits.slot_bytes,
            });
        }
        if u64::from(self.period_us) < u64::from(limits.min_dwell_us) * u64::from(self.steps) {
            return Err(HeaderError::DwellTooShort {
                period_us: self.period_us,
                steps: self.steps,
                min_dwell_us: limits.min_dwell_us,
            });
        }
        Ok(())
    }

    /// Whether `centroid_um` lies in this slot's work volume: its
    /// Euclidean distance from `center_um` is at most `max_offset_um`.
    /// Exact integer arithmetic; never overflows.
    pub fn in_work_volume(&self, centroid_um: [i32; 3]) -> bool {
        let max = u64::from(self.max_offset_um);
        let mut sum: u64 = 0;
        for (c, c0) in centroid_um.iter().zip(self.center_um) {
            let d = (i64::from(*c) - i64::from(c0)).unsigned_abs();
            if d > max {
                return false;
            }
            // d ≤ max < 2^32, so d² < 2^64 and three of them are checked.
            match d.checked_mul(d).and_then(|sq| sum.checked_add(sq)) {
                Some(s) => sum = s,
                None => return false,
            }
        }
        max.checked_mul(max).is_some_and(|m2| sum <= m2)
    }
}

/// `BeginUpload`'s own fields on top of the header.
pub(crate) fn validate_begin(
    slot: u8,
    header: &UploadHeader,
    encoding: Encoding,
    encoded_len: u32,
    intensity_table: bool,
    limits: &DeviceLimits,
) -> Result<(), HeaderError> {
    if slot >= limits.slots {
        return Err(HeaderError::BadSlot {
            slot,
            slots: limits.slots,
        });
    }
    header.validate(limits)?;
    // The table (one byte per step) lives with the phases: both must fit.
    let with_table = header.raw_len()
        + if intensity_table {
            u64::from(header.steps)
        } else {
            0
        };
    if with_table > u64::from(limits.slot_bytes) {
        return Err(HeaderError::TooLarge {
            raw: with_table,
            slot_bytes: limits.slot_bytes,
        });
    }
    if !encoded_len_range(encoding, header.steps, header.transducers)
        .contains(&u64::from(encoded_len))
    {
        return Err(HeaderError::EncodedLen {
            encoded_len,
            encoding,
        });
    }
    Ok(())
}

/// The paper's LM-S header, which the integration tests use too.
#[cfg(test)]
#[path = "../tests/common/lm_s_header.rs"]
mod paper;

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> UploadHeader {
        super::paper::lm_s_header(255)
    }

    const LIMITS: DeviceLimits = DeviceLimits {
        slots: 2,
        max_transducers: 996,
        slot_bytes: 200 * 996,
        min_dwell_us: 1000,
    };

    #[test]
    fn validate_maps_each_violation_to_its_code() {
        assert_eq!(header().validate(&LIMITS), Ok(()));
        type Break = fn(&mut UploadHeader);
        let cases: [(Break, NackCode); 11] = [
            (|h| h.steps = 0, NackCode::OutOfRange),
            (|h| h.transducers = 0, NackCode::OutOfRange),
            (|h| h.sound_speed_mm_s = 0, NackCode::OutOfRange),
            (|h| h.sound_speed_mm_s = 2_000_001, NackCode::OutOfRange),
            (|h| h.max_offset_um = 0, NackCode::OutOfRange),
            (|h| h.max_offset_um = 100_001, NackCode::OutOfRange),
            (|h| h.foci_per_step = 0, NackCode::OutOfRange),
            (|h| h.foci_per_step = 33, NackCode::OutOfRange),
            (|h| h.transducers = 997, NackCode::TooLarge),
            (|h| h.steps = 201, NackCode::TooLarge),
            (|h| h.period_us = 81_999, NackCode::DwellTooShort),
        ];
        for (i, (f, code)) in cases.iter().enumerate() {
            let mut h = header();
            f(&mut h);
            let e = h.validate(&LIMITS).unwrap_err();
            assert_eq!(e.nack(), *code, "case {i}: {e:?}");
        }
    }

    #[test]
    fn foci_per_step_is_refused_outside_1_to_32_naming_the_range() {
        extern crate std;
        use std::string::ToString;
        for (foci, ok) in [
            (0, false),
            (1, true),
            (4, true),
            (32, true),
            (33, false),
            (255, false),
        ] {
            let h = UploadHeader {
                foci_per_step: foci,
                ..header()
            };
            assert_eq!(h.validate(&LIMITS).is_ok(), ok, "{foci}");
        }
        let h = UploadHeader {
            foci_per_step: 0,
            ..header()
        };
        let e = h.validate(&LIMITS).unwrap_err();
        assert_eq!(e, HeaderError::FociPerStep(0));
        assert_eq!(e.nack(), NackCode::OutOfRange);
        assert_eq!(
            e.to_string(),
            "0 foci per step is outside the 1-32 a device accepts"
        );
    }

    #[test]
    fn begin_checks_slot_and_encoded_len() {
        let h = header();
        let v = |slot, enc, len| {
            validate_begin(slot, &h, enc, len, false, &LIMITS).map_err(|e| e.nack())
        };
        assert_eq!(v(0, Encoding::Raw, 82 * 996), Ok(()));
        assert_eq!(v(2, Encoding::Raw, 82 * 996), Err(NackCode::BadSlot));
        assert_eq!(v(0, Encoding::Raw, 82 * 996 - 1), Err(NackCode::OutOfRange));
        assert_eq!(v(0, Encoding::Delta, 0), Err(NackCode::OutOfRange));
        assert_eq!(v(0, Encoding::Delta, 995), Err(NackCode::OutOfRange));
        let min = 996 + (81 * 996u32).div_ceil(8);
        let max = 996 + (81 * 996 * 11u32).div_ceil(8);
        assert_eq!(v(0, Encoding::Delta, min), Ok(()));
        assert_eq!(v(0, Encoding::Delta, max), Ok(()));
        assert_eq!(v(0, Encoding::Delta, min - 1), Err(NackCode::OutOfRange));
        assert_eq!(v(0, Encoding::Delta, max + 1), Err(NackCode::OutOfRange));
        // A table of one byte per step counts against the slot: 200 steps
        // fill it, with a table 199 do not fit.
        let full = UploadHeader {
            steps: 200,
            period_us: 200_000,
            ..h
        };
        let t = |table| validate_begin(0, &full, Encoding::Raw, 200 * 996, table, &LIMITS);
        assert_eq!(t(false), Ok(()));
        assert_eq!(t(true).map_err(|e| e.nack()), Err(NackCode::TooLarge));
        let fits = UploadHeader {
            steps: 199,
            period_us: 199_000,
            ..h
        };
        assert_eq!(
            validate_begin(0, &fits, Encoding::Raw, 199 * 996, true, &LIMITS),
            Ok(())
        );
    }

    #[test]
    fn work_volume_is_a_ball_and_never_overflows() {
        let h = header();
        assert!(h.in_work_volume([0, 0, 200_000]));
        assert!(h.in_work_volume([20_000, 0, 200_000]));
        assert!(!h.in_work_volume([20_001, 0, 200_000]));
        // 15 mm on two axes is 21.2 mm away: outside the 20 mm ball.
        assert!(!h.in_work_volume([15_000, 15_000, 200_000]));
        assert!(h.in_work_volume([14_000, 14_000, 200_000]));
        for c in [
            [i32::MIN; 3],
            [i32::MAX; 3],
            [i32::MIN, 0, 200_000],
            [0, 0, i32::MIN],
        ] {
            assert!(!h.in_work_volume(c), "{c:?}");
        }
        let wide = UploadHeader {
            max_offset_um: u32::MAX,
            center_um: [i32::MIN; 3],
            ..h
        };
        assert!(!wide.in_work_volume([i32::MAX; 3]));
    }
}
