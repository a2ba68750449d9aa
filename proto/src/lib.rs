//! Wire protocol shared by the host (`lmhost`) and the firmware.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]
