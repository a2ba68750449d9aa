//! `lmhost`: plan, upload and stream lateral-modulation (LM) ultrasound
//! haptics for AUTD3-class phased arrays.
//!
//! The library does the work and knows nothing of the command line; the
//! `lmhost` binary (`src/main.rs` and its private `cmd` module, the only
//! place that uses clap) parses flags, calls the library and prints. Units
//! and the sign of the phase are fixed once, in [`units`]; everything else
//! links there.
#![warn(missing_docs)]
#![deny(clippy::print_stdout, clippy::print_stderr)]
#![cfg_attr(test, allow(clippy::print_stdout, clippy::print_stderr))]

pub mod array;
pub mod autd3;
pub mod backend;
pub mod bench;
pub mod calibrate;
pub mod clock;
pub mod conformance;
pub mod connect;
pub mod demo;
pub mod directivity;
pub mod error;
pub mod field;
pub mod files;
pub mod geom;
pub mod library;
pub mod limits;
pub mod link;
pub mod out;
pub mod pdf;
pub mod reader;
pub mod rig;
pub mod rng;
pub mod scene;
pub mod sequence;
pub mod simdev;
pub mod stimulus;
pub mod stimulus_file;
pub mod stop;
pub mod stream;
pub mod study;
pub mod synth;
pub mod track;
pub mod trajectory;
pub mod units;
pub mod upload;

pub use error::InputError;
