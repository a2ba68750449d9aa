//! Acoustic field simulation: pressure and radiation-pressure maps of a
//! phase sequence on an observation plane.
//!
//! # Model
//!
//! Every transducer is a point source. At distance `r` (mm) and angle `θ`
//! from its normal, a transducer driven with phase `φ` contributes
//!
//! ```text
//! p = P0 · D(θ) · exp(−α r) · exp(j (k r + φ)) / r        [Pa, peak amplitude]
//! ```
//!
//! with the phase sign of [`crate::units`], `k = 2π · 40 kHz / c`, the
//! [`Directivity`] `D`, the medium's amplitude attenuation `α` (Np/m; 0 by
//! default, as AUTD3 uses) and [`T4010A1_P0_PA_MM`] for `P0`. Drive phases
//! are the quantised `u8` values themselves (`φ = 2π · u / 256`); every
//! transducer runs at full amplitude, as in the paper.
//!
//! A reflector (a plane, reflection coefficient 1) is modelled by image
//! sources, and only when the caller passes one: each transducer gets a
//! mirror twin (position and normal mirrored through the plane) driven with
//! the same phase. Points on the far side of the reflector from the array
//! are behind an opaque wall and get zero pressure.
//!
//! # Outputs
//!
//! For a sequence of `N` steps (one LM cycle) on a grid of points,
//! [`FieldMaps`] holds the pressure amplitude and radiation pressure of
//! step 0, the radiation pressure averaged over the cycle, its maximum over
//! the cycle, and the power of its component at the LM frequency (DFT bin 1
//! over the cycle's steps). Radiation pressure is `α_rp |p|² / (2 ρ c²)`
//! (`α_rp` = 2 by default: a perfectly reflecting surface; `ρ` = 1.2 kg/m³).
//!
//! [`simulate`] is the fast path (f32, batched as a propagation block times
//! the drive matrix, 2 threads); [`simulate_reference`] is the plain f64
//! loop it is checked against.

pub mod am;
pub mod compare;
mod kernel;
mod maps;
mod model;
mod plane;
pub mod plot;
mod post;
mod reference;
mod stats;
pub mod study;

pub use crate::plan::directivity::Directivity;
pub use kernel::isa as fast_path_isa;
pub use maps::{DEFAULT_RADIATION_ALPHA, FieldMaps, Radiation, simulate};
pub use model::{
    C64, DEFAULT_DENSITY_KG_M3, FieldModel, Medium, Reflector, T4010A1_P0_PA_MM, drive_from_rad,
    drive_from_u8, model_for_scene,
};
pub use plane::{MAX_GRID_POINTS, ObservationPlane};
pub use post::{disk_force_n, half_peak_extent_mm, peak};
pub use reference::simulate_reference;

/// Invalid inputs to the field model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FieldError {
    /// No transducers.
    #[error("the scene has no transducers; add at least one device")]
    NoTransducers,
    /// A transducer position or normal is not finite, or a normal is zero.
    #[error("transducer {0} has a non-finite position or a zero/non-finite normal")]
    BadTransducer(usize),
    /// The medium is unphysical.
    #[error("bad medium: {0}")]
    BadMedium(&'static str),
    /// The reflector is degenerate.
    #[error("bad reflector: the point must be finite and the normal finite and non-zero")]
    BadReflector,
    /// Every transducer is on the reflector plane or behind it.
    #[error("no transducer is in front of the reflector; check the reflector's point and normal")]
    ReflectorHidesArray,
    /// The observation plane is invalid.
    #[error("bad observation plane: {0}")]
    BadPlane(String),
    /// The phase buffer does not hold steps × transducers bytes.
    #[error("phase sequence has {got} bytes, expected {steps} steps × {transducers} transducers")]
    BadSequence {
        /// Bytes given.
        got: usize,
        /// Steps asked for.
        steps: usize,
        /// Transducers in the model.
        transducers: usize,
    },
    /// A radiation-pressure parameter is invalid.
    #[error("radiation-pressure coefficient must be finite and positive, got {0}")]
    BadAlpha(f64),
}

#[cfg(test)]
mod tests;
