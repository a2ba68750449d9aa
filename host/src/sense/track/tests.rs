//! Hard cases and accuracy of the tracker on the synthetic finger.

use super::camera::CameraSetup;
use super::contact::{Tracker, reference};
use super::intrinsics::Intrinsics;
use super::presence::Hysteresis;
use super::source::{FrameSource, Replay};
use super::synth::{FingerSim, background_of};
use super::{FrameResult, Pipeline};
use crate::geom::{add, scale};
use crate::plan::scene::Scene;
use crate::rng::SplitMix64;
use crate::sense::stream::filter::FilterKind;

fn paper() -> Scene {
    Scene::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/paper.toml"
    )))
    .unwrap()
}

fn setup() -> (Scene, CameraSetup, Intrinsics, Tracker) {
    let scene = paper();
    let setup = CameraSetup::of_scene(&scene).unwrap();
    let intr = Intrinsics::D435_848X480;
    (scene, setup, intr, Tracker::new(intr, setup))
}

/// [`setup`] with the synthetic finger over the scene's background.
fn setup_sim() -> (CameraSetup, Intrinsics, Tracker, FingerSim) {
    let (scene, setup, intr, tr) = setup();
    (
        setup,
        intr,
        tr,
        FingerSim::new(setup, intr, background_of(&scene)),
    )
}

/// A finger at tip time `t_s` of the cycle, noise-free.
fn frame_at(sim: &FingerSim, t_s: f64) -> Vec<u16> {
    let mut f = Vec::new();
    sim.render_clean(sim.tip_mm(t_s), &mut f);
    f
}

fn tmp(name: &str) -> crate::files::Scratch {
    crate::files::scratch_file("track", name)
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
}

#[test]
fn fast_path_matches_the_full_frame_reference() {
    let (setup, intr, tr, sim) = setup_sim();
    let mut rng = SplitMix64::new(7);
    for t in [0.5, 1.0, 3.0, 3.3] {
        let mut f = frame_at(&sim, t);
        // Salt the frame with random depths so points near every box face
        // (and outside the rectangle) are exercised.
        for v in f.iter_mut() {
            if rng.below(4) == 0 {
                *v = (2000 + rng.below(2000)) as u16;
            }
        }
        let fast = tr.track(&f);
        let slow = reference(&intr, &setup, &f);
        assert_eq!(fast.points, slow.points, "t {t}");
        if let (Some(a), Some(b)) = (fast.centroid_mm, slow.centroid_mm) {
            assert!(close(a, b, 1e-9), "{a:?} {b:?}");
        }
        assert!(fast.points > 0 || t == 0.5);
    }
    // The rectangle is a small part of the frame.
    assert!(tr.roi().pixels() * 100 < (intr.pinhole.width * intr.pinhole.height) as usize);
}

#[test]
fn empty_box() {
    let (_, _, tr, sim) = setup_sim();
    let f = frame_at(&sim, 5.8); // away
    assert!(f.iter().any(|v| *v > 0), "the display is in view");
    let c = tr.track(&f);
    assert_eq!((c.points, c.centroid_mm), (0, None));
}

/// Every pixel at `depth`: tracked by the fast path and the reference,
/// both must find nothing in the box.
fn uniform_frame_is_empty(depth: u16) {
    let (_, setup, intr, tr) = setup();
    let f = vec![depth; (intr.pinhole.width * intr.pinhole.height) as usize];
    let c = tr.track(&f);
    assert_eq!((c.points, c.centroid_mm), (0, None), "depth {depth}");
    assert_eq!(reference(&intr, &setup, &f).points, 0, "depth {depth}");
}

#[test]
fn all_zero_frame() {
    uniform_frame_is_empty(0);
}

#[test]
fn saturated_depth_65535() {
    // 6.5 m away: nothing inside the box, a defined empty result.
    uniform_frame_is_empty(65535);
}

#[test]
fn finger_at_the_box_edge() {
    let (setup, intr, tr, sim) = setup_sim();
    let tb = setup.track_box;
    // Tip 5 mm off along a: half the pad is outside the box's side.
    let centre = sim.tip_mm(2.0).unwrap();
    let edge = add(centre, scale(tb.axes[0], 5.0));
    let mut f = Vec::new();
    sim.render_clean(Some(centre), &mut f);
    let full = tr.track(&f);
    sim.render_clean(Some(edge), &mut f);
    let half = tr.track(&f);
    assert!(
        half.points > 0 && half.points < full.points,
        "{half:?} {full:?}"
    );
    let c = half.centroid_mm.unwrap();
    assert!(tb.contains(c), "centroid inside the box");
    let along = crate::geom::dot(tb.axes[0], crate::geom::sub(c, tb.center_mm));
    assert!(along > 1.0, "centroid moves towards the edge: {along}");
    let r = reference(&intr, &setup, &f);
    assert_eq!(r.points, half.points);
}

#[test]
fn holes_95_percent() {
    let (setup, _, tr, mut sim) = setup_sim();
    sim.holes = 0.95;
    sim.noise_mm = 0.5;
    let mut f = Vec::new();
    let (_, truth) = sim.render(180, &tr, &mut f); // resting at t = 2 s
    assert!(truth.present);
    let c = tr.track(&f);
    // About 5 % of the area survives: under min_points, so not present,
    // but the centroid of what is left is still defined and in the box.
    assert!(c.points < truth.contact.points / 5, "{c:?}");
    assert!(c.points < setup.track_box.min_points);
    if let Some(p) = c.centroid_mm {
        assert!(setup.track_box.contains(p));
    }
    let mut pipe = Pipeline::new(
        tr.clone(),
        Hysteresis::default(),
        FilterKind::Gaussian.build(),
    );
    let r = pipe.step(2.0, &f);
    assert!(!r.present && r.centroid_mm().is_none() && r.filtered_mm.is_none());
}

#[test]
fn a_second_object_in_the_box() {
    let (setup, intr, tr, mut sim) = setup_sim();
    let finger = tr.track(&frame_at(&sim, 2.0));
    // A 3 mm ball near the box's far corner, inside the box.
    let tb = setup.track_box;
    let mut at = tb.center_mm;
    for (k, s) in [(0, -3.5), (1, -3.0), (2, -6.0)] {
        at = add(at, scale(tb.axes[k], s));
    }
    sim.second_object = Some((at, 1.5));
    let f = frame_at(&sim, 2.0);
    let both = tr.track(&f);
    // Defined result: the centroid of everything in the box (the paper's
    // method), pulled towards the second object.
    assert!(both.points > finger.points, "{both:?} {finger:?}");
    let r = reference(&intr, &setup, &f);
    assert_eq!(r.points, both.points);
    assert!(close(
        r.centroid_mm.unwrap(),
        both.centroid_mm.unwrap(),
        1e-9
    ));
    let shift = crate::geom::sub(both.centroid_mm.unwrap(), finger.centroid_mm.unwrap());
    assert!(crate::geom::dot(shift, tb.axes[0]) < 0.0);
}

/// A depth recording `name` of `frames`, each `width × height`.
fn depth_npy(name: &str, width: u32, height: u32, frames: &[&[u16]]) -> crate::files::Scratch {
    let p = tmp(name);
    let mut w = crate::npy::DepthNpyWriter::create(&p, width, height).unwrap();
    for f in frames {
        w.push(f).unwrap();
    }
    w.finish().unwrap();
    p
}

/// The error `Replay::open` gives for these arguments.
fn open_err(path: &std::path::Path, intr: Intrinsics, stamps: Option<Vec<f64>>) -> String {
    let from = std::path::Path::new("t.npy");
    Replay::open(path, intr, stamps.map(|t| (t, from)))
        .err()
        .unwrap()
        .to_string()
}

#[test]
fn wrong_frame_size_or_dtype() {
    let p = depth_npy("small.npy", 64, 48, &[&vec![0; 64 * 48]]);
    let e = open_err(&p, Intrinsics::D435_848X480, None);
    assert!(e.contains("64×48") && e.contains("848×480"), "{e}");
    let q = tmp("f8.npy");
    crate::npy::write_f64(&q, 2, 2, &[0.0; 4]).unwrap();
    let e = open_err(&q, Intrinsics::D435_848X480, None);
    assert!(e.contains("uint16"), "{e}");
}

#[test]
fn truncated_npy() {
    let p = depth_npy("trunc.npy", 8, 8, &[&[1; 64], &[2; 64]]);
    let b = std::fs::read(&p).unwrap();
    std::fs::write(&p, &b[..b.len() - 64]).unwrap();
    let mut i = Intrinsics::D435_848X480;
    i.pinhole.width = 8;
    i.pinhole.height = 8;
    let e = open_err(&p, i, None);
    assert!(e.contains("truncated") && !e.contains('\n'), "{e}");
}

#[test]
fn intrinsics_not_matching_the_frames() {
    let p = depth_npy("mismatch.npy", 640, 480, &[&vec![0; 640 * 480]]);
    let e = open_err(&p, Intrinsics::D435_848X480, None);
    assert!(e.contains("intrinsics say 848×480"), "{e}");
    // Time stamps that do not match the frame count.
    let mut i = Intrinsics::D435_848X480;
    i.pinhole.width = 640;
    let e = open_err(&p, i, Some(vec![0.0, 0.1]));
    assert!(e.contains("t.npy: 2 time stamps for 1 frames"), "{e}");
}

#[test]
fn recording_replays_frame_for_frame() {
    let (_, intr, tr, mut sim) = setup_sim();
    sim.window = Some(tr.roi());
    let p = tmp("rec.npy");
    let mut src = super::source::Synthetic::new(sim, 0.2);
    let mut rec = super::source::Recorder::create(&p, intr, None).unwrap();
    let mut want = Vec::new();
    while let Some(f) = src.next_frame().unwrap() {
        rec.push(&f).unwrap();
        want.push((f.t_s, tr.track(&f.depth)));
    }
    assert_eq!(rec.finish().unwrap(), 18);
    let mut r = Replay::open_with_defaults(&p, None, None).unwrap();
    let mut got = Vec::new();
    while let Some(f) = r.next_frame().unwrap() {
        got.push((f.t_s, tr.track(&f.depth)));
    }
    assert_eq!(got, want);
}

/// The accuracy bar: ≤ 0.2 mm RMS at 0.5 mm depth noise; presence right on
/// every frame away from transitions, at most one frame off at them.
#[test]
fn accuracy_on_the_synthetic_finger_at_half_a_millimetre_of_noise() {
    let (_, _, tr, mut sim) = setup_sim();
    sim.noise_mm = 0.5;
    sim.holes = 0.02;
    // The tracker reads only its rectangle, so render only that.
    sim.window = Some(tr.roi());
    let mut f = Vec::new();
    let mut truth = Vec::new();
    let mut raw = Vec::new();
    let (mut e2, mut n) = (0.0, 0u32);
    let mut pipe = Pipeline::new(tr.clone(), Hysteresis::default(), FilterKind::None.build());
    let mut gated = Vec::new();
    for i in 0..(2.0 * 6.0 * 90.0) as u64 {
        let (t, tv) = sim.render(i, &tr, &mut f);
        let r: FrameResult = pipe.step(t, &f);
        if let (true, Some(c), Some(g)) = (tv.present, r.centroid_mm(), tv.contact.centroid_mm) {
            e2 += (0..3).map(|k| (c[k] - g[k]).powi(2)).sum::<f64>();
            n += 1;
        }
        truth.push(tv.present);
        raw.push(r.present);
        gated.push(r.gated);
    }
    let rms = (e2 / n as f64).sqrt();
    eprintln!("centroid error {rms:.4} mm RMS over {n} frames");
    assert!(n > 600, "{n} frames with a finger");
    assert!(rms <= 0.2, "centroid error {rms:.3} mm RMS");
    let transitions: Vec<usize> = (1..truth.len())
        .filter(|&k| truth[k] != truth[k - 1])
        .collect();
    assert!(transitions.len() >= 4, "{transitions:?}");
    for k in 1..truth.len() - 1 {
        let steady = truth[k - 1] == truth[k] && truth[k] == truth[k + 1];
        if steady {
            assert_eq!(raw[k], truth[k], "raw presence wrong at frame {k}");
        }
    }
    for &k in &transitions {
        // At most one frame late: right by the frame after the change.
        assert_eq!(raw[k + 1], truth[k], "raw presence late at {k}");
        // The gate (2 in, 2 out) is at most one frame later still.
        assert_eq!(gated[k + 2], truth[k], "gate late at {k}");
    }
}

#[test]
fn one_noisy_frame_neither_mutes_nor_unmutes() {
    let (setup, intr, tr, sim) = setup_sim();
    let on = frame_at(&sim, 2.0);
    let off = vec![0u16; on.len()];
    let mut pipe = Pipeline::new(tr, Hysteresis::default(), FilterKind::Gaussian.build());
    let seq = [&off, &on, &off, &on, &on, &off, &on, &off, &off];
    let gated: Vec<bool> = seq
        .iter()
        .enumerate()
        .map(|(i, f)| pipe.step(i as f64 / 90.0, f).gated)
        .collect();
    assert_eq!(
        gated,
        [false, false, false, false, true, true, true, true, false]
    );
    let mut pipe2 = Pipeline::new(
        Tracker::new(intr, setup),
        Hysteresis::default(),
        FilterKind::Gaussian.build(),
    );
    for (i, f) in [&on, &on, &on, &off].iter().enumerate() {
        let r = pipe2.step(i as f64 / 90.0, f);
        if i >= 1 {
            // Through the dropout the filtered centre holds the last one.
            assert!(r.filtered_mm.is_some(), "frame {i}");
        }
    }
}
