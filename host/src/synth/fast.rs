//! The fast synthesis path: f32 struct-of-arrays, written so the compiler
//! vectorises it (flat loops over equal-length slices, no branches in the
//! inner loops), planned once and run per frame into caller-owned buffers
//! without allocating.
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
//! With several foci the phasor sum uses a branch-free sin/cos of `π u`
//! (`|u| ≤ ½`; Taylor to degree 9/10, error < 4e-6, then the double angle)
//! and a branch-free atan2 (Cephes `atanf` polynomial). Where the sum is
//! small (`|S| < 0.1 Σ|w|`), its angle is ill-conditioned, so those
//! transducers are recomputed with the f64 [`reference`](super::reference)
//! in a scalar fix-up pass. Result: every u8 is within 0.51 LSB of the
//! exact phase.
//!
//! **Instruction sets.** The kernels are generic over whether fused
//! multiply-add is available; [`Isa::Avx2Fma`] runs them inside
//! `#[target_feature(enable = "avx2,fma")]` functions (module `avx2`),
//! chosen at run time when the CPU has them. [`Isa::Portable`] is the
//! baseline build (SSE2 on x86-64) and is tested against the reference
//! too. Without FMA `mul_add` would be a library call, hence the switch.

use super::{Weight, reference};
use crate::array::Transducer;
use crate::geom::{Vec3, norm, sub};

/// Padding of the struct-of-arrays rows (lanes of the widest vector).
const L: usize = 8;

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
    isa: Isa,
}

/// Caller-owned scratch for multi-focus frames (phasor sums).
#[derive(Debug, Clone)]
pub struct Scratch {
    re: Vec<f32>,
    im: Vec<f32>,
}

/// A focus prepared for the kernels.
#[derive(Debug, Clone, Copy)]
struct Prep {
    ux: f32,
    uy: f32,
    uz: f32,
    inv_r0: f32,
    t0: f32,
    kappa: f32,
    far: bool,
}

/// The struct-of-arrays rows, all the same length.
#[derive(Clone, Copy)]
struct Rows<'a> {
    x: &'a [f32],
    y: &'a [f32],
    z: &'a [f32],
    pp: &'a [f32],
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
            isa: Isa::detect(),
        }
    }

    /// The same plan running the portable kernels (for comparison and
    /// tests; results agree within the accuracy bound, not bit for bit).
    pub fn portable(mut self) -> Self {
        self.isa = Isa::Portable;
        self
    }

    /// Which kernel build runs.
    pub fn isa(&self) -> Isa {
        self.isa
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
        let u = sub(f, self.centroid);
        let r0 = norm(u);
        let far = r0 > 2.0 * self.max_p && r0 > 0.0;
        if far {
            Prep {
                ux: (u[0] / r0) as f32,
                uy: (u[1] / r0) as f32,
                uz: (u[2] / r0) as f32,
                inv_r0: (1.0 / r0) as f32,
                t0: reference::propagation_turns(self.kappa, r0) as f32,
                kappa: self.kappa as f32,
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
                far,
            }
        }
    }

    /// Single-focus frame: `out[n] = q(−κ r_n)`. `out.len()` must equal
    /// [`len`](Self::len).
    pub fn focus(&self, focus: Vec3, out: &mut [u8]) {
        assert_eq!(
            out.len(),
            self.n,
            "output length must equal the transducer count"
        );
        let p = self.prep(focus);
        let rows = self.rows(self.n);
        let off = self.q_offset;
        match (self.isa, p.far) {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Isa::Avx2Fma` is only set after run-time detection.
            (Isa::Avx2Fma, true) => unsafe { avx2::focus::<true>(rows, &p, off, out) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            (Isa::Avx2Fma, false) => unsafe { avx2::focus::<false>(rows, &p, off, out) },
            (_, true) => focus_rows::<true, false>(rows, &p, off, out),
            (_, false) => focus_rows::<false, false>(rows, &p, off, out),
        }
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
        assert_eq!(
            out.len(),
            self.n,
            "output length must equal the transducer count"
        );
        if let Some(w) = weights {
            assert_eq!(w.len(), foci.len(), "one weight per focus");
        }
        if foci.is_empty() {
            out.fill(0);
            return;
        }
        if foci.len() == 1 && weights.is_none() {
            return self.focus(foci[0], out);
        }
        let n = self.n;
        scratch.re.fill(0.0);
        scratch.im.fill(0.0);
        let (re, im) = (&mut scratch.re[..n], &mut scratch.im[..n]);
        let rows = self.rows(n);
        let mut wsum = 0.0;
        for (i, &f) in foci.iter().enumerate() {
            let w = weights.map_or(Weight::ONE, |w| w[i]);
            wsum += w.re.hypot(w.im);
            let p = self.prep(f);
            let (wr, wi) = (w.re as f32, w.im as f32);
            match (self.isa, p.far) {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `Isa::Avx2Fma` is only set after run-time detection.
                (Isa::Avx2Fma, true) => unsafe {
                    avx2::accumulate::<true>(rows, &p, wr, wi, re, im)
                },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: as above.
                (Isa::Avx2Fma, false) => unsafe {
                    avx2::accumulate::<false>(rows, &p, wr, wi, re, im)
                },
                (_, true) => accumulate_rows::<true, false>(rows, &p, wr, wi, re, im),
                (_, false) => accumulate_rows::<false, false>(rows, &p, wr, wi, re, im),
            }
        }
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Isa::Avx2Fma` is only set after run-time detection.
            Isa::Avx2Fma => unsafe { avx2::angles(re, im, out) },
            _ => angles_rows::<false>(re, im, out),
        }
        // Ill-conditioned angles: redo in f64.
        let thr = 0.1 * wsum;
        let thr2 = (thr * thr) as f32;
        for (i, o) in out.iter_mut().enumerate() {
            let m2 = re[i] * re[i] + im[i] * im[i];
            // `== 0` also catches an all-zero weight set (thr2 = 0).
            if m2 < thr2 || m2 == 0.0 || m2.is_nan() {
                *o = super::quantise_turns(reference::phase_turns(
                    self.positions[i],
                    foci,
                    weights,
                    self.kappa,
                ));
            }
        }
    }
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
        table.re.clear();
        table.re.resize(len, 0.0);
        table.im.clear();
        table.im.resize(len, 0.0);
        table.points.clear();
        table.points.extend_from_slice(points);
        let rows = self.rows(stride);
        for ((&f, re), im) in points
            .iter()
            .zip(table.re.chunks_exact_mut(stride))
            .zip(table.im.chunks_exact_mut(stride))
        {
            let p = self.prep(f);
            match (self.isa, p.far) {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `Isa::Avx2Fma` is only set after run-time detection.
                (Isa::Avx2Fma, true) => unsafe {
                    avx2::accumulate::<true>(rows, &p, 1.0, 0.0, re, im)
                },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: as above.
                (Isa::Avx2Fma, false) => unsafe {
                    avx2::accumulate::<false>(rows, &p, 1.0, 0.0, re, im)
                },
                (_, true) => accumulate_rows::<true, false>(rows, &p, 1.0, 0.0, re, im),
                (_, false) => accumulate_rows::<false, false>(rows, &p, 1.0, 0.0, re, im),
            }
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
        assert_eq!(
            out.len(),
            self.n,
            "output length must equal the transducer count"
        );
        assert_eq!(table.stride, self.px.len(), "table from another plan");
        if let Some(w) = weights {
            assert_eq!(w.len(), idx.len(), "one weight per focus");
        }
        let n = self.n;
        let (re, im) = (&mut scratch.re[..n], &mut scratch.im[..n]);
        re.fill(0.0);
        im.fill(0.0);
        let mut wsum = 0.0;
        for (i, &k) in idx.iter().enumerate() {
            let w = weights.map_or(Weight::ONE, |w| w[i]);
            wsum += w.re.hypot(w.im);
            let (wr, wi) = (w.re as f32, w.im as f32);
            let base = k * table.stride;
            let (tr, ti) = (&table.re[base..base + n], &table.im[base..base + n]);
            match self.isa {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `Isa::Avx2Fma` is only set after run-time detection.
                Isa::Avx2Fma => unsafe { avx2::combine(tr, ti, wr, wi, re, im) },
                _ => combine_rows::<false>(tr, ti, wr, wi, re, im),
            }
        }
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Isa::Avx2Fma` is only set after run-time detection.
            Isa::Avx2Fma => unsafe { avx2::angles(re, im, out) },
            _ => angles_rows::<false>(re, im, out),
        }
        let thr = 0.1 * wsum;
        let thr2 = (thr * thr) as f32;
        for (j, o) in out.iter_mut().enumerate() {
            let m2 = re[j] * re[j] + im[j] * im[j];
            if m2 < thr2 || m2 == 0.0 || m2.is_nan() {
                let foci = idx
                    .iter()
                    .enumerate()
                    .map(|(i, &k)| (table.points[k], weights.map_or(Weight::ONE, |w| w[i])));
                *o = super::quantise_turns(reference::phasor_sum_turns(
                    self.positions[j],
                    foci,
                    self.kappa,
                ));
            }
        }
    }
}

/// AVX2 + FMA builds of the kernels: the same generic code, compiled with
/// those target features so it uses 8 lanes and fused multiply-adds.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Prep, Rows, accumulate_rows, angles_rows, combine_rows, focus_rows};

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn combine(
        tr: &[f32],
        ti: &[f32],
        wr: f32,
        wi: f32,
        re: &mut [f32],
        im: &mut [f32],
    ) {
        combine_rows::<true>(tr, ti, wr, wi, re, im)
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn focus<const FAR: bool>(
        rows: Rows<'_>,
        p: &Prep,
        off: f32,
        out: &mut [u8],
    ) {
        focus_rows::<FAR, true>(rows, p, off, out)
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn accumulate<const FAR: bool>(
        rows: Rows<'_>,
        p: &Prep,
        wr: f32,
        wi: f32,
        re: &mut [f32],
        im: &mut [f32],
    ) {
        accumulate_rows::<FAR, true>(rows, p, wr, wi, re, im)
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn angles(re: &[f32], im: &[f32], out: &mut [u8]) {
        angles_rows::<true>(re, im, out)
    }
}

/// `a · b + c`, fused when the kernel is built with FMA.
#[inline(always)]
fn fma<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

/// Single-focus kernel over `out.len()` transducers.
#[inline(always)]
fn focus_rows<const FAR: bool, const F: bool>(rows: Rows<'_>, p: &Prep, off: f32, out: &mut [u8]) {
    let n = out.len();
    let (x, y, z, pp) = (&rows.x[..n], &rows.y[..n], &rows.z[..n], &rows.pp[..n]);
    for i in 0..n {
        let t = turns::<FAR, F>(p, x[i], y[i], z[i], pp[i]);
        out[i] = quantise_pos(fma::<F>(-256.0, t, off));
    }
}

/// Adds `w · exp(−j 2π turns)` of one focus to the phasor sums.
#[inline(always)]
fn accumulate_rows<const FAR: bool, const F: bool>(
    rows: Rows<'_>,
    p: &Prep,
    wr: f32,
    wi: f32,
    re: &mut [f32],
    im: &mut [f32],
) {
    let n = re.len();
    let im = &mut im[..n];
    let (x, y, z, pp) = (&rows.x[..n], &rows.y[..n], &rows.z[..n], &rows.pp[..n]);
    for i in 0..n {
        let t = turns::<FAR, F>(p, x[i], y[i], z[i], pp[i]);
        let (c, s) = cos_sin_turns::<F>(t);
        // (wr + j wi)(cos − j sin)
        re[i] = fma::<F>(wr, c, fma::<F>(wi, s, re[i]));
        im[i] = fma::<F>(wi, c, fma::<F>(-wr, s, im[i]));
    }
}

/// Adds `(wr + j wi)` times a table row to the phasor sums.
#[inline(always)]
fn combine_rows<const F: bool>(
    tr: &[f32],
    ti: &[f32],
    wr: f32,
    wi: f32,
    re: &mut [f32],
    im: &mut [f32],
) {
    let n = re.len();
    let (tr, ti, im) = (&tr[..n], &ti[..n], &mut im[..n]);
    for j in 0..n {
        // (wr + j wi)(a + j b)
        re[j] = fma::<F>(wr, tr[j], fma::<F>(-wi, ti[j], re[j]));
        im[j] = fma::<F>(wi, tr[j], fma::<F>(wr, ti[j], im[j]));
    }
}

/// Quantised angle of every phasor sum.
#[inline(always)]
fn angles_rows<const F: bool>(re: &[f32], im: &[f32], out: &mut [u8]) {
    let n = out.len();
    let (re, im) = (&re[..n], &im[..n]);
    for i in 0..n {
        out[i] = quantise_pos(fma::<F>(256.0, atan2_turns::<F>(im[i], re[i]), 256.0));
    }
}

/// `round(v) mod 256` for `0 ≤ v < 2²³`, branch-free and vectorisable:
/// adding 2²³ leaves the rounded (to nearest) integer in the low mantissa
/// bits (a saturating `as i32` would not vectorise).
#[inline(always)]
fn quantise_pos(v: f32) -> u8 {
    (v + 8_388_608.0).to_bits() as u8
}

/// Propagation phase (turns) of a transducer at offset `(x, y, z)` from the
/// centroid, `pp = |p|²`; up to an integer number of turns.
#[inline(always)]
fn turns<const FAR: bool, const F: bool>(p: &Prep, x: f32, y: f32, z: f32, pp: f32) -> f32 {
    if FAR {
        let dot = fma::<F>(p.ux, x, fma::<F>(p.uy, y, p.uz * z));
        let dr = fma::<F>(pp, p.inv_r0, -2.0 * dot);
        let e = dr * p.inv_r0;
        let delta = dr / (1.0 + (1.0 + e).max(0.0).sqrt());
        fma::<F>(p.kappa, delta, p.t0)
    } else {
        let (dx, dy, dz) = (p.ux - x, p.uy - y, p.uz - z);
        let r2 = fma::<F>(dx, dx, fma::<F>(dy, dy, dz * dz));
        fma::<F>(p.kappa, r2.sqrt(), p.t0)
    }
}

/// `(cos 2πt, sin 2πt)` for any moderate `t` (|t| < 2²²), branch-free.
#[inline(always)]
fn cos_sin_turns<const F: bool>(t: f32) -> (f32, f32) {
    // Round to nearest with the 1.5·2²³ trick (vectorises, unlike round()).
    const MAGIC: f32 = 12_582_912.0;
    let u = t - ((t + MAGIC) - MAGIC);
    let th = std::f32::consts::PI * u; // |th| ≤ π/2
    let z = th * th;
    // Taylor series of sin (degree 9) and cos (degree 10) in Horner form;
    // errors (π/2)¹¹/11! ≈ 4e-6 and (π/2)¹²/12! ≈ 5e-7 at the ends.
    let s = th
        * fma::<F>(
            z,
            fma::<F>(
                z,
                fma::<F>(z, fma::<F>(z, 1.0 / 362_880.0, -1.0 / 5040.0), 1.0 / 120.0),
                -1.0 / 6.0,
            ),
            1.0,
        );
    let c = fma::<F>(
        z,
        fma::<F>(
            z,
            fma::<F>(
                z,
                fma::<F>(
                    z,
                    fma::<F>(z, -1.0 / 3_628_800.0, 1.0 / 40_320.0),
                    -1.0 / 720.0,
                ),
                1.0 / 24.0,
            ),
            -0.5,
        ),
        1.0,
    );
    (fma::<F>(c, c, -s * s), 2.0 * s * c)
}

/// `atan2(y, x) / 2π` in `[−½, ½]`, branch-free (selects only). Returns
/// NaN for `(0, 0)`; callers re-do small sums in f64.
#[inline(always)]
fn atan2_turns<const F: bool>(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let a = ax.min(ay) / ax.max(ay);
    let big = a > 0.414_213_57;
    let xr = if big { (a - 1.0) / (a + 1.0) } else { a };
    let y0 = if big { FRAC_PI_4 } else { 0.0 };
    let z = xr * xr;
    let poly = fma::<F>(
        fma::<F>(
            fma::<F>(
                fma::<F>(8.053_744_5e-2, z, -1.387_768_6e-1),
                z,
                1.997_771_1e-1,
            ),
            z,
            -3.333_295e-1,
        ) * z,
        xr,
        xr,
    );
    let mut r = y0 + poly;
    r = if ay > ax { FRAC_PI_2 - r } else { r };
    r = if x < 0.0 { PI - r } else { r };
    r = if y < 0.0 { -r } else { r };
    r * (0.5 / PI)
}

#[cfg(test)]
mod tests {
    use super::super::{error_lsb, reference};
    use super::*;
    use crate::rng::SplitMix64;
    use crate::scene::Scene;

    fn plan() -> SynthPlan {
        let s = Scene::default();
        SynthPlan::new(&s.transducers(), s.wavenumber_rad_per_mm())
    }

    /// The detected build and the portable one.
    fn plans() -> [SynthPlan; 2] {
        [plan(), plan().portable()]
    }

    /// Max error in LSB of the fast path against the exact f64 phase.
    fn max_err(plan: &SynthPlan, foci: &[Vec3], w: Option<&[Weight]>) -> f64 {
        let mut out = vec![0u8; plan.len()];
        let mut s = plan.scratch();
        plan.foci(foci, w, &mut s, &mut out);
        out.iter()
            .zip(plan.positions())
            .map(|(&q, &p)| error_lsb(q, reference::phase_turns(p, foci, w, plan.kappa)))
            .fold(0.0, f64::max)
    }

    #[test]
    fn seeded_random_foci_are_within_0_51_lsb() {
        for plan in plans() {
            seeded_random(&plan);
        }
    }

    fn seeded_random(plan: &SynthPlan) {
        let mut rng = SplitMix64::new(0x5eed);
        for case in 0..300 {
            let m = 1 + case % 4;
            let foci: Vec<Vec3> = (0..m)
                .map(|_| {
                    [
                        rng.uniform(-300.0, 300.0),
                        rng.uniform(-300.0, 300.0),
                        rng.uniform(-50.0, 600.0),
                    ]
                })
                .collect();
            let e = max_err(plan, &foci, None);
            assert!(
                e <= 0.51,
                "{:?} case {case}: {e} LSB for {foci:?}",
                plan.isa()
            );
        }
    }

    /// 10^5 seeded random focus sets (1-4 foci, ±1 m, both builds): run by
    /// `cargo test --release -p lmhost --lib -- --ignored long_random`.
    #[test]
    #[ignore = "long: run in release by cargo xtask ci"]
    fn long_random_foci_are_within_0_51_lsb() {
        for plan in plans() {
            let mut rng = SplitMix64::new(0x10_0000);
            let mut out = vec![0u8; plan.len()];
            let mut s = plan.scratch();
            for case in 0..50_000 {
                let m = 1 + case % 4;
                let foci: Vec<Vec3> = (0..m)
                    .map(|_| {
                        [
                            rng.uniform(-1000.0, 1000.0),
                            rng.uniform(-1000.0, 1000.0),
                            rng.uniform(-1000.0, 1000.0),
                        ]
                    })
                    .collect();
                plan.foci(&foci, None, &mut s, &mut out);
                for (&q, &p) in out.iter().zip(plan.positions()) {
                    let e = error_lsb(q, reference::phase_turns(p, &foci, None, plan.kappa));
                    assert!(
                        e <= 0.51,
                        "{:?} case {case}: {e} LSB for {foci:?}",
                        plan.isa()
                    );
                }
            }
        }
    }

    #[test]
    fn weighted_random_foci_are_within_0_51_lsb() {
        for plan in plans() {
            weighted_random(&plan);
        }
    }

    fn weighted_random(plan: &SynthPlan) {
        let mut rng = SplitMix64::new(42);
        for case in 0..50 {
            let foci: Vec<Vec3> = (0..3)
                .map(|_| {
                    [
                        rng.uniform(-50.0, 50.0),
                        rng.uniform(-50.0, 50.0),
                        rng.uniform(100.0, 300.0),
                    ]
                })
                .collect();
            let w: Vec<Weight> = (0..3)
                .map(|_| Weight {
                    re: rng.uniform(-1.0, 1.0),
                    im: rng.uniform(-1.0, 1.0),
                })
                .collect();
            let e = max_err(plan, &foci, Some(&w));
            assert!(e <= 0.51, "case {case}: {e} LSB");
        }
    }

    #[test]
    fn coincident_foci_match_a_single_focus() {
        let plan = plan();
        let f = [5.0, -7.0, 180.0];
        let (mut a, mut b) = (vec![0u8; plan.len()], vec![0u8; plan.len()]);
        plan.focus(f, &mut a);
        plan.foci(&[f, f, f, f], None, &mut plan.scratch(), &mut b);
        let diff = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        // Both are within 0.51 LSB of the same exact phase; they may only
        // differ where that phase sits on a rounding tie.
        assert!(diff < 5, "{diff} transducers differ");
        assert!(max_err(&plan, &[f, f, f, f], None) <= 0.51);
    }

    #[test]
    fn cancelling_foci_are_finite_and_exact() {
        let plan = plan();
        let f = [0.0, 0.0, 150.0];
        let w = [Weight::ONE, Weight::real(-1.0)];
        let mut out = vec![0u8; plan.len()];
        plan.foci(&[f, f], Some(&w), &mut plan.scratch(), &mut out);
        for (&q, &p) in out.iter().zip(plan.positions()) {
            let want = super::super::quantise_turns(reference::phase_turns(
                p,
                &[f, f],
                Some(&w),
                plan.kappa,
            ));
            assert_eq!(q, want);
        }
        // Half a wavelength apart along the axis: many near-zero sums.
        let e = max_err(&plan, &[[0.0, 0.0, 150.0], [0.0, 0.0, 154.25]], None);
        assert!(e <= 0.51, "{e}");
    }

    #[test]
    fn focus_on_a_transducer_and_behind_the_array() {
        let plan = plan();
        let on = plan.positions()[123];
        assert!(max_err(&plan, &[on], None) <= 0.51);
        assert!(max_err(&plan, &[on, [0.0, 0.0, 200.0]], None) <= 0.51);
        let mut out = vec![0u8; plan.len()];
        plan.focus(on, &mut out);
        assert_eq!(out[123], 0);
        assert!(max_err(&plan, &[[10.0, 20.0, -150.0]], None) <= 0.51);
        // Focus exactly at the centroid (r0 = 0, the near kernel).
        assert!(max_err(&plan, &[plan.centroid], None) <= 0.51);
    }

    #[test]
    fn very_large_coordinates_keep_precision() {
        for plan in plans() {
            large_coordinates(&plan);
        }
    }

    fn large_coordinates(plan: &SynthPlan) {
        for f in [
            [1.0e6, -2.0e6, 3.0e6],
            [0.0, 0.0, 1.0e8],
            [-7.3e7, 1.1e5, -4.0e7],
            [0.0, 0.0, 700.0],
        ] {
            let e = max_err(plan, &[f], None);
            assert!(e <= 0.51, "{f:?}: {e}");
            let e = max_err(plan, &[f, [f[0] + 3.0, f[1], f[2]]], None);
            assert!(e <= 0.51, "{f:?} pair: {e}");
        }
    }

    #[test]
    fn table_path_matches_the_reference() {
        for plan in plans() {
            let mut rng = SplitMix64::new(7);
            let pts: Vec<Vec3> = (0..12)
                .map(|_| {
                    [
                        rng.uniform(-20.0, 20.0),
                        rng.uniform(-20.0, 20.0),
                        rng.uniform(150.0, 250.0),
                    ]
                })
                .collect();
            let table = plan.phasor_table(&pts);
            assert_eq!(table.len(), 12);
            let mut out = vec![0u8; plan.len()];
            let mut s = plan.scratch();
            for idx in [&[0usize, 3, 6, 9][..], &[1, 1], &[11, 0, 5]] {
                let foci: Vec<Vec3> = idx.iter().map(|&k| pts[k]).collect();
                plan.foci_from_table(&table, idx, None, &mut s, &mut out);
                for (&q, &p) in out.iter().zip(plan.positions()) {
                    let e = error_lsb(q, reference::phase_turns(p, &foci, None, plan.kappa));
                    assert!(e <= 0.51, "{:?} {idx:?}: {e}", plan.isa());
                }
                let w = vec![Weight { re: 0.3, im: -0.8 }; idx.len()];
                plan.foci_from_table(&table, idx, Some(&w), &mut s, &mut out);
                for (&q, &p) in out.iter().zip(plan.positions()) {
                    let e = error_lsb(q, reference::phase_turns(p, &foci, Some(&w), plan.kappa));
                    assert!(e <= 0.51, "{:?} weighted {idx:?}: {e}", plan.isa());
                }
            }
        }
    }

    #[test]
    fn odd_transducer_counts_use_the_tail_path() {
        let s = Scene::default();
        let t = &s.transducers()[..13];
        let plan = SynthPlan::new(t, s.wavenumber_rad_per_mm());
        assert_eq!(plan.len(), 13);
        assert!(max_err(&plan, &[[0.0, 0.0, 100.0]], None) <= 0.51);
        assert!(max_err(&plan, &[[0.0, 0.0, 100.0], [3.0, 0.0, 100.0]], None) <= 0.51);
    }

    #[test]
    fn kernels_are_accurate_alone() {
        kernels_accurate::<false>();
        kernels_accurate::<true>();
    }

    fn kernels_accurate<const F: bool>() {
        let mut worst: f32 = 0.0;
        for i in -2000..=2000 {
            let t = i as f32 / 997.0;
            let (c, s) = cos_sin_turns::<F>(t);
            let a = 2.0 * std::f64::consts::PI * f64::from(t);
            worst = worst.max((f64::from(c) - a.cos()).abs() as f32);
            worst = worst.max((f64::from(s) - a.sin()).abs() as f32);
            let (y, x) = (s * 0.7, c * 0.7);
            let at = f64::from(atan2_turns::<F>(y, x));
            let want = f64::from(y).atan2(f64::from(x)) / (2.0 * std::f64::consts::PI);
            let d = (at - want).rem_euclid(1.0);
            worst = worst.max(d.min(1.0 - d) as f32);
        }
        assert!(worst < 1e-5, "{worst}");
    }
}
