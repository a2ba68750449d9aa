//! Output towards the transducer driver: one frame per step, and the
//! output's self-test (an SPI loopback on the boards that have one).

use embedded_hal::spi::{Operation, SpiDevice};
use lm_proto::SelfTest;

/// One output frame: the phases of every transducer for one step (centroid
/// correction already applied), the amplitude (the gate: 0 = muted) and
/// the entry's intensity. The driver's duty is amplitude × intensity / 255².
#[derive(Debug, Clone, Copy)]
pub struct OutputFrame<'a> {
    /// Timer count at which the step was due.
    pub due: u64,
    /// Slot the step comes from.
    pub slot: u8,
    /// Step index within the cycle.
    pub step: u16,
    /// Drive amplitude, 0 (muted) to 255 (full).
    pub amplitude: u8,
    /// The playing entry's intensity (`UploadHeader::intensity`), 0-255.
    pub intensity: u8,
    /// Phase per transducer (u8 = round(φ/2π·256) mod 256).
    pub phases: &'a [u8],
}

/// Where frames go. Boards implement this (or use [`SpiOutput`]).
pub trait OutputDriver {
    /// Driver error; the core counts failures and carries on.
    type Error;
    /// Sends one frame to the hardware, as soon as possible.
    fn write_frame(&mut self, frame: &OutputFrame<'_>) -> Result<(), Self::Error>;
    /// Runs the output's self-test (the protocol's `SelfTest`; the core
    /// calls it only while nothing plays). A board with an SPI output
    /// tests the bus by a loopback through one jumper from MOSI to MISO,
    /// chip select held inactive, with [`loopback_test`]. The default: the
    /// board has none.
    fn self_test(&mut self) -> SelfTest {
        SelfTest::Unsupported
    }
}

impl<T: OutputDriver + ?Sized> OutputDriver for &mut T {
    type Error = T::Error;
    fn write_frame(&mut self, frame: &OutputFrame<'_>) -> Result<(), Self::Error> {
        (**self).write_frame(frame)
    }
    fn self_test(&mut self) -> SelfTest {
        (**self).self_test()
    }
}

/// Bytes one loopback self-test sends and reads back.
pub const LOOPBACK_BYTES: usize = 1024;

/// Byte `i` of the loopback pattern: every byte value once (0-255), then
/// walking ones and walking zeros (256-511, a stuck or swapped line shows
/// at once), then a scrambled sequence (512-1023, so a shifted or
/// repeated read does not match by chance).
pub const fn loopback_pattern(i: usize) -> u8 {
    let k = i % LOOPBACK_BYTES;
    if k < 256 {
        k as u8
    } else if k < 512 {
        let bit = 1u8 << (k % 8);
        if (k / 8) & 1 == 0 { bit } else { !bit }
    } else {
        ((k as u32).wrapping_mul(2_654_435_761) >> 24) as u8
    }
}

/// The loopback self-test over `transfer(sent, received)`, one full-duplex
/// SPI transfer of equal lengths (a board calls its bus with chip select
/// held inactive, so the driver boards ignore it): [`LOOPBACK_BYTES`] of
/// [`loopback_pattern`] in pieces of 64, every byte read back compared
/// with the one sent. A transfer that fails counts its piece as read back
/// as zeros (so it fails the test unless the pattern is zero there).
pub fn loopback_test<E>(mut transfer: impl FnMut(&[u8], &mut [u8]) -> Result<(), E>) -> SelfTest {
    const PIECE: usize = 64;
    let (mut mismatches, mut first) = (0u32, None);
    let mut sent = [0u8; PIECE];
    let mut got = [0u8; PIECE];
    for start in (0..LOOPBACK_BYTES).step_by(PIECE) {
        for (j, b) in sent.iter_mut().enumerate() {
            *b = loopback_pattern(start + j);
        }
        got.fill(0);
        if transfer(&sent, &mut got).is_err() {
            got.fill(0);
        }
        for (j, (s, g)) in sent.iter().zip(&got).enumerate() {
            if s != g {
                mismatches += 1;
                first.get_or_insert(((start + j) as u32, *s, *g));
            }
        }
    }
    let bytes = LOOPBACK_BYTES as u32;
    match first {
        None => SelfTest::Passed { bytes },
        Some((first_mismatch, sent, got)) => SelfTest::Failed {
            bytes,
            mismatches,
            first_mismatch,
            sent,
            got,
        },
    }
}

/// First byte of every SPI frame.
pub const SPI_FRAME_MAGIC: u8 = 0xA5;

/// Bytes of the SPI frame header written before the phases.
pub const SPI_HEADER_LEN: usize = 7;

/// The SPI header for a frame:
/// `[0xA5, amplitude, intensity, step u16 LE, transducers u16 LE]`.
pub fn spi_header(frame: &OutputFrame<'_>) -> [u8; SPI_HEADER_LEN] {
    let s = frame.step.to_le_bytes();
    let n = (frame.phases.len() as u16).to_le_bytes();
    [
        SPI_FRAME_MAGIC,
        frame.amplitude,
        frame.intensity,
        s[0],
        s[1],
        n[0],
        n[1],
    ]
}

/// Sends each frame as one SPI transaction (chip select held):
/// the [`spi_header`] followed by the phase bytes.
#[derive(Debug)]
pub struct SpiOutput<S> {
    spi: S,
}

impl<S: SpiDevice> SpiOutput<S> {
    /// Wraps an embedded-hal 1.0 SPI device.
    pub fn new(spi: S) -> Self {
        Self { spi }
    }

    /// Gives the SPI device back.
    pub fn release(self) -> S {
        self.spi
    }
}

impl<S: SpiDevice> OutputDriver for SpiOutput<S> {
    type Error = S::Error;
    fn write_frame(&mut self, frame: &OutputFrame<'_>) -> Result<(), Self::Error> {
        let header = spi_header(frame);
        self.spi
            .transaction(&mut [Operation::Write(&header), Operation::Write(frame.phases)])
    }
}

/// What [`RecordingDriver`] keeps of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Record {
    /// [`OutputFrame::due`].
    pub due: u64,
    /// [`OutputFrame::slot`].
    pub slot: u8,
    /// [`OutputFrame::step`].
    pub step: u16,
    /// [`OutputFrame::amplitude`].
    pub amplitude: u8,
    /// [`OutputFrame::intensity`].
    pub intensity: u8,
    /// CRC-32 of the phases.
    pub phase_crc: u32,
    /// The first phase bytes (zero-padded).
    pub head: [u8; 8],
}

/// Test driver: keeps the last `N` frames in a ring and counts all of them.
#[derive(Debug)]
pub struct RecordingDriver<const N: usize> {
    ring: [Record; N],
    total: u64,
}

impl<const N: usize> Default for RecordingDriver<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RecordingDriver<N> {
    /// Empty recorder.
    pub const fn new() -> Self {
        Self {
            ring: [Record {
                due: 0,
                slot: 0,
                step: 0,
                amplitude: 0,
                intensity: 0,
                phase_crc: 0,
                head: [0; 8],
            }; N],
            total: 0,
        }
    }

    /// Frames written so far.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// The `i`-th most recent frame (0 = last), if still kept.
    pub fn back(&self, i: usize) -> Option<&Record> {
        if N == 0 || (i as u64) >= self.total || i >= N {
            return None;
        }
        let idx = ((self.total - 1 - i as u64) % N as u64) as usize;
        Some(&self.ring[idx])
    }

    /// The last frame written.
    pub fn last(&self) -> Option<&Record> {
        self.back(0)
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        self.total = 0;
    }
}

impl<const N: usize> OutputDriver for RecordingDriver<N> {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, frame: &OutputFrame<'_>) -> Result<(), Self::Error> {
        let mut head = [0u8; 8];
        let n = frame.phases.len().min(8);
        head[..n].copy_from_slice(&frame.phases[..n]);
        if N > 0 {
            self.ring[(self.total % N as u64) as usize] = Record {
                due: frame.due,
                slot: frame.slot,
                step: frame.step,
                amplitude: frame.amplitude,
                intensity: frame.intensity,
                phase_crc: lm_proto::crc32(frame.phases),
                head,
            };
        }
        self.total += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_passes_through_a_jumper_and_names_the_first_bad_byte() {
        let echo = |s: &[u8], g: &mut [u8]| -> Result<(), ()> {
            g.copy_from_slice(s);
            Ok(())
        };
        assert_eq!(loopback_test(echo), SelfTest::Passed { bytes: 1024 });
        // No jumper: MISO pulled up reads 0xFF everywhere.
        let open = |_: &[u8], g: &mut [u8]| -> Result<(), ()> {
            g.fill(0xFF);
            Ok(())
        };
        let want_ff = (0..LOOPBACK_BYTES)
            .filter(|&i| loopback_pattern(i) != 0xFF)
            .count() as u32;
        assert_eq!(
            loopback_test(open),
            SelfTest::Failed {
                bytes: 1024,
                mismatches: want_ff,
                first_mismatch: 0,
                sent: 0,
                got: 0xFF
            }
        );
        // One stuck bit.
        let stuck = |s: &[u8], g: &mut [u8]| -> Result<(), ()> {
            for (g, s) in g.iter_mut().zip(s) {
                *g = s | 0x10;
            }
            Ok(())
        };
        match loopback_test(stuck) {
            SelfTest::Failed {
                first_mismatch,
                sent,
                got,
                ..
            } => assert_eq!((first_mismatch, sent, got), (0, 0, 0x10)),
            other => panic!("{other:?}"),
        }
        // A bus that errors fails.
        let err = |_: &[u8], _: &mut [u8]| Err(());
        assert!(matches!(loopback_test(err), SelfTest::Failed { .. }));
        // The pattern has every byte value and both walks.
        let mut seen = [false; 256];
        for i in 0..256 {
            seen[usize::from(loopback_pattern(i))] = true;
        }
        assert!(seen.iter().all(|s| *s));
        assert_eq!((loopback_pattern(256), loopback_pattern(264)), (0x01, 0xFE));
    }

    #[test]
    fn recorder_keeps_the_last_frames() {
        let mut r = RecordingDriver::<2>::new();
        for step in 0..3u16 {
            let phases = [step as u8; 4];
            r.write_frame(&OutputFrame {
                due: u64::from(step),
                slot: 0,
                step,
                amplitude: 255,
                intensity: 255,
                phases: &phases,
            })
            .unwrap();
        }
        assert_eq!(r.total(), 3);
        assert_eq!(r.last().map(|x| x.step), Some(2));
        assert_eq!(r.back(1).map(|x| x.step), Some(1));
        assert_eq!(r.back(2), None);
        assert_eq!(r.last().unwrap().phase_crc, lm_proto::crc32(&[2; 4]));
        assert_eq!(r.last().unwrap().head, [2, 2, 2, 2, 0, 0, 0, 0]);
    }
}
