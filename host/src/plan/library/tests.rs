use super::*;
use crate::plan::trajectory::Steps;

#[test]
fn entries_default_to_the_plan_flags_and_keep_file_order() {
    let lib = Library::from_toml(
        "[[stimulus]]\nid = \"b\"\nfoci = 4\nintensity = 0.5\n\n[[stimulus]]\nid = \"a\"\nsteps = 64\nfreq = 25\nuntracked = true\n",
        "t",
    )
    .unwrap();
    assert_eq!(lib.entries.len(), 2);
    assert_eq!(lib.entries[0].id, "b");
    assert_eq!(lib.entries[0].stimulus.cycle.foci, 4);
    assert_eq!(lib.entries[0].stimulus.cycle.radius_mm, 3.0);
    assert_eq!(lib.entries[0].stimulus.intensity, 0.5);
    assert_eq!(lib.entries[1].stimulus.intensity, 1.0);
    assert!(!lib.entries[0].untracked);
    assert_eq!(lib.entries[1].stimulus.cycle.steps, Steps::Count(64));
    assert_eq!(lib.entries[1].stimulus.cycle.freq_hz, 25.0);
    assert!(lib.entries[1].untracked);
    assert_eq!(lib.find("a").map(|(i, _)| i), Some(1));
    assert!(lib.find("c").is_none());
}

#[test]
fn bad_libraries_are_one_line_errors_naming_the_entry() {
    for (text, needle) in [
        ("", "no stimuli"),
        ("[[stimulus]]\nradius = 3\n", "missing field `id`"),
        ("[[stimulus]]\nid = \"a b\"\n", "use letters"),
        (
            "[[stimulus]]\nid = \"a\"\n[[stimulus]]\nid = \"a\"\n",
            "used twice",
        ),
        (
            "[[stimulus]]\nid = \"a\"\nstep = 0.2\nsteps = 3\n",
            "not both",
        ),
        ("[[stimulus]]\nid = \"a\"\nradius = \"3\"\n", "line 3"),
        ("[[stimulus]]\nid = \"a\"\ncolour = 1\n", "unknown field"),
        ("[[stimulus]]\nid = \"a\"\nintensity = 2\n", "0..=1"),
        ("[[stimulus]]\nid = \"a\"\nintensity = -0.5\n", "0..=1"),
        ("[[stimulus]]\nid = \"a\"\ncenter = [0, 0, 1e9]\n", "±2000"),
    ] {
        let e = Library::from_toml(text, "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{text:?}: {e}");
        assert!(e.starts_with("stimulus library lib.toml: "), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn every_entry_is_planned_for_the_target_and_a_bad_one_is_named() {
    // A number out of its range is refused where the library is read ...
    let e = Library::from_toml(
        "[[stimulus]]\nid = \"ok\"\n[[stimulus]]\nid = \"huge\"\nradius = 1000\n",
        "t",
    )
    .unwrap_err();
    assert!(e.to_string().contains("stimulus 2 (`huge`): radius"), "{e}");
    // ... and one the device cannot play (a dwell under its minimum) where
    // it is planned for it.
    let lib = Library::from_toml(
        "[[stimulus]]\nid = \"ok\"\n[[stimulus]]\nid = \"fast\"\nfreq = 1000\nsteps = 1000\n",
        "t",
    )
    .unwrap();
    let e = lib.plan_for(&Target::Lm, &Scene::default()).unwrap_err();
    // Named as the loader names an entry: the file, the place, the id.
    assert!(
        format!("{e:#}").contains("stimulus library t: stimulus 2 (`fast`)"),
        "{e:#}"
    );
    let lib = Library::from_toml("[[stimulus]]\nid = \"x\"\nradius = 5\n", "t").unwrap();
    let lm = lib.plan_for(&Target::Lm, &Scene::default()).unwrap();
    let autd = lib.plan_for(&Target::Autd3, &Scene::default()).unwrap();
    // A = 5 mm at 0.23 mm: 137 steps as asked, 136 on AUTD3's grid.
    assert_eq!(lm[0].timing.steps, 137);
    assert_eq!(autd[0].timing.steps, 136);
}

const KINDS: &str = "[[stimulus]]\nid = \"liss\"\nfreq = 2\nsteps = 400\n\
    path = { shape = \"lissajous\", a = 5, b = 3, ratio = [3, 2] }\n\
    [[stimulus]]\nid = \"am\"\nam = { shape = \"square\", freq = 200, depth = 0.5 }\n\
    [[stimulus]]\nid = \"line\"\nfreq = 2\npath = { shape = \"line\", length = 8 }\n\
    [[stimulus]]\nid = \"ell\"\nfreq = 2\npath = { shape = \"ellipse\", a = 4, b = 2 }\n";

#[test]
fn paths_and_modulations_are_read_with_their_defaults() {
    let lib = Library::from_toml(KINDS, "t").unwrap();
    let s = |i: usize| &lib.entries[i].stimulus;
    assert_eq!(
        s(0).cycle.path,
        Path::Lissajous(Lissajous {
            a_mm: 5.0,
            b_mm: 3.0,
            n_a: 3,
            n_b: 2,
            phase_deg: 90.0
        })
    );
    assert_eq!(s(0).am, None);
    assert_eq!(s(1).cycle.path, Path::Circle);
    let am = s(1).am.unwrap();
    assert_eq!(
        (am.shape, am.freq_hz, am.depth),
        (AmShape::Square, 200.0, 0.5)
    );
    assert_eq!(s(2).cycle.path, Path::Line { length_mm: 8.0 });
    assert_eq!(
        s(3).cycle.path,
        Path::Ellipse {
            a_mm: 4.0,
            b_mm: 2.0
        }
    );
}

#[test]
fn every_kind_plans_for_autd3_and_the_lm_firmware_refuses_only_am() {
    let lib = Library::from_toml(KINDS, "t").unwrap();
    let scene = Scene::default();
    let autd = lib.plan_for(&Target::Autd3, &scene).unwrap();
    assert_eq!(autd[1].plan.am, lib.entries[1].stimulus.am);
    // The Lissajous figure spans ±5 mm along a and ±3 mm along b.
    let t = &autd[0].plan.trajectory;
    let span = |k: usize| {
        t.foci_mm
            .iter()
            .map(|f| f[k] - t.center_mm[k])
            .fold((f64::MAX, f64::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)))
    };
    let (u, v) = (span(0), span(1));
    assert!(
        u.0 < -4.9 && u.1 > 4.9 && v.0 < -2.9 && v.1 > 2.9,
        "{u:?} {v:?}"
    );
    assert!(u.1 < 5.0 + 1e-9 && v.1 < 3.0 + 1e-9);
    // The line keeps to the a axis.
    assert!(
        autd[2]
            .plan
            .trajectory
            .foci_mm
            .iter()
            .all(|f| f[1] == t.center_mm[1])
    );
    let e = lib.plan_for(&Target::Lm, &scene).unwrap_err();
    let e = format!("{e:#}");
    assert!(
        e.contains("stimulus 2 (`am`)") && e.contains("does not fit the LM firmware's steps"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");
    let no_am = Library {
        entries: lib
            .entries
            .iter()
            .filter(|e| e.id != "am")
            .cloned()
            .collect(),
        origin: lib.origin.clone(),
    };
    let lm = no_am.plan_for(&Target::Lm, &scene).unwrap();
    assert_eq!(lm[0].timing.steps, 400);
    assert!(lm.iter().all(|p| p.plan.am.is_none()));
}

#[test]
fn bad_paths_and_modulations_are_one_line_errors() {
    for (body, needle) in [
        ("path = { shape = \"line\" }", "needs `length`"),
        (
            "path = { shape = \"line\", length = 3, a = 1 }",
            "has no `a`",
        ),
        ("path = { shape = \"circle\", a = 1 }", "`radius`"),
        ("path = { shape = \"star\" }", "unknown variant"),
        (
            "path = { shape = \"ellipse\", a = 1, b = -1 }",
            "semi-axis b",
        ),
        (
            "path = { shape = \"lissajous\", a = 1, b = 1, ratio = [0, 1] }",
            "1..=32",
        ),
        (
            "radius = 2\npath = { shape = \"line\", length = 3 }",
            "circle's",
        ),
        (
            "am = { shape = \"sine\", freq = 1000 }",
            "modulation frequency",
        ),
        ("am = { shape = \"sine\", freq = 100, depth = 2 }", "depth"),
        ("am = { shape = \"sine\" }", "missing field `freq`"),
        (
            "am = { shape = \"sine\", freq = 100, offset = 2 }",
            "unknown field",
        ),
    ] {
        let text = format!("[[stimulus]]\nid = \"x\"\n{body}\n");
        let e = Library::from_toml(&text, "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{body}: {e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn an_entry_plays_phases_or_foci_from_a_file_beside_the_library() {
    let d = crate::files::scratch("library-files");
    let n = Scene::default().transducers().len();
    // Four steps of phases, each step one value on every transducer.
    let rows: Vec<Vec<u8>> = (0..4u8).map(|k| vec![k * 60; n]).collect();
    let phases = serde_json::json!({ "phases": rows, "dwell_us": 1000.0 });
    std::fs::write(d.join("p.json"), phases.to_string()).unwrap();
    let foci = serde_json::json!({ "foci_mm": [[[0.0, 0.0, 200.0]], [[2.0, 0.0, 200.0]]] });
    std::fs::write(d.join("f.json"), foci.to_string()).unwrap();
    std::fs::write(
        d.join("lib.toml"),
        "[[stimulus]]\nid = \"from-phases\"\nphases_file = \"p.json\"\nuntracked = true\n\n\
         [[stimulus]]\nid = \"from-foci\"\nfoci_file = \"f.json\"\nfreq = 5.0\n\n\
         [[stimulus]]\nid = \"circle\"\n",
    )
    .unwrap();
    let lib = Library::load(&d.join("lib.toml")).unwrap();
    assert_eq!(
        lib.entries[0].file,
        Some((Content::Phases, d.join("p.json")))
    );
    assert!(lib.entries[0].untracked);
    for target in [Target::Lm, Target::Autd3] {
        let plans = lib.plan_for(&target, &Scene::default()).unwrap();
        let (p, f) = (&plans[0].plan.sequence, &plans[1].plan.sequence);
        assert_eq!(p.header.steps, 4, "{target:?}");
        assert_eq!(p.step(2)[0], 120);
        assert!((p.dwell_us() - 1000.0).abs() < 1e-9, "{}", p.dwell_us());
        // Two foci at 5 Hz: 100 ms a step.
        assert_eq!(f.header.steps, 2);
        assert!((f.dwell_us() - 100_000.0).abs() < 1e-6, "{}", f.dwell_us());
        assert_ne!(f.step(0), f.step(1));
    }
    // A file that is not there is the entry's error, named.
    std::fs::remove_file(d.join("f.json")).unwrap();
    let e = lib.plan_for(&Target::Lm, &Scene::default()).unwrap_err();
    let e = crate::error::one_line(&e);
    assert!(e.contains("(`from-foci`)") && e.contains("f.json"), "{e}");
    std::fs::remove_dir_all(&d).unwrap();
    for (body, needle) in [
        (
            "phases_file = \"p.npy\"\nradius = 3.0",
            "`radius` does not apply to a stimulus from `phases_file`",
        ),
        (
            "foci_file = \"f.npy\"\nam = { shape = \"sine\", freq = 100.0 }",
            "`am` does not apply to a stimulus from `foci_file`",
        ),
        (
            "phases_file = \"p.npy\"\nfoci_file = \"f.npy\"",
            "give `phases_file` or `foci_file`, not both",
        ),
        ("phases_file = \" \"", "`phases_file` is empty"),
        // The plan flags' rule: a spacing with one focus changes nothing.
        (
            "foci = 1\nspacing = 3.0",
            "stimulus 1 (`x`): spacing applies to LM-M only: give foci 2 or more",
        ),
        ("spacing = 3.0", "spacing applies to LM-M only"),
    ] {
        let e = Library::from_toml(&format!("[[stimulus]]\nid = \"x\"\n{body}\n"), "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{body}: {e}");
    }
}

#[test]
fn an_id_with_a_line_break_or_a_pasted_value_is_refused_on_one_short_line() {
    // TOML's escapes put a line break inside an id; a key of thousands of
    // characters (with spaces, which no cut of long words catches).
    let cases = [
        "[[stimulus]]\nid = \"a\\nb\\r\\nc\"\n".to_owned(),
        format!(
            "[[stimulus]]\nid = \"x\"\npath = {{ shape = \"{}\" }}\n",
            "a b ".repeat(400)
        ),
        format!("[[stimulus]]\nid = \"{}\"\n", "\\n".repeat(300)),
    ];
    for text in &cases {
        let e = Library::from_toml(text, "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(!e.contains(['\n', '\r']) && e.len() < 400, "{e}");
        assert!(e.starts_with("stimulus library lib.toml: "), "{e}");
    }
    let e = Library::from_toml(&cases[0], "lib.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("`a\\nb\\r\\nc`"), "{e}");
}
