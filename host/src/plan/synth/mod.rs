//! Phase synthesis: from focus positions to one u8 phase per transducer.
//!
//! Convention ([`crate::units`]): one focus gets `φ = −k r`; several foci
//! get `φ = arg Σ_i w_i exp(−j k r_i)` with **equal weights** `w_i = 1`
//! (the paper's linear synthesis), and every transducer runs at full
//! amplitude. Phases are handled in **turns** (`φ / 2π`) and quantised as
//! `round(turns · 256) mod 256`.
//!
//! - [`reference`](mod@reference): plain f64, the definition every fast path is checked
//!   against. `k r` is reduced to a fraction of a turn in f64 before any
//!   trigonometry.
//! - [`fast`]: the hot path. Geometry is prepared once in a
//!   [`fast::SynthPlan`] (f32 struct-of-arrays relative to the array
//!   centroid); each frame writes into caller-owned buffers without
//!   allocating. Its u8 phases are within 0.51 LSB of the f64 phase.
//! - [`solver`]: beyond the paper: weighted synthesis and a GS-PAT style
//!   iterative solver that evens out the pressure at each focus.

pub mod fast;
pub mod reference;
pub mod solver;

/// Quantise a phase in turns to AUTD3's u8: `round(turns · 256) mod 256`,
/// ties rounding up (`floor(x + ½)`, as the fast path does), so 255.5 LSB
/// wraps to 0 and −0.5 LSB gives 0.
pub fn quantise_turns(turns: f64) -> u8 {
    (turns * 256.0 + 0.5).floor().rem_euclid(256.0) as u8
}

/// Distance in LSB between a u8 phase and an exact phase in turns, on the
/// circle (0 ..= 128).
pub fn error_lsb(q: u8, exact_turns: f64) -> f64 {
    let d = (f64::from(q) - exact_turns * 256.0).rem_euclid(256.0);
    d.min(256.0 - d)
}

/// A complex weight `re + j im` for one focus.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weight {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Weight {
    /// Weight 1 (the paper's equal-weight synthesis).
    pub const ONE: Self = Self { re: 1.0, im: 0.0 };

    /// A real weight.
    pub fn real(w: f64) -> Self {
        Self { re: w, im: 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantise_wraps_at_255_5() {
        assert_eq!(quantise_turns(255.5 / 256.0), 0);
        assert_eq!(quantise_turns(255.49 / 256.0), 255);
        assert_eq!(quantise_turns(-0.5 / 256.0), 0);
        assert_eq!(quantise_turns(-0.51 / 256.0), 255);
        assert_eq!(quantise_turns(0.5), 128);
        assert_eq!(quantise_turns(-0.25), 192);
        assert_eq!(quantise_turns(7.0 + 1.0 / 256.0), 1);
    }

    #[test]
    fn error_lsb_is_circular() {
        assert_eq!(error_lsb(0, 255.5 / 256.0), 0.5);
        assert_eq!(error_lsb(255, -0.5 / 256.0), 0.5);
        assert_eq!(error_lsb(128, 0.5), 0.0);
        assert_eq!(error_lsb(0, 0.5), 128.0);
    }
}
