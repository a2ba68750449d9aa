//! Units, axes and the phase convention used across `lmhost`.
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
