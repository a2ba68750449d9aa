//! Byte buffers in the AXI SRAM (`.axisram`, see `memory.x`): the stimulus
//! store, which does not fit the DTCM, and the SPI DMA buffers, which DMA1
//! cannot reach in the DTCM.
//!
//! The section is NOLOAD, so the runtime neither copies nor zeroes it; a
//! buffer is zeroed here before anyone reads it. Each static is declared
//! with `#[unsafe(link_section = ".axisram")]` by its owner.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

/// `N` bytes in the AXI SRAM, aligned to the D-cache line (32 bytes) so
/// that cache maintenance on them never reaches a neighbour.
#[repr(C, align(32))]
pub struct AxiBytes<const N: usize>(UnsafeCell<MaybeUninit<[u8; N]>>);

// SAFETY: the bytes are reached only through `take` (one `&'static mut`,
// handed out once under the caller's flag) or through `as_mut_ptr` by an
// owner that orders every access itself (src/output.rs: the thread touches
// a DMA buffer only while the SPI task does not, with acquire/release on
// the hand-over flag). Sharing the static shares no access by itself.
unsafe impl<const N: usize> Sync for AxiBytes<N> {}

impl<const N: usize> AxiBytes<N> {
    /// The (not yet zeroed) memory.
    pub const fn new() -> Self {
        Self(UnsafeCell::new(MaybeUninit::uninit()))
    }

    /// Zeroes the bytes and lends them out for the rest of the program,
    /// the first time `taken` is claimed; `None` after that. `taken` must
    /// belong to this buffer alone (an ordinary static, zeroed by the
    /// runtime).
    // `&self` → `&mut` is the point: the flag makes it happen once.
    #[allow(clippy::mut_from_ref)]
    pub fn take(&'static self, taken: &'static AtomicBool) -> Option<&'static mut [u8; N]> {
        if taken.swap(true, Ordering::AcqRel) {
            return None;
        }
        let slot = self.0.get();
        // SAFETY: `taken` was false and is ours, so no reference to these
        // bytes exists or will exist but the one made here; zeroing through
        // the raw pointer initialises every byte before the reference is
        // formed, and the static lives for the program.
        unsafe {
            (*slot).as_mut_ptr().write_bytes(0, 1);
            Some((*slot).assume_init_mut())
        }
    }

    /// The first byte's address, for an owner that shares the buffer with
    /// DMA under its own protocol (and zeroes it before the first read).
    pub const fn as_mut_ptr(&self) -> *mut u8 {
        self.0.get().cast()
    }
}
