//! AUTD3 arrays through the autd3 crates (`--port autd3:...`).
//!
//! One file per concern:
//! - [`port`]: `autd3:emulator`, `autd3:soem[:IF]`, `autd3:ethercrab[:IF]`,
//!   `autd3:remote:HOST:PORT`;
//! - [`geometry`]: scene devices → autd3 devices, positions checked to 1 µm;
//! - [`emulator`]: autd3's CPU + FPGA emulator as a clocked link with read-back;
//! - [`correction`]: centroid offsets from `lm-fw-core` as `PhaseCorrection`;
//! - [`safety`]: the firmware's gate, mute, silencer settings;
//! - [`firmware`]: the firmware version these autd3 crates speak, checked at open;
//! - [`open`]: a port's link, the rig checked against the scene and firmware;
//! - [`output`]: the output level through the modulation, under a lease;
//! - [`device`]: [`Autd3Backend`], the [`Backend`](crate::device::backend::Backend),
//!   driving the firmware's own player and policy.

pub mod correction;
pub mod device;
pub mod emulator;
pub mod ethercat;
pub mod firmware;
pub mod geometry;
pub mod open;
pub mod output;
pub mod port;
pub mod safety;

#[cfg(test)]
mod tests;

pub use device::Autd3Backend;
pub use emulator::{EmulatorHandle, EmulatorLink};
pub use port::Autd3Port;
