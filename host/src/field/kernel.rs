//! The fast path of [`super::simulate`]: propagation block × drive matrix.
//!
//! For a block of `B` grid points the propagation terms `G[i][j]` (point
//! `i`, transducer `j`, image source folded into the same column) are
//! computed once, in f32 split into real and imaginary arrays; the
//! geometry and the phase in turns are f64 so precision does not depend on
//! distance. The drive matrix `W[s][j] = exp(j 2π u / 256)` comes from the
//! 256-entry table of the quantised phases, so it is exact to f32. Then
//! every 4 points are multiplied against every pair of steps in one
//! pass over `j` (16 accumulators), which keeps both operands in L1/L2 and
//! gives the compiler a branch-free loop to vectorise. Each point's
//! statistics are reduced on the fly; no per-step map is stored.
//!
//! The same portable code is compiled three times: baseline, AVX2+FMA and
//! AVX-512, chosen at run time.

use super::model::Source;
use super::stats::{Stats, twiddles};
use super::{FieldModel, ObservationPlane};
use crate::plan::directivity::Directivity;

/// Points per block (a multiple of [`TILE_ROWS`]).
const BLOCK: usize = 16;
/// Transducer columns are padded to a multiple of this (≥ every lane count).
const PAD: usize = 16;
/// Directivity table segments over cos θ ∈ [0, 1] (0 behind the face).
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
    /// Directivity over cos θ ∈ [0, 1] (DIR_SEGMENTS + 2 entries), None
    /// for omni; behind the face (cos θ < 0) it is 0.
    dir: Option<Vec<f32>>,
    p0: f64,
    k_turns_per_mm: f64,
    atten_np_per_mm: f64,
    factor: f64,
    tw: Vec<(f64, f64)>,
}

fn soa(sources: &[Source]) -> [Vec<f64>; 6] {
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
            // The array, then its mirror image when there is a reflector.
            let images = (!sh.img[0].is_empty()).then_some(&sh.img);
            for src in std::iter::once(&sh.src).chain(images) {
                add_sources(
                    sh,
                    src,
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
    // Geometry in f64 (vectorisable): distance, cos θ, phase in turns.
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
        cosb[j] = c.min(1.0) as f32;
        turn[j] = (tr - tr.round()) as f32;
    }
    // Amplitude: P0 / r · D(θ) · exp(−α r).
    let p0 = sh.p0 as f32;
    if let Some(table) = &sh.dir {
        for j in 0..t {
            // Behind the face (cos θ < 0): no sound, as Directivity::gain.
            let behind = cosb[j] < 0.0;
            let x = cosb[j].max(0.0) * DIR_SEGMENTS as f32;
            let i = (x as usize).min(DIR_SEGMENTS);
            let f = x - i as f32;
            let d = table[i] + f * (table[i + 1] - table[i]);
            let d = if behind { 0.0 } else { d };
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

/// Rows of the register tile (points per pass over the columns).
const TILE_ROWS: usize = 4;

/// Eight complex dot products: 4 rows × 2 steps, over all columns.
///
/// `g` holds the rows' (re, im) slices, `w` the steps'. Each product keeps
/// two accumulators of `L` lanes (re gets `ar·xr − ai·xi`, im gets
/// `ar·xi + ai·xr`): 16 accumulators, 12 loads and 32 FMAs per chunk, which
/// fits AVX-512's 32 registers without spilling.
#[inline(always)]
fn dot4x2<const L: usize, const FMA: bool>(
    g: [(&[f32], &[f32]); TILE_ROWS],
    w: [(&[f32], &[f32]); 2],
) -> [[(f32, f32); 2]; TILE_ROWS] {
    let z = [0.0f32; L];
    let (mut r00, mut i00, mut r01, mut i01) = (z, z, z, z);
    let (mut r10, mut i10, mut r11, mut i11) = (z, z, z, z);
    let (mut r20, mut i20, mut r21, mut i21) = (z, z, z, z);
    let (mut r30, mut i30, mut r31, mut i31) = (z, z, z, z);
    let n = w[0].0.len() / L;
    let lanes = |v: &[f32], o: usize| -> [f32; L] {
        let mut a = [0.0; L];
        a.copy_from_slice(&v[o..o + L]);
        a
    };
    for c in 0..n {
        let o = c * L;
        let (xr, xi, yr, yi) = (
            lanes(w[0].0, o),
            lanes(w[0].1, o),
            lanes(w[1].0, o),
            lanes(w[1].1, o),
        );
        macro_rules! row {
            ($k:expr, $rx:ident, $ix:ident, $ry:ident, $iy:ident) => {{
                let ar = lanes(g[$k].0, o);
                let ai = lanes(g[$k].1, o);
                for l in 0..L {
                    $rx[l] = fma::<FMA>(ar[l], xr[l], $rx[l]);
                    $rx[l] = fma::<FMA>(-ai[l], xi[l], $rx[l]);
                    $ix[l] = fma::<FMA>(ar[l], xi[l], $ix[l]);
                    $ix[l] = fma::<FMA>(ai[l], xr[l], $ix[l]);
                    $ry[l] = fma::<FMA>(ar[l], yr[l], $ry[l]);
                    $ry[l] = fma::<FMA>(-ai[l], yi[l], $ry[l]);
                    $iy[l] = fma::<FMA>(ar[l], yi[l], $iy[l]);
                    $iy[l] = fma::<FMA>(ai[l], yr[l], $iy[l]);
                }
            }};
        }
        row!(0, r00, i00, r01, i01);
        row!(1, r10, i10, r11, i11);
        row!(2, r20, i20, r21, i21);
        row!(3, r30, i30, r31, i31);
    }
    let sum = |v: [f32; L]| v.iter().sum::<f32>();
    [
        [(sum(r00), sum(i00)), (sum(r01), sum(i01))],
        [(sum(r10), sum(i10)), (sum(r11), sum(i11))],
        [(sum(r20), sum(i20)), (sum(r21), sum(i21))],
        [(sum(r30), sum(i30)), (sum(r31), sum(i31))],
    ]
}

#[inline(always)]
fn row(m: &[f32], i: usize, tp: usize) -> &[f32] {
    &m[i * tp..(i + 1) * tp]
}

/// Multiply a block's propagation rows by every step's drives and fold the
/// radiation pressures into the points' statistics.
#[inline(always)]
fn gemm_stats<const L: usize, const FMA: bool>(
    sh: &Shared,
    gr: &[f32],
    gi: &[f32],
    out: &mut [Stats],
) {
    let tp = sh.tp;
    let steps = sh.steps;
    // BLOCK is a multiple of TILE_ROWS; rows past `out` are zero-filled.
    for r0 in (0..out.len()).step_by(TILE_ROWS) {
        let g = std::array::from_fn(|k| (row(gr, r0 + k, tp), row(gi, r0 + k, tp)));
        for s0 in (0..steps).step_by(2) {
            // An odd step count repeats the last step in the second slot.
            let s1 = (s0 + 1).min(steps - 1);
            let w = [
                (row(&sh.wr, s0, tp), row(&sh.wi, s0, tp)),
                (row(&sh.wr, s1, tp), row(&sh.wi, s1, tp)),
            ];
            let p = dot4x2::<L, FMA>(g, w);
            for (k, pk) in p.iter().enumerate() {
                let Some(st) = out.get_mut(r0 + k) else { break };
                for (q, &(re, im)) in pk.iter().enumerate() {
                    let s = if q == 0 { s0 } else { s1 };
                    if q == 1 && s1 == s0 {
                        continue;
                    }
                    let a2 = re as f64 * re as f64 + im as f64 * im as f64;
                    let prad = sh.factor * a2;
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
}
