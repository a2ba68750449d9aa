//! The planning wing: from a scene and a stimulus to the bytes a device
//! plays. Scene and array geometry, LM trajectories, phase synthesis,
//! sequences and their encodings, the stimulus as a study names it and its
//! one plan-for-target entry point, stimuli from files, stimulus libraries,
//! and the dwell grids of the devices planned for.
//!
//! Imports only the base (units, geometry, limits, files, npy). It never
//! opens a device: a target is a dwell grid ([`target::Target`]), not a port.

pub mod array;
pub mod directivity;
pub mod grid;
pub mod library;
pub mod modulation;
pub mod path;
pub mod scene;
pub mod sequence;
pub mod stimulus;
pub mod stimulus_file;
pub mod synth;
pub mod target;
pub mod trajectory;
