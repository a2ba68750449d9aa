//! Finger-centroid streaming: where samples come from ([`source`]), how they
//! are smoothed ([`filter`]) and how a filter is judged on a known track
//! ([`metrics`]).
//!
//! Positions are millimetres in the tracker's frame (the scene's frame);
//! mirroring into drive coordinates happens in the `stream` command, at the
//! link boundary, like every other unit conversion.

pub mod filter;
pub mod intake;
pub mod metrics;
pub mod plausible;
pub mod run;
pub mod source;
pub mod synthetic;

/// One tracker sample: the centroid of the finger's contact area.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sample {
    /// Tracker time stamp (s).
    pub t_s: f64,
    /// Centroid (mm).
    pub pos_mm: [f64; 3],
    /// Whether a finger is in the detection area at all.
    pub present: bool,
}
