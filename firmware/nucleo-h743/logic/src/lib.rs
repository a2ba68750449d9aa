//! The arithmetic and tables of the Nucleo-H743 board crate
//! (`lm-fw-nucleo-h743`), kept apart from its peripherals so that they are
//! tested on the host:
//!
//! - [`clocks`]: the clock plan (PLL dividers, bus prescalers, the USART3
//!   divider for `LM_BAUD`, the 1 MHz timebase, the SPI clock), each
//!   checked at compile time against RM0433's limits on both oscillators;
//! - [`pins`]: where every signal the firmware uses leaves the board, on
//!   both board revisions (NUCLEO-H743ZI, MB1137, and NUCLEO-H743ZI2,
//!   MB1364), with the manual table each row comes from; the board's
//!   README carries these tables as rendered here;
//! - [`selftest`]: the SPI loopback pattern (fixed bytes, walking bits, a
//!   maximal-length LFSR) and the comparison that reports mismatches;
//! - [`frame`]: packing one output frame into the SPI DMA buffer.
//!
//! no_std, no unsafe; the board crate is the only user.
#![no_std]
#![forbid(unsafe_code)]

pub mod clocks;
pub mod frame;
pub mod pins;
pub mod selftest;
