//! LM firmware for the STM32H743ZI Nucleo-144: USART3 (ST-LINK virtual COM
//! port) carries the protocol, TIM2 at 1 MHz drives the player, SPI1 sends
//! every step's frame to the transducer driver. Peripheral setup is in
//! [`board`]; the main loop is `lm_fw_core::serve`, as on every board.
#![no_std]
#![no_main]

mod board;
mod clocks;
mod usb;

use core::mem::MaybeUninit;

use cortex_m::peripheral::NVIC;
use cortex_m_rt::entry;
use lm_fw_core::{BOARD_LIBRARY_BYTES, Config, Device, SpiOutput, TakeOnce, memory_bytes, serve};
use stm32h7::stm32h743v::{self as pac, interrupt};

/// The stimulus library's arena: 448 KiB; with the rig's positions
/// (11,952 B) and the core's state it fits the 512 KiB AXI SRAM.
const LIBRARY_BYTES: usize = BOARD_LIBRARY_BYTES;
/// Transducers of the array this board drives (four AUTD3 boards), reported
/// as `Info::max_transducers`; at most `lm_fw_core::MAX_TRANSDUCERS` (1024,
/// the core's table size).
const ARRAY_TRANSDUCERS: u16 = lm_fw_core::DEFAULT_TRANSDUCERS;
const STORE_BYTES: usize = memory_bytes(LIBRARY_BYTES, ARRAY_TRANSDUCERS as usize);

/// The stimulus library and the rig's transducer positions.
static SEQUENCE_STORE: TakeOnce<[u8; STORE_BYTES]> = TakeOnce::new([0; STORE_BYTES]);
/// The core's state outside the store.
static DEVICE: TakeOnce<MaybeUninit<Device<'static>>> = TakeOnce::new(MaybeUninit::uninit());

#[entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        panic!("peripherals taken twice")
    };
    let board::Board {
        link,
        timer,
        spi,
        clocks,
    } = board::Board::init(dp);
    let mut cfg = Config::new(board::TIMER_HZ);
    cfg.max_transducers = ARRAY_TRANSDUCERS;
    // `lmhost info` says which oscillator the dwells are timed by.
    cfg.clock = match clocks.source {
        clocks::Source::Crystal => lm_proto::ClockSource::Crystal,
        clocks::Source::InternalRc => lm_proto::ClockSource::InternalRc,
    };
    let (Some(store), Some(slot)) = (SEQUENCE_STORE.take(), DEVICE.take()) else {
        panic!("board statics taken twice")
    };
    let dev = match Device::new(cfg, store) {
        Ok(d) => slot.write(d),
        Err(e) => panic!("device setup: {e}"),
    };
    // SAFETY: the handler only touches the receive side (see board::usart3_rx_isr).
    unsafe { NVIC::unmask(pac::Interrupt::USART3) };
    serve(link, || timer.now(), dev, &mut SpiOutput::new(spi))
}

#[interrupt]
fn USART3() {
    board::usart3_rx_isr();
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // Stop driving the array: disable SPI1 and release its chip select.
    cortex_m::interrupt::disable();
    // SAFETY: nothing else runs after a panic (interrupts are off).
    let dp = unsafe { pac::Peripherals::steal() };
    dp.SPI1.cr1().write(|w| w.spe().clear_bit());
    dp.GPIOD.bsrr().write(|w| w.bs14().set_());
    loop {
        cortex_m::asm::wfi();
    }
}
