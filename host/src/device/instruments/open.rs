//! Opening an instrument a port names: a serial path for a real one, or
//! `sim` for its simulated twin, so the bench commands and the study open
//! both the same way.

use super::chuo::{Axis, ChuoQt, QT_BAUD, QT_REPLY_TIMEOUT, QtConfig};
use super::contact::FingerPad;
use super::gauge::ForceGauge;
use super::imada::{IMADA_BAUD, Imada};
use super::mark10::{MARK10_BAUD, Mark10};
use super::sim_gauge::SimGauge;
use super::sim_stage::SimStage;
use super::stage::{Stage, StageLimits};
use crate::clock::Clock;
use crate::error::InputError;
use crate::limits::show;

/// The port name that opens a simulated twin.
pub const SIM: &str = "sim";

/// Which gauge protocol a port speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GaugeModel {
    /// IMADA ZTS/ZTA ([`Imada`]).
    Imada,
    /// Mark-10 Series 4/5/7 ([`Mark10`]).
    Mark10,
}

impl GaugeModel {
    /// The model's factory baud rate.
    pub fn default_baud(self) -> u32 {
        match self {
            Self::Imada => IMADA_BAUD,
            Self::Mark10 => MARK10_BAUD,
        }
    }
}

/// How to open a gauge.
#[derive(Debug, Clone)]
pub struct GaugeOptions {
    /// A serial port path, or [`SIM`].
    pub port: String,
    /// Its protocol.
    pub model: GaugeModel,
    /// Baud rate; the model's factory rate when `None`.
    pub baud: Option<u32>,
    /// For the twin: how deep its probe sits in the finger pad, mm.
    pub sim_depth_mm: Option<f64>,
    /// For the twin: the noise seed.
    pub seed: u64,
}

/// Open the gauge `o` names.
pub fn open_gauge(o: &GaugeOptions) -> anyhow::Result<Box<dyn ForceGauge>> {
    if o.port == SIM {
        let depth = o.sim_depth_mm.unwrap_or(0.0);
        if !(depth.is_finite() && (0.0..=20.0).contains(&depth)) {
            return Err(InputError::new(format!(
                "simulated depth {} mm is outside 0..20 mm",
                show(depth)
            ))
            .into());
        }
        // A stage twin parked at the depth, the pad touching at 0.
        let limits = StageLimits::new(-10.0, 30.0)?;
        let stage = SimStage::new(Clock::real(), limits, depth)?;
        return Ok(Box::new(SimGauge::new(
            stage.probe(),
            FingerPad::TYPICAL,
            o.seed,
        )));
    }
    if o.sim_depth_mm.is_some() {
        return Err(InputError::new(format!(
            "a simulated depth (--sim-depth) needs port {SIM}, not {}",
            o.port
        ))
        .into());
    }
    let baud = o.baud.unwrap_or(o.model.default_baud());
    Ok(match o.model {
        GaugeModel::Imada => Box::new(Imada::open(&o.port, baud)?),
        GaugeModel::Mark10 => Box::new(Mark10::open(&o.port, baud)?),
    })
}

/// How to open a stage.
#[derive(Debug, Clone)]
pub struct StageOptions {
    /// A serial port path, or [`SIM`].
    pub port: String,
    /// Soft limits of the push axis, mm.
    pub limits: StageLimits,
    /// Speed, mm/s.
    pub speed_mm_s: f64,
    /// The controller's pushing axis.
    pub axis: Axis,
    /// Micrometres per pulse.
    pub step_um: f64,
    /// Baud rate ([`QT_BAUD`] when `None`).
    pub baud: Option<u32>,
}

/// Open the stage `o` names; a twin starts at 0, or at the soft limit
/// nearest to it.
pub fn open_stage(o: &StageOptions) -> anyhow::Result<Box<dyn Stage>> {
    if o.port == SIM {
        let home = 0.0f64.clamp(o.limits.min_mm, o.limits.max_mm);
        let mut stage = SimStage::new(Clock::real(), o.limits, home)?;
        stage.set_speed(o.speed_mm_s)?;
        return Ok(Box::new(stage));
    }
    let cfg = QtConfig {
        axis: o.axis,
        step_um: o.step_um,
        limits: o.limits,
        speed_mm_s: o.speed_mm_s,
        accel_ms: 100,
        baud: o.baud.unwrap_or(QT_BAUD),
        reply_timeout: QT_REPLY_TIMEOUT,
    };
    Ok(Box::new(ChuoQt::open(&o.port, cfg)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gauge(port: &str, depth: Option<f64>) -> anyhow::Result<Box<dyn ForceGauge>> {
        open_gauge(&GaugeOptions {
            port: port.into(),
            model: GaugeModel::Imada,
            baud: None,
            sim_depth_mm: depth,
            seed: 1,
        })
    }

    #[test]
    fn sim_opens_the_twins_and_checks_its_depth() {
        let mut g = gauge(SIM, Some(2.0)).unwrap();
        let f = g.read().unwrap().force_n;
        assert!(
            (f - FingerPad::TYPICAL.force_at_depth_n(2.0)).abs() <= 0.03,
            "{f}"
        );
        for bad in [Some(-1.0), Some(f64::NAN), Some(25.0)] {
            let err = gauge(SIM, bad).err().unwrap();
            assert!(err.chain().any(|c| c.is::<InputError>()), "{err}");
        }
        let err = gauge("/dev/null", Some(1.0)).err().unwrap();
        assert!(err.chain().any(|c| c.is::<InputError>()), "{err}");
    }

    #[test]
    fn a_missing_port_is_an_io_error_naming_it() {
        let err = gauge("/dev/lmhost-no-such-gauge", None).err().unwrap();
        let msg = crate::error::one_line(&err);
        assert!(msg.starts_with("/dev/lmhost-no-such-gauge: "), "{msg}");
        assert!(!err.chain().any(|c| c.is::<InputError>()), "{msg}");
    }
}
