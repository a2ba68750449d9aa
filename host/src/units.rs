//! Units, axes and the phase convention used across `lmhost`, and the
//! one place host values (mm, s, m/s) become wire values (µm, µs, mm/s).
//!
//! - **Lengths** are millimetres (`f64`, suffix `_mm`) in the host library;
//!   on the wire they are integer micrometres (`i32`, suffix `_um`).
//! - **Time** is seconds (`f64`, suffix `_s`) in the library; the wire and
//!   the firmware use microseconds or timer counts.
//! - **Axes**: right-handed. The built-in scene puts the array in the z = 0
//!   plane facing +z, centred on the origin.
//! - **Phase**: AUTD3's convention. A transducer driven with phase `φ` emits
//!   `p ∝ exp(j(k r + φ))` at distance `r`; one focus at distance `r` gets
//!   `φ = −k r`, so all contributions arrive in phase. Several foci get
//!   `φ = arg Σ_i exp(−j k r_i)`.
//! - **Quantisation**: `u8 = round(φ / 2π · 256) mod 256`, so one LSB is
//!   2π/256 rad and 255.5 LSB wraps to 0.

use crate::error::InputError;
use crate::geom::Vec3;

/// Carrier frequency of the T4010A1 transducers (Hz): the wire's
/// [`lm_proto::CARRIER_HZ`], which the device's correction uses too.
pub const CARRIER_HZ: f64 = lm_proto::CARRIER_HZ as f64;

/// Default speed of sound (m/s), as AUTD3 uses.
pub const DEFAULT_SOUND_SPEED_M_S: f64 = 340.0;

/// Phase quantisation levels per turn ([`lm_proto::PHASE_LEVELS`]).
pub const PHASE_LEVELS: u32 = lm_proto::PHASE_LEVELS;

/// Wavenumber in rad/mm for a sound speed in m/s.
pub fn wavenumber_rad_per_mm(sound_speed_m_s: f64) -> f64 {
    2.0 * core::f64::consts::PI * CARRIER_HZ / (sound_speed_m_s * 1000.0)
}

/// Speed of sound in dry air (m/s) at a temperature in °C.
pub fn sound_speed_from_celsius(temp_c: f64) -> f64 {
    331.3 * (1.0 + temp_c / 273.15).sqrt()
}

// Host units to wire units: every conversion a wire value goes through,
// in one place. `sequence` calls them when it builds the upload header and
// the geometry, `stream` for each centroid it sends.

/// Speed of sound in m/s to the wire's rounded mm/s, or an error outside
/// the range a device accepts ([`lm_proto::SOUND_SPEED_MM_S`]).
pub fn sound_speed_mm_s(sound_speed_m_s: f64) -> Result<u32, InputError> {
    let range = lm_proto::SOUND_SPEED_MM_S;
    // The exact value is checked before it is rounded to the wire's unit.
    let exact = sound_speed_m_s * 1000.0;
    let mm_s = exact.round();
    if !(exact >= f64::from(*range.start()) && exact <= f64::from(*range.end())) {
        return Err(InputError::new(format!(
            "speed of sound {} m/s is outside the {}-{} m/s a device accepts",
            crate::limits::show(sound_speed_m_s),
            range.start() / 1000,
            range.end() / 1000,
        )));
    }
    Ok(mm_s as u32)
}

/// A work volume in mm to the wire's µm, or an error outside the
/// (0, 100] mm a device accepts ([`lm_proto::MAX_OFFSET_UM`]).
pub fn max_offset_um(max_offset_mm: f64) -> Result<u32, InputError> {
    let range = lm_proto::MAX_OFFSET_UM;
    // The exact value is checked before it is rounded to whole µm (100.0004
    // is outside (0, 100], not 100).
    let exact_um = max_offset_mm * 1000.0;
    let um = exact_um.round();
    if !(max_offset_mm > 0.0 && exact_um <= f64::from(*range.end())) {
        return Err(InputError::new(format!(
            "work volume (--max-offset) {} mm is outside (0, {}] mm",
            crate::limits::show(max_offset_mm),
            range.end() / 1000
        )));
    }
    if um < f64::from(*range.start()) {
        return Err(InputError::new(format!(
            "work volume (--max-offset) {} mm is less than the wire's {} µm; give at least 0.001 mm",
            crate::limits::show(max_offset_mm),
            range.start()
        )));
    }
    Ok(um as u32)
}

/// Millimetres to rounded micrometres, or an error when out of i32 range.
pub fn vec_mm_to_um(v: Vec3) -> Result<[i32; 3], InputError> {
    let mut o = [0i32; 3];
    for (o, x) in o.iter_mut().zip(v) {
        let um = (x * 1000.0).round();
        if !(um.is_finite() && um.abs() <= f64::from(i32::MAX)) {
            return Err(InputError::new(format!(
                "coordinate {} mm does not fit the wire's i32 micrometres (±2147 m)",
                crate::limits::show(x)
            )));
        }
        *o = um as i32;
    }
    Ok(o)
}

/// A period in seconds to the wire's rounded µs, or an error beyond u32.
pub fn period_us(period_s: f64) -> Result<u32, InputError> {
    let period_us = (period_s * 1e6).round();
    if period_us > f64::from(u32::MAX) {
        return Err(InputError::new(format!(
            "period {} s exceeds the wire's u32 microseconds (at most {} s: give an LM frequency of at least {} Hz)",
            crate::limits::show(period_s),
            f64::from(u32::MAX) / 1e6,
            crate::limits::Num(1e6 / f64::from(u32::MAX))
        )));
    }
    Ok(period_us as u32)
}

/// Millimetres to whole micrometres (rounded, saturating; for streamed
/// centroids, which the device checks against its work volume).
pub fn mm_to_um(mm: f64) -> i32 {
    (mm * 1000.0)
        .round()
        .clamp(i32::MIN as f64, i32::MAX as f64) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wavelength_at_340_is_8_5_mm() {
        let k = wavenumber_rad_per_mm(340.0);
        assert!((2.0 * core::f64::consts::PI / k - 8.5).abs() < 1e-12);
    }

    #[test]
    fn sound_speed_at_20_c() {
        assert!((sound_speed_from_celsius(20.0) - 343.2).abs() < 0.1);
    }
}
