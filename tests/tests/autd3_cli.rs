//! `lmhost upload --port autd3:...` end to end: the real binary against
//! autd3's firmware emulator, its JSON report and exit codes.

use std::path::Path;
use std::process::{Command, Output};

mod link_support;
use link_support::lmhost;

fn run(args: &[&str]) -> Output {
    Command::new(lmhost())
        .args(args)
        .env_remove("LMHOST_PORT")
        .output()
        .expect("lmhost runs")
}

fn one_line_error(o: &Output) -> String {
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    e
}

#[test]
fn upload_to_the_emulator_reports_grid_timing_and_a_clean_readback() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml");
    let o = run(&[
        "upload",
        "--port",
        "autd3:emulator",
        "--scene",
        scene.to_str().unwrap(),
        "--foci",
        "4",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["steps"], 82);
    assert_eq!(v["dwell_us"], 2450.0);
    assert!(
        (v["freq_hz"].as_f64().unwrap() - 4.9776).abs() < 1e-3,
        "{v}"
    );
    assert_eq!(v["readback_mismatches"], 0);
    assert_eq!(v["transducers"], 996);
}

#[test]
fn bad_autd3_ports_and_limits_exit_2_missing_links_exit_1() {
    let o = run(&["upload", "--port", "autd3:nope"]);
    assert_eq!(o.status.code(), Some(2));
    one_line_error(&o);
    let o = run(&[
        "upload",
        "--port",
        "autd3:emulator",
        "--freq",
        "100",
        "--steps",
        "82",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(one_line_error(&o).contains("25 µs"));
    let o = run(&["upload", "--port", "autd3:ethercrab:eth0"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(one_line_error(&o).contains("autd3-ethercrab"));
}
