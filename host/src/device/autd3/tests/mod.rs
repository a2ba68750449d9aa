//! The AUTD3 backend against autd3's firmware emulator.

use crate::clock::Clock;
use std::time::Duration;

use autd3::core::environment::Environment;
use autd3::core::gain::{Gain, GainCalculator, GainCalculatorGenerator, TransducerMask};
use autd3::prelude::{Focus, FocusOption, Point3, Segment};
use lm_fw_core::correction::compute_offsets;

use super::*;
use crate::device::backend::{Backend, CentroidOutcome};
use crate::error::InputError;
use crate::plan::grid::{self as timing, GridTiming};
use crate::plan::scene::{Device, Scene};
use crate::plan::sequence::{Plan, Synthesis};
use crate::plan::trajectory::{LmParams, Steps};
use lm_proto::{Centroid, DeviceState, MuteReason};

fn paper_scene() -> Scene {
    Scene::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/paper.toml"
    )))
    .unwrap()
}

fn scenes() -> [Scene; 2] {
    [Scene::default(), paper_scene()]
}

fn lm(scene: &Scene, radius_mm: f64, foci: usize) -> (Plan, GridTiming) {
    let mut p = LmParams::paper(scene.center_mm);
    p.cycle.radius_mm = radius_mm;
    p.cycle.foci = foci;
    timing::plan(&p, scene, &Synthesis::Linear).unwrap()
}

fn open(scene: &Scene) -> (Autd3Backend, EmulatorHandle, Clock) {
    let clock = Clock::manual();
    let (b, h) = Autd3Backend::open_emulator(scene, clock.clone(), None).unwrap();
    (b, h, clock)
}

/// The built-in scene and a backend on it.
fn open_default() -> (Scene, Autd3Backend, EmulatorHandle, Clock) {
    let scene = Scene::default();
    let (b, h, clock) = open(&scene);
    (scene, b, h, clock)
}

/// The built-in scene and a backend on it playing a 3 mm LM-S (`x`) from
/// slot 1, and a 4-focus LM-M of `radius_mm` (`y`) to upload into slot 0
/// while it plays.
fn playing_beside(radius_mm: f64) -> (Scene, Autd3Backend, EmulatorHandle, Clock, Plan, Plan) {
    let (scene, mut b, h, clock) = open_default();
    let (x, _) = lm(&scene, 3.0, 1);
    let (y, _) = lm(&scene, radius_mm, 4);
    b.upload(&x, Some(1)).unwrap();
    b.play(1, true).unwrap();
    (scene, b, h, clock, x, y)
}

/// Uploads a 3 mm, one-focus LM on `scene` into a free slot; returns the
/// plan and the slot.
fn upload_lm_s(b: &mut Autd3Backend, scene: &Scene) -> (Plan, u8) {
    let (plan, _) = lm(scene, 3.0, 1);
    let slot = b.upload(&plan, None).unwrap().slot;
    (plan, slot)
}

/// The default stimulus at half intensity, planned for an AUTD3 rig of
/// `scene`.
fn half_intensity(scene: &Scene) -> Plan {
    crate::plan::stimulus::Stimulus {
        intensity: 0.5,
        ..crate::plan::stimulus::Stimulus::default()
    }
    .plan_for(&crate::plan::target::Target::Autd3, scene.clone())
    .unwrap()
    .plan
}

/// Asserts the backend's status says `state` for `reason`; returns it.
#[track_caller]
fn assert_state(b: &mut Autd3Backend, state: DeviceState, reason: MuteReason) -> lm_proto::Status {
    let st = b.status().unwrap();
    assert_eq!((st.state, st.mute_reason), (state, reason), "{st:?}");
    st
}

fn is_input_error(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.is::<InputError>())
}

fn stm_segment(h: &EmulatorHandle) -> Segment {
    h.with_cpus(|c| {
        let s = c[0].fpga().current_stm_segment();
        assert!(c.iter().all(|c| c.fpga().current_stm_segment() == s));
        s
    })
}

/// Whether every transducer on every board is silent (intensity 0).
fn silent(h: &EmulatorHandle) -> bool {
    h.with_cpus(|c| {
        c.iter()
            .all(|cpu| cpu.fpga().drives().iter().all(|d| d.intensity.0 == 0))
    })
}

/// The first board's phase-correction bytes.
fn first_board_correction(h: &EmulatorHandle) -> Vec<u8> {
    h.with_cpus(|cpus| {
        cpus[0]
            .fpga()
            .phase_correction()
            .iter()
            .map(|p| p.0)
            .collect()
    })
}

fn modulation(h: &EmulatorHandle) -> u8 {
    h.with_cpus(|c| c[0].fpga().modulation())
}

#[test]
fn autd3_places_the_transducers_where_lmhost_plans_them() {
    for scene in scenes() {
        let (b, _h, _c) = open(&scene);
        let e = geometry::max_position_error_mm(&scene, b.geometry());
        assert!(
            e < geometry::POSITION_TOLERANCE_MM,
            "{}: {e} mm",
            scene.name
        );
    }
}

#[test]
fn rig_mismatch_and_overlap_are_input_errors() {
    let scene = Scene::default();
    let e = Autd3Backend::open_emulator(&scene, Clock::manual(), Some(2))
        .err()
        .unwrap();
    assert!(is_input_error(&e), "{e:#}");
    assert!(
        e.to_string().contains("4 devices but the AUTD3 rig has 2"),
        "{e}"
    );
    let mut overlap = Scene::default();
    overlap.devices[1] = Device::new([-90.0, -75.7, 0.0], [0.0; 3]);
    let e = Autd3Backend::open_emulator(&overlap, Clock::manual(), None)
        .err()
        .unwrap();
    assert!(is_input_error(&e), "{e:#}");
    assert!(e.to_string().contains("devices 0 and 1 overlap"), "{e}");
    // Real links are opt-in features: an operation error, not bad input.
    let e = Autd3Backend::open(&Autd3Port::parse("autd3:soem:eth0").unwrap(), &scene)
        .err()
        .unwrap();
    assert!(!is_input_error(&e));
    assert!(e.to_string().contains("autd3-soem"), "{e}");
}

#[test]
fn gain_stm_reads_back_byte_exact_for_lm_s_and_lm_m() {
    for scene in scenes() {
        let (mut b, h, _c) = open(&scene);
        for a in [2.0, 3.0, 4.0, 5.0, 6.0] {
            for foci in [1, 4] {
                let (plan, g) = lm(&scene, a, foci);
                let r = b.upload(&plan, None).unwrap();
                assert_eq!(
                    r.readback_mismatches(),
                    Some(0),
                    "{} A={a} foci={foci}",
                    scene.name
                );
                assert_eq!((r.steps, r.dwell_us), (g.steps, f64::from(g.dwell_us)));
                // The check can fail: other phases do not match.
                let mut other = plan.sequence.phases.clone();
                other[7] ^= 0x10;
                assert_eq!(b.readback_mismatches(r.slot, &other), Some(1));
                let seg = if r.slot == 0 {
                    Segment::S0
                } else {
                    Segment::S1
                };
                h.with_cpus(|c| {
                    for cpu in c {
                        assert_eq!(cpu.fpga().stm_freq_divide(seg), g.divide);
                        assert_eq!(cpu.fpga().stm_cycle(seg), g.steps);
                    }
                });
            }
        }
    }
}

#[test]
fn paper_timing_lands_on_the_fpga_divide() {
    let scene = paper_scene();
    let (mut b, h, _c) = open(&scene);
    let (plan, g) = lm(&scene, 3.0, 4);
    assert_eq!((g.steps, g.dwell_us), (82, 2450));
    let r = b.upload(&plan, Some(1)).unwrap();
    assert!((r.freq_hz - 4.977).abs() < 1e-3);
    h.with_cpus(|c| {
        let f = c[0].fpga();
        assert_eq!(f.stm_freq_divide(Segment::S1), 98);
        assert!(f.is_stm_gain_mode(Segment::S1));
        // Written looping forever (rep 0xFFFF): autd3 firmware switches
        // into an endless segment at once, so a play from silence sounds
        // at once wherever the slot sits.
        assert_eq!(f.stm_loop_count(Segment::S1), 0xFFFF);
    });
    // A dwell off the grid is refused as bad input.
    let mut off = plan.clone();
    off.trajectory.dwell_s = 2439e-6;
    let e = b.upload(&off, None).unwrap_err();
    assert_eq!(e.kind(), crate::device::backend::ErrorKind::Input, "{e:#}");
}

/// Issue 31.4: a read-back that differs is the upload's own failure, on
/// every caller (upload, stream, session, study, Python): the slot is
/// left empty, so nothing can play what was not planned.
#[test]
fn a_damaged_upload_fails_and_leaves_its_slot_empty() {
    let (scene, mut b, h, _c, _, y) = playing_beside(5.0);
    h.damage_next_stm_upload();
    let e = b.upload(&y, Some(0)).unwrap_err();
    assert_eq!(e.kind(), crate::device::backend::ErrorKind::Failed, "{e:#}");
    assert!(
        e.to_string()
            .contains("holds 1 phases in slot 0 that differ from the plan"),
        "{e}"
    );
    assert_eq!(b.slot_steps(0), None);
    assert!(b.play(0, true).is_err(), "a damaged slot does not play");
    assert_eq!(
        b.status().unwrap().slot,
        Some(1),
        "the playing slot plays on"
    );
    assert_eq!(stm_segment(&h), Segment::S1);
    // Sent again undamaged, it goes through and reads back clean.
    let r = b.upload(&y, Some(0)).unwrap();
    assert_eq!(r.readback_mismatches(), Some(0));
    // The shared upload path says the same (what the CLI, the session and
    // Python call).
    h.damage_next_stm_upload();
    let planned = crate::plan::stimulus::Stimulus::default()
        .plan_for(&crate::plan::target::Target::Autd3, scene.clone())
        .unwrap();
    let e = crate::device::upload::upload(
        &mut b,
        &planned,
        Some(0),
        crate::device::upload::Play::Untracked,
    )
    .unwrap_err();
    assert!(format!("{e:#}").contains("differ from the plan"), "{e:#}");
    assert_eq!(b.status().unwrap().slot, Some(1));
}

#[test]
fn the_emulator_runs_the_firmware_these_crates_speak() {
    let (_, mut b, _h, _c) = open_default();
    let info = b.info().unwrap();
    assert_eq!(info.firmware.len(), 4);
    for f in &info.firmware {
        assert!(f.contains(&firmware::needed()), "{f}");
    }
}

#[test]
fn corrections_read_back_equal_the_cores_offsets() {
    for scene in scenes() {
        let (mut b, h, _c) = open(&scene);
        let (plan, _) = lm(&scene, 3.0, 4);
        let slot = b.upload(&plan, None).unwrap().slot;
        b.play(slot, false).unwrap();
        let c0 = plan.sequence.header.center_um;
        let positions = correction::packed_positions_um(&scene).unwrap();
        for (seq, d) in [
            [0, 0, 0],
            [1500, -800, 0],
            [-3000, 2000, 1200],
            [400, 4000, -2500],
        ]
        .into_iter()
        .enumerate()
        {
            let c = [c0[0] + d[0], c0[1] + d[1], c0[2] + d[2]];
            b.centroid(&Centroid {
                host_time_us: 0,
                seq: seq as u32 + 1,
                present: true,
                pos_um: c,
            })
            .unwrap();
            let mut want = vec![0u8; scene.transducer_count()];
            compute_offsets(&positions, c0, c, 340.0, &mut want);
            let got: Vec<u8> = h.with_cpus(|cpus| {
                cpus.iter()
                    .flat_map(|c| c.fpga().phase_correction().into_iter().map(|p| p.0))
                    .collect()
            });
            assert_eq!(got, want, "{} centroid {c:?}", scene.name);
            if d != [0, 0, 0] {
                assert!(want.iter().any(|&x| x != 0));
            }
        }
    }
}

#[test]
fn mutes_until_tracked_on_absence_and_when_stale() {
    let (scene, mut b, h, clock) = open_default();
    assert_eq!(modulation(&h), safety::MUTED, "muted from the start");
    let (plan, slot) = upload_lm_s(&mut b, &scene);
    b.play(slot, false).unwrap();
    assert_eq!(modulation(&h), safety::MUTED, "muted until tracked");
    let c = plan.sequence.header.center_um;
    let upd = |seq, present| Centroid {
        host_time_us: 0,
        seq,
        present,
        pos_um: c,
    };
    b.centroid(&upd(1, true)).unwrap();
    assert_eq!(modulation(&h), safety::FULL);
    b.centroid(&upd(2, false)).unwrap();
    assert_eq!(modulation(&h), safety::MUTED, "absent");
    assert!(b.centroid(&upd(2, true)).is_err(), "stale sequence number");
    b.centroid(&upd(3, true)).unwrap();
    assert_eq!(modulation(&h), safety::FULL);
    clock.advance(Duration::from_millis(100));
    b.tick().unwrap();
    assert_eq!(modulation(&h), safety::FULL, "100 ms is not yet stale");
    clock.advance(Duration::from_millis(1));
    b.tick().unwrap();
    assert_eq!(modulation(&h), safety::MUTED, "stale");
    let st = b.status().unwrap();
    assert_eq!(st.state, DeviceState::Muted);
    assert_eq!(st.mute_reason, MuteReason::TrackingStale);
    // Untracked play sounds at once.
    b.play(slot, true).unwrap();
    assert_eq!(modulation(&h), safety::FULL);
    // Stop: muted at once, as the firmware; the segment stays, so a play
    // resumes without an upload (drop writes the null gain: see below).
    b.stop().unwrap();
    assert_eq!(modulation(&h), safety::MUTED);
    assert_eq!(b.status().unwrap().state, DeviceState::Stopped);
    b.play(slot, true).unwrap();
    assert_eq!(modulation(&h), safety::FULL);
}

#[test]
fn drop_leaves_the_array_silent() {
    let (scene, mut b, h, _c) = open_default();
    let (_, slot) = upload_lm_s(&mut b, &scene);
    b.play(slot, true).unwrap();
    assert_eq!(modulation(&h), safety::FULL);
    assert!(h.with_cpus(|c| c[0].fpga().drives().iter().all(|d| d.intensity.0 == 0xFF)));
    drop(b);
    // Our drop mutes and writes a null gain; autd3's own close then clears
    // the devices (modulation back to 255, gain still null): silent.
    assert!(silent(&h));
}

#[test]
fn link_broken_mid_upload_keeps_the_playing_segment() {
    let (_, mut b, h, _c, x, y) = playing_beside(6.0);
    h.break_after(Some(5));
    let e = b.upload(&y, Some(0)).unwrap_err();
    assert_eq!(
        e.kind(),
        crate::device::backend::ErrorKind::Failed,
        "a failed operation, exit 1: {e:#}"
    );
    h.break_after(None);
    assert_eq!(stm_segment(&h), Segment::S1);
    assert_eq!(b.readback_mismatches(1, &x.sequence.phases), Some(0));
    let st = b.status().unwrap();
    assert_eq!(st.slot, Some(1));
    assert_eq!(b.slot_steps(0), None, "the half-written slot is empty");
    assert!(b.play(0, true).is_err());
    assert_eq!(stm_segment(&h), Segment::S1);
    // Repaired, the same upload goes through.
    assert_eq!(
        b.upload(&y, Some(0)).unwrap().readback_mismatches(),
        Some(0)
    );
}

#[test]
fn planned_phases_equal_autd3s_focus_gain() {
    for scene in scenes() {
        let (b, _h, _c) = open(&scene);
        let mut p = LmParams::paper(scene.center_mm);
        p.cycle.radius_mm = 0.0;
        p.cycle.steps = Steps::Count(2);
        let (plan, _) = timing::plan(&p, &scene, &Synthesis::Linear).unwrap();
        let f = plan.trajectory.drive_step(0)[0];
        let geo = b.geometry();
        let mut env = Environment::new();
        env.sound_speed = scene.sound_speed_m_s as f32 * 1000.0;
        let mut generator = Focus::new(
            Point3::new(f[0] as f32, f[1] as f32, f[2] as f32),
            FocusOption::default(),
        )
        .init(geo, &env, &TransducerMask::AllEnabled)
        .unwrap();
        let mut worst = 0i32;
        for dev in geo.iter() {
            let calc = generator.generate(dev);
            for tr in dev.iter() {
                let ours = plan.sequence.step(0)[dev.idx() * 249 + tr.idx()];
                let theirs = calc.calc(tr).phase.0;
                let d = i32::from(ours.wrapping_sub(theirs) as i8).abs();
                worst = worst.max(d);
            }
        }
        assert_eq!(worst, 0, "{}: worst difference {worst} LSB", scene.name);
    }
}

#[test]
fn remote_link_without_a_server_fails_with_one_line() {
    // Port 1 on localhost: nothing listens, the connection is refused.
    let port = Autd3Port::parse("autd3:remote:127.0.0.1:1").unwrap();
    let e = Autd3Backend::open(&port, &Scene::default()).err().unwrap();
    assert!(!is_input_error(&e), "{e:#}");
    assert!(e.to_string().contains("autd3:remote:127.0.0.1:1"), "{e}");
}

#[test]
fn status_reports_the_firmwares_mute_reasons_and_refuses_out_of_range() {
    let (scene, mut b, h, _c) = open_default();
    assert_eq!(b.status().unwrap().state, DeviceState::Idle);
    let (plan, slot) = upload_lm_s(&mut b, &scene);
    b.play(slot, false).unwrap();
    let st = b.status().unwrap();
    assert_eq!(st.state, DeviceState::Muted);
    assert_eq!(st.mute_reason, MuteReason::WaitingForTracking);
    let c = plan.sequence.header.center_um;
    let max = plan.sequence.header.max_offset_um as i32;
    let at = |seq, dx: i32, present| Centroid {
        host_time_us: 0,
        seq,
        present,
        pos_um: [c[0] + dx, c[1], c[2]],
    };
    assert_eq!(
        b.centroid(&at(1, 1000, true)).unwrap(),
        CentroidOutcome::Applied
    );
    let st = assert_state(&mut b, DeviceState::Playing, MuteReason::None);
    assert_eq!(st.correction_um, [1000, 0, 0]);
    assert_eq!(st.last_centroid_seq, 1);
    assert_eq!(modulation(&h), safety::FULL);
    // Outside the work volume: refused, muted, offsets unchanged.
    let before = first_board_correction(&h);
    assert_eq!(
        b.centroid(&at(2, max + 1000, true)).unwrap(),
        CentroidOutcome::OutOfRange
    );
    let st = b.status().unwrap();
    assert_eq!(st.mute_reason, MuteReason::CentroidOutOfRange);
    assert_eq!(modulation(&h), safety::MUTED);
    let after = first_board_correction(&h);
    assert_eq!(before, after);
    // Back in range: sounds again.
    b.centroid(&at(3, 0, true)).unwrap();
    assert_eq!(b.status().unwrap().mute_reason, MuteReason::None);
    b.centroid(&at(4, 0, false)).unwrap();
    assert_eq!(b.status().unwrap().mute_reason, MuteReason::FingerAbsent);
    b.stop().unwrap();
    assert_state(&mut b, DeviceState::Stopped, MuteReason::Stopped);
}

/// Issue 10: a live source that goes silent without ending (a tracker
/// that stopped sending) must not leave the array sounding: the streaming
/// loop keeps ticking the host-side gate while it waits for a sample.
#[test]
fn streaming_mutes_when_a_live_source_goes_silent() {
    use crate::sense::stream::Sample;
    use crate::sense::stream::filter::Passthrough;
    use crate::sense::stream::run::{Pace, on_thread, stream};

    let scene = Scene::default();
    let (mut b, h, clock) = open(&scene);
    let (plan, _) = lm(&scene, 3.0, 1);
    let slot = b.upload(&plan, None).unwrap().slot;
    b.play(slot, false).unwrap();
    assert_eq!(modulation(&h), safety::MUTED, "muted until tracked");

    let (tx, rx) = std::sync::mpsc::channel::<anyhow::Result<Sample>>();
    let center = scene.center_mm;
    let acked = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let acked_w = acked.clone();
    // The tracker's side: 5 present samples, then silence while the loop
    // is watched through the emulated devices; only then does it end.
    let watcher = std::thread::spawn(move || {
        let wait_for = |done: &dyn Fn() -> bool| {
            // A guard against hanging, not a timing goal.
            let give_up = std::time::Instant::now() + Duration::from_secs(5);
            while std::time::Instant::now() < give_up {
                if done() {
                    return true;
                }
                std::thread::sleep(Duration::from_millis(1));
            }
            false
        };
        for i in 0..5 {
            let s = Sample {
                t_s: i as f64 / 90.0,
                pos_mm: center,
                present: true,
            };
            tx.send(Ok(s)).unwrap();
        }
        let all_applied = wait_for(&|| acked_w.load(std::sync::atomic::Ordering::SeqCst) == 5);
        let sounding = modulation(&h) == safety::FULL;
        // The tracker goes silent for 150 ms of the backend's time.
        clock.advance(Duration::from_millis(150));
        let muted_while_silent = wait_for(&|| modulation(&h) == safety::MUTED);
        drop(tx);
        (all_applied && sounding, muted_while_silent)
    });
    let report = stream(
        &mut b,
        on_thread(move || rx).unwrap(),
        &mut Passthrough,
        |p| p,
        Pace::Arrival,
        |_, _, _| {
            acked.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            Ok(())
        },
    )
    .unwrap();
    let (sounding, muted_while_silent) = watcher.join().unwrap();
    assert!(sounding, "the 5 samples were applied and the array sounded");
    assert_eq!(report.samples, 5);
    assert_eq!(report.acked, 5);
    assert!(
        muted_while_silent,
        "the array muted while the source was silent, before it ended"
    );
    let st = b.status().unwrap();
    assert_eq!(st.state, DeviceState::Muted);
    assert_eq!(st.mute_reason, MuteReason::TrackingStale);
}

#[test]
fn a_stimulus_intensity_is_the_output_level_while_it_sounds() {
    let (scene, mut b, h, _clock) = open_default();
    let half = half_intensity(&scene);
    assert_eq!(half.sequence.header.intensity, 128);
    let slot = b.upload(&half, None).unwrap().slot;
    b.play(slot, true).unwrap();
    assert_eq!(modulation(&h), 128, "half intensity while sounding");
    b.stop().unwrap();
    assert_eq!(modulation(&h), safety::MUTED);
    // A full-intensity stimulus in the other slot sounds at full level.
    let (full, _) = lm(&scene, 3.0, 1);
    let other = b.upload(&full, None).unwrap().slot;
    assert_ne!(other, slot);
    b.play(other, true).unwrap();
    assert_eq!(modulation(&h), safety::FULL);
}

mod play;
