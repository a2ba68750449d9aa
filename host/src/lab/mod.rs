//! The lab wing: a researcher's day. The rig session behind `lmhost
//! session` ([`session`]), studies ([`study`]) and their statistics
//! ([`stats`]), calibration, the demo, the bench report and the rig check
//! (`doctor`). The top of the library: it may import every wing;
//! nothing imports it but the CLI and the Python package.

pub mod bench;
pub mod calibrate;
pub mod demo;
pub mod doctor;
pub mod session;
pub mod stats;
pub mod study;
pub mod view;

#[cfg(test)]
mod tests;
