//! Hardware-free core of the LM firmware.
#![no_std]
#![warn(missing_docs)]
