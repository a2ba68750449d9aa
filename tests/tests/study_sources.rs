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

fn protocol(d: &Path) -> std::path::PathBuf {
    let p = d.join("two.toml");
    std::fs::write(
        &p,
        format!(
            r#"name = "two"
library = "{}"
sets = 1
stimulus = "{{type}}-a3"

[timeline]
wait_for_finger = true
on_s = 0.3
iti_s = 0.1
gate = "untracked"

[[factor]]
name = "type"
levels = ["lms-5hz", "lms-25hz"]

[[question]]
id = "vibration"
kind = "likert"
points = 7
low = "not at all"
high = "very"
text = "How intense?"
"#,
            studies("paper-library.toml")
        ),
    )
    .unwrap();
    p
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
    let answers = d.join("answers.txt");
    std::fs::write(&answers, "3\n5\n").unwrap();
    let out = d.join("out");
    let o = run_on(
        protocol(&d).to_str().unwrap(),
        "autd3:emulator",
        &out,
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
    )
    .output()
    .unwrap();
    ok(&o);
    let r = rows(&out.join("P01"));
    assert_eq!(r.len(), 2);
    let s = std::fs::read_to_string(out.join("P01/session.json")).unwrap();
    assert!(s.contains("stream:"), "{s}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_session_flags_are_the_studys() {
    // Flags only `session` had: refused for what they are, not unknown.
    let d = scratch("sources-flags");
    let out = d.join("out");
    let o = run_on(
        protocol(&d).to_str().unwrap(),
        "autd3:emulator",
        &out,
        &["--responses", "/dev/null", "--depth-stream", "-"],
    )
    .output()
    .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--scene is needed with --depth, --camera and --depth-stream"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
