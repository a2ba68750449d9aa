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

#[cfg(test)]
impl Sample {
    /// A present finger at `x` mm on the x axis, 200 mm above the array,
    /// stamped `t_s`: the tests' plain sample.
    pub(crate) fn at(t_s: f64, x: f64) -> Self {
        Self {
            t_s,
            pos_mm: [x, 0.0, 200.0],
            present: true,
        }
    }
}
