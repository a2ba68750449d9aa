//! Board support for QEMU's `mps2-an500` (Cortex-M7 with FPv5, the core of
//! the STM32H743; 25 MHz peripherals): the CMSDK UART0 that carries the
//! protocol, CMSDK TIMER0 as the player's free-running clock, a counting
//! output sink, and a panic handler that reports over semihosting and exits
//! QEMU with a failure status. No logic of its own: [`lm_fw_core::serve`]
//! hands received bytes and timer counts to [`lm_fw_core::Device`].
//!
//! The same image runs on `mps2-an386` (Cortex-M4F): both FPGA images put
//! ZBT SSRAM1 at 0, SSRAM2&3 at `0x2000_0000`, UART0 and TIMER0 where this
//! crate looks for them, and the thumbv7em-eabihf code uses only the
//! single-precision FPU both cores have.
//!
//! Output: QEMU's MPS2 models have no device behind an SPI bus that could
//! stand for the transducer driver, so frames go to [`FrameCounter`], which
//! keeps what a test needs to see (count, last step, muted frames). The real
//! board (`firmware/nucleo-h743`) sends them over SPI1 with the core's
//! `SpiOutput`.
#![no_std]
#![warn(missing_docs)]

use core::ptr::{read_volatile, write_volatile};

use lm_fw_core::{Config, HostLink, OutputDriver, OutputFrame};

/// The stimulus library's arena: the Nucleo-H743's
/// ([`lm_fw_core::BOARD_LIBRARY_BYTES`], 448 KiB), so what QEMU holds the
/// real board holds.
pub const LIBRARY_BYTES: usize = lm_fw_core::BOARD_LIBRARY_BYTES;
/// Transducers of the array this board drives (four AUTD3 boards), reported
/// as `Info::max_transducers`; at most `lm_fw_core::MAX_TRANSDUCERS` (1024,
/// the core's table size).
pub const ARRAY_TRANSDUCERS: u16 = lm_fw_core::DEFAULT_TRANSDUCERS;
/// Bytes of sequence memory for the core (the library and the rig's positions).
pub const STORE_BYTES: usize = lm_fw_core::memory_bytes(LIBRARY_BYTES, ARRAY_TRANSDUCERS as usize);

/// The core's configuration on this board: TIMER0's 25 MHz counts.
pub fn config() -> Config {
    let mut c = Config::new(PCLK_HZ);
    c.max_transducers = ARRAY_TRANSDUCERS;
    // QEMU's timer: the host machine's clock, or under `-icount` the
    // guest's instruction count (a host holds it to neither).
    c.clock = lm_proto::ClockSource::Emulated;
    c
}

/// Peripheral clock of the MPS2 images: the APB timers and UART count this.
pub const PCLK_HZ: u32 = 25_000_000;

/// A block of 32-bit memory-mapped registers at `base`.
#[derive(Clone, Copy)]
struct Registers {
    base: usize,
}

impl Registers {
    fn read(self, off: usize) -> u32 {
        // SAFETY: the owner's `new` contract: `base` is a valid register
        // block of the peripheral, and nothing else drives it.
        unsafe { read_volatile((self.base + off) as *const u32) }
    }

    fn write(self, off: usize, v: u32) {
        // SAFETY: as in `read`.
        unsafe { write_volatile((self.base + off) as *mut u32, v) }
    }
}

/// CMSDK APB UART (QEMU `cmsdk-apb-uart`).
pub struct Uart(Registers);

/// UART0 of the MPS2 images, wired to QEMU's `serial0`.
pub const UART0_BASE: usize = 0x4000_4000;

const UART_DATA: usize = 0x00;
const UART_STATE: usize = 0x04;
const UART_CTRL: usize = 0x08;
const UART_BAUDDIV: usize = 0x10;
const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;

impl Uart {
    /// Enables TX and RX at `baud` (QEMU ignores the rate but insists on a
    /// divider of at least 16).
    ///
    /// # Safety
    /// `base` must be a CMSDK APB UART that nothing else drives.
    pub unsafe fn new(base: usize, baud: u32) -> Self {
        let r = Registers { base };
        r.write(UART_BAUDDIV, (PCLK_HZ / baud).max(16));
        r.write(UART_CTRL, CTRL_TX_EN | CTRL_RX_EN);
        Self(r)
    }

    /// One received byte, if any (the UART holds only one).
    pub fn try_read(&mut self) -> Option<u8> {
        if self.0.read(UART_STATE) & STATE_RX_FULL != 0 {
            Some(self.0.read(UART_DATA) as u8)
        } else {
            None
        }
    }

    /// Sends `bytes`, waiting for room in the transmit register.
    pub fn write_all(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while self.0.read(UART_STATE) & STATE_TX_FULL != 0 {}
            self.0.write(UART_DATA, u32::from(b));
        }
    }
}

/// CMSDK APB timer run as a free-running 32-bit up-counter at [`PCLK_HZ`].
pub struct Timer(Registers);

/// TIMER0 of the MPS2 images.
pub const TIMER0_BASE: usize = 0x4000_0000;

const TIMER_CTRL: usize = 0x00;
const TIMER_VALUE: usize = 0x04;
const TIMER_RELOAD: usize = 0x08;

impl Timer {
    /// Starts the timer counting down from 2^32 − 1 and wrapping there, so
    /// `!VALUE` counts up through all 2^32 values.
    ///
    /// # Safety
    /// `base` must be a CMSDK APB timer that nothing else drives.
    pub unsafe fn new(base: usize) -> Self {
        let r = Registers { base };
        r.write(TIMER_CTRL, 0);
        r.write(TIMER_RELOAD, u32::MAX);
        r.write(TIMER_VALUE, u32::MAX);
        r.write(TIMER_CTRL, 1);
        Self(r)
    }

    /// A second reader of the same running timer (reading has no side effects).
    pub fn clone_of(other: &Timer) -> Timer {
        Timer(other.0)
    }

    /// Counts since start, wrapping every 2^32 (172 s at 25 MHz).
    pub fn now(&self) -> u32 {
        !self.0.read(TIMER_VALUE)
    }
}

/// Output sink standing in for the transducer driver (see the crate docs).
#[derive(Debug, Default, Clone, Copy)]
pub struct FrameCounter {
    /// Frames written.
    pub frames: u32,
    /// Of those, frames with amplitude 0.
    pub muted: u32,
    /// Step of the last frame.
    pub last_step: u16,
    /// Phase of transducer 0 in the last frame (keeps the frame observable).
    pub last_phase0: u8,
    /// Intensity of the last frame.
    pub last_intensity: u8,
}

impl OutputDriver for FrameCounter {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, frame: &OutputFrame<'_>) -> Result<(), Self::Error> {
        self.frames = self.frames.wrapping_add(1);
        if frame.amplitude == 0 {
            self.muted = self.muted.wrapping_add(1);
        }
        self.last_step = frame.step;
        self.last_phase0 = frame.phases.first().copied().unwrap_or(0);
        self.last_intensity = frame.intensity;
        Ok(())
    }
}

/// UART0 as the serve loop's host link. Polled: QEMU delivers UART input
/// one byte at a time as the guest reads it, so nothing is lost while a
/// step is computed.
impl HostLink for Uart {
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        let mut n = 0;
        while n < buf.len() {
            match self.try_read() {
                Some(b) => {
                    buf[n] = b;
                    n += 1;
                }
                None => break,
            }
        }
        n
    }

    fn send(&mut self, bytes: &[u8]) {
        self.write_all(bytes);
    }
}

/// Prints over semihosting (QEMU's stdout with `-semihosting-config target=native`).
pub use cortex_m_semihosting::{hprint, hprintln};

/// Ends the QEMU run with a pass/fail status via semihosting.
pub fn exit(success: bool) -> ! {
    use cortex_m_semihosting::debug;
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Only reached without semihosting (e.g. on a debugger that ignores it).
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("firmware panic: {}", info);
    exit(false)
}
