//! Board support for QEMU's `mps2-an386` (Cortex-M4F, 25 MHz): the CMSDK
//! UART0 that carries the protocol, CMSDK TIMER0 as the player's free-running
//! clock, and a panic handler that reports over semihosting and exits QEMU
//! with a failure status. No logic of its own: everything else is the core's.
#![no_std]
#![warn(missing_docs)]

use core::ptr::{read_volatile, write_volatile};

/// Peripheral clock of the AN386 image: the APB timers and UART count this.
pub const PCLK_HZ: u32 = 25_000_000;

/// CMSDK APB UART (QEMU `cmsdk-apb-uart`).
pub struct Uart {
    base: usize,
}

/// UART0 of the AN386 image, wired to QEMU's `serial0`.
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
        let u = Self { base };
        u.write(UART_BAUDDIV, (PCLK_HZ / baud).max(16));
        u.write(UART_CTRL, CTRL_TX_EN | CTRL_RX_EN);
        u
    }

    fn read(&self, off: usize) -> u32 {
        // SAFETY: `new`'s contract: a valid, exclusively owned UART block.
        unsafe { read_volatile((self.base + off) as *const u32) }
    }

    fn write(&self, off: usize, v: u32) {
        // SAFETY: as in `read`.
        unsafe { write_volatile((self.base + off) as *mut u32, v) }
    }

    /// One received byte, if any (the UART holds only one).
    pub fn try_read(&mut self) -> Option<u8> {
        if self.read(UART_STATE) & STATE_RX_FULL != 0 {
            Some(self.read(UART_DATA) as u8)
        } else {
            None
        }
    }

    /// Sends `bytes`, waiting for room in the transmit register.
    pub fn write_all(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while self.read(UART_STATE) & STATE_TX_FULL != 0 {}
            self.write(UART_DATA, u32::from(b));
        }
    }
}

/// CMSDK APB timer run as a free-running 32-bit up-counter at [`PCLK_HZ`].
pub struct Timer {
    base: usize,
}

/// TIMER0 of the AN386 image.
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
        let t = Self { base };
        // SAFETY: `new`'s contract.
        unsafe {
            write_volatile((base + TIMER_CTRL) as *mut u32, 0);
            write_volatile((base + TIMER_RELOAD) as *mut u32, u32::MAX);
            write_volatile((base + TIMER_VALUE) as *mut u32, u32::MAX);
            write_volatile((base + TIMER_CTRL) as *mut u32, 1);
        }
        t
    }

    /// Counts since start, wrapping every 2^32 (172 s at 25 MHz).
    pub fn now(&self) -> u32 {
        // SAFETY: `new`'s contract.
        !unsafe { read_volatile((self.base + TIMER_VALUE) as *const u32) }
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
