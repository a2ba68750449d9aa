//! The distributions the tests need: normal, chi-square, Student t and
//! non-central t. erfc and log-gamma are libm's (musl's, about 1 ulp);
//! the regularized incomplete beta and gamma functions are `statrs`'
//! (continued fractions, about 1e-14 where we use them); the normal and t
//! quantiles and the non-central t are ours. Every function here is
//! checked against scipy in `host/tests/stats_scipy.rs`.
//!
//! statrs' own erf/erfc are not used: in 0.18 they are good to only
//! about 1e-10 relative (their interval constants were truncated), which
//! shows up as 1e-4 relative errors in a non-central t tail of 1e-9.

use std::f64::consts::{PI, SQRT_2};

use statrs::function::{beta, erf, gamma};

/// v > 0; false for NaN (so a NaN degree of freedom is refused).
fn is_positive(v: f64) -> bool {
    v > 0.0
}

/// ln Γ(x), x > 0.
pub fn ln_gamma(x: f64) -> f64 {
    libm::lgamma(x)
}

/// The standard normal CDF Φ(x).
pub fn norm_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / SQRT_2)
}

/// The standard normal survival function 1 − Φ(x), accurate in the tail.
pub fn norm_sf(x: f64) -> f64 {
    0.5 * libm::erfc(x / SQRT_2)
}

/// The standard normal density φ(x).
fn norm_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * PI).sqrt()
}

/// The standard normal quantile Φ⁻¹(p); ±∞ at 0 and 1, NaN outside.
///
/// statrs' inverse erfc gives the start (good to about 1e-10), two Newton
/// steps on the accurate CDF finish it: on Φ for p ≤ ½ and on 1 − Φ with
/// 1 − p (exact for p ≥ ½) above, so neither tail loses digits.
pub fn norm_ppf(p: f64) -> f64 {
    if !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    if p == 0.0 {
        return f64::NEG_INFINITY;
    }
    if p == 1.0 {
        return f64::INFINITY;
    }
    let mut x = -SQRT_2 * erf::erfc_inv(2.0 * p);
    for _ in 0..2 {
        let pdf = norm_pdf(x);
        if !is_positive(pdf) {
            break;
        }
        let step = if p <= 0.5 {
            (norm_cdf(x) - p) / pdf
        } else {
            ((1.0 - p) - norm_sf(x)) / pdf
        };
        x -= step;
    }
    x
}

/// The chi-square survival function P(X > x) with `df` degrees of freedom.
pub fn chi2_sf(x: f64, df: f64) -> f64 {
    if x.is_nan() || !is_positive(df) {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    gamma::checked_gamma_ur(df / 2.0, x / 2.0).unwrap_or(f64::NAN)
}

/// I_x(a, b), the regularized incomplete beta function; NaN for
/// arguments outside its domain (statrs' unchecked form panics).
fn beta_reg(a: f64, b: f64, x: f64) -> f64 {
    beta::checked_beta_reg(a, b, x).unwrap_or(f64::NAN)
}

/// Student t survival function P(T > t) with `df` degrees of freedom.
pub fn t_sf(t: f64, df: f64) -> f64 {
    if t.is_nan() || !is_positive(df) {
        return f64::NAN;
    }
    if t.is_infinite() {
        return if t > 0.0 { 0.0 } else { 1.0 };
    }
    // P(|T| > |t|) = I_{df/(df+t²)}(df/2, 1/2).
    let tail = 0.5 * beta_reg(df / 2.0, 0.5, df / (df + t * t));
    if t > 0.0 { tail } else { 1.0 - tail }
}

/// Student t CDF P(T ≤ t).
pub fn t_cdf(t: f64, df: f64) -> f64 {
    t_sf(-t, df)
}

/// Student t density.
fn t_pdf(t: f64, df: f64) -> f64 {
    (ln_gamma((df + 1.0) / 2.0)
        - ln_gamma(df / 2.0)
        - 0.5 * (df * PI).ln()
        - (df + 1.0) / 2.0 * (t * t / df).ln_1p())
    .exp()
}

/// The Student t quantile of the upper tail: the t with P(T > t) = p.
///
/// Safeguarded Newton on `t_sf` (bisection whenever a step leaves the
/// bracket), to the last few bits of t_sf's accuracy; at most 1,200
/// steps in all (the bracket's doubling included), so it always ends.
pub fn t_isf(p: f64, df: f64) -> f64 {
    if !(0.0..=1.0).contains(&p) || !is_positive(df) {
        return f64::NAN;
    }
    if p == 0.0 {
        return f64::INFINITY;
    }
    if p == 1.0 {
        return f64::NEG_INFINITY;
    }
    if p > 0.5 {
        return -t_isf(1.0 - p, df);
    }
    if p == 0.5 {
        return 0.0;
    }
    // Bracket [lo, hi] with t_sf(lo) > p ≥ t_sf(hi).
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    let mut guard = 0;
    while t_sf(hi, df) > p {
        lo = hi;
        hi *= 2.0;
        guard += 1;
        if guard > 1100 || hi.is_infinite() {
            return f64::NAN;
        }
    }
    let mut t = 0.5 * (lo + hi);
    for _ in 0..100 {
        let f = t_sf(t, df) - p;
        if f > 0.0 {
            lo = t;
        } else {
            hi = t;
        }
        // t_sf falls with t: Newton's step is +f / pdf.
        let step = f / t_pdf(t, df);
        let mut next = t + step;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - t).abs() <= 4.0 * f64::EPSILON * next.abs() || hi - lo <= 4.0 * f64::EPSILON * hi
        {
            return next;
        }
        t = next;
    }
    t
}

/// Largest λ = δ²/2 the non-central t series takes (|δ| ≈ 1414): beyond
/// it the log of a Poisson weight loses more than 1e-9 to rounding.
const MAX_LAMBDA: f64 = 1.0e6;

/// The non-central t CDF P(T ≤ t) with `df` degrees of freedom and
/// non-centrality `nc`; NaN where the series does not reach (|nc| above
/// about 1414, or no convergence in its step budget).
///
/// With s = |t|, x = s²/(s² + ν), λ = δ²/2, the Poisson weights
/// p_j = e^{−λ} λ^j / j! and q_j = δ e^{−λ} λ^j / (√2 Γ(j + 3/2))
/// (Guenther 1978; Lenth's AS 243), for s ≥ 0
///
/// F(s; ν, δ) = Φ(−δ) + ½ S_I,  S_I = Σ_j [ p_j I_x(j + ½, ν/2) + q_j I_x(j + 1, ν/2) ],
///
/// and, with 1 − I_x(a, b) = I_{1−x}(b, a), the upper tail
///
/// 1 − F(s; ν, δ) = ½ S_J,  S_J = Σ_j [ p_j I_{1−x}(ν/2, j + ½) + q_j I_{1−x}(ν/2, j + 1) ],
///
/// whose terms are all positive for δ ≥ 0. For δ < 0 the upper tail is
/// Φ(δ) − ½ S_I instead (the terms of either sum cancel then; this way
/// the error scales with Φ(δ), not with 1). Negative t goes through
/// P(T ≤ t) = P(−T ≥ −t), −T ~ t'(ν, −δ). No tail is ever 1 − (the other
/// tail), so a tail of 1e-10 keeps its digits; where terms cancel (a lower
/// tail with δ > 0) the result is good to about 1e-14 absolute, as is
/// scipy's (Boost's) there.
pub fn nct_cdf(t: f64, df: f64, nc: f64) -> f64 {
    if t.is_nan() || !is_positive(df) || !nc.is_finite() {
        return f64::NAN;
    }
    if t >= 0.0 {
        nct_below(t, df, nc)
    } else {
        nct_above(-t, df, -nc)
    }
}

/// The non-central t survival function P(T > t) = P(−T < −t), −T ~
/// t'(ν, −δ) (see [`nct_cdf`]).
pub fn nct_sf(t: f64, df: f64, nc: f64) -> f64 {
    nct_cdf(-t, df, -nc)
}

/// F(s; ν, δ) for s ≥ 0.
fn nct_below(s: f64, df: f64, nc: f64) -> f64 {
    (norm_cdf(-nc) + 0.5 * nct_series(s, df, nc, Form::Lower)).clamp(0.0, 1.0)
}

/// 1 − F(s; ν, δ) for s ≥ 0.
fn nct_above(s: f64, df: f64, nc: f64) -> f64 {
    if nc >= 0.0 {
        (0.5 * nct_series(s, df, nc, Form::Upper)).clamp(0.0, 1.0)
    } else {
        // T > s ≥ 0 needs Z + δ > 0: the tail is at most Φ(δ).
        let bound = norm_cdf(nc);
        (bound - 0.5 * nct_series(s, df, nc, Form::Lower)).clamp(0.0, bound)
    }
}

/// Which incomplete beta function the series weighs.
#[derive(Clone, Copy, PartialEq)]
enum Form {
    /// I_x(a, ν/2): the lower tail's series.
    Lower,
    /// I_{1−x}(ν/2, a) = 1 − I_x(a, ν/2): the upper tail's.
    Upper,
}

/// Σ_j [p_j K(j + ½) + q_j K(j + 1)] for s ≥ 0, K the [`Form`]'s
/// incomplete beta function. The sum starts at
/// the Poisson mode j = ⌊λ⌋ and runs both ways (as Boost's does), with
/// the incomplete beta functions from one evaluation per chain and the
/// recurrence I_x(a + 1, b) = I_x(a, b) − T(a), T(a) = x^a (1 − x)^b /
/// (a B(a, b)) (for the upper form the sign turns).
fn nct_series(s: f64, df: f64, nc: f64, form: Form) -> f64 {
    let lower = form == Form::Lower;
    let x = s * s / (s * s + df);
    // 1 − x without cancellation when s is large.
    let y = df / (s * s + df);
    if s.is_infinite() || x == 0.0 {
        // x = 1: every I is 1; x = 0 (s² underflows against ν): every I is 0.
        let i_all = if s.is_infinite() { 1.0 } else { 0.0 };
        let k = if lower { i_all } else { 1.0 - i_all };
        // Σ p_j = 1 and Σ q_j = 2 Φ(δ) − 1.
        return k * (1.0 + (2.0 * norm_cdf(nc) - 1.0));
    }
    if nc == 0.0 {
        // Only p_0 = 1 is left: I_x(½, ν/2) or its complement.
        return if lower {
            beta_reg(0.5, df / 2.0, x)
        } else {
            beta_reg(df / 2.0, 0.5, y)
        };
    }
    let lambda = nc * nc / 2.0;
    if lambda > MAX_LAMBDA {
        return f64::NAN;
    }
    let b = df / 2.0;
    let (ln_x, ln_y) = (x.ln(), y.ln());
    let mode = lambda.floor();
    let ln_pois = -lambda + mode * lambda.ln();
    let p_mode = (ln_pois - ln_gamma(mode + 1.0)).exp();
    let q_mode = nc.signum()
        * (ln_pois + nc.abs().ln() - 0.5 * std::f64::consts::LN_2 - ln_gamma(mode + 1.5)).exp();
    let step_term =
        |a: f64| (a * ln_x + b * ln_y + ln_gamma(a + b) - ln_gamma(a + 1.0) - ln_gamma(b)).exp();
    let k_at = |a: f64| {
        if lower {
            beta_reg(a, b, x)
        } else {
            beta_reg(b, a, y)
        }
    };
    // Moving a up by one, K changes by −T(a) (lower) or +T(a) (upper).
    let up = if lower { -1.0 } else { 1.0 };
    let (a_p, a_q) = (mode + 0.5, mode + 1.0);
    let (k_p_mode, k_q_mode) = (k_at(a_p), k_at(a_q));
    if k_p_mode.is_nan() || k_q_mode.is_nan() {
        return f64::NAN;
    }
    let (t_p_mode, t_q_mode) = (step_term(a_p), step_term(a_q));

    // The stopping test compares a term's size (its parts' magnitudes,
    // which with δ < 0 cancel) with the sizes summed so far, so a sum that
    // cancels to nearly nothing still ends.
    let mut sum = 0.0;
    let mut size_sum = 0.0;
    // Backwards from the mode.
    {
        let (mut p, mut q) = (p_mode, q_mode);
        let (mut kp, mut kq) = (k_p_mode, k_q_mode);
        let (mut tp, mut tq) = (t_p_mode, t_q_mode);
        let mut last = f64::INFINITY;
        let mut j = mode;
        loop {
            sum += p * kp + q * kq;
            let size = p * kp.abs() + q.abs() * kq.abs();
            size_sum += size;
            if j == 0.0 || (size <= f64::EPSILON * size_sum && size <= last) {
                break;
            }
            last = size;
            // To j − 1: the weights, then T(a − 1) = T(a) a / (x (a − 1 + b)).
            p *= j / lambda;
            q *= (j + 0.5) / lambda;
            let (ap, aq) = (j + 0.5, j + 1.0);
            tp *= ap / (x * (ap - 1.0 + b));
            tq *= aq / (x * (aq - 1.0 + b));
            kp -= up * tp;
            kq -= up * tq;
            j -= 1.0;
        }
    }
    // Forwards from the mode.
    {
        let (mut p, mut q) = (p_mode, q_mode);
        let (mut kp, mut kq) = (k_p_mode, k_q_mode);
        let (mut tp, mut tq) = (t_p_mode, t_q_mode);
        let budget = 100.0 + 40.0 * lambda.sqrt();
        let mut j = mode;
        loop {
            let (ap, aq) = (j + 0.5, j + 1.0);
            kp += up * tp;
            kq += up * tq;
            tp *= x * (ap + b) / (ap + 1.0);
            tq *= x * (aq + b) / (aq + 1.0);
            j += 1.0;
            p *= lambda / j;
            q *= lambda / (j + 0.5);
            sum += p * kp + q * kq;
            let size = p * kp.abs() + q.abs() * kq.abs();
            size_sum += size;
            if size <= f64::EPSILON * size_sum || (p == 0.0 && q == 0.0) {
                break;
            }
            if j - mode > budget {
                return f64::NAN;
            }
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_is_symmetric_and_inverts() {
        assert_eq!(norm_cdf(0.0), 0.5);
        for x in [-3.0, -0.5, 0.7, 2.0] {
            assert!((norm_cdf(x) - norm_sf(-x)).abs() < 1e-16);
            assert!((norm_ppf(norm_cdf(x)) - x).abs() < 1e-12);
        }
        assert!(norm_ppf(1.5).is_nan());
    }

    #[test]
    fn t_quantile_inverts_the_survival_function() {
        for df in [1.0, 2.0, 9.0, 99.0] {
            for p in [0.4, 0.025, 1e-6, 0.9] {
                let t = t_isf(p, df);
                assert!((t_sf(t, df) / p - 1.0).abs() < 1e-12, "df {df} p {p}");
            }
        }
        // df = 1 is Cauchy: t = tan(π (1/2 − p)).
        let t = t_isf(0.025, 1.0);
        assert!((t / (PI * 0.475).tan() - 1.0).abs() < 1e-13);
    }

    #[test]
    fn non_central_t_lower_tails_against_an_independent_integral() {
        // P(T ≤ t) = ∫ Φ(t s − δ) f_S(s) ds, S = √(χ²_ν/ν), by mpmath's
        // quadrature at 40 digits (not scipy: its Boost code is 9e-6 off
        // at the last one).
        let truth = [
            ((-1.0, 9.0, 0.7), 5.153951316147252e-2),
            ((-4.0, 29.0, 2.5), 3.265400021546947e-9),
            ((-4.0, 99.0, 2.5), 2.020541178484438e-10),
        ];
        for ((t, df, nc), want) in truth {
            let got = nct_cdf(t, df, nc);
            // The terms cancel here: 1e-14 absolute is what the series keeps.
            assert!(
                (got - want).abs() < 1e-14,
                "nct_cdf({t}, {df}, {nc}) = {got:e}, want {want:e}"
            );
        }
    }

    #[test]
    fn non_central_t_with_zero_shift_is_student_t() {
        for t in [-3.0, -0.2, 0.0, 1.5] {
            assert!((nct_cdf(t, 7.0, 0.0) - t_cdf(t, 7.0)).abs() < 1e-15);
        }
        // A tiny shift is continuous with it.
        assert!((nct_cdf(1.5, 7.0, 1e-9) - t_cdf(1.5, 7.0)).abs() < 1e-9);
        // The two tails add up to one.
        for (t, nc) in [(-2.0, 1.5), (0.5, -0.7), (3.0, 4.0), (-1.0, -2.0)] {
            let sum = nct_cdf(t, 5.0, nc) + nct_sf(t, 5.0, nc);
            assert!((sum - 1.0).abs() < 1e-14, "t {t} nc {nc}: {sum}");
        }
        // Beyond the series' reach it says so.
        assert!(nct_cdf(1.0, 3.0, 2000.0).is_nan());
    }
}
