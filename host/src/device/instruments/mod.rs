//! The lab's instruments for the paper's Experiment 3 ("Equivalent
//! Physical Stimulus"): a motorised stage pushes a force gauge into the
//! other finger pad in step with each 2 s on-phase, and the median force
//! of the gauge is the measure.
//!
//! Two small traits, each with real serial drivers and a simulated twin,
//! so the whole loop runs in CI:
//!
//! | trait | drivers | twin |
//! |---|---|---|
//! | [`Stage`]: absolute moves on the push axis (mm, soft limits), waited for within a timeout from distance and speed, stop, home | [`ChuoQt`]: CHUO PRECISION QT controllers (QT-AMM3, QT-ADM2, …), 9600 baud | [`SimStage`]: moves at its speed (5 mm/s) on a [`crate::clock::Clock`] |
//! | [`ForceGauge`]: one reading in N (the gauge's unit read from the reply and converted), a time-stamped series at a rate | [`Imada`]: IMADA ZTS/ZTA (`D`), 19200 baud; [`Mark10`]: Mark-10 Series 4/5/7 (`?`), 115200 baud | [`SimGauge`]: a ZTS-50N reading a [`FingerPad`] at the stage's position |
//!
//! [`open_gauge`] and [`open_stage`] open what a port names (a serial
//! path, or `sim` for the twin). [`press()`] is one push of the experiment over any stage and gauge, with
//! the safe ending every failure gets (stimulus off, stage stopped and
//! back at rest). Errors are one [`InstrumentError`] type whose message
//! starts with the port.
//!
//! The drivers speak plain ASCII request/response protocols through
//! [`port::LineIo`] over any [`Port`] (a `serialport` port, or an
//! in-memory peer in the tests that speaks the documented protocol,
//! malformed replies, silence and unit changes included). Each driver's
//! docs cite the source of its command set.

pub mod chuo;
pub mod contact;
pub mod error;
pub mod gauge;
pub mod imada;
pub mod mark10;
pub mod open;
pub mod port;
pub mod press;
pub mod serial_gauge;
pub mod sim_gauge;
pub mod sim_stage;
pub mod stage;
pub mod unit;

pub use chuo::{Axis, ChuoQt, QtConfig};
pub use contact::FingerPad;
pub use error::InstrumentError;
pub use gauge::{ForceGauge, Reading, Series};
pub use imada::Imada;
pub use mark10::Mark10;
pub use open::{
    GaugeModel, GaugeOptions, SIM, StageOptions, StagePort, check_rig, open_gauge, open_rig,
    open_stage,
};
pub use port::Port;
pub use press::{PressError, PressPlan, Pressed, press};
pub use sim_gauge::{GaugeSpec, SimGauge};
pub use sim_stage::{SimStage, StageProbe};
pub use stage::{Move, Stage, StageLimits};
pub use unit::ForceUnit;

#[cfg(test)]
mod gauge_driver_tests;
