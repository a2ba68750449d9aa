//! The fast synthesis path: f32 struct-of-arrays in blocks of eight
//! transducers, computed in explicit SIMD lanes (module `lanes`) with no
//! branches in the inner loops, planned once and run per frame into
//! caller-owned buffers without allocating.
//!
//! **Precision.** Positions are stored relative to the array centroid `c`.
//! For a focus `f` with `u = f − c`, `r0 = |u|` (f64) and a transducer at
//! `c + p`:
//!
//! - far foci (`r0 > 2 max|p|`): `r − r0 = D / (r + r0)` with
//!   `D = |p|² − 2 u·p`, evaluated scale-free as
//!   `δ = (D/r0) / (1 + sqrt(1 + D/r0²))`, and the phase in turns is
//!   `frac(κ r0)` (exact, f64) `+ κ δ` (f32, `|δ| ≤ max|p|`). Nothing in f32
//!   grows with the distance, so precision holds at kilometres.
//! - near foci: `κ |u − p| − round(κ r0)` directly in f32 (`r ≤ 3 max|p|`).
//!
//! With several foci the phasor sum uses a branch-free `√2 sin/cos` of
//! `π u` (`|u| ≤ ½`; minimax polynomials of degree 9/8, then the double
//! angle in two operations) and a branch-free atan2 (one division, Cephes
//! `atanf` polynomial). Where the sum is
//! small (`|S| < 0.1 Σ|w|`), its angle is ill-conditioned, so those
//! transducers are recomputed with the f64 [`reference`](mod@super::reference)
//! in one scalar fix-up pass shared by every multi-focus path. Result: every u8 is within 0.51 LSB of the
//! exact phase.
//!
//! **Instruction sets.** The kernels (module `kernels`) are generic over
//! eight f32 lanes; [`Isa::Avx2Fma`] runs them on one ymm register with
//! FMA inside `#[target_feature(enable = "avx2,fma")]` functions (module
//! `avx2`), [`Isa::Portable`] on two SSE2 registers (module `sse2`, the
//! x86-64 baseline; plain arrays elsewhere), a multiply then an add where
//! FMA is missing (`f32::mul_add` would be a library call). Both builds
//! are tested against the reference. The build is chosen once, when the plan
//! is made (as RustFFT chooses its algorithm once): the plan holds a table
//! of kernel functions and a frame only calls through it.

#[cfg(target_arch = "x86_64")]
mod avx2;
mod kernels;
mod lanes;
#[cfg(target_arch = "x86_64")]
mod sse2;

#[cfg(test)]
mod tests;

use kernels::{Kernels, Prep, Rows, Term};
use lanes::LANES;

use super::{Weight, reference};
use crate::geom::{Vec3, norm, sub};
use crate::plan::array::Transducer;

/// Padding of the struct-of-arrays rows (the kernels' block of lanes).
const L: usize = LANES;

/// Foci (or table terms) a [`Scratch`] holds without allocating.
const SCRATCH_FOCI: usize = crate::plan::trajectory::MAX_FOCI;

/// Which kernel build runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Isa {
    /// Baseline target features (SSE2 on x86-64), no FMA.
    Portable,
    /// x86-64 AVX2 + FMA (detected at run time).
    Avx2Fma,
}

impl Isa {
    /// The best kernel build this CPU runs.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            return Isa::Avx2Fma;
        }
        Isa::Portable
    }
}

/// Prepared geometry for the fast path.
#[derive(Debug, Clone)]
pub struct SynthPlan {
    n: usize,
    px: Vec<f32>,
    py: Vec<f32>,
    pz: Vec<f32>,
    pp: Vec<f32>,
    centroid: Vec3,
    positions: Vec<Vec3>,
    kappa: f64,
    max_p: f64,
    /// `256 · M` with `M` ≥ any |turns| + 1: keeps the values handed to
    /// [`quantise_pos`] positive.
    q_offset: f32,
    kernels: Kernels,
}

/// Caller-owned scratch for multi-focus frames: the prepared foci and a
/// fix-up flag byte per block of transducers. Holds up to
/// [`MAX_FOCI`](crate::plan::trajectory::MAX_FOCI) foci without
/// allocating.
#[derive(Debug, Clone)]
pub struct Scratch {
    re: Vec<f32>,
    im: Vec<f32>,
    preps: Vec<Prep>,
    terms: Vec<Term>,
    flags: Vec<u8>,
}

impl SynthPlan {
    /// Prepares `transducers` for wavenumber `k_rad_per_mm`.
    pub fn new(transducers: &[Transducer], k_rad_per_mm: f64) -> Self {
        let positions: Vec<Vec3> = transducers.iter().map(|t| t.pos_mm).collect();
        Self::from_positions(positions, k_rad_per_mm)
    }

    /// Prepares bare positions (mm) for wavenumber `k_rad_per_mm`.
    pub fn from_positions(positions: Vec<Vec3>, k_rad_per_mm: f64) -> Self {
        let n = positions.len();
        let mut centroid = [0.0; 3];
        for p in &positions {
            for a in 0..3 {
                centroid[a] += p[a] / n.max(1) as f64;
            }
        }
        let padded = n.div_ceil(L) * L;
        let (mut px, mut py, mut pz, mut pp) = (
            vec![0.0f32; padded],
            vec![0.0f32; padded],
            vec![0.0f32; padded],
            vec![0.0f32; padded],
        );
        let mut max_p: f64 = 0.0;
        for (i, p) in positions.iter().enumerate() {
            let d = sub(*p, centroid);
            px[i] = d[0] as f32;
            py[i] = d[1] as f32;
            pz[i] = d[2] as f32;
            pp[i] = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) as f32;
            max_p = max_p.max(norm(d));
        }
        let kappa = k_rad_per_mm / (2.0 * std::f64::consts::PI);
        let m = (kappa * max_p).ceil() + 2.0;
        Self {
            n,
            px,
            py,
            pz,
            pp,
            centroid,
            positions,
            kappa,
            max_p,
            q_offset: (256.0 * m) as f32,
            kernels: best_kernels(),
        }
    }

    /// The same plan running the portable kernels (for comparison and
    /// tests; results agree within the accuracy bound, not bit for bit).
    pub fn portable(mut self) -> Self {
        self.kernels = Kernels::PORTABLE;
        self
    }

    /// Which kernel build runs.
    pub fn isa(&self) -> Isa {
        self.kernels.isa
    }

    /// Number of transducers.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the plan has no transducers.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Transducer positions (mm), for the reference path.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Propagation constant κ = k / 2π (turns per mm).
    pub fn kappa_turns_per_mm(&self) -> f64 {
        self.kappa
    }

    /// Scratch sized for this plan.
    pub fn scratch(&self) -> Scratch {
        Scratch {
            re: vec![0.0; self.px.len()],
            im: vec![0.0; self.px.len()],
            preps: Vec::with_capacity(SCRATCH_FOCI),
            terms: Vec::with_capacity(SCRATCH_FOCI),
            flags: vec![0; self.px.len() / L],
        }
    }

    /// The frame contract: `out` holds one phase per transducer and there
    /// is one weight per focus.
    fn check_frame(&self, out: &[u8], foci: usize, weights: Option<&[Weight]>) {
        assert_eq!(
            out.len(),
            self.n,
            "output length must equal the transducer count"
        );
        if let Some(w) = weights {
            assert_eq!(w.len(), foci, "one weight per focus");
        }
    }

    fn rows(&self, n: usize) -> Rows<'_> {
        Rows {
            x: &self.px[..n],
            y: &self.py[..n],
            z: &self.pz[..n],
            pp: &self.pp[..n],
        }
    }

    fn prep(&self, f: Vec3) -> Prep {
        self.prep_weighted(f, Weight::ONE)
    }

    fn prep_weighted(&self, f: Vec3, w: Weight) -> Prep {
        let u = sub(f, self.centroid);
        let r0 = norm(u);
        let far = r0 > 2.0 * self.max_p && r0 > 0.0;
        let (wr, wi) = (w.re as f32, w.im as f32);
        if far {
            Prep {
                ux: (u[0] / r0) as f32,
                uy: (u[1] / r0) as f32,
                uz: (u[2] / r0) as f32,
                inv_r0: (1.0 / r0) as f32,
                t0: reference::propagation_turns(self.kappa, r0) as f32,
                kappa: self.kappa as f32,
                wr,
                wi,
                far,
            }
        } else {
            Prep {
                ux: u[0] as f32,
                uy: u[1] as f32,
                uz: u[2] as f32,
                inv_r0: 0.0,
                t0: -(self.kappa * r0).round() as f32,
                kappa: self.kappa as f32,
                wr,
                wi,
                far,
            }
        }
    }

    /// Single-focus frame: `out[n] = q(−κ r_n)`. `out.len()` must equal
    /// [`len`](Self::len).
    pub fn focus(&self, focus: Vec3, out: &mut [u8]) {
        self.check_frame(out, 1, None);
        let p = self.prep(focus);
        let rows = self.rows(self.px.len());
        self.kernels.focus(rows, &p, self.q_offset, out);
    }

    /// Multi-focus frame: `out[n] = q(arg Σ_i w_i exp(−j 2π κ r_in))`,
    /// equal weights when `weights` is `None`. No allocation; `scratch`
    /// comes from [`scratch`](Self::scratch).
    pub fn foci(
        &self,
        foci: &[Vec3],
        weights: Option<&[Weight]>,
        scratch: &mut Scratch,
        out: &mut [u8],
    ) {
        self.check_frame(out, foci.len(), weights);
        if foci.is_empty() {
            out.fill(0);
            return;
        }
        if foci.len() == 1 && weights.is_none() {
            return self.focus(foci[0], out);
        }
        let mut wsum = 0.0;
        scratch.preps.clear();
        for (i, &f) in foci.iter().enumerate() {
            let w = weight(weights, i);
            wsum += w.re.hypot(w.im);
            scratch.preps.push(self.prep_weighted(f, w));
        }
        let rows = self.rows(self.px.len());
        let s = &mut *scratch;
        (self.kernels.sums[usize::from(weights.is_some())])(rows, &s.preps, &mut s.re, &mut s.im);
        self.angles(s, wsum, out, || {
            foci.iter()
                .enumerate()
                .map(|(i, &f)| (f, weight(weights, i)))
        });
    }

    /// Quantised angles of the phasor sums in `s` into `out`, then the
    /// fix-up: where a sum is small against the total weight `wsum` its
    /// f32 angle is ill-conditioned, so the angle kernel flagged it (a bit
    /// per transducer) and that transducer is redone in f64 over
    /// `foci()`'s `(focus, weight)` pairs. Only flagged blocks cost more
    /// than a byte test.
    fn angles<I: Iterator<Item = (Vec3, Weight)>>(
        &self,
        s: &mut Scratch,
        wsum: f64,
        out: &mut [u8],
        foci: impl Fn() -> I,
    ) {
        let thr2 = fix_up_threshold(wsum);
        (self.kernels.angles)(&s.re, &s.im, thr2, out, &mut s.flags);
        for (b, &f) in s.flags.iter().enumerate() {
            let mut bits = f;
            while bits != 0 {
                let j = b * L + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if let Some(o) = out.get_mut(j) {
                    *o = super::quantise_turns(reference::phasor_sum_turns(
                        self.positions[j],
                        foci(),
                        self.kappa,
                    ));
                }
            }
        }
    }
}

/// The kernels' fix-up threshold on `|S|²` for a total weight `wsum`:
/// `(0.1 wsum)²`, at least the smallest normal f32 so that a zero sum
/// (an all-zero weight set too) is always redone.
fn fix_up_threshold(wsum: f64) -> f32 {
    let thr = 0.1 * wsum;
    ((thr * thr) as f32).max(f32::MIN_POSITIVE)
}

/// Weight `i` of `weights`, 1 when there are none.
fn weight(weights: Option<&[Weight]>, i: usize) -> Weight {
    weights.map_or(Weight::ONE, |w| w[i])
}

/// Phasor rows `exp(−j 2π κ r_kn)` of a set of points (a whole LM
/// trajectory), so a sequence whose foci are drawn from those points pays
/// the trigonometry once per point instead of once per focus and step.
#[derive(Debug, Clone, Default)]
pub struct PhasorTable {
    stride: usize,
    re: Vec<f32>,
    im: Vec<f32>,
    points: Vec<Vec3>,
}

impl PhasorTable {
    /// Number of points (rows).
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the table has no rows.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

impl SynthPlan {
    /// Computes the phasor row of every point (allocates the table).
    pub fn phasor_table(&self, points: &[Vec3]) -> PhasorTable {
        let mut t = PhasorTable::default();
        self.fill_phasor_table(points, &mut t);
        t
    }

    /// Refills `table` with the rows of `points`, reusing its memory (no
    /// allocation once it has held as many rows).
    pub fn fill_phasor_table(&self, points: &[Vec3], table: &mut PhasorTable) {
        let stride = self.px.len();
        let len = stride * points.len();
        table.stride = stride;
        // Every value is written below: only the length changes here.
        table.re.resize(len, 0.0);
        table.im.resize(len, 0.0);
        table.points.clear();
        table.points.extend_from_slice(points);
        let rows = self.rows(stride);
        for ((&f, re), im) in points
            .iter()
            .zip(table.re.chunks_exact_mut(stride))
            .zip(table.im.chunks_exact_mut(stride))
        {
            (self.kernels.phasors)(rows, &self.prep(f), re, im);
        }
    }

    /// Multi-focus frame whose foci are table rows `idx`: the same result
    /// and accuracy as [`foci`](Self::foci) on those points, without
    /// trigonometry per focus. No allocation.
    pub fn foci_from_table(
        &self,
        table: &PhasorTable,
        idx: &[usize],
        weights: Option<&[Weight]>,
        scratch: &mut Scratch,
        out: &mut [u8],
    ) {
        self.check_frame(out, idx.len(), weights);
        assert_eq!(table.stride, self.px.len(), "table from another plan");
        let mut wsum = 0.0;
        scratch.terms.clear();
        for (i, &k) in idx.iter().enumerate() {
            let w = weight(weights, i);
            wsum += w.re.hypot(w.im);
            assert!(k < table.len(), "table row {k} of {}", table.len());
            scratch.terms.push(Term {
                base: k * table.stride,
                wr: w.re as f32,
                wi: w.im as f32,
            });
        }
        let s = &mut *scratch;
        let sums = self.kernels.table_sums[usize::from(weights.is_some())];
        sums(&table.re, &table.im, &s.terms, &mut s.re, &mut s.im);
        self.angles(s, wsum, out, || {
            idx.iter()
                .enumerate()
                .map(|(i, &k)| (table.points[k], weight(weights, i)))
        });
    }
}

/// The best kernel build this CPU runs (chosen here, above both builds, so
/// neither imports the other's selector).
fn best_kernels() -> Kernels {
    #[cfg(target_arch = "x86_64")]
    if let Some(k) = avx2::kernels() {
        return k;
    }
    Kernels::PORTABLE
}
