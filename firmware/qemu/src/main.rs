//! LM firmware for QEMU's mps2-an500 board (Cortex-M7): UART0 carries the protocol,
//! TIMER0 (25 MHz) drives the player, frames go to a counting sink.
//! Run it with `cargo xtask qemu`.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use lm_fw_core::{Device, serve};
use lm_fw_qemu::{FrameCounter, STORE_BYTES, TIMER0_BASE, Timer, UART0_BASE, Uart, config};
use static_cell::ConstStaticCell;

/// The stimulus library and the rig's transducer positions.
static SEQUENCE_STORE: ConstStaticCell<[u8; STORE_BYTES]> = ConstStaticCell::new([0; STORE_BYTES]);
/// The core's state outside the store (a static, so the ELF's memory map shows it).
static DEVICE: ConstStaticCell<MaybeUninit<Device<'static>>> =
    ConstStaticCell::new(MaybeUninit::uninit());

#[entry]
fn main() -> ! {
    let (Some(store), Some(slot)) = (SEQUENCE_STORE.try_take(), DEVICE.try_take()) else {
        panic!("board statics taken twice")
    };
    let dev = match Device::new(config(), store) {
        Ok(d) => slot.write(d),
        Err(e) => panic!("device setup: {e}"),
    };
    // SAFETY: `main` runs once and is the only user of UART0 and TIMER0.
    let (uart, timer) = unsafe { (Uart::new(UART0_BASE, 115_200), Timer::new(TIMER0_BASE)) };
    serve(uart, || timer.now(), dev, &mut FrameCounter::default())
}
