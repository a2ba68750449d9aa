//! LM firmware for QEMU's mps2-an386 board: UART0 carries the protocol,
//! TIMER0 (25 MHz) drives the player, frames go to a counting sink.
//! Run it with `cargo xtask qemu`.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use cortex_m_rt::entry;
use lm_fw_core::{Device, serve};
use lm_fw_qemu::{FrameCounter, STORE_BYTES, TIMER0_BASE, Timer, UART0_BASE, Uart, config};

/// Both sequence slots with their transducer positions.
static mut SEQUENCE_STORE: [u8; STORE_BYTES] = [0; STORE_BYTES];
/// The core's state outside the store (a static, so the ELF's memory map shows it).
static mut DEVICE: MaybeUninit<Device<'static>> = MaybeUninit::uninit();

#[entry]
fn main() -> ! {
    // SAFETY: `main` runs once and is the only user of these statics and of
    // UART0 and TIMER0.
    let (uart, timer, dev) = unsafe {
        let store = &mut *addr_of_mut!(SEQUENCE_STORE);
        let dev = match Device::new(config(), store) {
            Ok(d) => d,
            Err(e) => panic!("device setup: {e}"),
        };
        let dev = (*addr_of_mut!(DEVICE)).write(dev);
        (Uart::new(UART0_BASE, 115_200), Timer::new(TIMER0_BASE), dev)
    };
    serve(uart, || timer.now(), dev, &mut FrameCounter::default())
}
