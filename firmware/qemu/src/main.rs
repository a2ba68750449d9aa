//! LM firmware for QEMU's mps2-an386 board.
#![no_std]
#![no_main]
