use std::path::PathBuf;

use super::*;
use crate::sense::track::presence::Hysteresis;

fn synthetic(json: bool) -> Options {
    Options {
        scene: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/paper.toml"
        ))),
        fast: true,
        json,
        z_profile: Some(ZProfile::parse("3,8", 0.3, false).unwrap()),
        ..Options::new(Source::Synthetic {
            finger: SyntheticFinger::new(Some(0.2), None, None).unwrap(),
            intrinsics: None,
        })
    }
}

#[test]
fn a_synthetic_session_prints_a_line_per_frame_and_scores_the_truth() {
    let mut lines = Vec::new();
    let report = TrackRun::open(synthetic(true))
        .unwrap()
        .run(None, &mut |l: &str| {
            lines.push(l.to_owned());
            Ok(())
        })
        .unwrap();
    let frames = (0.2f64 * 90.0).round() as usize;
    assert_eq!(lines.len(), frames, "{lines:?}");
    for l in &lines {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert!(v["truth_present"].is_boolean() && v.get("z_profile_mm").is_some());
        // No filter, no device: still the gate's centre, there exactly
        // while the gate is open.
        assert_eq!(
            v["filtered_mm"].is_null(),
            v["gated_present"] == false,
            "{v}"
        );
    }
    assert!(report.summary[0].starts_with(&format!("{frames} frames of 848×480")));
    assert!(report.summary[1].starts_with("vs ground truth: centroid error"));
    assert!(report.summary[2].starts_with("surface depth profile:"));
    assert_eq!(report.summary.len(), 3, "{report:?}");
}

/// Every JSON line carries the gate's verdict, so `--enter-frames` shows
/// in the output even without a filter or a device.
#[test]
fn the_json_lines_carry_the_gated_presence_the_gate_flags_change() {
    let gated = |gate: Hysteresis| {
        let mut o = synthetic(true);
        o.source = Source::Synthetic {
            finger: SyntheticFinger::new(Some(1.0), None, None).unwrap(),
            intrinsics: None,
        };
        o.gate = gate;
        o.z_profile = None;
        let mut n = 0;
        TrackRun::open(o)
            .unwrap()
            .run(None, &mut |l: &str| {
                let v: serde_json::Value = serde_json::from_str(l).unwrap();
                n += usize::from(v["gated_present"].as_bool().expect("gated_present"));
                Ok(())
            })
            .unwrap();
        n
    };
    let quick = gated(Hysteresis::default());
    let slow = gated(Hysteresis::new(20, 2).unwrap());
    assert!(quick > slow && slow > 0, "{quick} vs {slow}");
}

#[test]
fn a_scene_is_needed_but_for_the_synthetic_finger() {
    let mut o = Options::new(Source::Camera { intrinsics: None });
    let e = TrackRun::open(o.clone()).err().unwrap();
    assert!(e.downcast_ref::<InputError>().is_some());
    assert_eq!(
        e.to_string(),
        "--scene is needed: its [camera] and [tracking] place the box"
    );
    o.source = Source::Synthetic {
        finger: SyntheticFinger::new(Some(0.1), None, None).unwrap(),
        intrinsics: None,
    };
    assert!(TrackRun::open(o).is_ok());
}

#[test]
fn a_replan_without_a_device_is_refused() {
    let mut o = synthetic(false);
    o.z_profile = Some(ZProfile::parse("3,8", 0.3, true).unwrap());
    let e = TrackRun::open(o.clone()).err().unwrap();
    assert!(e.downcast_ref::<InputError>().is_some());
    assert_eq!(
        e.to_string(),
        "--replan needs --port: the re-planned stimulus is uploaded to the device"
    );
    o.device = true;
    let run = TrackRun::open(o).unwrap();
    assert!(run.z_profile().is_some_and(|z| z.replan()));
}

#[test]
fn a_plot_frame_beyond_the_run_names_the_flag() {
    // Not made beforehand: a fresh folder may reuse the inode of an input
    // another test read and deleted, which `--plot` would then refuse.
    let scratch = crate::files::scratch("track-run-plot-frame");
    let dir = scratch.join("plots");
    let mut o = synthetic(false);
    o.plot = Some(Plot {
        dir: dir.clone(),
        frame: Some(1000),
    });
    let e = TrackRun::open(o)
        .unwrap()
        .run(None, &mut |_| Ok(()))
        .unwrap_err();
    // No plot, and the folder the run made for them removed with it.
    assert!(!dir.exists(), "{} left", dir.display());
    assert!(e.downcast_ref::<InputError>().is_some());
    assert_eq!(e.to_string(), "--plot-frame 1000 is beyond the 18 frames");
}
