//! Memory a board hands to the core: a `static` lent out once as
//! `&'static mut`, with no `static mut` and no `unsafe` in the board.
//! Boards use [`static_cell::ConstStaticCell`] for this: its value is the
//! `static`'s initialiser, never built on the stack (a store is hundreds
//! of kB, which `cortex_m::singleton!` or `StaticCell::init` would first
//! build there), and `try_take` hands it out exactly once.
//!
//! ```
//! use static_cell::ConstStaticCell;
//!
//! static STORE: ConstStaticCell<[u8; 64]> = ConstStaticCell::new([0; 64]);
//! let store: &'static mut [u8; 64] = STORE.try_take().unwrap();
//! store[0] = 1;
//! assert!(STORE.try_take().is_none()); // never a second `&mut`
//! ```
//!
//! [`TakeOnce`] is that cell under its old name, kept only until the
//! Nucleo board (being rewritten) moves to `ConstStaticCell`; remove it then.

use static_cell::ConstStaticCell;

/// [`ConstStaticCell`] with `take` returning `None` on a second call:
/// the Nucleo board's name for it until it moves to `static_cell`.
pub struct TakeOnce<T>(ConstStaticCell<T>);

impl<T> TakeOnce<T> {
    /// A cell holding `value`.
    pub const fn new(value: T) -> Self {
        Self(ConstStaticCell::new(value))
    }

    /// The value, the first time; `None` on every later call.
    pub fn take(&'static self) -> Option<&'static mut T> {
        self.0.try_take()
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
