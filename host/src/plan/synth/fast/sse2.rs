//! [`Lanes`] in SSE2, the x86-64 baseline: the portable build's eight
//! lanes are two xmm registers.

use std::arch::x86_64::{
    __m128, __m128i, _mm_add_ps, _mm_and_ps, _mm_and_si128, _mm_andnot_ps, _mm_castps_si128,
    _mm_castsi128_ps, _mm_cmpgt_ps, _mm_cmpnge_ps, _mm_cvtsi128_si64, _mm_div_ps, _mm_loadu_ps,
    _mm_max_ps, _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_or_ps, _mm_packs_epi32,
    _mm_packus_epi16, _mm_set1_epi32, _mm_set1_ps, _mm_sqrt_ps, _mm_srai_epi32, _mm_storeu_ps,
    _mm_sub_ps, _mm_xor_ps,
};
use std::ops::{Add, Div, Mul, Neg, Sub};

use super::lanes::{LANES, Lanes, arith_ops, binary_methods};

/// `$e` (SSE/SSE2 intrinsics) in an `unsafe` block.
macro_rules! sse {
    ($e:expr) => {
        // SAFETY: SSE and SSE2 are part of every x86-64 target (the
        // baseline this module is compiled for), so they are always there.
        unsafe { $e }
    };
}

/// `$op` (an SSE intrinsic of two registers) on both registers of two
/// [`Sse`]s.
macro_rules! sse_each {
    ($a:expr, $b:expr, $op:ident) => {
        $a.each($b, |a, b| sse!($op(a, b)))
    };
}

/// Eight lanes in two SSE registers.
#[derive(Clone, Copy, Debug)]
pub(super) struct Sse([__m128; 2]);

impl Sse {
    #[inline(always)]
    fn each(self, o: Self, f: impl Fn(__m128, __m128) -> __m128) -> Self {
        Self([f(self.0[0], o.0[0]), f(self.0[1], o.0[1])])
    }
}

/// The sign bit of every lane.
#[inline(always)]
fn sign() -> __m128 {
    sse!(_mm_set1_ps(-0.0))
}

impl Lanes for Sse {
    type Mask = Sse;

    #[inline(always)]
    fn splat(x: f32) -> Self {
        let v = sse!(_mm_set1_ps(x));
        Self([v, v])
    }

    #[inline(always)]
    fn load(s: &[f32]) -> Self {
        let s = &s[..LANES];
        // `s` holds eight f32 (checked above); unaligned loads.
        sse!(Self([
            _mm_loadu_ps(s.as_ptr()),
            _mm_loadu_ps(s[4..].as_ptr())
        ]))
    }

    #[inline(always)]
    fn store(self, s: &mut [f32]) {
        let s = &mut s[..LANES];
        // `s` holds eight f32 (checked above); unaligned stores.
        sse!({
            _mm_storeu_ps(s.as_mut_ptr(), self.0[0]);
            _mm_storeu_ps(s[4..].as_mut_ptr(), self.0[1]);
        })
    }

    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        self * b + c
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        sse!(Self([_mm_sqrt_ps(self.0[0]), _mm_sqrt_ps(self.0[1])]))
    }

    #[inline(always)]
    fn abs(self) -> Self {
        sse!(Self([
            _mm_andnot_ps(sign(), self.0[0]),
            _mm_andnot_ps(sign(), self.0[1])
        ]))
    }

    binary_methods! {
        sse_each:
        min => _mm_min_ps,
        max => _mm_max_ps,
        gt => _mm_cmpgt_ps,
        not_ge => _mm_cmpnge_ps,
    }

    #[inline(always)]
    fn flip_sign_of(self, o: Self) -> Self {
        self.each(o, |a, b| sse!(_mm_xor_ps(a, _mm_and_ps(b, sign()))))
    }

    #[inline(always)]
    fn select(m: Self, a: Self, b: Self) -> Self {
        let pick = |m, a, b| sse!(_mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)));
        Self([pick(m.0[0], a.0[0], b.0[0]), pick(m.0[1], a.0[1], b.0[1])])
    }

    #[inline(always)]
    fn select_negative(o: Self, a: Self, b: Self) -> Self {
        let mask = |v| sse!(_mm_castsi128_ps(_mm_srai_epi32::<31>(_mm_castps_si128(v))));
        Self::select(Self([mask(o.0[0]), mask(o.0[1])]), a, b)
    }

    #[inline(always)]
    fn bits(m: Self) -> u8 {
        sse!(_mm_movemask_ps(m.0[0]) | (_mm_movemask_ps(m.0[1]) << 4)) as u8
    }

    #[inline(always)]
    fn low_bytes(self) -> [u8; LANES] {
        sse!({
            let byte = _mm_set1_epi32(0xff);
            let lo: __m128i = _mm_and_si128(_mm_castps_si128(self.0[0]), byte);
            let hi: __m128i = _mm_and_si128(_mm_castps_si128(self.0[1]), byte);
            let words = _mm_packs_epi32(lo, hi);
            _mm_cvtsi128_si64(_mm_packus_epi16(words, words)) as u64
        })
        .to_le_bytes()
    }
}

arith_ops!(Sse, sse_each: _mm_add_ps, _mm_sub_ps, _mm_mul_ps, _mm_div_ps);

impl Neg for Sse {
    type Output = Sse;
    #[inline(always)]
    fn neg(self) -> Sse {
        sse!(Self([
            _mm_xor_ps(self.0[0], sign()),
            _mm_xor_ps(self.0[1], sign())
        ]))
    }
}
