//! The device policy's conformance table: play / centroid / stop / loss /
//! out-of-volume / timed-play / queued-takeover / empty-upload /
//! never-uploaded scenarios that every
//! [`Backend`] must pass with the same states, mute reasons, corrections,
//! centroid outcomes, slots and step counts.
//!
//! The rules live once, in [`lm_fw_core::policy`]; this table checks that
//! each device actually follows them through its own mechanics: the LM
//! firmware (the simulated device in process, the firmware under QEMU) and
//! an AUTD3 rig (autd3's firmware emulator). Each scenario runs on a freshly
//! opened device; time moves only through [`Dut::wait`] (a manual clock in
//! process, real time against QEMU), and waits are far from the 100 ms
//! staleness limit on both sides, so the table holds on a loaded machine.

use std::time::Duration;

use lm_proto::{Centroid, DeviceState, MuteReason, NackCode, PlayAt};

use crate::device::backend::{Backend, CentroidOutcome};
use crate::plan::sequence::Plan;

/// Lets a duration pass on a device's clock.
pub type Wait = Box<dyn FnMut(&mut dyn Backend, Duration) -> anyhow::Result<()>>;

/// A device under test and the way to let time pass for it.
pub struct Dut {
    /// The device, freshly opened (idle, nothing uploaded).
    pub dev: Box<dyn Backend>,
    /// Lets `d` pass on the device's clock (a manual clock moves on; a
    /// device on its own clock is watched until it has played that long).
    pub wait: Wait,
}

/// What a scenario does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// Uploads the wide (20 mm work volume) or the narrow (2 mm) plan into
    /// `slot`.
    Upload {
        /// Slot (0 or 1: every device has two).
        slot: u8,
        /// Which plan.
        narrow: bool,
    },
    /// Plays `slot`.
    Play {
        /// Slot.
        slot: u8,
        /// When the switch happens.
        at: PlayAt,
        /// Untracked play.
        untracked: bool,
    },
    /// Plays `slot` for `steps` steps (`play_for`).
    PlayFor {
        /// Slot.
        slot: u8,
        /// Steps to play.
        steps: u32,
        /// Untracked play.
        untracked: bool,
    },
    /// `Stop`.
    Stop,
    /// A centroid `dx_um` from the planned centre along x.
    Centroid {
        /// Sequence number.
        seq: u32,
        /// Offset from the planned centre (µm, x).
        dx_um: i32,
        /// Finger present.
        present: bool,
    },
    /// Lets time pass (ms).
    Wait(u64),
    /// Uploads into `slot` the wide plan emptied of `what`: a plan that
    /// carries nothing.
    UploadEmpty {
        /// Slot.
        slot: u8,
        /// What the plan lacks.
        what: Empty,
    },
}

/// What an emptied plan lacks (SPEC section 3, Lists, at the plan's level).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Empty {
    /// No steps, no phases: an upload of no chunk.
    Steps,
    /// An intensity table of no levels.
    Levels,
}

/// What a centroid update came to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Accepted.
    Applied,
    /// Refused: outside the playing slot's work volume.
    OutOfRange,
    /// Refused: its sequence number is not newer.
    Stale,
    /// An upload or a play refused as bad input before anything was sent.
    BadInput,
    /// A play refused: the slot holds no committed sequence.
    NotCommitted,
}

/// The state expected after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Expect {
    /// `Status::state`.
    pub state: DeviceState,
    /// `Status::mute_reason`.
    pub mute: MuteReason,
    /// `Status::correction_um[0]` (the others are 0).
    pub correction_x_um: i32,
    /// A centroid step's outcome, or a refused upload's or play's.
    pub outcome: Option<Outcome>,
    /// `(Status::slot, Status::queued_slot)`, where the step checks them.
    pub slots: Option<(Option<u8>, Option<u8>)>,
    /// Steps played, `cycles × N + step`, where the step checks them.
    pub played: Option<u64>,
}

/// A named scenario: steps, each with the state expected after it.
pub struct Scenario {
    /// What it checks.
    pub name: &'static str,
    /// Steps and expectations.
    pub steps: &'static [(Step, Expect)],
}

const fn ex(state: DeviceState, mute: MuteReason, correction_x_um: i32) -> Expect {
    Expect {
        state,
        mute,
        correction_x_um,
        outcome: None,
        slots: None,
        played: None,
    }
}

impl Expect {
    /// Also checks the playing (or last played) and the queued slot.
    const fn slots(self, slot: Option<u8>, queued: Option<u8>) -> Self {
        Expect {
            slots: Some((slot, queued)),
            ..self
        }
    }

    /// Also checks the steps played.
    const fn played(self, steps: u64) -> Self {
        Expect {
            played: Some(steps),
            ..self
        }
    }
}

const fn after(outcome: Outcome, e: Expect) -> Expect {
    Expect {
        outcome: Some(outcome),
        ..e
    }
}

const fn play(slot: u8, untracked: bool) -> Step {
    Step::Play {
        slot,
        at: PlayAt::NextCycle,
        untracked,
    }
}

const fn at(seq: u32, dx_um: i32) -> Step {
    Step::Centroid {
        seq,
        dx_um,
        present: true,
    }
}

const fn gone(seq: u32) -> Step {
    Step::Centroid {
        seq,
        dx_um: 0,
        present: false,
    }
}

/// The wide plan into slot 1 (an AUTD3 starts on segment 0, so slot 1 is
/// the first one a switch goes to).
const UPLOAD: Step = Step::Upload {
    slot: 1,
    narrow: false,
};
const STALE_WAIT: Step = Step::Wait(300);
/// The wide plan into slot 0 too.
const UPLOAD_0: Step = Step::Upload {
    slot: 0,
    narrow: false,
};
/// The narrow plan (a smaller work volume) into slot 0.
const NARROW_0: Step = Step::Upload {
    slot: 0,
    narrow: true,
};
const fn upload_empty(slot: u8, what: Empty) -> Step {
    Step::UploadEmpty { slot, what }
}

/// A timed play's steps: 73 ms of the 5 Hz stimulus, fewer than a cycle.
const TIMED: u32 = 30;

use DeviceState::{Idle, Muted, Playing, Stopped};
use MuteReason as M;
use Outcome::{Applied, BadInput, NotCommitted, OutOfRange, Stale};

/// Stopped by itself after a timed play of `slot`, [`TIMED`] steps
/// counted.
const fn timed_out(slot: u8) -> Expect {
    ex(Stopped, M::Stopped, 0)
        .slots(Some(slot), None)
        .played(TIMED as u64)
}

const fn play_for(slot: u8) -> Step {
    Step::PlayFor {
        slot,
        steps: TIMED,
        untracked: true,
    }
}

/// The table.
pub const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "tracked play waits for the finger, follows it, mutes on loss and staleness, stops",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (play(1, false), ex(Muted, M::WaitingForTracking, 0)),
            (at(1, 1000), after(Applied, ex(Playing, M::None, 1000))),
            (gone(2), after(Applied, ex(Muted, M::FingerAbsent, 1000))),
            (at(2, 0), after(Stale, ex(Muted, M::FingerAbsent, 1000))),
            (at(3, -500), after(Applied, ex(Playing, M::None, -500))),
            (STALE_WAIT, ex(Muted, M::TrackingStale, -500)),
            (at(4, 0), after(Applied, ex(Playing, M::None, 0))),
            (Step::Stop, ex(Stopped, M::Stopped, 0)),
            (Step::Stop, ex(Stopped, M::Stopped, 0)),
        ],
    },
    Scenario {
        name: "stop while idle stays idle",
        steps: &[(Step::Stop, ex(Idle, M::None, 0))],
    },
    Scenario {
        name: "untracked play sounds without a finger, is never stale and never corrected",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (play(1, true), ex(Playing, M::None, 0)),
            (at(1, 1000), after(Applied, ex(Playing, M::None, 0))),
            (gone(2), after(Applied, ex(Playing, M::None, 0))),
            (STALE_WAIT, ex(Playing, M::None, 0)),
            (Step::Stop, ex(Stopped, M::Stopped, 0)),
        ],
    },
    Scenario {
        name: "out of the work volume: refused, muted, never steered, until back inside or gone",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (play(1, false), ex(Muted, M::WaitingForTracking, 0)),
            (at(1, 0), after(Applied, ex(Playing, M::None, 0))),
            (
                at(2, 25_000),
                after(OutOfRange, ex(Muted, M::CentroidOutOfRange, 0)),
            ),
            (at(3, 1000), after(Applied, ex(Playing, M::None, 1000))),
            (
                at(4, -25_000),
                after(OutOfRange, ex(Muted, M::CentroidOutOfRange, 0)),
            ),
            (gone(5), after(Applied, ex(Muted, M::FingerAbsent, 1000))),
            (at(6, 2000), after(Applied, ex(Playing, M::None, 2000))),
        ],
    },
    Scenario {
        name: "playing another slot while one plays keeps the gate open and accepts a restarted count",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (UPLOAD_0, ex(Idle, M::None, 0)),
            (play(1, false), ex(Muted, M::WaitingForTracking, 0)),
            (at(7, 1000), after(Applied, ex(Playing, M::None, 1000))),
            (play(0, false), ex(Playing, M::None, 1000)),
            (at(1, 500), after(Applied, ex(Playing, M::None, 500))),
            (at(1, 0), after(Stale, ex(Playing, M::None, 500))),
        ],
    },
    Scenario {
        name: "a slot taking over re-checks the last centroid against its own work volume",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (NARROW_0, ex(Idle, M::None, 0)),
            (play(1, false), ex(Muted, M::WaitingForTracking, 0)),
            (at(1, 5000), after(Applied, ex(Playing, M::None, 5000))),
            (play(0, false), ex(Playing, M::None, 5000)),
            // Past the loop end: the narrow slot plays and the last
            // centroid (stale by now) lies outside its volume, which names
            // the mute first.
            (Step::Wait(300), ex(Muted, M::CentroidOutOfRange, 0)),
            (at(2, 1000), after(Applied, ex(Playing, M::None, 1000))),
            (
                at(3, 5000),
                after(OutOfRange, ex(Muted, M::CentroidOutOfRange, 0)),
            ),
        ],
    },
    Scenario {
        name: "a timed play stops by itself after its steps, counted at the limit and frozen",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (play_for(1), ex(Playing, M::None, 0).slots(Some(1), None)),
            (Step::Wait(300), timed_out(1)),
            (Step::Wait(100), timed_out(1)),
        ],
    },
    Scenario {
        name: "a slot played while another plays takes over at the cycle end; its timed play counts from there",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (UPLOAD_0, ex(Idle, M::None, 0)),
            (play(1, true), ex(Playing, M::None, 0).slots(Some(1), None)),
            (play_for(0), ex(Playing, M::None, 0).slots(Some(1), Some(0))),
            // Past the cycle end (≤ 201 ms) and the 30 steps after it.
            (Step::Wait(500), timed_out(0)),
        ],
    },
    Scenario {
        name: "stop drops a queued slot: it never takes over",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (UPLOAD_0, ex(Idle, M::None, 0)),
            (play(1, true), ex(Playing, M::None, 0).slots(Some(1), None)),
            (
                play(0, true),
                ex(Playing, M::None, 0).slots(Some(1), Some(0)),
            ),
            (Step::Stop, ex(Stopped, M::Stopped, 0).slots(Some(1), None)),
            (STALE_WAIT, ex(Stopped, M::Stopped, 0).slots(Some(1), None)),
        ],
    },
    Scenario {
        name: "an upload that carries nothing is refused; the slot's old entry and what plays stay",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (UPLOAD_0, ex(Idle, M::None, 0)),
            (play(1, true), ex(Playing, M::None, 0).slots(Some(1), None)),
            (
                upload_empty(0, Empty::Steps),
                after(BadInput, ex(Playing, M::None, 0).slots(Some(1), None)),
            ),
            (
                upload_empty(0, Empty::Levels),
                after(BadInput, ex(Playing, M::None, 0).slots(Some(1), None)),
            ),
            // Slot 0 still holds its entry: it queues.
            (
                play(0, true),
                ex(Playing, M::None, 0).slots(Some(1), Some(0)),
            ),
        ],
    },
    Scenario {
        name: "a slot never uploaded is refused as not committed and nothing plays",
        steps: &[
            (
                play(1, true),
                after(NotCommitted, ex(Idle, M::None, 0).slots(None, None)),
            ),
            (
                play_for(1),
                after(NotCommitted, ex(Idle, M::None, 0).slots(None, None)),
            ),
        ],
    },
    Scenario {
        name: "a centroid numbered 0, the wire's none, is stale and changes nothing",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (play(1, false), ex(Muted, M::WaitingForTracking, 0)),
            (
                at(0, 1000),
                after(Stale, ex(Muted, M::WaitingForTracking, 0)),
            ),
            (at(1, 1000), after(Applied, ex(Playing, M::None, 1000))),
            (at(0, 0), after(Stale, ex(Playing, M::None, 1000))),
        ],
    },
    Scenario {
        name: "stop then play starts a new session: old centroids forgotten",
        steps: &[
            (UPLOAD, ex(Idle, M::None, 0)),
            (play(1, false), ex(Muted, M::WaitingForTracking, 0)),
            (at(9, 1000), after(Applied, ex(Playing, M::None, 1000))),
            (Step::Stop, ex(Stopped, M::Stopped, 0)),
            (play(1, false), ex(Muted, M::WaitingForTracking, 0)),
            (at(1, 0), after(Applied, ex(Playing, M::None, 0))),
        ],
    },
];

/// Runs every scenario, each on a device from `open`, uploading `wide`
/// (work volume ≥ 20 mm) and `narrow` (≤ 2 mm) plans made for that
/// device. Returns one line per disagreement (empty: the device conforms).
pub fn run(
    open: &mut dyn FnMut() -> anyhow::Result<Dut>,
    wide: &Plan,
    narrow: &Plan,
) -> anyhow::Result<Vec<String>> {
    let mut failures = Vec::new();
    for sc in SCENARIOS {
        let mut dut = open()?;
        if let Err(e) = run_one(&mut dut, sc, wide, narrow, &mut failures) {
            failures.push(format!("{}: {e:#}", sc.name));
        }
    }
    Ok(failures)
}

fn run_one(
    dut: &mut Dut,
    sc: &Scenario,
    wide: &Plan,
    narrow: &Plan,
    failures: &mut Vec<String>,
) -> anyhow::Result<()> {
    let center = wide.sequence.header.center_um;
    let n = u64::from(wide.sequence.header.steps);
    for (i, (step, want)) in sc.steps.iter().enumerate() {
        let mut outcome = None;
        match *step {
            Step::Upload { slot, narrow: n } => {
                dut.dev.upload(if n { narrow } else { wide }, Some(slot))?;
            }
            Step::UploadEmpty { slot, what } => {
                let mut empty = wide.clone();
                let s = &mut empty.sequence;
                match what {
                    Empty::Steps => {
                        s.header.steps = 0;
                        s.phases.clear();
                        s.intensity_table = None;
                    }
                    Empty::Levels => s.intensity_table = Some(Vec::new()),
                }
                outcome = refused(dut.dev.upload(&empty, Some(slot)).map(|_| ()))?;
            }
            Step::Play {
                slot,
                at,
                untracked,
            } => outcome = refused(dut.dev.play_at(slot, at, untracked))?,
            Step::PlayFor {
                slot,
                steps,
                untracked,
            } => outcome = refused(dut.dev.play_for(slot, untracked, steps))?,
            Step::Stop => dut.dev.stop()?,
            Step::Centroid {
                seq,
                dx_um,
                present,
            } => {
                let c = Centroid {
                    host_time_us: 0,
                    seq,
                    present,
                    pos_um: [center[0] + dx_um, center[1], center[2]],
                };
                outcome = Some(match dut.dev.centroid(&c) {
                    Ok(CentroidOutcome::Applied) => Outcome::Applied,
                    Ok(CentroidOutcome::OutOfRange) => Outcome::OutOfRange,
                    Err(e) if e.refusal() == Some(NackCode::OutOfOrder) => Outcome::Stale,
                    Err(e) => return Err(e.into()),
                });
            }
            Step::Wait(ms) => (dut.wait)(dut.dev.as_mut(), Duration::from_millis(ms))?,
        }
        let st = dut.dev.status()?;
        let got = Expect {
            state: st.state,
            mute: st.mute_reason,
            correction_x_um: st.correction_um[0],
            outcome,
            // Compared only where the table checks them.
            slots: want.slots.map(|_| (st.slot, st.queued_slot)),
            played: want
                .played
                .map(|_| u64::from(st.cycles) * n + u64::from(st.step)),
        };
        let other_axes = st.correction_um[1] != 0 || st.correction_um[2] != 0;
        if got != *want || other_axes {
            failures.push(format!(
                "{} on {}: step {i} ({step:?}): expected {want:?}, got {got:?} (correction {:?})",
                sc.name,
                dut.dev.describe(),
                st.correction_um
            ));
        }
    }
    Ok(())
}

/// A refusal the table names, as its outcome (`None`: done); any other
/// error ends the scenario.
fn refused(r: crate::device::backend::Result<()>) -> anyhow::Result<Option<Outcome>> {
    use crate::device::backend::ErrorKind;
    match r {
        Ok(()) => Ok(None),
        Err(e) if e.kind() == ErrorKind::Input => Ok(Some(Outcome::BadInput)),
        Err(e) if e.refusal() == Some(NackCode::NotCommitted) => Ok(Some(Outcome::NotCommitted)),
        Err(e) => Err(e.into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::Clock;
    use crate::device::autd3::Autd3Backend;
    use crate::plan::scene::Scene;
    use crate::plan::stimulus::Stimulus;
    use crate::plan::target::Target;

    /// The paper's LM-S for `target` on the built-in scene: wide (the
    /// default 20 mm volume) and narrow (2 mm).
    fn plans(target: &Target) -> (Plan, Plan) {
        let wide = Stimulus::default()
            .plan_for(target, Scene::default())
            .unwrap()
            .plan;
        let mut narrow = wide.clone();
        narrow.sequence.set_max_offset_mm(2.0).unwrap();
        assert!(wide.sequence.header.max_offset_um >= 20_000);
        (wide, narrow)
    }

    /// A fresh simulated LM firmware in process on a manual clock.
    fn sim_dut() -> anyhow::Result<Dut> {
        let clock = Clock::manual_at_us(1_000_000);
        let (dev, _) = crate::device::connect::simulated(clock.clone())?;
        Ok(Dut {
            dev: Box::new(dev),
            wait: Box::new(move |_, d| {
                clock.advance(d);
                Ok(())
            }),
        })
    }

    fn assert_conforms(failures: Vec<String>) {
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    #[test]
    fn the_simulated_lm_firmware_conforms() {
        let (wide, narrow) = plans(&Target::Lm);
        let failures = run(&mut sim_dut, &wide, &narrow).unwrap();
        assert_conforms(failures);
    }

    #[test]
    fn the_autd3_emulator_conforms() {
        let (wide, narrow) = plans(&Target::Autd3);
        let failures = run(
            &mut || {
                let clock = Clock::manual_at_us(1_000_000);
                let (dev, _) = Autd3Backend::open_emulator(&Scene::default(), clock.clone(), None)?;
                Ok(Dut {
                    dev: Box::new(dev),
                    wait: Box::new(move |_, d| {
                        clock.advance(d);
                        Ok(())
                    }),
                })
            },
            &wide,
            &narrow,
        )
        .unwrap();
        assert_conforms(failures);
    }

    /// The table is not vacuous: a device that ignored the work volume
    /// (here: a policy fed no volume) would disagree.
    #[test]
    fn a_device_that_breaks_a_rule_is_caught() {
        let (wide, _) = plans(&Target::Lm);
        // Both "plans" wide: the take-over scenario expects a mute that a
        // 20 mm volume never gives.
        let failures = run(&mut sim_dut, &wide, &wide).unwrap();
        assert!(
            failures.iter().any(|f| f.contains("taking over")),
            "{failures:?}"
        );
    }
}
