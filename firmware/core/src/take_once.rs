//! Memory a board hands to the core: a `static` lent out once as
//! `&'static mut`, with no `static mut` and no `unsafe` in the board.
//!
//! ```
//! use lm_fw_core::TakeOnce;
//!
//! static STORE: TakeOnce<[u8; 64]> = TakeOnce::new([0; 64]);
//! let store: &'static mut [u8; 64] = STORE.take().unwrap();
//! store[0] = 1;
//! assert!(STORE.take().is_none()); // never a second `&mut`
//! ```

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

/// A value that [`TakeOnce::take`] hands out exactly once, for the rest of
/// the program. Unlike `cortex_m::singleton!`, the value is a `static`'s
/// initialiser, never built on the stack (a store is hundreds of kB).
pub struct TakeOnce<T> {
    value: UnsafeCell<T>,
    taken: AtomicBool,
}

// SAFETY: the value is reached only through the one `&'static mut` that
// `take` hands out (the atomic swap lets exactly one caller through), so
// sharing the cell between threads or interrupts shares no access to `T`;
// moving that access to another thread needs `T: Send`.
unsafe impl<T: Send> Sync for TakeOnce<T> {}

impl<T> TakeOnce<T> {
    /// A cell holding `value`.
    pub const fn new(value: T) -> Self {
        Self {
            value: UnsafeCell::new(value),
            taken: AtomicBool::new(false),
        }
    }

    /// The value, the first time; `None` on every later call.
    // `&self` → `&mut T` is the point: the atomic makes it happen once.
    #[allow(clippy::mut_from_ref)]
    pub fn take(&'static self) -> Option<&'static mut T> {
        if self.taken.swap(true, Ordering::AcqRel) {
            return None;
        }
        // SAFETY: `taken` was false, so no other reference to the value was
        // ever made, and none will be: this one lives for the program.
        Some(unsafe { &mut *self.value.get() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_value_is_taken_once() {
        static CELL: TakeOnce<[u32; 4]> = TakeOnce::new([7; 4]);
        let v = CELL.take().expect("first take");
        assert_eq!(*v, [7; 4]);
        v[1] = 9;
        assert!(CELL.take().is_none());
        assert!(CELL.take().is_none());
        assert_eq!(v[1], 9);
    }
}
