//! A flag that has no effect in the mode chosen (a simulated twin, a
//! source, a port kind, a command that plays nothing, another flag) is
//! refused in one line naming it, exit 2, before any device opens or any
//! file is written; where it applies it is still taken.

mod link_support;
use link_support::{fails, ok, scratch_dir};

/// `lmhost args…` exits 2 with one line on stderr naming `flag` and
/// saying `why`.
#[track_caller]
fn refused(args: &[&str], flag: &str, why: &str) {
    let err = fails(args, 2);
    assert!(err.contains(flag) && err.contains(why), "{args:?}: {err}");
}

fn studies() -> String {
    format!("{}/../studies", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn the_gauge_twin_refuses_the_real_gauges_settings() {
    for (flag, value) in [
        ("--baud", "19200"),
        ("--model", "mark10"),
        ("--model", "imada"),
    ] {
        refused(
            &["gauge", "read", "--port", "sim", flag, value],
            flag,
            "does not apply to the simulated gauge (port sim)",
        );
    }
    // The twin's own settings are taken.
    ok(&[
        "gauge",
        "read",
        "--port",
        "sim",
        "--sim-depth",
        "1",
        "--seed",
        "2",
    ]);
}

#[test]
fn the_stage_twin_refuses_the_controllers_settings() {
    for cmd in [&["move", "--to", "1"][..], &["position"], &["home"]] {
        for (flag, value) in [("--baud", "9600"), ("--step-um", "0.5"), ("--axis", "B")] {
            let mut args = vec!["stage"];
            args.extend_from_slice(cmd);
            args.extend(["--port", "sim", flag, value]);
            refused(
                &args,
                flag,
                "does not apply to the simulated stage (port sim)",
            );
        }
    }
    // The twin's own: limits and speed.
    let out = ok(&[
        "stage", "move", "--port", "sim", "--to", "0.2", "--speed", "20", "--min", "0", "--max",
        "5",
    ]);
    assert!(out.starts_with("at 0.2 mm"), "{out}");
}

#[test]
fn a_study_on_the_twins_refuses_the_real_instruments_settings_before_writing() {
    let dir = scratch_dir("ignored-flags-study");
    let out = dir.join("out");
    let protocol = format!("{}/paper-exp3.toml", studies());
    for (flag, value) in [
        ("--stage-axis", "B"),
        ("--stage-step-um", "0.5"),
        ("--stage-baud", "9600"),
        ("--gauge-model", "mark10"),
        ("--gauge-baud", "19200"),
    ] {
        refused(
            &[
                "study",
                "run",
                &protocol,
                "--port",
                "autd3:emulator",
                "--participant",
                "P01",
                "--out",
                out.to_str().unwrap(),
                "--finger",
                "synthetic",
                "--responses",
                "/dev/null",
                "--stage",
                "sim",
                "--gauge",
                "sim",
                flag,
                value,
            ],
            flag,
            "does not apply to the simulated",
        );
        assert!(!out.exists(), "{flag}: the study wrote {}", out.display());
    }
}

#[test]
fn the_sims_fault_seed_needs_faults() {
    refused(
        &["sim", "--seed", "3"],
        "--seed",
        "applies with --faults only",
    );
}

#[test]
fn stream_refuses_a_length_or_pace_its_source_does_not_have() {
    let dir = scratch_dir("ignored-flags-stream");
    let file = dir.join("track.csv");
    std::fs::write(&file, "0,0,0,200,1\n").unwrap();
    let file = file.to_str().unwrap();
    // No device is opened: the port need not exist.
    let port = "/dev/lmhost-no-such-port";
    for extra in [
        &["--seconds", "5"][..],
        &["--input", file, "--seconds", "5"],
        &["--input", "-", "--seconds", "5"],
    ] {
        let mut args = vec!["stream", "--port", port];
        args.extend_from_slice(extra);
        refused(&args, "--seconds", "applies to --synthetic");
    }
    for extra in [
        &["--fast"][..],
        &["--input", "-", "--fast"],
        &["--udp", "47991", "--fast"],
    ] {
        let mut args = vec!["stream", "--port", port];
        args.extend_from_slice(extra);
        refused(&args, "--fast", "applies to --synthetic and --input FILE");
    }
}

#[test]
fn track_refuses_link_settings_without_a_port_and_fast_on_a_live_source() {
    for (flag, value) in [("--baud", "9600"), ("--tries", "3"), ("--lease", "5")] {
        refused(
            &[
                "track",
                "--synthetic",
                "--seconds",
                "0.1",
                "--fast",
                flag,
                value,
            ],
            flag,
            "applies with --port only",
        );
    }
    for source in [&["--camera"][..], &["--stream", "-"]] {
        let mut args = vec!["track", "--fast"];
        args.extend_from_slice(source);
        refused(&args, "--fast", "cannot be used with");
    }
}

#[test]
fn simulate_compare_refuses_the_radius_its_columns_replace() {
    let dir = scratch_dir("ignored-flags-simulate");
    let out = dir.join("cmp");
    refused(
        &[
            "simulate",
            "--compare",
            "--radius",
            "4",
            "--out",
            out.to_str().unwrap(),
        ],
        "--radius",
        "cannot be used with",
    );
    assert!(!out.exists());
}

#[test]
fn a_lease_is_refused_where_nothing_plays() {
    let port = "/dev/lmhost-no-such-port";
    for cmd in ["status", "stop", "selftest"] {
        refused(
            &[cmd, "--port", port, "--lease", "5"],
            "--lease",
            &format!("`lmhost {cmd}` plays nothing"),
        );
    }
    refused(
        &["upload", "--port", port, "--no-play", "--lease", "5"],
        "--lease",
        "cannot be used with",
    );
}

#[test]
fn an_autd3_refuses_a_timeout_given_for_it_not_one_set_for_every_device() {
    refused(
        &["status", "--port", "autd3:emulator", "--timeout-ms", "500"],
        "--timeout-ms",
        "applies to the LM firmware's serial link",
    );
    // $LMHOST_TIMEOUT_MS, set once for every device, is not a setting of
    // this one.
    let o = std::process::Command::new(link_support::lmhost())
        .args(["status", "--port", "autd3:emulator"])
        .env("LMHOST_TIMEOUT_MS", "500")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
