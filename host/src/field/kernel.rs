//! The fast path of [`super::simulate`]: propagation block × drive matrix.
//!
//! For a block of `B` grid points the propagation terms `G[i][j]` (point
//! `i`, transducer `j`, image source folded into the same column) are
//! computed once, in f32 split into real and imaginary arrays; the
//! geometry and the phase in turns are f64 so precision does not depend on
//! distance. The drive matrix `W[s][j] = exp(j 2π u / 256)` comes from the
//! 256-entry table of the quantised phases, so it is exact to f32. Then
//! every pair of points is multiplied against every pair of steps in one
//! pass over `j` (16 accumulators), which keeps both operands in L1/L2 and
//! gives the compiler a branch-free loop to vectorise. Each point's
//! statistics are reduced on the fly; no per-step map is stored.
//!
//! The same portable code is compiled three times: baseline, AVX2+FMA and
//! AVX-512, chosen at run time.

use super::{FieldModel, ObservationPlane, Stats, twiddles};
use crate::directivity::Directivity;

/// Points per block (even).
const BLOCK: usize = 16;
/// Transducer columns are padded to a multiple of this (≥ every lane count).
const PAD: usize = 16;
/// Directivity table segments over |cos θ| ∈ [0, 1].
const DIR_SEGMENTS: usize = 8192;

/// Read-only inputs shared by the worker threads.
struct Shared<'a> {
    plane: &'a ObservationPlane,
    /// Transducers (real, unpadded).
    t: usize,
    /// Padded column count.
    tp: usize,
    steps: usize,
    /// Sources (SoA, f64): direct then image (image empty if none).
    src: [Vec<f64>; 6],
    img: [Vec<f64>; 6],
    wall: Option<([f64; 3], [f64; 3])>,
    /// Drive matrix, steps × tp.
    wr: Vec<f32>,
    wi: Vec<f32>,
    /// Directivity over |cos θ| (DIR_SEGMENTS + 2 entries), None for omni.
    dir: Option<Vec<f32>>,
    p0: f64,
    k_turns_per_mm: f64,
    atten_np_per_mm: f64,
    factor: f64,
    tw: Vec<(f64, f64)>,
}

fn soa(sources: &[super::Source]) -> [Vec<f64>; 6] {
    let mut out: [Vec<f64>; 6] = Default::default();
    for s in sources {
        for a in 0..3 {
            out[a].push(s.pos_mm[a]);
            out[3 + a].push(s.normal[a]);
        }
    }
    out
}

/// Name of the instruction set the fast path uses on this machine.
pub fn isa() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
            return "avx512";
        }
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            return "avx2+fma";
        }
    }
    "baseline"
}

pub(super) fn run(
    model: &FieldModel,
    plane: &ObservationPlane,
    phases: &[u8],
    steps: usize,
    factor: f64,
) -> Vec<Stats> {
    let t = model.transducers();
    let tp = t.div_ceil(PAD) * PAD;
    let table: Vec<(f32, f32)> = (0..256)
        .map(|u| {
            let (s, c) = (2.0 * std::f64::consts::PI * u as f64 / 256.0).sin_cos();
            (c as f32, s as f32)
        })
        .collect();
    let mut wr = vec![0.0f32; steps * tp];
    let mut wi = vec![0.0f32; steps * tp];
    for s in 0..steps {
        for j in 0..t {
            let (c, si) = table[phases[s * t + j] as usize];
            wr[s * tp + j] = c;
            wi[s * tp + j] = si;
        }
    }
    let dir = match model.directivity {
        Directivity::Omni => None,
        d => Some(
            (0..DIR_SEGMENTS + 2)
                .map(|i| {
                    let c = (i as f64 / DIR_SEGMENTS as f64).min(1.0);
                    d.gain(c.acos()) as f32
                })
                .collect(),
        ),
    };
    let sh = Shared {
        plane,
        t,
        tp,
        steps,
        src: soa(&model.direct),
        img: soa(&model.images),
        wall: model.wall,
        wr,
        wi,
        dir,
        p0: model.p0_pa_mm,
        k_turns_per_mm: model.wavenumber_rad_per_mm() / (2.0 * std::f64::consts::PI),
        atten_np_per_mm: model.medium.attenuation_np_per_m * 1e-3,
        factor,
        tw: twiddles(steps),
    };
    let n = plane.nu() * plane.nv();
    let mut stats = vec![Stats::default(); n];
    let blocks = n.div_ceil(BLOCK);
    let threads = std::thread::available_parallelism()
        .map_or(1, |p| p.get())
        .clamp(1, 2)
        .min(blocks);
    if threads <= 1 {
        work(&sh, 0, &mut stats);
    } else {
        // Contiguous halves, cut on a block boundary.
        let cut = blocks.div_ceil(2) * BLOCK;
        let (a, b) = stats.split_at_mut(cut.min(n));
        let sh = &sh;
        std::thread::scope(|scope| {
            scope.spawn(move || work(sh, cut, b));
            work(sh, 0, a);
        });
    }
    stats
}

/// Process points `first .. first + out.len()`.
fn work(sh: &Shared, first: usize, out: &mut [Stats]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the features were detected just above.
            return unsafe { x86::work_avx512(sh, first, out) };
        }
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the features were detected just above.
            return unsafe { x86::work_avx2(sh, first, out) };
        }
    }
    work_generic::<8, false>(sh, first, out)
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Shared, Stats, work_generic};

    #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
    pub(super) unsafe fn work_avx512(sh: &Shared, first: usize, out: &mut [Stats]) {
        work_generic::<16, true>(sh, first, out)
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn work_avx2(sh: &Shared, first: usize, out: &mut [Stats]) {
        work_generic::<8, true>(sh, first, out)
    }
}

/// Per-thread scratch for one block.
struct Scratch {
    gr: Vec<f32>,
    gi: Vec<f32>,
    inv_r: Vec<f32>,
    cosb: Vec<f32>,
    turn: Vec<f32>,
    r: Vec<f64>,
}

#[inline(always)]
fn work_generic<const L: usize, const FMA: bool>(sh: &Shared, first: usize, out: &mut [Stats]) {
    let tp = sh.tp;
    let mut sc = Scratch {
        gr: vec![0.0; BLOCK * tp],
        gi: vec![0.0; BLOCK * tp],
        inv_r: vec![0.0; tp],
        cosb: vec![0.0; tp],
        turn: vec![0.0; tp],
        r: vec![0.0; tp],
    };
    let nu = sh.plane.nu();
    for (bi, chunk) in out.chunks_mut(BLOCK).enumerate() {
        let base = first + bi * BLOCK;
        for row in 0..BLOCK {
            let (gr, gi) = (
                &mut sc.gr[row * tp..(row + 1) * tp],
                &mut sc.gi[row * tp..(row + 1) * tp],
            );
            gr.fill(0.0);
            gi.fill(0.0);
            if row >= chunk.len() {
                continue;
            }
            let idx = base + row;
            let p = sh.plane.point(idx % nu, idx / nu);
            if let Some((w, n)) = sh.wall {
                let h = (p[0] - w[0]) * n[0] + (p[1] - w[1]) * n[1] + (p[2] - w[2]) * n[2];
                if h < 0.0 {
                    continue;
                }
            }
            add_sources(
                sh,
                &sh.src,
                p,
                &mut sc.r,
                &mut sc.inv_r,
                &mut sc.cosb,
                &mut sc.turn,
                gr,
                gi,
            );
            if !sh.img[0].is_empty() {
                add_sources(
                    sh,
                    &sh.img,
                    p,
                    &mut sc.r,
                    &mut sc.inv_r,
                    &mut sc.cosb,
                    &mut sc.turn,
                    gr,
                    gi,
                );
            }
        }
        gemm_stats::<L, FMA>(sh, &sc.gr, &sc.gi, chunk);
    }
}

/// Add one set of sources' propagation terms at point `p` into `gr`, `gi`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn add_sources(
    sh: &Shared,
    s: &[Vec<f64>; 6],
    p: [f64; 3],
    rbuf: &mut [f64],
    inv_r: &mut [f32],
    cosb: &mut [f32],
    turn: &mut [f32],
    gr: &mut [f32],
    gi: &mut [f32],
) {
    let t = sh.t;
    let k = sh.k_turns_per_mm;
    // Geometry in f64 (vectorisable): distance, |cos θ|, phase in turns.
    for j in 0..t {
        let dx = p[0] - s[0][j];
        let dy = p[1] - s[1][j];
        let dz = p[2] - s[2][j];
        let r2 = dx * dx + dy * dy + dz * dz;
        let r = r2.sqrt();
        let ok = r2 > 0.0;
        let inv = if ok { 1.0 / r } else { 0.0 };
        let c = (s[3][j] * dx + s[4][j] * dy + s[5][j] * dz) * inv;
        let tr = r * k;
        rbuf[j] = r;
        inv_r[j] = inv as f32;
        cosb[j] = c.abs().min(1.0) as f32;
        turn[j] = (tr - tr.round()) as f32;
    }
    // Amplitude: P0 / r · D(θ) · exp(−α r).
    let p0 = sh.p0 as f32;
    if let Some(table) = &sh.dir {
        for j in 0..t {
            let x = cosb[j] * DIR_SEGMENTS as f32;
            let i = (x as usize).min(DIR_SEGMENTS);
            let f = x - i as f32;
            let d = table[i] + f * (table[i + 1] - table[i]);
            inv_r[j] *= p0 * d;
        }
    } else {
        for v in inv_r[..t].iter_mut() {
            *v *= p0;
        }
    }
    if sh.atten_np_per_mm > 0.0 {
        for j in 0..t {
            inv_r[j] *= (-sh.atten_np_per_mm * rbuf[j]).exp() as f32;
        }
    }
    // exp(j 2π turn) from sin/cos of π·turn ∈ [−π/2, π/2] and the double
    // angle: branch-free polynomials, error ~2e-7.
    for j in 0..t {
        let x = std::f32::consts::PI * turn[j];
        let x2 = x * x;
        let s = x
            * (1.0
                + x2 * (-1.0 / 6.0
                    + x2 * (1.0 / 120.0
                        + x2 * (-1.0 / 5040.0
                            + x2 * (1.0 / 362_880.0 + x2 * (-1.0 / 39_916_800.0))))));
        let c = 1.0
            + x2 * (-0.5
                + x2 * (1.0 / 24.0
                    + x2 * (-1.0 / 720.0
                        + x2 * (1.0 / 40_320.0
                            + x2 * (-1.0 / 3_628_800.0 + x2 * (1.0 / 479_001_600.0))))));
        let a = inv_r[j];
        gr[j] += a * (c * c - s * s);
        gi[j] += a * (2.0 * s * c);
    }
}

#[inline(always)]
fn fma<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA { a.mul_add(b, c) } else { a * b + c }
}

/// Four complex dot products: rows (a, b) × steps (x, y), over all columns.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn dot2x2<const L: usize, const FMA: bool>(
    ar: &[f32],
    ai: &[f32],
    br: &[f32],
    bi: &[f32],
    xr: &[f32],
    xi: &[f32],
    yr: &[f32],
    yi: &[f32],
) -> [(f32, f32); 4] {
    let mut acc = [[0.0f32; L]; 16];
    let it = ar
        .chunks_exact(L)
        .zip(ai.chunks_exact(L))
        .zip(br.chunks_exact(L).zip(bi.chunks_exact(L)))
        .zip(xr.chunks_exact(L).zip(xi.chunks_exact(L)))
        .zip(yr.chunks_exact(L).zip(yi.chunks_exact(L)));
    for ((((ar, ai), (br, bi)), (xr, xi)), (yr, yi)) in it {
        for l in 0..L {
            let (a_r, a_i, b_r, b_i) = (ar[l], ai[l], br[l], bi[l]);
            let (x_r, x_i, y_r, y_i) = (xr[l], xi[l], yr[l], yi[l]);
            acc[0][l] = fma::<FMA>(a_r, x_r, acc[0][l]);
            acc[1][l] = fma::<FMA>(a_i, x_i, acc[1][l]);
            acc[2][l] = fma::<FMA>(a_r, x_i, acc[2][l]);
            acc[3][l] = fma::<FMA>(a_i, x_r, acc[3][l]);
            acc[4][l] = fma::<FMA>(a_r, y_r, acc[4][l]);
            acc[5][l] = fma::<FMA>(a_i, y_i, acc[5][l]);
            acc[6][l] = fma::<FMA>(a_r, y_i, acc[6][l]);
            acc[7][l] = fma::<FMA>(a_i, y_r, acc[7][l]);
            acc[8][l] = fma::<FMA>(b_r, x_r, acc[8][l]);
            acc[9][l] = fma::<FMA>(b_i, x_i, acc[9][l]);
            acc[10][l] = fma::<FMA>(b_r, x_i, acc[10][l]);
            acc[11][l] = fma::<FMA>(b_i, x_r, acc[11][l]);
            acc[12][l] = fma::<FMA>(b_r, y_r, acc[12][l]);
            acc[13][l] = fma::<FMA>(b_i, y_i, acc[13][l]);
            acc[14][l] = fma::<FMA>(b_r, y_i, acc[14][l]);
            acc[15][l] = fma::<FMA>(b_i, y_r, acc[15][l]);
        }
    }
    let sum = |v: &[f32; L]| v.iter().sum::<f32>();
    let mut out = [(0.0, 0.0); 4];
    for (q, o) in out.iter_mut().enumerate() {
        let a = &acc[4 * q..4 * q + 4];
        *o = (sum(&a[0]) - sum(&a[1]), sum(&a[2]) + sum(&a[3]));
    }
    out
}

/// Multiply a block's propagation rows by every step's drives and fold the
/// radiation pressures into the points' statistics.
#[inline(always)]
fn row(m: &[f32], i: usize, tp: usize) -> &[f32] {
    &m[i * tp..(i + 1) * tp]
}

#[inline(always)]
fn gemm_stats<const L: usize, const FMA: bool>(
    sh: &Shared,
    gr: &[f32],
    gi: &[f32],
    out: &mut [Stats],
) {
    let tp = sh.tp;
    let steps = sh.steps;
    for r0 in (0..out.len()).step_by(2) {
        let r1 = r0 + 1; // < BLOCK; a missing last row is zero-filled
        let (ar, ai, br, bi) = (
            row(gr, r0, tp),
            row(gi, r0, tp),
            row(gr, r1, tp),
            row(gi, r1, tp),
        );
        for s0 in (0..steps).step_by(2) {
            let s1 = (s0 + 1).min(steps - 1);
            let p = dot2x2::<L, FMA>(
                ar,
                ai,
                br,
                bi,
                row(&sh.wr, s0, tp),
                row(&sh.wi, s0, tp),
                row(&sh.wr, s1, tp),
                row(&sh.wi, s1, tp),
            );
            let pts = [
                (r0, s0, p[0]),
                (r0, s1, p[1]),
                (r1, s0, p[2]),
                (r1, s1, p[3]),
            ];
            for (k, &(r, s, (re, im))) in pts.iter().enumerate() {
                // An odd step count repeats the last step in the second slot.
                if r >= out.len() || (s1 == s0 && k % 2 == 1) {
                    continue;
                }
                let a2 = re as f64 * re as f64 + im as f64 * im as f64;
                let prad = sh.factor * a2;
                let st = &mut out[r];
                if s == 0 {
                    st.amp0 = a2.sqrt();
                    st.p0 = prad;
                }
                st.sum += prad;
                st.max = st.max.max(prad);
                st.x1_re += prad * sh.tw[s].0;
                st.x1_im += prad * sh.tw[s].1;
            }
        }
    }
}
