//! LM firmware for the STM32H743ZI Nucleo-144 (bring-up: UART echo).
#![no_std]
#![no_main]

mod board;

use cortex_m_rt::entry;
use stm32h7::stm32h743v as pac;

#[entry]
fn main() -> ! {
    let dp = pac::Peripherals::take().expect("peripherals are taken once, here");
    let mut b = board::Board::init(dp);
    loop {
        if let Some(c) = b.uart.try_read() {
            b.uart.write_all(&[c]);
        }
        let _ = b.timer.now();
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // Stop driving the array: disable SPI1 and hold its chip select high.
    // SAFETY: nothing else runs after a panic.
    let dp = unsafe { pac::Peripherals::steal() };
    dp.SPI1.cr1().write(|w| w.spe().clear_bit());
    dp.GPIOD.bsrr().write(|w| unsafe { w.bits(1 << 14) });
    loop {
        cortex_m::asm::wfi();
    }
}
