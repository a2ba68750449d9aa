//! Beyond the paper: weighted synthesis and a GS-PAT style iterative
//! solver for several foci, plus the free-field pressure model used to
//! compare them.
//!
//! **Model.** Transducer `n` driven with phase `φ_n` at full amplitude adds
//! `g(θ_in) / r_in · exp(j(k r_in + φ_n))` at focus `i` (point source,
//! directivity `g`, AUTD3's sign). `F_in = g / r · exp(j k r)` is the
//! forward propagator.
//!
//! **GS-PAT** (Plasencia et al. 2020), phase-only: with the backward
//! propagator `B_ni = conj(F_in) / Σ_n |F_in|²` and `R = F B` (m × m),
//! start from focus phasors `a_i = 1` and iterate `a ← unit(R (w ⊙ a))`,
//! re-weighting `w_i ← w_i · mean|Γ| / |Γ_i|` so weak foci ask for more
//! (weighted GS); then drive `φ_n = arg Σ_i B_ni w_i a_i` at full amplitude.
//! The iteration runs on the m × m matrix only, so its cost is that of one
//! weighted frame plus `m² T` for `R`.

use super::Weight;
use crate::geom::{Vec3, norm, sub};
use crate::plan::array::Transducer;
use crate::plan::directivity::Directivity;

/// A complex number (f64) for the solver.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct C {
    re: f64,
    im: f64,
}

impl C {
    fn mul(self, o: C) -> C {
        C {
            re: self.re * o.re - self.im * o.im,
            im: self.re * o.im + self.im * o.re,
        }
    }
    fn conj(self) -> C {
        C {
            re: self.re,
            im: -self.im,
        }
    }
    fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    fn add(self, o: C) -> C {
        C {
            re: self.re + o.re,
            im: self.im + o.im,
        }
    }
}

fn propagator(t: &Transducer, f: Vec3, k: f64, dir: Directivity) -> C {
    let d = sub(f, t.pos_mm);
    let r = norm(d);
    if r == 0.0 {
        // On the source: unbounded 1/r; cap at 1 mm so a solver stays finite.
        return C { re: 1.0, im: 0.0 };
    }
    let g = dir.gain_towards(t.normal, d) / r;
    let a = (k * r).rem_euclid(2.0 * std::f64::consts::PI);
    C {
        re: g * a.cos(),
        im: g * a.sin(),
    }
}

/// Pressure magnitude (arbitrary units: amplitude 1 at 1 mm) at each of
/// `points` for drive phases `turns` (one per transducer).
pub fn focus_pressures(
    transducers: &[Transducer],
    turns: &[f64],
    points: &[Vec3],
    k_rad_per_mm: f64,
    dir: Directivity,
) -> Vec<f64> {
    points
        .iter()
        .map(|&f| {
            let mut s = C::default();
            for (t, &ph) in transducers.iter().zip(turns) {
                let a = 2.0 * std::f64::consts::PI * ph;
                s = s.add(propagator(t, f, k_rad_per_mm, dir).mul(C {
                    re: a.cos(),
                    im: a.sin(),
                }));
            }
            s.abs()
        })
        .collect()
}

/// Phases (turns) for weighted synthesis `arg Σ_i w_i exp(−j k r_i)`.
pub fn weighted_turns(
    transducers: &[Transducer],
    foci: &[Vec3],
    weights: &[Weight],
    k_rad_per_mm: f64,
) -> Vec<f64> {
    let kappa = k_rad_per_mm / (2.0 * std::f64::consts::PI);
    transducers
        .iter()
        .map(|t| super::reference::phase_turns(t.pos_mm, foci, Some(weights), kappa))
        .collect()
}

/// GS-PAT phase-only solution for equal amplitude at every focus after
/// `iterations` steps; returns one phase (turns) per transducer.
pub fn gspat_turns(
    transducers: &[Transducer],
    foci: &[Vec3],
    k_rad_per_mm: f64,
    dir: Directivity,
    iterations: usize,
) -> Vec<f64> {
    let m = foci.len();
    let f: Vec<Vec<C>> = foci
        .iter()
        .map(|&p| {
            transducers
                .iter()
                .map(|t| propagator(t, p, k_rad_per_mm, dir))
                .collect()
        })
        .collect();
    let norms: Vec<f64> = f
        .iter()
        .map(|row| {
            row.iter()
                .map(|c| c.re * c.re + c.im * c.im)
                .sum::<f64>()
                .max(1e-300)
        })
        .collect();
    // R_ij = Σ_n F_in conj(F_jn) / |F_j|².
    let mut r = vec![vec![C::default(); m]; m];
    for i in 0..m {
        for j in 0..m {
            let mut s = C::default();
            for (a, b) in f[i].iter().zip(&f[j]) {
                s = s.add(a.mul(b.conj()));
            }
            r[i][j] = C {
                re: s.re / norms[j],
                im: s.im / norms[j],
            };
        }
    }
    // a: focus phasors (unit); w: amplitude weights, re-balanced every
    // iteration so weak foci ask for more (weighted GS).
    let mut a = vec![C { re: 1.0, im: 0.0 }; m];
    let mut w = vec![1.0f64; m];
    for _ in 0..iterations {
        let g: Vec<C> = (0..m)
            .map(|i| {
                (0..m).fold(C::default(), |s, j| {
                    s.add(r[i][j].mul(C {
                        re: a[j].re * w[j],
                        im: a[j].im * w[j],
                    }))
                })
            })
            .collect();
        let mean = g.iter().map(|x| x.abs()).sum::<f64>() / m as f64;
        for ((ai, wi), gi) in a.iter_mut().zip(w.iter_mut()).zip(g) {
            let n = gi.abs();
            if n > 0.0 {
                *ai = C {
                    re: gi.re / n,
                    im: gi.im / n,
                };
                *wi *= mean / n;
            }
        }
    }
    let a: Vec<C> = a
        .iter()
        .zip(&w)
        .map(|(x, &k)| C {
            re: x.re * k,
            im: x.im * k,
        })
        .collect();
    (0..transducers.len())
        .map(|n| {
            let x = (0..m).fold(C::default(), |s, i| {
                let b = f[i][n].conj();
                s.add(
                    C {
                        re: b.re / norms[i],
                        im: b.im / norms[i],
                    }
                    .mul(a[i]),
                )
            });
            x.im.atan2(x.re) / (2.0 * std::f64::consts::PI)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::scene::Scene;

    fn spread() -> Vec<Vec3> {
        vec![
            [-40.0, -40.0, 120.0],
            [40.0, -40.0, 160.0],
            [-40.0, 40.0, 220.0],
            [60.0, 60.0, 300.0],
        ]
    }

    fn uniformity(p: &[f64]) -> f64 {
        p.iter().cloned().fold(f64::INFINITY, f64::min) / p.iter().cloned().fold(0.0, f64::max)
    }

    #[test]
    fn gspat_evens_out_foci_that_linear_synthesis_leaves_unequal() {
        let s = Scene::default();
        let t = s.transducers();
        let k = s.wavenumber_rad_per_mm();
        let foci = spread();
        let lin = weighted_turns(&t, &foci, &[Weight::ONE; 4], k);
        let gs = gspat_turns(&t, &foci, k, s.directivity, 20);
        let pl = focus_pressures(&t, &lin, &foci, k, s.directivity);
        let pg = focus_pressures(&t, &gs, &foci, k, s.directivity);
        assert!(uniformity(&pg) > uniformity(&pl), "{pg:?} vs {pl:?}");
        assert!(uniformity(&pg) > 0.8, "{pg:?}");
    }

    #[test]
    fn single_focus_pressure_peaks_at_the_focus() {
        let s = Scene::default();
        let t = s.transducers();
        let k = s.wavenumber_rad_per_mm();
        let f = [0.0, 0.0, 200.0];
        let ph = weighted_turns(&t, &[f], &[Weight::ONE], k);
        let p = focus_pressures(&t, &ph, &[f, [0.0, 8.0, 200.0]], k, s.directivity);
        assert!(p[0] > 2.0 * p[1], "{p:?}");
        // With every contribution in phase, the pressure is Σ g/r.
        let sum: f64 = t
            .iter()
            .map(|tr| {
                s.directivity.gain_towards(tr.normal, sub(f, tr.pos_mm)) / norm(sub(f, tr.pos_mm))
            })
            .sum();
        assert!((p[0] - sum).abs() / sum < 1e-9);
    }
}
