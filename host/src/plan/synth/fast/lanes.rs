//! Eight f32 lanes: the [`Lanes`] operations the kernels are written in,
//! and the plain-array build of them. The kernels are generic over
//! `Lanes`, so each instruction set brings one small implementation of
//! these operations (AVX2 + FMA in [`super::avx2`], SSE2 in
//! [`super::sse2`], [`Arr`] anywhere) and the kernel code itself is
//! written once. A kernel keeps a block of eight transducers in registers
//! across its loop over foci, which a compiler's loop vectoriser alone
//! does not do.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Lanes per block.
pub(super) const LANES: usize = 8;

/// Eight f32 lanes and the operations the kernels use. Every method is a
/// lane-wise operation.
pub(super) trait Lanes:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A lane condition per lane (a comparison's result).
    type Mask: Copy;

    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// The first eight values of `s`.
    fn load(s: &[f32]) -> Self;
    /// Writes the lanes to the first eight values of `s`.
    fn store(self, s: &mut [f32]);
    /// The lanes as an array (for the tests).
    #[cfg_attr(not(test), allow(dead_code))]
    #[inline(always)]
    fn to_array(self) -> [f32; LANES] {
        let mut a = [0.0; LANES];
        self.store(&mut a);
        a
    }
    /// `self · b + c`, fused where the instruction set has FMA.
    fn mul_add(self, b: Self, c: Self) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Minimum (of non-NaN lanes).
    fn min(self, o: Self) -> Self;
    /// Maximum (of non-NaN lanes).
    fn max(self, o: Self) -> Self;
    /// `self` with its sign flipped where `o`'s sign bit is set (`−0` too).
    fn flip_sign_of(self, o: Self) -> Self;
    /// `self > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// `!(self >= o)`: below `o`, or NaN.
    fn not_ge(self, o: Self) -> Self::Mask;
    /// `a` where `m`, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `a` where `o`'s sign bit is set (`−0` too), else `b`.
    fn select_negative(o: Self, a: Self, b: Self) -> Self;
    /// Bit `l` set where lane `l` of `m` is.
    fn bits(m: Self::Mask) -> u8;
    /// The low byte of each lane's bit pattern: `round(x − 2²³) mod 256`
    /// for a lane in `[2²³, 2²⁴)`.
    fn low_bytes(self) -> [u8; LANES];
}

/// Eight lanes as a plain array: the portable build on targets without a
/// SIMD implementation here (and a check of the others in the tests).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
pub(super) struct Arr(pub(super) [f32; LANES]);

#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
impl Arr {
    #[inline(always)]
    fn map(self, f: impl Fn(f32) -> f32) -> Self {
        Self(std::array::from_fn(|l| f(self.0[l])))
    }

    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        Self(std::array::from_fn(|l| f(self.0[l], o.0[l])))
    }

    #[inline(always)]
    fn test(self, o: Self, f: impl Fn(f32, f32) -> bool) -> [bool; LANES] {
        std::array::from_fn(|l| f(self.0[l], o.0[l]))
    }
}

impl Lanes for Arr {
    type Mask = [bool; LANES];

    #[inline(always)]
    fn splat(x: f32) -> Self {
        Self([x; LANES])
    }

    #[inline(always)]
    fn load(s: &[f32]) -> Self {
        let mut v = [0.0; LANES];
        v.copy_from_slice(&s[..LANES]);
        Self(v)
    }

    #[inline(always)]
    fn store(self, s: &mut [f32]) {
        s[..LANES].copy_from_slice(&self.0);
    }

    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l] * b.0[l] + c.0[l]))
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f32::sqrt)
    }

    #[inline(always)]
    fn abs(self) -> Self {
        self.map(f32::abs)
    }

    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.zip(o, f32::min)
    }

    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, f32::max)
    }

    #[inline(always)]
    fn flip_sign_of(self, o: Self) -> Self {
        self.zip(o, |a, b| {
            f32::from_bits(a.to_bits() ^ (b.to_bits() & 0x8000_0000))
        })
    }

    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        self.test(o, |a, b| a > b)
    }

    #[inline(always)]
    fn not_ge(self, o: Self) -> Self::Mask {
        // NaN compares as neither: `partial_cmp` gives `None`.
        self.test(o, |a, b| a.partial_cmp(&b).is_none_or(|c| c.is_lt()))
    }

    #[inline(always)]
    fn select(m: Self::Mask, a: Self, b: Self) -> Self {
        Self(std::array::from_fn(|l| if m[l] { a.0[l] } else { b.0[l] }))
    }

    #[inline(always)]
    fn select_negative(o: Self, a: Self, b: Self) -> Self {
        Self(std::array::from_fn(|l| {
            if o.0[l].is_sign_negative() {
                a.0[l]
            } else {
                b.0[l]
            }
        }))
    }

    #[inline(always)]
    fn bits(m: Self::Mask) -> u8 {
        (0..LANES).fold(0, |acc, l| acc | u8::from(m[l]) << l)
    }

    #[inline(always)]
    fn low_bytes(self) -> [u8; LANES] {
        std::array::from_fn(|l| self.0[l].to_bits() as u8)
    }
}

/// Lane-wise binary methods for a lane type's `impl` blocks, `fn f(self,
/// o: Self) -> Self` for each `f => op`: the body is `$pair!(self, o, op)`,
/// where the type's own `$pair` macro applies one operation (an
/// operator, an intrinsic) to every lane. Every method is
/// `#[inline(always)]`, as the hand-written ones are.
macro_rules! binary_methods {
    ($pair:ident: $($f:ident => $op:tt),* $(,)?) => {$(
        #[inline(always)]
        fn $f(self, o: Self) -> Self {
            $pair!(self, o, $op)
        }
    )*};
}

/// `Add`, `Sub`, `Mul` and `Div` for lane type `$t`: each its operation
/// through [`binary_methods`] with the type's `$pair` macro.
macro_rules! arith_ops {
    ($t:ident, $pair:ident: $add:tt, $sub:tt, $mul:tt, $div:tt) => {
        arith_ops!(@each $t, $pair: Add add $add, Sub sub $sub, Mul mul $mul, Div div $div);
    };
    (@each $t:ident, $pair:ident: $($tr:ident $f:ident $op:tt),*) => {$(
        impl $tr for $t {
            type Output = $t;
            binary_methods!($pair: $f => $op);
        }
    )*};
}

pub(super) use {arith_ops, binary_methods};

/// `$a $op $b` in every lane of [`Arr`]s.
macro_rules! arr_zip {
    ($a:expr, $b:expr, $op:tt) => {
        $a.zip($b, |x, y| x $op y)
    };
}

arith_ops!(Arr, arr_zip: +, -, *, /);

impl Neg for Arr {
    type Output = Arr;
    #[inline(always)]
    fn neg(self) -> Arr {
        self.map(|x| -x)
    }
}
