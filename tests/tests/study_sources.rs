//! `lmhost study run` takes the finger sources `lmhost session` takes
//! (one set of flags): here a recorded centroid stream, which plays at its
//! time stamps, so a recording longer than the study keeps the finger on
//! the marker for the whole run (read as fast as the disk gives it, it
//! ended at once and the run stopped on it).

use std::path::Path;

mod link_support;
#[allow(dead_code)]
mod study_support;
use study_support::*;

/// Two of the paper's stimuli, one set, one question, untracked
/// (`study_support/two.toml`).
fn protocol(d: &Path) -> std::path::PathBuf {
    let p = d.join("two.toml");
    let text =
        include_str!("study_support/two.toml").replace("{library}", &studies("paper-library.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

/// `study run` of [`protocol`] on autd3's emulator for P01 into `d/out`,
/// then `extra`.
fn run_two(d: &Path, extra: &[&str]) -> std::process::Output {
    let proto = protocol(d);
    run_on(
        proto.to_str().unwrap(),
        "autd3:emulator",
        &d.join("out"),
        extra,
    )
    .output()
    .unwrap()
}

#[test]
fn a_recorded_stream_is_a_finger_source_played_at_its_time_stamps() {
    let d = scratch("sources");
    // 120 s of a finger resting at the centre, 20 samples a second.
    let rec = d.join("finger.csv");
    let lines: String = (0..2400)
        .map(|i| format!("{:.2},0,0,200,1\n", i as f64 * 0.05))
        .collect();
    std::fs::write(&rec, lines).unwrap();
    let answers = answers_file(&d, "3\n5\n");
    ok(&run_two(
        &d,
        &[
            "--responses",
            answers.to_str().unwrap(),
            "--stream",
            rec.to_str().unwrap(),
            "--filter",
            "none",
            "--seed",
            "1",
        ],
    ));
    let out = d.join("out");
    n_rows(&out.join("P01"), 2);
    let s = std::fs::read_to_string(out.join("P01/session.json")).unwrap();
    assert!(s.contains("stream:"), "{s}");
}

#[test]
fn the_session_flags_are_the_studys() {
    // Flags only `session` had: refused for what they are, not unknown.
    let d = scratch("sources-flags");
    let o = run_two(&d, &["--responses", "/dev/null", "--depth-stream", "-"]);
    says(
        &refused(&o),
        &["--scene is needed with --depth, --camera and --depth-stream"],
    );
}
