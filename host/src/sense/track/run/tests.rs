use super::*;

fn synthetic(json: bool) -> Options {
    Options {
        scene: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/paper.toml"
        ))),
        depth: None,
        timestamps: None,
        intrinsics: None,
        synthetic: true,
        seconds: Some(0.2),
        noise_mm: None,
        holes: None,
        camera: false,
        stream: None,
        record: None,
        fast: true,
        json,
        plot: None,
        plot_frame: None,
        filter: None,
        z_profile: Some("3,8".into()),
        replan_mm: 0.3,
        replan: false,
        enter_frames: 2,
        leave_frames: 2,
        device: false,
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
        assert!(v.get("filtered_mm").is_none(), "no filter, no device: {v}");
    }
    assert!(report.summary[0].starts_with(&format!("{frames} frames of 848×480")));
    assert!(report.summary[1].starts_with("vs ground truth: centroid error"));
    assert!(report.summary[2].starts_with("surface depth profile:"));
    assert_eq!(report.summary.len(), 3, "{report:?}");
}

#[test]
fn bad_options_are_input_errors_naming_the_flag() {
    let mut o = synthetic(false);
    o.enter_frames = 0;
    let e = TrackRun::open(o).err().unwrap();
    assert!(e.downcast_ref::<InputError>().is_some());
    assert_eq!(e.to_string(), "--enter-frames 0 must be between 1 and 90");
    let mut o = synthetic(false);
    o.z_profile = Some("3".into());
    let e = TrackRun::open(o).err().unwrap().to_string();
    assert!(
        e.starts_with("--z-profile `3` must be RADIUS_MM,STEPS"),
        "{e}"
    );
}
