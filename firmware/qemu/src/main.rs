//! LM firmware for QEMU's mps2-an386 board (plumbing bring-up: UART echo
//! stamped with the timer; replaced by the core's device loop).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use lm_fw_qemu::{TIMER0_BASE, Timer, UART0_BASE, Uart};

#[entry]
fn main() -> ! {
    // SAFETY: the only owners of UART0 and TIMER0.
    let (mut uart, timer) = unsafe { (Uart::new(UART0_BASE, 115_200), Timer::new(TIMER0_BASE)) };
    uart.write_all(b"lm-fw-qemu\n");
    loop {
        if let Some(b) = uart.try_read() {
            let t = timer.now();
            uart.write_all(&[b]);
            let _ = t;
        }
    }
}
