//! `lmhost doctor` end to end: healthy devices pass, a dead one fails in
//! one line, and every check is one line.

mod link_support;
use link_support::{Sim, one_line_error, run, scratch_dir};

#[test]
fn doctor_passes_the_simulated_device_and_the_autd3_emulator() {
    let sim = Sim::start(&[]);
    let o = run(&["doctor", "--port", &sim.port, "--port", "autd3:emulator"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lm: Vec<&str> = out.lines().filter(|l| l.contains("lm board:")).collect();
    assert!(
        lm.iter().any(|l| l.starts_with("ok ")
            && l.contains(&sim.port)
            && l.contains("996 transducers")),
        "{out}"
    );
    assert!(
        out.lines().any(|l| l.starts_with("ok ")
            && l.contains("autd3:emulator")
            && l.contains("996 transducers")),
        "{out}"
    );
    // JSON has the same checks.
    let o = run(&["doctor", "--port", &sim.port, "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        v.as_array()
            .unwrap()
            .iter()
            .any(|c| c["what"] == "lm board" && c["outcome"] == "ok")
    );
}

#[test]
fn a_device_that_does_not_answer_fails_the_doctor_in_one_line() {
    let dir = scratch_dir("doctor");
    // Neither a missing path nor a regular file is a board: opening either
    // as a port fails, in one FAIL line naming it.
    let regular = dir.join("ttyFILE");
    std::fs::write(&regular, b"not a serial port").unwrap();
    for not_a_port in [dir.join("ttyNONE"), regular] {
        let name = not_a_port.file_name().unwrap().to_str().unwrap();
        let o = run(&[
            "doctor",
            "--port",
            not_a_port.to_str().unwrap(),
            "--timeout-ms",
            "50",
        ]);
        one_line_error(&o, 1);
        let out = String::from_utf8_lossy(&o.stdout);
        let fail: Vec<&str> = out.lines().filter(|l| l.starts_with("FAIL")).collect();
        assert_eq!(fail.len(), 1, "{name}: {out}");
        assert!(fail[0].contains(name) && fail[0].contains(" — "), "{out}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
