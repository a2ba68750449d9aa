//! `lmhost`: plan, upload and stream lateral-modulation (LM) ultrasound
//! haptics for AUTD3-class phased arrays.
//!
//! The library does the work and knows nothing of the command line; the
//! `lmhost` binary (the `lmhost-cli` crate, the only user of clap) parses
//! flags, calls the library and prints. Units and the sign of the phase
//! are fixed once, in [`units`]; everything else links there.
//!
//! The library is grouped into wings by role, over a small base:
//!
//! | wing | job | may import |
//! |---|---|---|
//! | [`lab`] | the rig session, studies, calibration, demo, bench | every wing |
//! | [`sense`] | depth frames → centroid, centroid streaming | `device`, `field`, `plan`, base |
//! | [`device`] | backends, the LM link, AUTD3, the simulated device, upload | `plan`, base |
//! | [`field`] | acoustic field simulation and figures | `plan`, base |
//! | [`plan`] | scene, trajectory, synthesis, sequence, stimulus, library | base |
//! | base | [`units`], [`geom`], [`clock`], [`limits`], [`files`], [`npy`], [`out`](mod@out), [`stop`], [`rng`], [`error`], [`pdf`] | base only |
//!
//! `python3 xtask/module_cycles.py` enforces the order (a CI step).
#![warn(missing_docs)]
#![deny(clippy::print_stdout, clippy::print_stderr)]
#![cfg_attr(test, allow(clippy::print_stdout, clippy::print_stderr))]

pub mod device;
pub mod field;
pub mod lab;
pub mod plan;
pub mod sense;

pub mod clock;
pub mod error;
pub mod files;
pub mod geom;
pub mod json;
pub mod limits;
pub mod npy;
pub mod out;
pub mod pdf;
pub mod rng;
pub mod stop;
pub mod units;
pub mod whole;

pub use error::InputError;
