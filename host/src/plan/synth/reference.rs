//! Plain f64 synthesis: the definition the fast path is checked against.

use super::Weight;
use crate::geom::{Vec3, norm, sub};

/// `frac(κ r)` with `κ = k / 2π` (turns per mm): the propagation phase of
/// distance `r` in turns, reduced to `[−0.5, 0.5]` in f64.
pub fn propagation_turns(kappa_turns_per_mm: f64, r_mm: f64) -> f64 {
    let t = kappa_turns_per_mm * r_mm;
    t - t.round()
}

/// Exact drive phase in turns of a transducer at `pos` for `foci` with
/// `weights` (`None` = equal weights):
/// `arg Σ_i w_i exp(−j 2π κ r_i) / 2π`, in `[−0.5, 0.5]`.
///
/// One focus is `−frac(κ r)` (no trigonometry). A phasor sum of exactly
/// zero yields `atan2(±0, ±0)`: a finite, deterministic phase.
pub fn phase_turns(pos: Vec3, foci: &[Vec3], weights: Option<&[Weight]>, kappa: f64) -> f64 {
    if foci.len() == 1 && weights.is_none() {
        return -propagation_turns(kappa, norm(sub(foci[0], pos)));
    }
    phasor_sum_turns(
        pos,
        foci.iter()
            .enumerate()
            .map(|(i, &f)| (f, weights.map_or(Weight::ONE, |w| w[i]))),
        kappa,
    )
}

/// `arg Σ w exp(−j 2π κ r) / 2π` over `(focus, weight)` pairs (always the
/// phasor sum, even for one focus).
pub fn phasor_sum_turns(pos: Vec3, foci: impl Iterator<Item = (Vec3, Weight)>, kappa: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for (f, w) in foci {
        let a = 2.0 * std::f64::consts::PI * propagation_turns(kappa, norm(sub(f, pos)));
        let (s, c) = a.sin_cos();
        // (w_re + j w_im)(cos a − j sin a)
        re += w.re * c + w.im * s;
        im += w.im * c - w.re * s;
    }
    im.atan2(re) / (2.0 * std::f64::consts::PI)
}

/// The exact phase (turns) of every transducer position, passed through
/// `map` into `out`: `|t| t` for the turns themselves,
/// [`quantise_turns`](super::quantise_turns) for the u8 phases.
pub fn frame_with<T>(
    positions: &[Vec3],
    foci: &[Vec3],
    weights: Option<&[Weight]>,
    kappa: f64,
    out: &mut [T],
    map: impl Fn(f64) -> T,
) {
    for (o, p) in out.iter_mut().zip(positions) {
        *o = map(phase_turns(*p, foci, weights, kappa));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::wavenumber_rad_per_mm;

    fn kappa() -> f64 {
        wavenumber_rad_per_mm(340.0) / (2.0 * std::f64::consts::PI)
    }

    #[test]
    fn one_focus_is_minus_k_r() {
        // λ = 8.5 mm: a focus 8.5·10 + 2.125 mm away is a quarter turn late.
        let t = phase_turns([0.0; 3], &[[0.0, 0.0, 87.125]], None, kappa());
        assert!((t + 0.25).abs() < 1e-12, "{t}");
        assert_eq!(super::super::quantise_turns(t), 192);
    }

    #[test]
    fn two_coincident_foci_equal_one_focus() {
        let f = [10.0, -3.0, 170.0];
        let p = [50.0, 20.0, 0.0];
        let one = phase_turns(p, &[f], None, kappa());
        let two = phase_turns(p, &[f, f], None, kappa());
        assert!((one - two).abs() < 1e-12);
    }

    #[test]
    fn cancelling_foci_give_a_finite_deterministic_phase() {
        // Same point with weights +1 and −1: the phasor sum is exactly 0.
        let f = [0.0, 0.0, 100.0];
        let w = [Weight::ONE, Weight::real(-1.0)];
        let a = phase_turns([1.0, 2.0, 0.0], &[f, f], Some(&w), kappa());
        let b = phase_turns([1.0, 2.0, 0.0], &[f, f], Some(&w), kappa());
        assert!(a.is_finite() && a == b);
    }

    #[test]
    fn focus_on_the_transducer_is_phase_zero() {
        let p = [12.0, 34.0, 0.0];
        assert_eq!(phase_turns(p, &[p], None, kappa()), 0.0);
        let t = phase_turns(p, &[p, [12.0, 34.0, 4.25]], None, kappa());
        // 0 and a half-turn-late focus: sum is 1 + exp(jπ) = 0 → finite.
        assert!(t.is_finite());
    }
}
