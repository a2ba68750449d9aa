//! What `lmhost plan --out` writes, `lmhost upload --phases` reads: each
//! of its three forms (.json, .npy, .bin) uploads the phases plan made,
//! the same CRC and timing, on `lmhost sim` and `autd3:emulator`; a plan
//! report changed after plan wrote it, or made for the other target, is
//! refused with one line naming the file.

mod link_support;
use link_support::{
    Sim, assert_fields, emulator_json, fails, json, json_file, ok, scratch_dir, upload_json,
};

/// `plan ARGS --out DIR/NAME.{json,npy,bin}`; the paths, and `plan --json`.
fn planned(d: &std::path::Path, name: &str, args: &[&str]) -> (Vec<String>, serde_json::Value) {
    let files: Vec<String> = ["json", "npy", "bin"]
        .iter()
        .map(|e| d.join(format!("{name}.{e}")).to_str().unwrap().to_owned())
        .collect();
    for f in &files {
        let mut a = vec!["plan"];
        a.extend_from_slice(args);
        a.extend_from_slice(&["--out", f]);
        ok(&a);
    }
    let mut a = vec!["plan", "--json"];
    a.extend_from_slice(args);
    (files, json(&a))
}

#[test]
fn every_plan_out_form_uploads_what_plan_made_on_the_lm_firmware() {
    let d = scratch_dir("plan-out-lm");
    let sim = Sim::start(&[]);
    let (f, p) = planned(&d, "lmm", &["--radius", "3", "--foci", "4"]);
    let report = json_file(&f[0]);
    assert_eq!(report["crc32"], p["crc32"]);
    // The report alone: its phases and its timing (no --freq).
    let v = upload_json(&sim.port, &["--phases", &f[0]]);
    assert_eq!(v["crc32"], p["crc32"], "{v}");
    assert_eq!(v["steps"], p["steps"], "{v}");
    assert_eq!(v["dwell_us"], p["timing"]["dwell_us"], "{v}");
    assert_eq!(v["freq_hz"], p["timing"]["freq_hz"], "{v}");
    // .npy and raw .bin carry no timing: --freq gives it.
    for file in &f[1..] {
        let v = upload_json(&sim.port, &["--phases", file, "--freq", "5"]);
        assert_eq!(v["crc32"], p["crc32"], "{file}: {v}");
        assert_eq!(v["dwell_us"], p["timing"]["dwell_us"], "{v}");
    }
    let e = fails(
        &[
            "upload", "--port", &sim.port, "--phases", &f[0], "--freq", "5",
        ],
        2,
    );
    assert!(e.contains(&f[0]) && e.contains("give one"), "{e}");
    let e = fails(&["upload", "--port", &sim.port, "--phases", &f[2]], 2);
    assert!(e.contains("--freq"), "{e}");
    // A raw file whose length is not whole steps of this device's.
    let short = d.join("short.bin");
    std::fs::write(&short, vec![0u8; 996 * 3 + 5]).unwrap();
    let short = short.to_str().unwrap();
    let e = fails(
        &[
            "upload", "--port", &sim.port, "--phases", short, "--freq", "5",
        ],
        2,
    );
    assert!(e.contains(short) && e.contains("2993 bytes"), "{e}");
    // A plan made for an AUTD3 (its 25 µs grid), refused by name.
    let (a, _) = planned(&d, "a", &["--target", "autd3", "--radius", "3"]);
    let e = fails(&["upload", "--port", &sim.port, "--phases", &a[0]], 2);
    assert!(
        e.contains(&a[0]) && e.contains("planned for target autd3"),
        "{e}"
    );
}

/// A change to a plan report.
type Edit = dyn Fn(&mut serde_json::Value);

#[test]
fn a_plan_report_changed_after_plan_wrote_it_is_refused() {
    let d = scratch_dir("plan-out-edited");
    let sim = Sim::start(&[]);
    let (f, _) = planned(&d, "p", &["--steps", "8", "--freq", "20"]);
    let good = json_file(&f[0]);
    let edited = |name: &str, edit: &Edit| {
        let mut v = good.clone();
        edit(&mut v);
        let p = d.join(name);
        std::fs::write(&p, v.to_string()).unwrap();
        p.to_str().unwrap().to_owned()
    };
    let cases: [(&str, &Edit, &str); 6] = [
        ("phase.json", &|v| v["phases"][3][7] = 1.into(), "crc32"),
        (
            "row.json",
            &|v| v["phases"][2] = serde_json::json!([0, 1]),
            "step 2 has 2 phases",
        ),
        ("steps.json", &|v| v["steps"] = 9.into(), "9 steps"),
        (
            "extra.json",
            &|v| v["note"] = "mine".into(),
            "unknown field `note`",
        ),
        (
            "header_extra.json",
            &|v| v["header"]["note"] = "mine".into(),
            "unknown field `note`",
        ),
        (
            "timing.json",
            &|v| v["timing"]["dwell_us"] = 7000.0.into(),
            "period_us",
        ),
    ];
    for (name, edit, says) in cases {
        let p = edited(name, edit);
        let e = fails(&["upload", "--port", &sim.port, "--phases", &p], 2);
        assert!(e.contains(&p) && e.contains(says), "{name}: {e}");
    }
    // A key given twice is refused, not the last one taken.
    let text = std::fs::read_to_string(&f[0]).unwrap();
    for key in ["crc32", "phases"] {
        let twice = d.join(format!("twice_{key}.json"));
        std::fs::write(
            &twice,
            text.replacen("{", &format!("{{\"{key}\":[[1]],"), 1),
        )
        .unwrap();
        let twice = twice.to_str().unwrap();
        let e = fails(&["upload", "--port", &sim.port, "--phases", twice], 2);
        assert!(e.contains(&format!("duplicate field `{key}`")), "{e}");
    }
    // Untouched, it uploads.
    let p = edited("same.json", &|_| {});
    assert_eq!(
        upload_json(&sim.port, &["--phases", &p])["crc32"],
        good["crc32"]
    );
}

#[test]
fn every_plan_out_form_uploads_what_plan_made_on_the_autd3_emulator() {
    let d = scratch_dir("plan-out-autd3");
    let (f, p) = planned(
        &d,
        "a",
        &["--target", "autd3", "--radius", "3", "--foci", "4"],
    );
    let v = emulator_json("upload", &["--phases", &f[0]]);
    assert_fields(
        &v,
        &["crc32", "divide", "readback_mismatches"],
        serde_json::json!([p["crc32"], p["timing"]["divide"], 0]),
    );
    for file in &f[1..] {
        let v = emulator_json("upload", &["--phases", file, "--freq", "5"]);
        assert_eq!(v["crc32"], p["crc32"], "{file}: {v}");
        assert_eq!(v["readback_mismatches"], 0, "{v}");
    }
    // The LM firmware's plan is not on the AUTD3's grid: refused by name.
    let (l, _) = planned(&d, "lm", &["--radius", "3"]);
    let e = fails(
        &["upload", "--port", "autd3:emulator", "--phases", &l[0]],
        2,
    );
    assert!(
        e.contains(&l[0]) && e.contains("planned for target lm"),
        "{e}"
    );
}
