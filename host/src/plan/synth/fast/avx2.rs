//! AVX2 + FMA builds of the kernels: the same generic code over [`Avx`]
//! lanes (one ymm register, fused multiply-adds), compiled inside
//! `#[target_feature(enable = "avx2,fma")]` functions.
//!
//! The builds are private; the only way to reach them is [`kernels`],
//! which checks the CPU first. That check is the one safety argument for
//! every `unsafe` below: [`Avx`] is private to this module, and its values
//! and methods are only ever used inside those builds.

use std::arch::x86_64::{
    __m256, _CMP_GT_OQ, _CMP_NGE_UQ, _mm_cvtsi128_si64, _mm256_add_ps, _mm256_and_ps,
    _mm256_andnot_ps, _mm256_blendv_ps, _mm256_castps_si256, _mm256_castsi256_si128, _mm256_cmp_ps,
    _mm256_div_ps, _mm256_fmadd_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_permutevar8x32_epi32, _mm256_set1_ps,
    _mm256_setr_epi8, _mm256_setr_epi32, _mm256_shuffle_epi8, _mm256_sqrt_ps, _mm256_storeu_ps,
    _mm256_sub_ps, _mm256_xor_ps,
};
use std::ops::{Add, Div, Mul, Neg, Sub};

use super::Isa;
use super::kernels::{
    Kernels, Prep, Rows, Term, angle_rows, focus_rows, phasor_rows, sum_rows, table_rows,
};
use super::lanes::{LANES, Lanes, arith_ops, binary_methods};

/// Eight lanes in one AVX register.
#[derive(Clone, Copy, Debug)]
struct Avx(__m256);

/// `$e` (AVX2/FMA intrinsics) in an `unsafe` block.
macro_rules! avx {
    ($e:expr) => {
        // SAFETY: `Avx` is only used inside the `#[target_feature(enable =
        // "avx2,fma")]` builds below, reached only after `kernels` has
        // detected both features.
        unsafe { $e }
    };
}

/// `$op` (an AVX intrinsic of two registers) on two [`Avx`]s.
macro_rules! avx_pair {
    ($a:expr, $b:expr, $op:ident) => {
        Avx(avx!($op($a.0, $b.0)))
    };
}

/// The sign bit of every lane.
#[inline(always)]
fn sign() -> __m256 {
    avx!(_mm256_set1_ps(-0.0))
}

impl Lanes for Avx {
    type Mask = Avx;

    #[inline(always)]
    fn splat(x: f32) -> Self {
        Self(avx!(_mm256_set1_ps(x)))
    }

    #[inline(always)]
    fn load(s: &[f32]) -> Self {
        let s = &s[..LANES];
        // `s` holds eight f32 (checked above); an unaligned load.
        Self(avx!(_mm256_loadu_ps(s.as_ptr())))
    }

    #[inline(always)]
    fn store(self, s: &mut [f32]) {
        let s = &mut s[..LANES];
        // `s` holds eight f32 (checked above); an unaligned store.
        avx!(_mm256_storeu_ps(s.as_mut_ptr(), self.0))
    }

    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        Self(avx!(_mm256_fmadd_ps(self.0, b.0, c.0)))
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        Self(avx!(_mm256_sqrt_ps(self.0)))
    }

    #[inline(always)]
    fn abs(self) -> Self {
        Self(avx!(_mm256_andnot_ps(sign(), self.0)))
    }

    binary_methods!(avx_pair: min => _mm256_min_ps, max => _mm256_max_ps);

    #[inline(always)]
    fn flip_sign_of(self, o: Self) -> Self {
        Self(avx!(_mm256_xor_ps(self.0, _mm256_and_ps(o.0, sign()))))
    }

    #[inline(always)]
    fn gt(self, o: Self) -> Self {
        Self(avx!(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0)))
    }

    #[inline(always)]
    fn not_ge(self, o: Self) -> Self {
        Self(avx!(_mm256_cmp_ps::<_CMP_NGE_UQ>(self.0, o.0)))
    }

    #[inline(always)]
    fn select(m: Self, a: Self, b: Self) -> Self {
        Self(avx!(_mm256_blendv_ps(b.0, a.0, m.0)))
    }

    #[inline(always)]
    fn select_negative(o: Self, a: Self, b: Self) -> Self {
        // `blendv` looks at the sign bit only.
        Self(avx!(_mm256_blendv_ps(b.0, a.0, o.0)))
    }

    #[inline(always)]
    fn bits(m: Self) -> u8 {
        avx!(_mm256_movemask_ps(m.0)) as u8
    }

    #[inline(always)]
    fn low_bytes(self) -> [u8; LANES] {
        avx!({
            // Byte 0 of each dword to the front of its 128-bit half, then
            // the two halves' first dwords together.
            let gather = _mm256_setr_epi8(
                0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, //
                0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,
            );
            let b = _mm256_shuffle_epi8(_mm256_castps_si256(self.0), gather);
            let b = _mm256_permutevar8x32_epi32(b, _mm256_setr_epi32(0, 4, 0, 0, 0, 0, 0, 0));
            (_mm_cvtsi128_si64(_mm256_castsi256_si128(b)) as u64).to_le_bytes()
        })
    }
}

arith_ops!(Avx, avx_pair: _mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps, _mm256_div_ps);

impl Neg for Avx {
    type Output = Avx;
    #[inline(always)]
    fn neg(self) -> Avx {
        Avx(avx!(_mm256_xor_ps(self.0, sign())))
    }
}

/// For each `name => kernel(args)`: a `#[target_feature]` build of the
/// kernel and a safe wrapper with the signature [`Kernels`] stores.
macro_rules! avx2_builds {
    ($($name:ident => $kernel:expr, ($($arg:ident: $ty:ty),*);)*) => {$(
        fn $name($($arg: $ty),*) {
            #[target_feature(enable = "avx2,fma")]
            fn build($($arg: $ty),*) {
                $kernel($($arg),*)
            }
            // SAFETY: `$name` is reachable only through the table that
            // `kernels` returns after detecting AVX2 and FMA.
            unsafe { build($($arg),*) }
        }
    )*};
}

avx2_builds! {
    focus_near => focus_rows::<Avx, false>, (rows: Rows<'_>, p: &Prep, off: f32, out: &mut [u8]);
    focus_far => focus_rows::<Avx, true>, (rows: Rows<'_>, p: &Prep, off: f32, out: &mut [u8]);
    sums_equal => sum_rows::<Avx, false>,
        (rows: Rows<'_>, foci: &[Prep], re: &mut [f32], im: &mut [f32]);
    sums_weighted => sum_rows::<Avx, true>,
        (rows: Rows<'_>, foci: &[Prep], re: &mut [f32], im: &mut [f32]);
    phasors => phasor_rows::<Avx>, (rows: Rows<'_>, p: &Prep, re: &mut [f32], im: &mut [f32]);
    table_equal => table_rows::<Avx, false>,
        (tre: &[f32], tim: &[f32], terms: &[Term], re: &mut [f32], im: &mut [f32]);
    table_weighted => table_rows::<Avx, true>,
        (tre: &[f32], tim: &[f32], terms: &[Term], re: &mut [f32], im: &mut [f32]);
    angles => angle_rows::<Avx>,
        (re: &[f32], im: &[f32], thr2: f32, out: &mut [u8], flags: &mut [u8]);
}

/// The AVX2 + FMA kernel set, if this CPU runs it.
pub(super) fn kernels() -> Option<Kernels> {
    (Isa::detect() == Isa::Avx2Fma).then_some(Kernels {
        isa: Isa::Avx2Fma,
        focus: [focus_near, focus_far],
        sums: [sums_equal, sums_weighted],
        phasors,
        table_sums: [table_equal, table_weighted],
        angles,
    })
}

/// [`super::tests::lanes_accuracy`] on AVX2 + FMA lanes, if this CPU runs
/// them.
#[cfg(test)]
pub(super) fn lanes_accuracy() -> Option<(f64, f64)> {
    #[target_feature(enable = "avx2,fma")]
    fn run() -> (f64, f64) {
        super::tests::lanes_accuracy::<Avx>()
    }
    // SAFETY: `run` is called only once AVX2 and FMA are detected.
    (Isa::detect() == Isa::Avx2Fma).then(|| unsafe { run() })
}
