//! The devices wing: everything that talks to hardware or its models.
//! The [`backend::Backend`] trait every device kind implements, the serial
//! link and its client for the LM firmware, AUTD3 arrays through the autd3
//! crates, opening the device a port names ([`connect`]), the simulated
//! LM device, the one upload report, the one centroid sender
//! ([`centroids`]), the device policy's conformance table, the wiring
//! map of the driver boards, and the lab's serial instruments (stage,
//! force gauge) with their simulated twins.
//!
//! Imports the base and the planning wing; never the sensing or lab wings.

pub mod autd3;
pub mod backend;
pub mod centroids;
pub mod conformance;
pub mod connect;
pub mod instruments;
pub mod link;
pub mod simdev;
pub mod upload;
pub mod wiring;
