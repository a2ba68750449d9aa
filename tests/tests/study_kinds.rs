//! Library entries beyond the circle end to end: a study with an AM entry
//! and a Lissajous entry runs on autd3's emulator (every upload read back
//! with 0 mismatches) and on the simulated LM device (the AM as the
//! entry's intensity table, protocol v6, every commit's CRC over the
//! stored phases and levels acknowledged), which refuses an AM its steps
//! cannot carry with one line naming those that fit; `simulate` renders
//! both from the library (the figure's extent on the map, the AM power at
//! its frequency).

use std::path::Path;

mod link_support;
use link_support::{Sim, json_file, one_line_error};
#[allow(dead_code)]
mod study_support;
use study_support::*;

/// A Lissajous entry and an AM entry.
const LIBRARY: &str = include_str!("study_support/kinds-library.toml");

/// A scratch folder `name` holding `library` and the one-factor protocol
/// over its two entries, one set, one question
/// (`study_support/kinds.toml`): the folder and the protocol's path.
fn kinds_study(name: &str, library: &str) -> (Scratch, String) {
    let d = scratch(name);
    std::fs::write(d.join("kinds-library.toml"), library).unwrap();
    let p = d.join("kinds.toml");
    std::fs::write(&p, include_str!("study_support/kinds.toml")).unwrap();
    (d, p.display().to_string())
}

fn run(proto: &str, port: &str, out: &Path, answers: &Path) -> std::process::Output {
    answered_p01(proto, port, out, "0.05", answers, "1")
}

/// Runs the study over both entries on `port` with `answers` (in a
/// scratch folder `name`): each entry preloaded, presented and recorded
/// once. Their `preloaded` events.
fn plays_both_entries(name: &str, port: &str, answers: &str) -> Vec<serde_json::Value> {
    let (d, proto) = kinds_study(name, LIBRARY);
    let answers = answers_file(&d, answers);
    let out = d.join("out");
    ok(&run(&proto, port, &out, &answers));
    let r = n_rows(&out.join("P01"), 2);
    let mut played: Vec<&str> = r.iter().map(|x| x["stimulus"].as_str()).collect();
    played.sort();
    assert_eq!(played, ["am", "liss"]);
    let events = std::fs::read_to_string(out.join("P01/events.jsonl")).unwrap();
    let onsets = events
        .lines()
        .filter(|l| l.contains("\"event\":\"onset\""))
        .count();
    assert_eq!(onsets, 2, "{events}");
    let uploads: Vec<serde_json::Value> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["event"] == "preloaded")
        .collect();
    assert_eq!(uploads.len(), 2, "{events}");
    uploads
}

#[test]
fn an_am_and_a_lissajous_entry_play_in_a_study_on_the_emulator() {
    for u in &plays_both_entries("kinds-emu", "autd3:emulator", "3\n5\n") {
        assert_eq!(u["readback_mismatches"], 0, "{u}");
    }
}

#[test]
fn the_simulated_device_plays_the_am_and_lissajous_entries_in_a_study() {
    let sim = Sim::start(&[]);
    // The LM link reads nothing back byte by byte (null); its commit, acked
    // for both, is the device's CRC over the phases and levels it stored.
    for u in &plays_both_entries("kinds-sim", &sim.port, "4\n5\n") {
        assert!(u["readback_mismatches"].is_null(), "{u}");
    }
}

#[test]
fn the_simulated_device_refuses_an_am_its_steps_cannot_carry_in_one_line() {
    let sim = Sim::start(&[]);
    // 200 Hz on the default 82 steps of a 5 Hz cycle: 2 steps a period.
    // The whole library is planned for the device at start, so nothing is
    // written.
    let (d, proto) = kinds_study("kinds-sim-refused", &LIBRARY.replace("100.0", "200.0"));
    let answers = answers_file(&d, "4\n5\n");
    let refused = d.join("refused");
    let o = run(&proto, &sim.port, &refused, &answers);
    let err = one_line_error(&o, 2);
    assert!(
        err.contains("`am`") && err.contains("does not fit"),
        "{err}"
    );
    assert!(err.contains("from 5 to 100 Hz"), "{err}");
    assert!(!refused.join("P01/trials.csv").exists());
}

/// `study check` calls valid only what `run` plays: on the LM firmware the
/// AM that does not fit is refused by the same planning, on an AUTD3 (or
/// either, unnamed) the protocol is valid.
#[test]
fn study_check_refuses_for_the_lm_firmware_a_library_it_cannot_plan() {
    let (_d, proto) = kinds_study("kinds-check", &LIBRARY.replace("100.0", "200.0"));
    let check = |target: Option<&str>| {
        let mut c = std::process::Command::new(link_support::lmhost());
        c.args(["study", "check", &proto]);
        if let Some(t) = target {
            c.args(["--target", t]);
        }
        c.output().unwrap()
    };
    let err = one_line_error(&check(Some("lm")), 2);
    assert!(
        err.starts_with("error: the library cannot be planned for the LM firmware: ")
            && err.contains("`am`")
            && err.contains("does not fit"),
        "{err}"
    );
    for target in [Some("autd3"), None] {
        let o = check(target);
        assert!(o.status.success(), "{target:?}: {o:?}");
    }
}

fn simulate(d: &Path, id: &str) -> serde_json::Value {
    let lib = d.join("kinds-library.toml");
    std::fs::write(&lib, LIBRARY).unwrap();
    let out = d.join(id);
    let o = std::process::Command::new(link_support::lmhost())
        .args([
            "simulate",
            "--library",
            lib.to_str().unwrap(),
            "--stimulus",
            id,
            "--plane-size",
            "16,10",
            "--plane-step",
            "0.5",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    ok(&o);
    json_file(out.join("summary.json"))
}

#[test]
fn simulate_renders_the_lissajous_figure_and_the_am_power_at_its_frequency() {
    let d = scratch("kinds-simulate");
    let s = simulate(&d, "liss");
    assert_eq!(s["stimulus"]["path"], "lissajous");
    // The figure spans ±5 mm along a and ±2 mm along b (plus the focal
    // spot): wider than high by about 2 × (5 − 2) mm, as a circle is not.
    let ext = &s["mean_pressure_half_peak_extent_mm"];
    let span = |k: &str| ext[k][1].as_f64().unwrap() - ext[k][0].as_f64().unwrap();
    let (u, v) = (span("u"), span("v"));
    assert!((10.0..=14.0).contains(&u), "{ext}");
    assert!((4.0..=8.0).contains(&v), "{ext}");
    assert!((u - v - 6.0).abs() <= 1.5, "{ext}");
    assert!(s["am"].is_null());
    let a = simulate(&d, "am");
    let am = &a["am"];
    assert_eq!(am["force_spectrum_peak_hz"], 100.0, "{am}");
    assert_eq!(am["realised_freq_hz"], 100.0, "{am}");
    // Full depth: the mean pressure keeps 3/8; the AM power is there.
    assert!((am["mean_square_envelope"].as_f64().unwrap() - 0.375).abs() < 1e-9);
    assert!(am["am_power_peak_pa2"].as_f64().unwrap() > 0.0, "{am}");
    assert!(d.join("am/am_power.png").exists() && !d.join("liss/am_power.png").exists());
}
