//! AVX2 + FMA builds of the kernels: the same generic code, compiled with
//! those target features so it uses 8 lanes and fused multiply-adds.
//!
//! The builds are private; the only way to reach them is [`kernels`],
//! which checks the CPU first. That check is the one safety argument for
//! every `unsafe` call below.

use super::Isa;
use super::kernels::{Kernels, Prep, Rows, accumulate_rows, angles_rows, combine_rows, focus_rows};

/// For each `name => kernel(args)`: a `#[target_feature]` build of the
/// kernel and a safe wrapper with the signature [`Kernels`] stores.
macro_rules! avx2_builds {
    ($($name:ident => $kernel:expr, ($($arg:ident: $ty:ty),*);)*) => {$(
        fn $name($($arg: $ty),*) {
            #[target_feature(enable = "avx2,fma")]
            unsafe fn build($($arg: $ty),*) {
                $kernel($($arg),*)
            }
            // SAFETY: `$name` is reachable only through the table that
            // `kernels` returns after detecting AVX2 and FMA.
            unsafe { build($($arg),*) }
        }
    )*};
}

avx2_builds! {
    focus_near => focus_rows::<false, true>, (rows: Rows<'_>, p: &Prep, off: f32, out: &mut [u8]);
    focus_far => focus_rows::<true, true>, (rows: Rows<'_>, p: &Prep, off: f32, out: &mut [u8]);
    accumulate_near => accumulate_rows::<false, true>,
        (rows: Rows<'_>, p: &Prep, wr: f32, wi: f32, re: &mut [f32], im: &mut [f32]);
    accumulate_far => accumulate_rows::<true, true>,
        (rows: Rows<'_>, p: &Prep, wr: f32, wi: f32, re: &mut [f32], im: &mut [f32]);
    combine => combine_rows::<true>,
        (tr: &[f32], ti: &[f32], wr: f32, wi: f32, re: &mut [f32], im: &mut [f32]);
    angles => angles_rows::<true>, (re: &[f32], im: &[f32], out: &mut [u8]);
}

/// The AVX2 + FMA kernel set, if this CPU runs it.
pub(super) fn kernels() -> Option<Kernels> {
    (Isa::detect() == Isa::Avx2Fma).then_some(Kernels {
        isa: Isa::Avx2Fma,
        focus: [focus_near, focus_far],
        accumulate: [accumulate_near, accumulate_far],
        combine,
        angles,
    })
}
