//! LM firmware for the STM32H743ZI Nucleo-144 (NUCLEO-H743ZI and
//! NUCLEO-H743ZI2, one binary for both) on embassy-stm32.
//!
//! Thread mode runs `lm_fw_core::serve`, the busy-polling loop every board
//! shares, over [`link::Links`] (the ST-LINK virtual COM port and the user
//! USB port), the 1 MHz count of embassy-time's TIM2 driver and
//! [`output::DriverOutput`] (SPI1 by DMA). Two interrupt executors run the
//! async side: the SPI task at the higher priority, so chip select rises as
//! soon as a frame is out; the USB device and its CDC-ACM class below it.
//! Nothing async ever waits on the serve loop, and the serve loop never
//! waits on the host.
//!
//! The timebase: embassy-time with a TIM2 driver at
//! `tick-hz-1_000_000`, the HAL's own timer driver rather than ours: its
//! prescaler is TIM2's clock / 1 MHz (200 on the crystal, 64 on HSI, exact
//! on both, checked in the logic crate), it extends the count to 64 bits in
//! an overflow interrupt every 32.8 ms, and the same clock stamps the defmt
//! log and times the USB reply patience. The serve loop takes its low 32
//! bits, as it took TIM2's counter before.
//!
//! Logging: defmt over RTT (defmt-rtt's non-blocking mode: with no probe
//! attached a full buffer drops messages and never waits). Its control
//! block sits in the DTCM (memory.x), which the D-cache does not hold, so
//! the probe reads it coherently.
#![no_std]
#![no_main]

mod board;
mod clocks;
mod link;
mod mem;
mod output;
mod usb;

use core::mem::MaybeUninit;
use core::sync::atomic::AtomicBool;

use cortex_m_rt::{ExceptionFrame, entry, exception};
use defmt_rtt as _;
use embassy_executor::InterruptExecutor;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use lm_fw_core::{BOARD_LIBRARY_BYTES, Config, Device, FW_VERSION, TakeOnce, memory_bytes, serve};
use lm_fw_nucleo_h743_logic::clocks as plan;

use crate::mem::AxiBytes;

/// The stimulus library's arena: 448 KiB; with the rig's positions
/// (11,952 B) it fills most of the 512 KiB AXI SRAM.
const LIBRARY_BYTES: usize = BOARD_LIBRARY_BYTES;
/// Transducers of the array this board drives (four AUTD3 boards), reported
/// as `Info::max_transducers`; at most `lm_fw_core::MAX_TRANSDUCERS` (1024,
/// the core's table size).
const ARRAY_TRANSDUCERS: u16 = lm_fw_core::DEFAULT_TRANSDUCERS;
const STORE_BYTES: usize = memory_bytes(LIBRARY_BYTES, ARRAY_TRANSDUCERS as usize);

/// The stimulus library and the rig's transducer positions, in the AXI
/// SRAM (they do not fit the DTCM).
#[unsafe(link_section = ".axisram.store")]
static SEQUENCE_STORE: AxiBytes<STORE_BYTES> = AxiBytes::new();
static LIBRARY_CLAIMED: AtomicBool = AtomicBool::new(false);
/// The core's state outside the store, in the DTCM.
static DEVICE: TakeOnce<MaybeUninit<Device<'static>>> = TakeOnce::new(MaybeUninit::uninit());

/// Runs the SPI task (chip select's timing matters): priority 3.
static SPI_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
/// Runs the USB device and the CDC-ACM class: priority 5.
static USB_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

// The executors run in the handlers of two interrupts no peripheral here
// uses (UART4 and UART5 are not enabled); pending them wakes the executor.
#[interrupt]
unsafe fn UART4() {
    // SAFETY: this is UART4's handler, the interrupt SPI_EXECUTOR was
    // started on, and it is unmasked only by `start`.
    unsafe { SPI_EXECUTOR.on_interrupt() }
}

#[interrupt]
unsafe fn UART5() {
    // SAFETY: as above, for USB_EXECUTOR and UART5.
    unsafe { USB_EXECUTOR.on_interrupt() }
}

defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_micros());

#[entry]
fn main() -> ! {
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        panic!("core peripherals taken twice")
    };
    // Caches on first, so everything after runs from them (Cortex-M7 TRM,
    // "L1 caches"). The DTCM is not cached; the AXI SRAM and flash are.
    cp.SCB.enable_icache();
    cp.SCB.enable_dcache(&mut cp.CPUID);
    defmt::info!(
        "lm-fw-nucleo-h743 {=u8}.{=u8}.{=u8}, protocol v{=u8}: I- and D-cache on",
        FW_VERSION[0],
        FW_VERSION[1],
        FW_VERSION[2],
        lm_proto::PROTOCOL_VERSION
    );

    let source = clocks::probe_hse();
    let p = embassy_stm32::init(clocks::config(source));
    clocks::log(source, &p.RCC);

    interrupt::UART4.set_priority(Priority::P3);
    let spi_spawner = SPI_EXECUTOR.start(interrupt::UART4);
    interrupt::UART5.set_priority(Priority::P5);
    let usb_spawner = USB_EXECUTOR.start(interrupt::UART5);

    let board::Board {
        link,
        output: mut driver,
    } = board::init(p, source, cp.SCB, spi_spawner, usb_spawner);

    let report = driver.spi_loopback();
    match report.first {
        None if report.passed() => defmt::info!(
            "SPI loopback: {=u32} bytes, all back (MOSI-MISO wire fitted)",
            report.bytes
        ),
        first => defmt::info!(
            "SPI loopback: {=u32} of {=u32} bytes differ, first {} \
             (expected without the MOSI-MISO wire; with it, check the wiring)",
            report.mismatches,
            report.bytes,
            first.map(|m| (m.index, m.sent, m.got))
        ),
    }

    let mut cfg = Config::new(plan::TIMER_HZ);
    cfg.max_transducers = ARRAY_TRANSDUCERS;
    // `lmhost info` says which oscillator the dwells are timed by.
    cfg.clock = source.wire();
    let (Some(store), Some(slot)) = (SEQUENCE_STORE.take(&LIBRARY_CLAIMED), DEVICE.take()) else {
        panic!("board statics taken twice")
    };
    let dev = match Device::new(cfg, store) {
        Ok(d) => slot.write(d),
        Err(e) => panic!("device setup: {}", e),
    };
    defmt::info!(
        "serving: {=u16} transducers, {=usize} B library, timer {=u32} Hz",
        ARRAY_TRANSDUCERS,
        LIBRARY_BYTES,
        plan::TIMER_HZ
    );
    // The low 32 bits of embassy-time's 1 MHz count: the free-running
    // counter `serve` widens itself.
    serve(
        link,
        || embassy_time::Instant::now().as_ticks() as u32,
        dev,
        &mut driver,
    )
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // Stop driving the array first: nothing else runs after this.
    cortex_m::interrupt::disable();
    output::silence();
    defmt::error!("panic: {}", defmt::Display2Format(info));
    // A fault the probe catches (probe-rs stops on it and prints the
    // backtrace); without a probe the fault handler below idles.
    cortex_m::asm::udf()
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    output::silence();
    defmt::error!("hard fault at pc {=u32:#010x}", frame.pc());
    loop {
        cortex_m::asm::wfi();
    }
}
