//! Shapiro-Wilk's test of normality: W and its p-value by Royston's
//! algorithm (AS R94, Applied Statistics 44, 1995), as scipy computes them,
//! for 3 ≤ n ≤ 5000.
//!
//! AS R94 approximates the weights from normal scores (AS 111's quantile)
//! and the p-value by a normalizing transformation of W (AS 66's tail
//! area); both low-order approximations are part of the algorithm, so they
//! are kept here as published rather than swapped for more accurate
//! functions: the result is then Royston's (and scipy's) to rounding.

use serde::Serialize;

use super::{Method, StatsError, present};

/// A Shapiro-Wilk test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShapiroWilk {
    /// W, in (0, 1]; small when the data are far from normal.
    pub w: f64,
    /// The p-value of the null hypothesis that the data are normal.
    pub p: f64,
    /// Values used.
    pub n: usize,
    /// Missing (NaN) values left out.
    pub excluded: usize,
    /// Always [`Method::Royston`].
    pub method: Method,
}

/// The most values: Royston's approximation of the p-value was fitted up
/// to n = 5000 (scipy warns beyond it).
pub const MAX_N: usize = 5000;

/// AS R94's SMALL: a range below it counts as zero.
const SMALL: f64 = 1e-19;

/// Shapiro-Wilk's W and p for `x` (NaN values left out).
pub fn shapiro_wilk(x: &[f64]) -> Result<ShapiroWilk, StatsError> {
    let kept = present(x)?;
    let n = kept.len();
    let excluded = x.len() - n;
    StatsError::at_least("Shapiro-Wilk", "values", 3, n)?;
    if n > MAX_N {
        return Err(StatsError::TooMany {
            test: "Shapiro-Wilk",
            max: MAX_N,
            got: n,
        });
    }
    // scipy subtracts a value near the median (the middle one in input
    // order) before anything else, so that data far from zero keep their
    // digits; W does not change otherwise.
    let shift = kept[n / 2];
    let mut v = kept;
    v.sort_by(f64::total_cmp);
    for x in &mut v {
        *x -= shift;
    }
    let range = v[n - 1] - v[0];
    if range < SMALL {
        return Err(StatsError::ZeroRange);
    }
    let a = weights(n);
    let (w, p) = w_and_p(&v, range, &a);
    Ok(ShapiroWilk {
        w,
        p,
        n,
        excluded,
        method: Method::Royston,
    })
}

/// c[0] + c[1] x + c[2] x² + ...
fn poly(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// AS R94's weights for the upper half of the order statistics, largest
/// first (a_n, a_{n−1}, …); the lower half takes them with the sign
/// turned.
fn weights(n: usize) -> Vec<f64> {
    const C1: [f64; 6] = [0.0, 0.221157, -0.147981, -2.071190, 4.434685, -2.706056];
    const C2: [f64; 6] = [0.0, 0.042981, -0.293762, -1.752461, 5.682633, -3.582633];
    let half = n / 2;
    if n == 3 {
        return vec![std::f64::consts::FRAC_1_SQRT_2];
    }
    let an = n as f64;
    // Blom's scores for the expected normal order statistics.
    let m: Vec<f64> = (1..=half)
        .map(|i| ppnd((i as f64 - 0.375) / (an + 0.25)))
        .collect();
    let summ2 = 2.0 * m.iter().map(|v| v * v).sum::<f64>();
    let ssumm2 = summ2.sqrt();
    let rsn = 1.0 / an.sqrt();
    let a1 = poly(&C1, rsn) - m[0] / ssumm2;
    let mut a = vec![0.0; half];
    let (first, fac) = if n > 5 {
        let a2 = -m[1] / ssumm2 + poly(&C2, rsn);
        let fac = ((summ2 - 2.0 * m[0] * m[0] - 2.0 * m[1] * m[1])
            / (1.0 - 2.0 * a1 * a1 - 2.0 * a2 * a2))
            .sqrt();
        a[1] = a2;
        (2, fac)
    } else {
        let fac = ((summ2 - 2.0 * m[0] * m[0]) / (1.0 - 2.0 * a1 * a1)).sqrt();
        (1, fac)
    };
    a[0] = a1;
    for i in first..half {
        a[i] = -m[i] / fac;
    }
    a
}

/// W and its p-value for the sorted, shifted `x` with `range` > 0.
fn w_and_p(x: &[f64], range: f64, a: &[f64]) -> (f64, f64) {
    const C3: [f64; 4] = [0.5440, -0.39978, 0.025054, -6.714e-4];
    const C4: [f64; 4] = [1.3822, -0.77857, 0.062767, -0.0020322];
    const C5: [f64; 4] = [-1.5861, -0.31082, -0.083751, 0.0038915];
    const C6: [f64; 3] = [-0.4803, -0.082676, 0.0030302];
    const G: [f64; 2] = [-2.273, 0.459];
    let n = x.len();
    let an = n as f64;
    // The weight of the i-th order statistic (ascending): −a for the
    // lower half, +a mirrored for the upper, 0 in the middle of odd n.
    let coef = |i: usize| {
        let j = n - 1 - i;
        match i.cmp(&j) {
            std::cmp::Ordering::Less => -a[i],
            std::cmp::Ordering::Greater => a[j],
            std::cmp::Ordering::Equal => 0.0,
        }
    };
    // W as the squared correlation of the weights and the data, both
    // centred (the weights sum to 0 only up to rounding).
    let sa = (0..n).map(coef).sum::<f64>() / an;
    let sx = x.iter().map(|v| v / range).sum::<f64>() / an;
    let (mut ssa, mut ssx, mut sax) = (0.0, 0.0, 0.0);
    for (i, v) in x.iter().enumerate() {
        let da = coef(i) - sa;
        let dx = v / range - sx;
        ssa += da * da;
        ssx += dx * dx;
        sax += da * dx;
    }
    let ssassx = (ssa * ssx).sqrt();
    let w1 = (ssassx - sax) * (ssassx + sax) / (ssa * ssx);
    let w = 1.0 - w1;

    if n == 3 {
        // Exact for n = 3 (W ≥ 3/4 in theory; rounding can dip below).
        if w < 0.75 {
            return (0.75, 0.0);
        }
        let p = 1.0 - 6.0 / std::f64::consts::PI * w.sqrt().acos();
        return (w, p);
    }
    let mut y = w1.ln();
    let ln_n = an.ln();
    let (m, s) = if n <= 11 {
        let gamma = poly(&G, an);
        if y >= gamma {
            // Beyond the transformation's range: AS R94 answers SMALL.
            return (w, SMALL);
        }
        y = -(gamma - y).ln();
        (poly(&C3, an), poly(&C4, an).exp())
    } else {
        (poly(&C5, ln_n), poly(&C6, ln_n).exp())
    };
    (w, alnorm((y - m) / s, true))
}

/// AS 111 (Beasley and Springer 1977): the normal quantile, to about
/// 1e-7, as AS R94 uses it for its scores.
fn ppnd(p: f64) -> f64 {
    const A: [f64; 4] = [
        2.50662823884,
        -18.61500062529,
        41.39119773534,
        -25.44106049637,
    ];
    const B: [f64; 4] = [
        -8.47351093090,
        23.08336743743,
        -21.06224101826,
        3.13082909833,
    ];
    const C: [f64; 4] = [-2.78718931138, -2.29796479134, 4.85014127135, 2.32121276858];
    const D: [f64; 2] = [3.54388924762, 1.63706781897];
    let q = p - 0.5;
    if q.abs() <= 0.42 {
        let r = q * q;
        return q * (((A[3] * r + A[2]) * r + A[1]) * r + A[0])
            / ((((B[3] * r + B[2]) * r + B[1]) * r + B[0]) * r + 1.0);
    }
    let r = if q > 0.0 { 1.0 - p } else { p };
    if r <= 0.0 {
        return 0.0;
    }
    let r = (-r.ln()).sqrt();
    let v = (((C[3] * r + C[2]) * r + C[1]) * r + C[0]) / ((D[1] * r + D[0]) * r + 1.0);
    if q < 0.0 { -v } else { v }
}

/// AS 66 (Hill 1973): the normal tail area above `x` (`upper`) or below,
/// with scipy's upper cut-off of 38 (Hill's was 18.66).
fn alnorm(x: f64, upper: bool) -> f64 {
    const LTONE: f64 = 7.0;
    const UTZERO: f64 = 38.0;
    const CON: f64 = 1.28;
    let mut up = upper;
    let mut z = x;
    // NaN goes this way too, as in scipy.
    if z.is_nan() || z <= 0.0 {
        up = !up;
        z = -z;
    }
    let tail = if !(z <= LTONE || (up && z <= UTZERO)) {
        0.0
    } else {
        let y = 0.5 * z * z;
        if z <= CON {
            0.5 - z
                * (0.398942280444
                    - 0.399903438504 * y
                        / (y + 5.75885480458
                            - 29.8213557808
                                / (y + 2.62433121679 + 48.6959930692 / (y + 5.92885724438))))
        } else {
            0.398942280385 * (-y).exp()
                / (z - 3.8052e-8
                    + 1.00000615302
                        / (z + 3.98064794e-4
                            + 1.98615381364
                                / (z - 0.151679116635
                                    + 5.29330324926
                                        / (z + 4.8385912808
                                            - 15.1508972451
                                                / (z + 0.742380924027
                                                    + 30.789933034 / (z + 3.99019417011))))))
        }
    };
    if up { tail } else { 1.0 - tail }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_evenly_spaced_values_are_perfectly_normal() {
        let r = shapiro_wilk(&[1.0, 2.0, 3.0]).unwrap();
        assert!((r.w - 1.0).abs() < 1e-12);
        assert!((r.p - 1.0).abs() < 1e-9);
    }

    #[test]
    fn n3_minimum_is_three_quarters() {
        let r = shapiro_wilk(&[1.0, 2.0, 2.0]).unwrap();
        assert!((r.w - 0.75).abs() < 1e-12);
        assert!(r.p < 1e-10);
    }

    #[test]
    fn weights_are_unit_length() {
        for n in [4, 5, 6, 11, 12, 50, 5000] {
            let a = weights(n);
            let ss = 2.0 * a.iter().map(|v| v * v).sum::<f64>();
            assert!((ss - 1.0).abs() < 1e-3, "n {n}: {ss}");
            assert!(a.windows(2).all(|w| w[0] > w[1]), "n {n}: decreasing");
        }
    }

    #[test]
    fn refusals_say_why() {
        assert!(matches!(
            shapiro_wilk(&[1.0, f64::NAN, 2.0]),
            Err(StatsError::TooFew {
                needed: 3,
                got: 2,
                ..
            })
        ));
        assert_eq!(shapiro_wilk(&[4.0; 6]), Err(StatsError::ZeroRange));
        let many: Vec<f64> = (0..=MAX_N).map(|i| i as f64).collect();
        assert!(matches!(
            shapiro_wilk(&many),
            Err(StatsError::TooMany { .. })
        ));
        let r = shapiro_wilk(&[1.0, f64::NAN, 3.0, 4.0, 7.0]).unwrap();
        assert_eq!((r.n, r.excluded), (4, 1));
    }

    #[test]
    fn as66_and_as111_are_the_normal_distribution() {
        for x in [-2.0, -0.3, 0.0, 0.9, 1.5, 3.0, 6.0] {
            let exact = super::super::special::norm_sf(x);
            assert!(
                (alnorm(x, true) - exact).abs() < 1e-9 * exact.max(1e-3),
                "x {x}"
            );
        }
        for p in [0.01, 0.2, 0.5, 0.7, 0.999] {
            let exact = super::super::special::norm_ppf(p);
            assert!((ppnd(p) - exact).abs() < 1e-6, "p {p}");
        }
    }
}
