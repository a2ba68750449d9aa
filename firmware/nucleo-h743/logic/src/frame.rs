//! One output frame in the SPI DMA buffer: the same bytes the core's
//! `SpiOutput` sends (`lm_fw_core::output::spi_header`, then one phase byte
//! per transducer; `firmware/DRIVER.md`, "Frame"), packed into memory the
//! DMA can read, whole D-cache lines at a time.

use lm_fw_core::MAX_TRANSDUCERS;
use lm_fw_core::output::{OutputFrame, SPI_HEADER_LEN, spi_header};

/// The Cortex-M7 D-cache line, bytes: buffers that DMA reads or writes are
/// aligned to it and a whole number of it long, so that cleaning or
/// invalidating them never touches a neighbour (Cortex-M7 TRM, "L1 caches").
pub const CACHE_LINE: usize = 32;

/// The frame buffer: the largest frame (header and
/// `lm_fw_core::MAX_TRANSDUCERS` phases) in whole cache lines.
pub const FRAME_BUFFER_BYTES: usize =
    (SPI_HEADER_LEN + MAX_TRANSDUCERS).div_ceil(CACHE_LINE) * CACHE_LINE;

const _: () = assert!(FRAME_BUFFER_BYTES.is_multiple_of(CACHE_LINE));
const _: () = assert!(FRAME_BUFFER_BYTES >= crate::selftest::CHUNK);

/// Writes `frame` into `buf` as one SPI transaction's bytes; returns their
/// number, or `None` (and leaves `buf` alone) if they do not fit.
pub fn pack(buf: &mut [u8], frame: &OutputFrame<'_>) -> Option<usize> {
    let len = SPI_HEADER_LEN.checked_add(frame.phases.len())?;
    let out = buf.get_mut(..len)?;
    let (head, phases) = out.split_at_mut(SPI_HEADER_LEN);
    head.copy_from_slice(&spi_header(frame));
    phases.copy_from_slice(frame.phases);
    Some(len)
}

/// `len` rounded up to whole cache lines: the bytes to clean before the
/// DMA reads the first `len`.
pub const fn whole_lines(len: usize) -> usize {
    len.div_ceil(CACHE_LINE) * CACHE_LINE
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn frame(phases: &[u8]) -> OutputFrame<'_> {
        OutputFrame {
            due: 9,
            slot: 3,
            step: 0x0201,
            amplitude: 200,
            intensity: 128,
            phases,
        }
    }

    #[test]
    fn packs_the_bytes_spi_output_sends() {
        let phases: Vec<u8> = (0..996u32).map(|i| (i * 7) as u8).collect();
        let mut buf = [0xEEu8; FRAME_BUFFER_BYTES];
        let n = pack(&mut buf, &frame(&phases)).unwrap();
        assert_eq!(n, 7 + 996);
        assert_eq!(&buf[..7], &[0xA5, 200, 128, 0x01, 0x02, 0xE4, 0x03]);
        assert_eq!(&buf[7..n], &phases[..]);
        assert_eq!(buf[n], 0xEE, "nothing past the frame");
    }

    #[test]
    fn the_largest_frame_fits_and_a_larger_one_is_refused() {
        let max = [1u8; MAX_TRANSDUCERS];
        let mut buf = [0u8; FRAME_BUFFER_BYTES];
        assert_eq!(
            pack(&mut buf, &frame(&max)),
            Some(SPI_HEADER_LEN + MAX_TRANSDUCERS)
        );
        let mut small = [0x55u8; 16];
        assert_eq!(pack(&mut small, &frame(&[0; 10])), None);
        assert_eq!(small, [0x55; 16], "untouched when it does not fit");
        assert_eq!(FRAME_BUFFER_BYTES, 1056);
    }

    #[test]
    fn whole_lines_round_up() {
        assert_eq!(whole_lines(0), 0);
        assert_eq!(whole_lines(1), 32);
        assert_eq!(whole_lines(32), 32);
        assert_eq!(whole_lines(1003), 1024);
    }
}
