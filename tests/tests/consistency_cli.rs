//! One behaviour, one report on every backend: the LM firmware (`lmhost
//! sim`) and AUTD3 (`autd3:emulator`) take the same stimulus flags and
//! print the same upload schema; `plan --target autd3` is what an AUTD3
//! plays; stimulus files go through the planned stimulus's checks.

use std::collections::BTreeSet;

mod link_support;
use link_support::{
    Sim, assert_fields, emulator_json, fails, json, ok, scratch_dir, stream_json, upload_json,
};

fn keys(v: &serde_json::Value) -> BTreeSet<String> {
    v.as_object().unwrap().keys().cloned().collect()
}

#[test]
fn upload_json_has_the_same_keys_on_both_backends() {
    let sim = Sim::start(&[]);
    let lm = upload_json(&sim.port, &[]);
    let a = emulator_json("upload", &[]);
    assert_eq!(keys(&lm), keys(&a), "\nLM {lm}\nAUTD3 {a}");
    for k in [
        "crc32",
        "seconds",
        "payload_bytes",
        "wire_bytes_sent",
        "frames",
        "divide",
        "readback_mismatches",
        "steps",
        "dwell_us",
        "requested_dwell_us",
        "freq_hz",
        "requested_freq_hz",
        "step_mm",
        "requested_step_mm",
    ] {
        assert!(lm.get(k).is_some(), "{k} missing: {lm}");
    }
    // Same stimulus, same phases: the same CRC on both (the default is on
    // the grid's N too); what one cannot know is null there.
    assert_eq!(lm["crc32"], a["crc32"]);
    assert!(
        lm["frames"].is_null() && lm["divide"].is_null() && lm["readback_mismatches"].is_null()
    );
    assert!(lm["wire_bytes_sent"].as_u64().unwrap() > 0, "{lm}");
    assert_eq!(a["divide"], 98);
    assert!(
        a["frames"].as_u64().unwrap() > 0 && a["wire_bytes_sent"].is_null(),
        "{a}"
    );
    assert_eq!(a["payload_bytes"], 82 * 996);
    assert!(lm["seconds"].as_f64().unwrap() > 0.0 && a["seconds"].as_f64().unwrap() > 0.0);
}

#[test]
fn stream_plan_flags_upload_and_play_on_the_lm_firmware() {
    let sim = Sim::uploaded(&[]);
    // No stimulus flag: the LM firmware plays again what it played (slot 0).
    let v = stream_json(&sim.port, &["--synthetic", "--fast", "--seconds", "0.2"]);
    assert!(v["upload"].is_null(), "{v}");
    let st = json(&["status", "--port", &sim.port, "--json"]);
    assert_fields(&st, &["slot", "queued_slot"], serde_json::json!([0, null]));
    // Stimulus flags: planned, uploaded into the free slot and played.
    let plan_flags = [
        "--synthetic",
        "--fast",
        "--seconds",
        "0.2",
        "--foci",
        "4",
        "--radius",
        "3",
    ];
    let v = stream_json(&sim.port, &plan_flags);
    let u = &v["upload"];
    assert_eq!(u["slot"], 1, "{v}");
    assert_eq!(u["steps"], 82, "{v}");
    assert!(u["playing"] == true && u["divide"].is_null(), "{v}");
    let st = json(&["status", "--port", &sim.port, "--json"]);
    assert!(st["slot"] == 1 || st["queued_slot"] == 1, "{st}");
    // On AUTD3 the same flags give the same report, on the grid.
    let a = stream_json("autd3:emulator", &plan_flags);
    assert_eq!(keys(&a["upload"]), keys(u), "{a}");
    assert_eq!(a["upload"]["divide"], 98);
    // A flag that cannot apply is refused.
    let e = fails(
        &[
            "stream",
            "--port",
            &sim.port,
            "--iterations",
            "5",
            "--synthetic",
        ],
        2,
    );
    assert!(
        e.contains("--iterations applies to --method gspat only"),
        "{e}"
    );
}

#[test]
fn plan_target_autd3_is_what_the_autd3_plays() {
    let d = scratch_dir("consistency-target");
    let npy = d.join("a5.npy");
    let v = json(&[
        "plan",
        "--target",
        "autd3",
        "--radius",
        "5",
        "--json",
        "--out",
        npy.to_str().unwrap(),
    ]);
    assert_eq!(v["steps"], 136, "{v}");
    assert_eq!(v["target"], "autd3");
    assert_eq!(v["timing"]["divide"], 59, "{v}");
    assert_eq!(v["timing"]["dwell_us"], 1475.0, "{v}");
    assert_eq!(json(&["plan", "--radius", "5", "--json"])["steps"], 137);
    let text = ok(&["plan", "--target", "autd3", "--radius", "5"]);
    assert!(
        text.contains("steps N = 136") && text.contains("dwell 1475 µs = 59 × 25 µs"),
        "{text}"
    );
    // The AUTD3 backend uploads the same phases (its read-back is clean
    // against its plan, and the CRCs agree) ...
    let a = emulator_json("upload", &["--radius", "5"]);
    assert_fields(
        &a,
        &["steps", "readback_mismatches"],
        serde_json::json!([136, 0]),
    );
    assert_eq!(a["crc32"], v["crc32"], "{a}");
    // ... and the exported file, uploaded as phases at 5 Hz, reads back
    // byte for byte with the same timing.
    let f = emulator_json(
        "upload",
        &["--phases", npy.to_str().unwrap(), "--freq", "5"],
    );
    assert_eq!(f["crc32"], v["crc32"], "{f}");
    assert_eq!(f["readback_mismatches"], 0, "{f}");
    assert_fields(&f, &["steps", "divide"], serde_json::json!([136, 59]));
    let bytes = std::fs::read(&npy).unwrap();
    assert_eq!(bytes.len(), 128 + 136 * 996);
}

#[test]
fn stimulus_files_upload_through_the_same_checks() {
    let d = scratch_dir("consistency-files");
    let sim = Sim::start(&[]);
    // Foci as JSON: the paper's LM-S circle at 8 steps, dwell in the file.
    let foci: Vec<Vec<[f64; 3]>> = (0..8)
        .map(|j| {
            let th = 2.0 * std::f64::consts::PI * j as f64 / 8.0;
            vec![[3.0 * th.cos(), 3.0 * th.sin(), 200.0]]
        })
        .collect();
    let fj = d.join("foci.json");
    std::fs::write(
        &fj,
        serde_json::json!({"foci_mm": foci, "dwell_us": 25000}).to_string(),
    )
    .unwrap();
    let fj = fj.to_str().unwrap();
    let v = upload_json(&sim.port, &["--foci-file", fj]);
    assert_fields(&v, &["steps", "freq_hz"], serde_json::json!([8, 5.0]));
    // The same circle planned: the same phases.
    let p = json(&["plan", "--steps", "8", "--json"]);
    assert_eq!(v["crc32"], p["crc32"], "{v}");
    // On AUTD3 too (25 ms is on the grid), read back clean.
    let a = emulator_json("upload", &["--foci-file", fj]);
    assert_fields(
        &a,
        &["divide", "readback_mismatches"],
        serde_json::json!([1000, 0]),
    );
    // Phases as JSON, and the refusals.
    let pj = d.join("phases.json");
    std::fs::write(
        &pj,
        serde_json::json!({"phases": vec![vec![0u8; 996]; 4], "dwell_us": 2010}).to_string(),
    )
    .unwrap();
    let pj = pj.to_str().unwrap();
    let v = upload_json(&sim.port, &["--phases", pj]);
    assert_eq!(v["steps"], 4);
    let e = fails(&["upload", "--port", "autd3:emulator", "--phases", pj], 2);
    assert!(e.contains(pj) && e.contains("25 µs grid"), "{e}");
    let e = fails(
        &["upload", "--port", &sim.port, "--phases", pj, "--freq", "5"],
        2,
    );
    assert!(e.contains("give one"), "{e}");
    let e = fails(
        &[
            "upload",
            "--port",
            &sim.port,
            "--foci-file",
            fj,
            "--radius",
            "3",
        ],
        2,
    );
    assert!(e.contains("--radius"), "{e}");
}
