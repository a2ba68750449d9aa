//! The stimulus files' tests: round trips through every form and the
//! refusals, one line naming the file.

use super::*;

fn tmp(name: &str, bytes: &[u8]) -> crate::files::Scratch {
    let p = crate::files::scratch_file("stimfile", name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn npy_f64(shape: &[usize], data: &[f64]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let header = format!(
        "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
        dims.join(", ")
    );
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    let pad = (64 - (10 + header.len() + 1) % 64) % 64;
    out.extend_from_slice(&((header.len() + pad + 1) as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend(std::iter::repeat_n(b' ', pad));
    out.push(b'\n');
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// `upload --phases P --freq 5` on an LM port, planned in `scene`.
fn lm_phases_at_5_hz(p: &Path, scene: &Scene) -> Result<TargetPlan, InputError> {
    plan_for(
        Content::Phases,
        p,
        &Target::Lm,
        scene.clone(),
        Some(5.0),
        None,
    )
}

/// The default stimulus planned in the default scene, and that scene.
fn default_planned() -> (Scene, TargetPlan) {
    let scene = Scene::default();
    let planned = crate::plan::stimulus::Stimulus::default()
        .plan(scene.clone())
        .unwrap();
    (scene, planned)
}

#[test]
fn a_planned_sequence_round_trips_through_a_phases_file() {
    let (scene, planned) = default_planned();
    let p = tmp("rt.npy", &planned.plan.sequence.to_npy());
    let got = lm_phases_at_5_hz(&p, &scene).unwrap();
    assert_eq!(got.plan.sequence.phases, planned.plan.sequence.phases);
    assert_eq!(
        got.plan.sequence.header.period_us,
        planned.plan.sequence.header.period_us
    );
    assert_eq!(got.timing.steps, 82);
    // On AUTD3 the same file at 5 Hz lands on the grid: 2450 µs.
    let a = Target::Autd3;
    let g = plan_for(Content::Phases, &p, &a, scene, Some(5.0), None).unwrap();
    assert_eq!((g.timing.divide, g.timing.dwell_us), (Some(98), 2450.0));
}

#[test]
fn foci_files_synthesise_like_the_planner() {
    let scene = Scene::default();
    let planned = crate::plan::stimulus::Stimulus::paper_lm_m()
        .plan(scene.clone())
        .unwrap();
    let t = &planned.plan.trajectory;
    let mm: Vec<f64> = t.foci_mm.iter().flatten().copied().collect();
    let p = tmp("foci.npy", &npy_f64(&[t.steps, t.foci, 3], &mm));
    let got = plan_for(
        Content::Foci,
        &p,
        &Target::Lm,
        scene.clone(),
        Some(5.0),
        Some(t.center_mm),
    )
    .unwrap();
    assert_eq!(got.plan.sequence.phases, planned.plan.sequence.phases);
    assert_eq!(got.plan.sequence.header, planned.plan.sequence.header);
    // JSON, with a dwell on the grid for AUTD3.
    let rows: Vec<Vec<[f64; 3]>> = (0..t.steps).map(|j| t.foci_step(j).to_vec()).collect();
    let j = serde_json::json!({"foci_mm": rows, "dwell_us": 2450.0}).to_string();
    let p = tmp("foci.json", j.as_bytes());
    let a = Target::Autd3;
    let g = plan_for(Content::Foci, &p, &a, scene, None, None).unwrap();
    assert_eq!(g.timing.divide, Some(98));
}

/// A bad file: name, bytes, content, target, --freq, what the error says.
type Bad<'a> = (&'a str, Vec<u8>, Content, &'a Target, Option<f64>, &'a str);

#[test]
fn bad_files_are_one_line_naming_the_file() {
    let scene = Scene::default();
    let a = Target::Autd3;
    let row = vec![0u8; 996];
    let ok_rows = serde_json::json!({"phases": vec![row.clone(); 4], "dwell_us": 2000.0});
    let cases: Vec<Bad<'_>> = vec![
        ("short.json", serde_json::json!({"phases": [[1, 2, 3]], "dwell_us": 2000.0}).to_string().into_bytes(), Content::Phases, &Target::Lm, None, "996 transducers"),
        ("notime.json", serde_json::json!({"phases": vec![row.clone(); 4]}).to_string().into_bytes(), Content::Phases, &Target::Lm, None, "no timing"),
        ("twice.json", ok_rows.to_string().into_bytes(), Content::Phases, &Target::Lm, Some(5.0), "give one"),
        ("offgrid.json", serde_json::json!({"phases": vec![row.clone(); 4], "dwell_us": 2010.0}).to_string().into_bytes(), Content::Phases, &a, None, "25 µs grid"),
        ("fast.json", serde_json::json!({"phases": vec![row.clone(); 4], "dwell_us": 10.0}).to_string().into_bytes(), Content::Phases, &Target::Lm, None, "over 4 steps is out of range: allowed 250..="),
        ("extra.json", serde_json::json!({"phases": [row.clone()], "dwell_us": 2000.0, "x": 1}).to_string().into_bytes(), Content::Phases, &Target::Lm, None, "unknown field"),
        ("few.json", serde_json::json!({"phases": [row.clone()], "dwell_us": 2000.0}).to_string().into_bytes(), Content::Phases, &a, None, "2..=1024 steps"),
        ("behind.json", serde_json::json!({"foci_mm": [[[0, 0, -50]]], "dwell_us": 2000.0}).to_string().into_bytes(), Content::Foci, &Target::Lm, None, "behind"),
        ("far.json", serde_json::json!({"foci_mm": [[[0, 0, 1e9]]], "dwell_us": 2000.0}).to_string().into_bytes(), Content::Foci, &Target::Lm, None, "±2000"),
        ("ragged.json", serde_json::json!({"foci_mm": [[[0, 0, 200]], [[0, 0, 200], [1, 0, 200]]], "dwell_us": 2000.0}).to_string().into_bytes(), Content::Foci, &Target::Lm, None, "as many"),
        ("nan.npy", npy_f64(&[1, 1, 3], &[0.0, f64::NAN, 200.0]), Content::Foci, &Target::Lm, Some(5.0), "out of range"),
        ("shape.npy", npy_f64(&[1, 3], &[0.0, 0.0, 200.0]), Content::Foci, &Target::Lm, Some(5.0), "(steps, foci, 3)"),
        ("dtype.npy", npy_f64(&[1, 1, 3], &[0.0, 0.0, 200.0]), Content::Phases, &Target::Lm, Some(5.0), "uint8"),
        ("trunc.npy", npy_f64(&[2, 1, 3], &[0.0, 0.0, 200.0]), Content::Foci, &Target::Lm, Some(5.0), "needs"),
    ];
    for (name, bytes, content, target, freq, says) in cases {
        let p = tmp(name, &bytes);
        let e = plan_for(content, &p, target, scene.clone(), freq, None)
            .err()
            .unwrap_or_else(|| panic!("{name} was accepted"))
            .to_string();
        assert!(e.contains(says), "{name}: {e}");
        assert!(e.contains(name), "{name}: {e}");
        assert!(!e.contains('\n'), "{name}: {e}");
    }
}

#[test]
fn a_plan_report_uploads_what_plan_made_on_both_targets() {
    // LM-M at half output, on the paper's mirrored scene and the default.
    let paper =
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml")).unwrap();
    let mut s = crate::plan::stimulus::Stimulus::paper_lm_m();
    s.intensity = 0.5;
    for (scene, target) in [
        (paper.clone(), Target::Lm),
        (Scene::default(), Target::Lm),
        (Scene::default(), Target::Autd3),
    ] {
        let planned = s.plan_for(&target, scene.clone()).unwrap();
        let name = format!(
            "report-{}-{}.json",
            target.name(),
            scene.reflector.is_some()
        );
        let p = tmp(
            &name,
            &planned.out_bytes(Path::new(&name), &target).unwrap(),
        );
        let got = plan_for(Content::Phases, &p, &target, scene.clone(), None, None).unwrap();
        let (a, b) = (&got.plan.sequence, &planned.plan.sequence);
        assert_eq!(a.phases, b.phases, "{name}");
        assert_eq!(a.header, b.header, "{name}");
        assert_eq!(a.crc32(), b.crc32(), "{name}");
        assert_eq!(got.timing.divide, planned.timing.divide, "{name}");
        // The other target's port, and another scene, are refused by name.
        let other = match target {
            Target::Lm => Target::Autd3,
            Target::Autd3 => Target::Lm,
        };
        let e = plan_for(Content::Phases, &p, &other, scene, None, None)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains(&format!("planned for target {}", target.name())),
            "{e}"
        );
        if target == Target::Lm {
            let o = if got.plan.scene.reflector.is_some() {
                Scene::default()
            } else {
                paper.clone()
            };
            let e = plan_for(Content::Phases, &p, &target, o, None, None)
                .err()
                .unwrap();
            assert!(e.to_string().contains("--scene"), "{e}");
        }
    }
}

/// A plan's report or summary given where it does not replay the plan
/// says what it is and what does (it was "unknown field `center_mm`" as
/// a foci file, "missing field `phases` at line 1 column 4734" as phases).
#[test]
fn a_plan_report_where_it_cannot_replay_says_what_does() {
    let (scene, planned) = default_planned();
    let report = planned
        .out_bytes(Path::new("report.json"), &Target::Lm)
        .unwrap();
    let with_phases = tmp("report-foci.json", &report);
    let e = plan_for(
        Content::Foci,
        &with_phases,
        &Target::Lm,
        scene.clone(),
        None,
        None,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("is a `lmhost plan --out` report, not a foci file"),
        "{e}"
    );
    assert!(
        e.contains("--phases") && e.contains("report-foci.json"),
        "{e}"
    );
    // The summary `plan --json` prints, without its phases, either way.
    let mut summary: serde_json::Value = serde_json::from_slice(&report).unwrap();
    summary.as_object_mut().unwrap().remove("phases");
    let summary = tmp("summary.json", summary.to_string().as_bytes());
    for content in [Content::Phases, Content::Foci] {
        let e = plan_for(content, &summary, &Target::Lm, scene.clone(), None, None)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("is a plan summary without its phases"), "{e}");
        assert!(e.contains("plan --out F.json"), "{e}");
    }
    // The report itself still replays as phases.
    let got = plan_for(
        Content::Phases,
        &with_phases,
        &Target::Lm,
        scene,
        None,
        None,
    )
    .unwrap();
    assert_eq!(got.plan.sequence.phases, planned.plan.sequence.phases);
}

#[test]
fn raw_bin_phases_are_whole_steps_of_the_device() {
    let (scene, planned) = default_planned();
    let p = tmp("rt.bin", &planned.plan.sequence.phases);
    let got = lm_phases_at_5_hz(&p, &scene).unwrap();
    assert_eq!(got.plan.sequence.phases, planned.plan.sequence.phases);
    assert_eq!(got.plan.sequence.header, planned.plan.sequence.header);
    for (name, len, says) in [("odd.bin", 997, "997 bytes"), ("empty.bin", 0, "0 bytes")] {
        let p = tmp(name, &vec![0u8; len]);
        let e = lm_phases_at_5_hz(&p, &scene).err().unwrap().to_string();
        assert!(
            e.contains(says) && e.contains(name) && !e.contains('\n'),
            "{e}"
        );
    }
}

#[test]
fn raw_phases_under_another_extension_are_told_to_be_named_bin() {
    let (scene, planned) = default_planned();
    // What `plan --out F.raw` writes: the raw bytes.
    let p = tmp("rt.raw", &planned.plan.sequence.phases);
    let e = lm_phases_at_5_hz(&p, &scene).err().unwrap().to_string();
    assert!(
        e.contains("rt.raw") && e.contains("name raw phase bytes .bin"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");
    // A .json file that is not JSON gets no such hint: it is named right.
    let j = tmp("bad.json", b"[1,2");
    let e = lm_phases_at_5_hz(&j, &scene).err().unwrap().to_string();
    assert!(e.contains("bad.json") && !e.contains(".bin"), "{e}");
}

/// `null` is never a key left out: `dwell_us: null` beside `--freq` is
/// not "no dwell", a report's `intensity_table: null` not "no AM"; the
/// `null`s plan writes itself (`timing.am_freq_hz`, `timing.divide`)
/// read as it meant them.
#[test]
fn a_null_where_a_key_may_be_left_out_is_refused_naming_it() {
    let scene = Scene::default();
    let row = vec![0u8; 996];
    let null = crate::json::NULL_REFUSED;
    for (name, json, content) in [
        (
            "null-dwell.json",
            serde_json::json!({"phases": vec![row.clone(); 4], "dwell_us": null}),
            Content::Phases,
        ),
        (
            "null-foci-dwell.json",
            serde_json::json!({"foci_mm": [[[0, 0, 200]]], "dwell_us": null}),
            Content::Foci,
        ),
    ] {
        let p = tmp(name, json.to_string().as_bytes());
        let e = plan_for(content, &p, &Target::Lm, scene.clone(), Some(5.0), None)
            .err()
            .unwrap_or_else(|| panic!("{name} was accepted"))
            .to_string();
        assert!(e.contains(&format!("dwell_us: {null}")), "{name}: {e}");
        // Left out, the frequency gives the timing.
        let mut left_out = json.clone();
        left_out.as_object_mut().unwrap().remove("dwell_us");
        let p = tmp(name, left_out.to_string().as_bytes());
        plan_for(content, &p, &Target::Lm, scene.clone(), Some(5.0), None).unwrap();
    }
    let (_, planned) = default_planned();
    let report = planned
        .out_bytes(Path::new("report.json"), &Target::Lm)
        .unwrap();
    let mut v: serde_json::Value = serde_json::from_slice(&report).unwrap();
    assert!(v["timing"]["am_freq_hz"].is_null() && v["timing"]["divide"].is_null());
    let p = tmp("report-nulls.json", &report);
    plan_for(Content::Phases, &p, &Target::Lm, scene.clone(), None, None).unwrap();
    for key in ["intensity_table", "drive_foci_mm"] {
        v[key] = serde_json::Value::Null;
        let p = tmp("report-null-key.json", v.to_string().as_bytes());
        let e = plan_for(Content::Phases, &p, &Target::Lm, scene.clone(), None, None)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(&format!("{key}: {null}")), "{e}");
        v.as_object_mut().unwrap().remove(key);
    }
}
