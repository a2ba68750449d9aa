//! On-target tests under QEMU.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use lm_fw_qemu::{TIMER0_BASE, Timer, exit, hprintln};

#[entry]
fn main() -> ! {
    let timer = unsafe { Timer::new(TIMER0_BASE) };
    let a = timer.now();
    for _ in 0..1000 {
        cortex_m::asm::nop();
    }
    let b = timer.now();
    hprintln!("timer advanced {} counts", b.wrapping_sub(a));
    hprintln!("1 passed, 0 failed");
    exit(b != a)
}
