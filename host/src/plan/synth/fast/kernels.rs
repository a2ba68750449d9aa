//! The kernels of the fast path, generic over whether fused multiply-add
//! is available, and [`Kernels`]: one build of all of them, chosen once per
//! plan. The generic code is written for the auto-vectoriser (flat loops
//! over equal-length slices, selects instead of branches); [`super::avx2`]
//! compiles the same code with AVX2 + FMA enabled.

use super::Isa;

/// Single-focus kernel: rows, focus, quantiser offset, output.
pub(super) type FocusFn = fn(Rows<'_>, &Prep, f32, &mut [u8]);
/// Adds one focus's weighted phasors: rows, focus, weight, sums.
pub(super) type AccumulateFn = fn(Rows<'_>, &Prep, f32, f32, &mut [f32], &mut [f32]);
/// Adds a weighted table row: row (re, im), weight, sums.
pub(super) type CombineFn = fn(&[f32], &[f32], f32, f32, &mut [f32], &mut [f32]);
/// Quantised angles of the sums.
pub(super) type AnglesFn = fn(&[f32], &[f32], &mut [u8]);

/// One build of every kernel. Chosen once when the plan is made, as
/// RustFFT picks its algorithm once; a frame then only calls through it.
/// `[near, far]` pairs are indexed by [`Prep::far`].
#[derive(Clone, Copy)]
pub(super) struct Kernels {
    pub(super) isa: Isa,
    pub(super) focus: [FocusFn; 2],
    pub(super) accumulate: [AccumulateFn; 2],
    pub(super) combine: CombineFn,
    pub(super) angles: AnglesFn,
}

impl std::fmt::Debug for Kernels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Kernels").field("isa", &self.isa).finish()
    }
}

impl Kernels {
    /// The baseline build (SSE2 on x86-64), no FMA: runs on every CPU.
    pub(super) const PORTABLE: Self = Self {
        isa: Isa::Portable,
        focus: [focus_rows::<false, false>, focus_rows::<true, false>],
        accumulate: [
            accumulate_rows::<false, false>,
            accumulate_rows::<true, false>,
        ],
        combine: combine_rows::<false>,
        angles: angles_rows::<false>,
    };

    /// Single-focus frame.
    pub(super) fn focus(&self, rows: Rows<'_>, p: &Prep, off: f32, out: &mut [u8]) {
        (self.focus[usize::from(p.far)])(rows, p, off, out)
    }

    /// Adds `w · exp(−j 2π turns)` of one focus to the sums.
    pub(super) fn accumulate(
        &self,
        rows: Rows<'_>,
        p: &Prep,
        w: (f32, f32),
        re: &mut [f32],
        im: &mut [f32],
    ) {
        (self.accumulate[usize::from(p.far)])(rows, p, w.0, w.1, re, im)
    }
}

/// A focus prepared for the kernels.
#[derive(Debug, Clone, Copy)]
pub(super) struct Prep {
    pub(super) ux: f32,
    pub(super) uy: f32,
    pub(super) uz: f32,
    pub(super) inv_r0: f32,
    pub(super) t0: f32,
    pub(super) kappa: f32,
    pub(super) far: bool,
}

/// The struct-of-arrays rows, all the same length.
#[derive(Clone, Copy)]
pub(super) struct Rows<'a> {
    pub(super) x: &'a [f32],
    pub(super) y: &'a [f32],
    pub(super) z: &'a [f32],
    pub(super) pp: &'a [f32],
}

/// `a · b + c`, fused when the kernel is built with FMA.
#[inline(always)]
fn fma<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

/// Single-focus kernel over `out.len()` transducers.
#[inline(always)]
pub(super) fn focus_rows<const FAR: bool, const F: bool>(
    rows: Rows<'_>,
    p: &Prep,
    off: f32,
    out: &mut [u8],
) {
    let n = out.len();
    let (x, y, z, pp) = (&rows.x[..n], &rows.y[..n], &rows.z[..n], &rows.pp[..n]);
    for i in 0..n {
        let t = turns::<FAR, F>(p, x[i], y[i], z[i], pp[i]);
        out[i] = quantise_pos(fma::<F>(-256.0, t, off));
    }
}

/// Adds `w · exp(−j 2π turns)` of one focus to the phasor sums.
#[inline(always)]
pub(super) fn accumulate_rows<const FAR: bool, const F: bool>(
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
pub(super) fn combine_rows<const F: bool>(
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
pub(super) fn angles_rows<const F: bool>(re: &[f32], im: &[f32], out: &mut [u8]) {
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
pub(super) fn cos_sin_turns<const F: bool>(t: f32) -> (f32, f32) {
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
pub(super) fn atan2_turns<const F: bool>(y: f32, x: f32) -> f32 {
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
