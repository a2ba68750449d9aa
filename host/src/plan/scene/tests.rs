use super::*;
use crate::geom::euler_xyz_deg;

fn close(a: Vec3, b: Vec3, tol: f64) -> bool {
    norm(sub(a, b)) < tol
}

#[test]
fn default_scene_is_a_flat_2x2_centred_on_the_origin() {
    let s = Scene::default();
    let t = s.transducers();
    assert_eq!(t.len(), 996);
    assert_eq!(s.transducer_count(), 996);
    let mut c = [0.0; 3];
    for tr in &t {
        assert_eq!(tr.pos_mm[2], 0.0);
        assert_eq!(tr.normal, [0.0, 0.0, 1.0]);
        c = add(c, tr.pos_mm);
    }
    // The missing corner positions make the centroid slightly off 0 in
    // y, but x and y stay within one pitch of the origin.
    let c = scale(c, 1.0 / t.len() as f64);
    assert!(c[0].abs() < 10.16 && c[1].abs() < 10.16, "{c:?}");
    // Devices do not overlap: the two lower devices' grids are 192 mm apart.
    assert!((t[249].pos_mm[0] - t[0].pos_mm[0] - 192.0).abs() < 1e-9);
}

#[test]
fn euler_rotations_follow_the_right_hand_rule() {
    let r = euler_xyz_deg([90.0, 0.0, 0.0]);
    assert!(close(mat_vec(&r, [0.0, 0.0, 1.0]), [0.0, -1.0, 0.0], 1e-12));
    let r = euler_xyz_deg([0.0, 90.0, 0.0]);
    assert!(close(mat_vec(&r, [0.0, 0.0, 1.0]), [1.0, 0.0, 0.0], 1e-12));
    let r = euler_xyz_deg([0.0, 0.0, 90.0]);
    assert!(close(mat_vec(&r, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], 1e-12));
    // x first, then z: z-axis → (0,-1,0) → (1,0,0).
    let r = euler_xyz_deg([90.0, 0.0, 90.0]);
    assert!(close(mat_vec(&r, [0.0, 0.0, 1.0]), [1.0, 0.0, 0.0], 1e-12));
}

#[test]
fn mirroring_is_an_involution_and_keeps_points_on_the_plane() {
    let r = Reflector {
        point_mm: [0.0, 0.0, 10.0],
        normal: unit([0.0, 1.0, 1.0], "n").unwrap(),
    };
    let p = [3.0, 30.0, 30.0];
    let m = r.mirror(p);
    assert!(close(r.mirror(m), p, 1e-12));
    assert!(!close(m, p, 1.0));
    let on = [5.0, -4.0, 14.0];
    assert!(close(r.mirror(on), on, 1e-12));
    // Plane z = 0: mirror flips z.
    let z = Reflector {
        point_mm: [0.0; 3],
        normal: [0.0, 0.0, 1.0],
    };
    assert!(close(z.mirror([1.0, 2.0, 3.0]), [1.0, 2.0, -3.0], 1e-12));
}

#[test]
fn scene_file_round_trip_with_rig_and_medium() {
    let s = Scene::from_toml(
        r#"
        directivity = "omni"
        center_mm = [0.0, 30.0, 30.0]
        [medium]
        temperature_c = 20.0
        [rig]
        position_mm = [0.0, 0.0, 100.0]
        rotation_deg = [180.0, 0.0, 0.0]
        [[device]]
        center_mm = [0.0, 0.0, 0.0]
        "#,
        "t.toml",
    )
    .unwrap();
    assert_eq!(s.directivity, Directivity::Omni);
    assert!((s.sound_speed_m_s - 343.2).abs() < 0.1);
    let t = s.transducers();
    assert_eq!(t.len(), 249);
    assert!(close(t[0].normal, [0.0, 0.0, -1.0], 1e-12));
    assert!(t.iter().all(|tr| (tr.pos_mm[2] - 100.0).abs() < 1e-9));
    assert_eq!(s.name, "t.toml");
}

#[test]
fn scene_file_errors_name_the_file_and_field() {
    let cases = [
        ("[[device]]\ncenter_mm = [0.0, 0.0]\n", "center_mm"),
        (
            "[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\nspin = 3\n",
            "spin",
        ),
        (
            "directivity = \"laser\"\n[[device]]\ncenter_mm = [0,0,0]\n",
            "directivity",
        ),
        ("name = \"x\"\n", "[[device]]"),
        (
            "[reflector]\npoint_mm = [0.0,0.0,0.0]\nnormal = [0.0,0.0,0.0]\n[[device]]\ncenter_mm = [0.0,0.0,0.0]\n",
            "reflector.normal",
        ),
        (
            "[medium]\nsound_speed_m_s = -3.0\n[[device]]\ncenter_mm = [0.0,0.0,0.0]\n",
            "medium.sound_speed_m_s",
        ),
        (
            "[lm_plane]\na = [1.0,0.0,0.0]\nb = [1.0,1.0,0.0]\n[[device]]\ncenter_mm = [0.0,0.0,0.0]\n",
            "lm_plane",
        ),
    ];
    for (text, field) in cases {
        let e = Scene::from_toml(text, "bad.toml").unwrap_err().to_string();
        assert!(e.starts_with("scene file bad.toml: "), "{e}");
        assert!(e.contains(field), "{e} should name {field}");
        assert!(!e.contains('\n'), "multi-line: {e}");
    }
}

#[test]
fn missing_scene_file_is_a_one_line_input_error() {
    let e = Scene::load(Path::new("/nonexistent/scene.toml")).unwrap_err();
    assert_eq!(
        e.to_string(),
        "cannot read scene file /nonexistent/scene.toml: no such file or directory"
    );
}

#[test]
fn paper_scene_parses_and_aims_at_the_mirrored_marker() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml");
    let s = Scene::load(Path::new(path)).unwrap();
    assert_eq!(s.transducer_count(), 996);
    assert_eq!(s.center_mm, [0.0, 30.0, 30.0]);
    let refl = s.reflector.expect("paper scene has a reflector");
    let target = refl.mirror(s.center_mm);
    // Every device faces the mirrored marker within 25° (tilted 20° in).
    for d in &s.devices {
        let n = mat_vec(&d.rotation, [0.0, 0.0, 1.0]);
        let to = unit(sub(target, d.center_mm), "to").unwrap();
        let ang = dot(n, to).clamp(-1.0, 1.0).acos().to_degrees();
        assert!(ang < 25.0, "device off target by {ang}°");
    }
    // The LM plane is orthonormal.
    let p = s.lm_plane;
    assert!(dot(p.a, p.b).abs() < 1e-9 && (norm(p.c) - 1.0).abs() < 1e-9);
}

#[test]
fn overlapping_or_far_away_devices_are_refused() {
    let two =
        |a: &str, b: &str| format!("[[device]]\ncenter_mm = {a}\n[[device]]\ncenter_mm = {b}\n");
    let e = Scene::from_toml(&two("[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]"), "t").unwrap_err();
    assert!(e.0.contains("overlap"), "{e}");
    let e = Scene::from_toml(&two("[0.0, 0.0, 0.0]", "[100.0, 0.0, 0.0]"), "t").unwrap_err();
    assert!(e.0.contains("overlap"), "{e}");
    assert!(Scene::from_toml(&two("[0.0, 0.0, 0.0]", "[192.0, 0.0, 0.0]"), "t").is_ok());
    let e = Scene::from_toml("[[device]]\ncenter_mm = [1e300, 0.0, 0.0]\n", "t").unwrap_err();
    assert!(e.0.contains("±2000 mm") && e.0.contains("1e300"), "{e}");
}

#[test]
fn faces_means_strictly_in_front_of_some_device() {
    let s = Scene::default();
    assert!(s.faces([0.0, 0.0, 200.0]));
    assert!(!s.faces([0.0, 0.0, 0.0]));
    assert!(!s.faces([0.0, 0.0, -100.0]));
}

#[test]
fn lm_plane_beam_angle_flags_a_plane_that_contains_the_beam() {
    let s = Scene::default();
    let a = s.lm_plane_beam_angle_deg([0.0, 0.0, 200.0]).unwrap();
    assert!((a - 90.0).abs() < 1e-9, "{a}");
    let mut edge = s.clone();
    edge.lm_plane = LmPlane::new([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], None, "t").unwrap();
    assert!(edge.lm_plane_beam_angle_deg([0.0, 0.0, 200.0]).unwrap() < 1e-9);
    let paper = Scene::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/paper.toml"
    )))
    .unwrap();
    let a = paper.lm_plane_beam_angle_deg(paper.center_mm).unwrap();
    assert!(
        a > 80.0,
        "the paper scene's circle must face the reflected wave: {a}°"
    );
}

/// Every parse error names its line and the field there, found by the
/// error's span, whatever form the key has.
#[test]
fn parse_errors_name_the_line_and_the_field_by_span() {
    let dev = "[[device]]\ncenter_mm = [0, 0, 0]\n";
    for (text, want) in [
        // A wrong type in the second device, its array over two lines.
        (
            format!("{dev}[[device]]\ncenter_mm = [0,\n  \"x\", 0]\n"),
            "line 5, field `device[1].center_mm`",
        ),
        // A dotted key and an inline table.
        (
            format!("medium.sound_speed_m_s = \"fast\"\n{dev}"),
            "line 1, field `medium.sound_speed_m_s`",
        ),
        (
            format!("calibration = {{ pressure_scale = true }}\n{dev}"),
            "line 1, field `calibration.pressure_scale`",
        ),
        // An unknown key is named, a missing one is on its table's line.
        (
            format!("{dev}[rig]\nspin = 1\n"),
            "line 4, field `rig.spin`",
        ),
        (format!("{dev}[reflector]\nnormal = [0, 0, 1]\n"), "line 3"),
        // A syntax error has a line but no field.
        (format!("center_mm = [0, 0\n{dev}"), "line 2: "),
    ] {
        let e = Scene::from_toml(&text, "s.toml").unwrap_err().0;
        assert!(e.contains(want) && !e.contains('\n'), "{text:?}: {e}");
    }
}

#[test]
fn a_float_that_underflows_is_refused_naming_line_and_field() {
    for (text, want) in [
        (
            "[[device]]\ncenter_mm = [0.0, 1e-400, 0.0]\n",
            "line 2, field `device[0].center_mm`: 1e-400 is too small",
        ),
        (
            "[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\nrotation_deg = [0.0, 0.0, 4.9e-324]\n",
            "line 3, field `device[0].rotation_deg`: 4.9e-324 is too small",
        ),
    ] {
        let e = Scene::from_toml(text, "s.toml").unwrap_err().to_string();
        assert!(
            e.starts_with("scene file s.toml: ") && e.contains(want),
            "{e}"
        );
    }
    // Without the check the first reads as a device at y = 0.
    assert!(toml::from_str::<toml::Value>("y = 1e-400").is_ok());
}

#[test]
fn an_unknown_value_holding_a_line_break_is_said_whole_on_one_line() {
    // toml quotes the value in its message; cut at the value's line
    // break, the message repeated it up to there, its quote left open.
    let long = format!("{}\\n{}", "a b ".repeat(200), "c d ".repeat(200));
    let text = format!("directivity = \"{long}\"\n[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\n");
    let e = Scene::from_toml(&text, "s.toml").unwrap_err().to_string();
    assert!(
        e.starts_with("scene file s.toml: line 1, field `directivity`: unknown variant `a b"),
        "{e}"
    );
    assert!(
        e.contains("…(1602 characters)…") && e.contains("c d `, expected"),
        "{e}"
    );
    assert!(!e.contains('\n') && e.len() < 400, "{e}");
    let short = "directivity = \"x\\ny\"\n[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\n";
    let e = Scene::from_toml(short, "s.toml").unwrap_err().to_string();
    assert!(e.contains("unknown variant `x\\ny`, expected"), "{e}");
}

#[test]
fn a_left_handed_lm_plane_is_refused_naming_a_cross_b() {
    let scene = |c: &str| {
        Scene::from_toml(
            &format!(
                "[lm_plane]\na = [1.0,0.0,0.0]\nb = [0.0,1.0,0.0]\nc = {c}\n[[device]]\ncenter_mm = [0.0,0.0,0.0]\n"
            ),
            "bad.toml",
        )
    };
    assert_eq!(
        scene("[0.0,0.0,-1.0]").unwrap_err().to_string(),
        "scene file bad.toml: lm_plane.c must be a × b = [0, 0, 1] (a, b, c right-handed): this c is −(a × b), which reverses the circle's direction about c and the side the depth profile is on; give a × b or leave c out"
    );
    // a × b given, or left out: the same plane.
    let given = scene("[0.0,0.0,1.0]").unwrap().lm_plane;
    assert_eq!(given, LmPlane::default());
    // The paper's tilted plane is right-handed.
    let paper =
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml")).unwrap();
    let p = paper.lm_plane;
    assert!(crate::geom::dot(crate::geom::cross(p.a, p.b), p.c) > 0.999);
}
