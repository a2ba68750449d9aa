//! The kernels of the fast path, generic over the eight [`Lanes`] they
//! compute in, and [`Kernels`]: one build of all of them, chosen once per
//! plan. The portable build runs them on SSE2 lanes (x86-64's baseline;
//! plain arrays elsewhere); [`super::avx2`] builds them on AVX2 + FMA
//! lanes inside `#[target_feature]` functions.
//!
//! A multi-focus frame is a pass over the transducers per focus, adding
//! its phasors into the sums (each pass a long run of independent blocks
//! of eight, which the CPU overlaps), then one pass that takes each sum's
//! angle, quantises it and flags the blocks whose sums are too small for
//! an f32 angle (for the f64 fix-up). Per focus and block that is a
//! distance (a square root), the range reduction folded into two
//! multiply-adds, two short polynomials (see [`half_turn`]) and two
//! multiply-adds into the sums.

use super::Isa;
#[cfg(not(target_arch = "x86_64"))]
use super::lanes::Arr as Portable;
use super::lanes::{LANES, Lanes};
#[cfg(target_arch = "x86_64")]
use super::sse2::Sse as Portable;

/// Single-focus kernel: rows, focus, quantiser offset, output.
pub(super) type FocusFn = fn(Rows<'_>, &Prep, f32, &mut [u8]);
/// Sets the phasor sums (re, im) of a set of foci.
pub(super) type SumsFn = fn(Rows<'_>, &[Prep], &mut [f32], &mut [f32]);
/// One phasor-table row: rows, point, row (re, im).
pub(super) type PhasorsFn = fn(Rows<'_>, &Prep, &mut [f32], &mut [f32]);
/// Sets the phasor sums (re, im) of table rows: table (re, im), terms.
pub(super) type TableSumsFn = fn(&[f32], &[f32], &[Term], &mut [f32], &mut [f32]);
/// Quantised angles of the sums (re, im) and the fix-up flags: threshold
/// on `|S|²`, output, a flag byte per block.
pub(super) type AnglesFn = fn(&[f32], &[f32], f32, &mut [u8], &mut [u8]);

/// One build of every kernel. Chosen once when the plan is made, as
/// RustFFT picks its algorithm once; a frame then only calls through it.
/// `focus` pairs are `[near, far]`, indexed by [`Prep::far`]; `sums` and
/// `table_sums` pairs are `[equal weights, weighted]`.
#[derive(Clone, Copy)]
pub(super) struct Kernels {
    pub(super) isa: Isa,
    pub(super) focus: [FocusFn; 2],
    pub(super) sums: [SumsFn; 2],
    pub(super) phasors: PhasorsFn,
    pub(super) table_sums: [TableSumsFn; 2],
    pub(super) angles: AnglesFn,
}

impl std::fmt::Debug for Kernels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Kernels").field("isa", &self.isa).finish()
    }
}

impl Kernels {
    /// The baseline build (SSE2 on x86-64, no FMA): runs on every CPU.
    pub(super) const PORTABLE: Self = Self {
        isa: Isa::Portable,
        focus: [focus_rows::<Portable, false>, focus_rows::<Portable, true>],
        sums: [sum_rows::<Portable, false>, sum_rows::<Portable, true>],
        phasors: phasor_rows::<Portable>,
        table_sums: [table_rows::<Portable, false>, table_rows::<Portable, true>],
        angles: angle_rows::<Portable>,
    };

    /// Single-focus frame.
    pub(super) fn focus(&self, rows: Rows<'_>, p: &Prep, off: f32, out: &mut [u8]) {
        (self.focus[usize::from(p.far)])(rows, p, off, out)
    }
}

/// A focus prepared for the kernels (module docs of [`super`]).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Prep {
    /// Near: the focus relative to the centroid (mm); far: its direction.
    pub(super) ux: f32,
    pub(super) uy: f32,
    pub(super) uz: f32,
    /// Far: `1 / r0`.
    pub(super) inv_r0: f32,
    /// Near: `−round(κ r0)`, an integer; far: `frac(κ r0)`.
    pub(super) t0: f32,
    pub(super) kappa: f32,
    /// Complex weight (1 for equal weights).
    pub(super) wr: f32,
    pub(super) wi: f32,
    pub(super) far: bool,
}

/// A weighted phasor-table row in a table frame: the row starts at
/// `base` in the table.
#[derive(Debug, Clone, Copy)]
pub(super) struct Term {
    pub(super) base: usize,
    pub(super) wr: f32,
    pub(super) wi: f32,
}

/// The struct-of-arrays rows, all the same length, a multiple of
/// [`LANES`] (zero padding past the last transducer).
#[derive(Clone, Copy)]
pub(super) struct Rows<'a> {
    pub(super) x: &'a [f32],
    pub(super) y: &'a [f32],
    pub(super) z: &'a [f32],
    pub(super) pp: &'a [f32],
}

/// 1.5 · 2²³: adding it rounds an f32 of magnitude < 2²² to an integer
/// (to nearest, ties to even), which subtracting it again recovers.
const ROUND: f32 = 12_582_912.0;
/// 2²³: a value in `[2²³, 2²⁴)` holds `round(v − 2²³)` in its low
/// mantissa bits (the quantiser's offset).
const TWO_23: f32 = 8_388_608.0;

/// Fills `out` (`&mut [u8]`) block by block with `$block` (a
/// `[u8; LANES]` of block `$b`): whole blocks in the loop, a shorter last
/// block after it (so the loop itself has no copy of variable length).
///
/// A macro, not a function taking a closure: a closure is a function of
/// its own without the caller's `#[target_feature]`, and where the
/// compiler declines to inline it every lane operation inside becomes a
/// call (measured: the AVX2 frame 25x slower than the SSE2 one).
macro_rules! write_blocks {
    ($out:expr, |$b:ident| $block:expr) => {{
        let out: &mut [u8] = $out;
        let whole = out.len() / LANES;
        let mut chunks = out.chunks_exact_mut(LANES);
        for ($b, dst) in (&mut chunks).enumerate() {
            dst.copy_from_slice(&$block);
        }
        let rest = chunks.into_remainder();
        if !rest.is_empty() {
            let $b = whole;
            let q: [u8; LANES] = $block;
            let k = rest.len();
            rest.copy_from_slice(&q[..k]);
        }
    }};
}

impl<'a> Rows<'a> {
    /// The first `blocks` blocks of every row (bounds checked once here,
    /// so the kernels' loads need no checks of their own).
    #[inline(always)]
    fn blocks(&self, blocks: usize) -> Self {
        let n = blocks * LANES;
        Self {
            x: &self.x[..n],
            y: &self.y[..n],
            z: &self.z[..n],
            pp: &self.pp[..n],
        }
    }

    /// Block `b`: `(x, y, z, |p|²)`.
    #[inline(always)]
    fn block<V: Lanes>(&self, b: usize) -> (V, V, V, V) {
        let o = b * LANES;
        // No closure here (see `write_blocks!`).
        (
            V::load(&self.x[o..o + LANES]),
            V::load(&self.y[o..o + LANES]),
            V::load(&self.z[o..o + LANES]),
            V::load(&self.pp[o..o + LANES]),
        )
    }
}

/// Single-focus kernel over `out.len()` transducers:
/// `round(−256 κ r) mod 256` (plus whole turns).
#[inline(always)]
pub(super) fn focus_rows<V: Lanes, const FAR: bool>(
    rows: Rows<'_>,
    p: &Prep,
    off: f32,
    out: &mut [u8],
) {
    let rows = rows.blocks(out.len().div_ceil(LANES));
    write_blocks!(out, |b| {
        let (x, y, z, pp) = rows.block::<V>(b);
        let v = if FAR {
            let t = far_turns(p, x, y, z, pp);
            V::splat(-256.0).mul_add(t, V::splat(off + TWO_23))
        } else {
            // −256 (κ r + t0) + off + 2²³ in one rounding: the constant is
            // an integer below 2²⁴, so it is exact.
            let c = off + TWO_23 - 256.0 * p.t0;
            V::splat(-256.0 * p.kappa).mul_add(distance(p, x, y, z), V::splat(c))
        };
        v.low_bytes()
    })
}

/// Distance (mm) from the near focus `p` to the transducers at `(x, y, z)`.
#[inline(always)]
fn distance<V: Lanes>(p: &Prep, x: V, y: V, z: V) -> V {
    let (dx, dy, dz) = (V::splat(p.ux) - x, V::splat(p.uy) - y, V::splat(p.uz) - z);
    dx.mul_add(dx, dy.mul_add(dy, dz * dz)).sqrt()
}

/// Far focus: propagation phase in turns up to whole turns,
/// `frac(κ r0) + κ δ` with `δ = r − r0` evaluated scale-free.
#[inline(always)]
fn far_turns<V: Lanes>(p: &Prep, x: V, y: V, z: V, pp: V) -> V {
    let dot = V::splat(p.ux).mul_add(x, V::splat(p.uy).mul_add(y, V::splat(p.uz) * z));
    let inv_r0 = V::splat(p.inv_r0);
    let dr = pp.mul_add(inv_r0, V::splat(-2.0) * dot);
    let e = dr * inv_r0;
    let one = V::splat(1.0);
    let delta = dr / (one + (one + e).max(V::splat(0.0)).sqrt());
    V::splat(p.kappa).mul_add(delta, V::splat(p.t0))
}

/// Propagation phase of focus `p` in turns, reduced to `[−½, ½]`.
///
/// Near foci: `κ r + t0` rounded to an integer `N` by one multiply-add
/// onto `t0 + 1.5·2²³` (exact: both are integers), then `κ r + (t0 − N)`
/// by a second: the fraction is rounded once, at its own magnitude.
#[inline(always)]
fn reduced_turns<V: Lanes>(p: &Prep, x: V, y: V, z: V, pp: V) -> V {
    if p.far {
        reduced::<V, true>(p, x, y, z, pp)
    } else {
        reduced::<V, false>(p, x, y, z, pp)
    }
}

/// [`reduced_turns`] for a focus known to be far (`FAR`) or near.
#[inline(always)]
fn reduced<V: Lanes, const FAR: bool>(p: &Prep, x: V, y: V, z: V, pp: V) -> V {
    let kappa = V::splat(p.kappa);
    if FAR {
        let t = far_turns(p, x, y, z, pp);
        let round = V::splat(ROUND);
        t - ((t + round) - round)
    } else {
        let r = distance(p, x, y, z);
        let t0 = p.t0 + ROUND;
        let v = kappa.mul_add(r, V::splat(t0));
        kappa.mul_add(r, V::splat(t0) - v)
    }
}

/// `(√2 sin πu, √2 cos πu)` for `|u| ≤ ½`: minimax polynomials of degree
/// 9 and 8 in `u` (absolute error below 5e-9 and 7e-8 before f32
/// rounding, 3e-7 after). The scale √2 makes the full-turn phasor two operations:
/// `cos 2πu = C² − 1` and `sin 2πu = S·C`.
#[inline(always)]
pub(super) fn half_turn<V: Lanes>(u: V) -> (V, V) {
    let z = u * u;
    let k = V::splat;
    let s = k(1.092_057_5e-1).mul_add(z, k(-8.457_636e-1));
    let s = s.mul_add(z, k(3.606_289));
    let s = s.mul_add(z, k(-7.308_241_4));
    let s = s.mul_add(z, k(4.442_883)) * u;
    let c = k(3.106_981_8e-1).mul_add(z, k(-1.883_563));
    let c = c.mul_add(z, k(5.739_461));
    let c = c.mul_add(z, k(-6.978_851));
    let c = c.mul_add(z, k(std::f32::consts::SQRT_2));
    (s, c)
}

/// `exp(−j 2π u)` from [`half_turn`]: `(cos 2πu, −sin 2πu)`.
#[inline(always)]
pub(super) fn phasor<V: Lanes>(u: V) -> (V, V) {
    let (s, c) = half_turn(u);
    (c.mul_add(c, V::splat(-1.0)), -(s * c))
}

/// The angle of `x + j y` in LSB (`atan2(y, x) · 128 / π`, in
/// `[−128, 128]`), branch-free: one division folds the octant (`a =
/// min/max`, and `(a − 1)/(a + 1)` above tan π/8) and the Cephes `atanf`
/// polynomial, scaled to LSB, does the rest. NaN for `(0, 0)`: such sums
/// are flagged and redone in f64.
#[inline(always)]
pub(super) fn atan2_lsb<V: Lanes>(y: V, x: V) -> V {
    const K: f32 = 128.0 / std::f32::consts::PI;
    let k = V::splat;
    let (ax, ay) = (x.abs(), y.abs());
    let (mn, mx) = (ax.min(ay), ax.max(ay));
    let big = mn.gt(mx * k(0.414_213_57));
    let num = V::select(big, mn - mx, mn);
    let den = V::select(big, mn + mx, mx);
    let a = num / den;
    let z = a * a;
    let p = k(8.053_744_5e-2 * K).mul_add(z, k(-1.387_768_6e-1 * K));
    let p = p.mul_add(z, k(1.997_771_1e-1 * K));
    let p = p.mul_add(z, k(-3.333_295e-1 * K));
    let p = p.mul_add(z, k(K));
    let r = a.mul_add(p, V::select(big, k(32.0), k(0.0)));
    let r = V::select(ay.gt(ax), k(64.0) - r, r);
    let r = V::select_negative(x, k(128.0) - r, r);
    r.flip_sign_of(y)
}

/// Quantised angle of every sum into `out` (`round(angle · 256 / 2π) mod
/// 256`), and a flag byte per block: bit `l` set where lane `l`'s `|S|²`
/// is below `thr2` (or NaN). The sums cover `out` in whole blocks.
#[inline(always)]
pub(super) fn angle_rows<V: Lanes>(
    re: &[f32],
    im: &[f32],
    thr2: f32,
    out: &mut [u8],
    flags: &mut [u8],
) {
    let nb = out.len().div_ceil(LANES);
    let (re, im, flags) = (&re[..nb * LANES], &im[..nb * LANES], &mut flags[..nb]);
    write_blocks!(out, |b| {
        let o = b * LANES;
        let (re, im) = (V::load(&re[o..o + LANES]), V::load(&im[o..o + LANES]));
        let m2 = re.mul_add(re, im * im);
        flags[b] = V::bits(m2.not_ge(V::splat(thr2)));
        // Offset by 256 so the value stays positive.
        (atan2_lsb(im, re) + V::splat(TWO_23 + 256.0)).low_bytes()
    })
}

/// Sets `re`, `im` (whole blocks) to `Σ w exp(−j 2π κ r)` over `foci`
/// (`w = 1` unless `W`): one pass over the rows per focus.
#[inline(always)]
pub(super) fn sum_rows<V: Lanes, const W: bool>(
    rows: Rows<'_>,
    foci: &[Prep],
    re: &mut [f32],
    im: &mut [f32],
) {
    let rows = rows.blocks(re.len() / LANES);
    let im = &mut im[..re.len()];
    // Equal weights: Σ (C² − 1) as Σ C² from −m (one FMA per focus).
    let m = foci.len() as f32;
    for (i, p) in foci.iter().enumerate() {
        match (i == 0, p.far) {
            (true, false) => add_focus::<V, W, true, false>(&rows, p, m, re, im),
            (true, true) => add_focus::<V, W, true, true>(&rows, p, m, re, im),
            (false, false) => add_focus::<V, W, false, false>(&rows, p, m, re, im),
            (false, true) => add_focus::<V, W, false, true>(&rows, p, m, re, im),
        }
    }
}

/// Adds focus `p`'s phasors into the sums (`FIRST`: sets them, from `−m`
/// for equal weights, see [`sum_rows`]).
#[inline(always)]
fn add_focus<V: Lanes, const W: bool, const FIRST: bool, const FAR: bool>(
    rows: &Rows<'_>,
    p: &Prep,
    m: f32,
    re: &mut [f32],
    im: &mut [f32],
) {
    for b in 0..re.len() / LANES {
        let o = b * LANES;
        let (x, y, z, pp) = rows.block::<V>(b);
        let (s, c) = half_turn(reduced::<V, FAR>(p, x, y, z, pp));
        let (re, im) = (&mut re[o..o + LANES], &mut im[o..o + LANES]);
        let (r0, i0) = if FIRST {
            (V::splat(if W { 0.0 } else { -m }), V::splat(0.0))
        } else {
            (V::load(re), V::load(im))
        };
        let (r, i) = if W {
            let (cos, sin) = (c.mul_add(c, V::splat(-1.0)), s * c);
            let (wr, wi) = (V::splat(p.wr), V::splat(p.wi));
            // (wr + j wi)(cos − j sin)
            (
                wr.mul_add(cos, wi.mul_add(sin, r0)),
                wi.mul_add(cos, (-wr).mul_add(sin, i0)),
            )
        } else {
            (c.mul_add(c, r0), (-s).mul_add(c, i0))
        };
        r.store(re);
        i.store(im);
    }
}

/// One phasor-table row: `exp(−j 2π κ r)` of point `p` for every padded
/// lane of `rows`.
#[inline(always)]
pub(super) fn phasor_rows<V: Lanes>(rows: Rows<'_>, p: &Prep, re: &mut [f32], im: &mut [f32]) {
    let rows = rows.blocks(re.len() / LANES);
    let im = &mut im[..re.len()];
    for b in 0..re.len() / LANES {
        let o = b * LANES;
        let (x, y, z, pp) = rows.block::<V>(b);
        let (c, s) = phasor(reduced_turns(p, x, y, z, pp));
        c.store(&mut re[o..o + LANES]);
        s.store(&mut im[o..o + LANES]);
    }
}

/// Sets `re`, `im` (whole blocks) to the weighted sum of the table rows
/// `terms` (`w = 1` unless `W`): one pass per row.
#[inline(always)]
pub(super) fn table_rows<V: Lanes, const W: bool>(
    tre: &[f32],
    tim: &[f32],
    terms: &[Term],
    re: &mut [f32],
    im: &mut [f32],
) {
    let n = re.len();
    let im = &mut im[..n];
    for (i, t) in terms.iter().enumerate() {
        let (a, b) = (&tre[t.base..t.base + n], &tim[t.base..t.base + n]);
        let (wr, wi) = (V::splat(t.wr), V::splat(t.wi));
        for o in (0..n).step_by(LANES) {
            let (a, b) = (V::load(&a[o..o + LANES]), V::load(&b[o..o + LANES]));
            let (r0, i0) = if i == 0 {
                (V::splat(0.0), V::splat(0.0))
            } else {
                (V::load(&re[o..o + LANES]), V::load(&im[o..o + LANES]))
            };
            let (r, i) = if W {
                // (wr + j wi)(a + j b)
                (
                    wr.mul_add(a, (-wi).mul_add(b, r0)),
                    wi.mul_add(a, wr.mul_add(b, i0)),
                )
            } else {
                (r0 + a, i0 + b)
            };
            r.store(&mut re[o..o + LANES]);
            i.store(&mut im[o..o + LANES]);
        }
    }
}
