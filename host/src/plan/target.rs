//! The planning target.

use crate::plan::grid::GridTiming;
use crate::plan::scene::Scene;
use crate::plan::sequence::{Plan, Synthesis};
use crate::plan::trajectory::LmParams;

/// What a plan is made for: the device's dwell grid and step limits, not
/// its port (planning never opens a device).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// The LM firmware: any dwell its microsecond timer can count.
    Lm,
    /// An AUTD3 rig: GainSTM patterns on the FPGA's 25 µs grid
    /// ([`crate::plan::grid`]).
    Autd3,
}

impl Target {
    /// Every target.
    pub const ALL: [Target; 2] = [Self::Lm, Self::Autd3];

    /// Its name (`--target`, a plan's JSON summary, Python's `target=`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Lm => "lm",
            Self::Autd3 => "autd3",
        }
    }

    /// `params` planned for this device: on AUTD3 on its 25 µs dwell grid
    /// (with the realised timing), else as asked.
    pub fn plan_on_grid(
        &self,
        params: &LmParams,
        scene: &Scene,
        synthesis: &Synthesis,
    ) -> anyhow::Result<(Plan, Option<GridTiming>)> {
        match self {
            Self::Lm => Ok((Plan::new(scene.clone(), params, synthesis)?, None)),
            Self::Autd3 => {
                let (plan, g) = crate::plan::grid::plan(params, scene, synthesis)?;
                Ok((plan, Some(g)))
            }
        }
    }
}
