//! `lmhost plan` and `lmhost scene` end to end: the real binary, its exit
//! codes, its outputs.
//!
//! The binary is built once into this test's own target dir and profile
//! (`link_support::lmhost`).

use std::path::Path;
use std::process::Command;

mod link_support;
use link_support::{fails, lmhost, run, scratch_dir};

fn scene_path() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes/paper.toml")
        .display()
        .to_string()
}

#[test]
fn plan_prints_a_summary_and_exits_0() {
    let o = run(&["plan", "--radius", "3", "--foci", "4"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = String::from_utf8(o.stdout).unwrap();
    assert!(s.contains("LM-M (4 foci, l = 13)"), "{s}");
    assert!(s.contains("steps N = 82"), "{s}");
    assert!(s.contains("dwell 2.439 ms"), "{s}");
}

#[test]
fn plan_json_has_phases_only_when_asked() {
    let o = run(&["plan", "--json"]);
    assert!(o.status.success());
    let v = String::from_utf8(o.stdout).unwrap();
    assert!(
        v.contains("\"steps\":82") && !v.contains("\"phases\""),
        "{v}"
    );
    let o = run(&["plan", "--json", "--phases", "--steps", "4", "--freq", "1"]);
    let v = String::from_utf8(o.stdout).unwrap();
    assert!(v.contains("\"phases\":[["), "{v}");
}

#[test]
fn plan_writes_npy_json_and_raw_by_extension() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plan_cli_out");
    std::fs::create_dir_all(&dir).unwrap();
    let npy = dir.join("s.npy");
    let raw = dir.join("s.bin");
    let json = dir.join("s.json");
    for p in [&npy, &raw, &json] {
        let o = run(&["plan", "--foci", "4", "--out", p.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let raw = std::fs::read(raw).unwrap();
    assert_eq!(raw.len(), 82 * 996);
    let npy = std::fs::read(npy).unwrap();
    assert!(npy.starts_with(b"\x93NUMPY"));
    assert_eq!(&npy[npy.len() - raw.len()..], &raw[..]);
    let json = std::fs::read_to_string(json).unwrap();
    assert!(json.contains("\"phases\""));
}

#[test]
fn scene_json_exports_every_transducer() {
    let o = run(&["scene", "--scene", &scene_path(), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = String::from_utf8(o.stdout).unwrap();
    assert_eq!(v.matches("\"pos_mm\"").count(), 996);
    assert_eq!(v.matches("\"normal\"").count(), 996 + 1);
}

#[test]
fn bad_inputs_exit_2_with_one_line() {
    let bad: &[&[&str]] = &[
        &["plan", "--radius", "NaN"],
        &["plan", "--radius", "-3"],
        &["plan", "--freq", "inf"],
        &["plan", "--step", "-0.2"],
        &["plan", "--center", "0,0"],
        &["plan", "--foci", "4", "--spacing", "0.1"],
        &["plan", "--radius", "1", "--foci", "4"],
        &["plan", "--freq", "50"],
        &["plan", "--scene", "/nonexistent/scene.toml"],
        &["scene", "--scene", "/nonexistent/scene.toml"],
    ];
    for args in bad {
        let err = fails(args, 2);
        assert!(err.starts_with("error: "), "{err}");
        assert!(!err.contains("panicked"));
    }
}

/// A message echoes what it was given (a path, a port, a flag's value);
/// what a terminal would act on in it (an escape sequence, a carriage
/// return, a right-to-left override) is shown escaped, in lmhost's own
/// errors and in clap's alike.
#[test]
fn what_a_terminal_would_act_on_is_shown_escaped_in_errors() {
    let cases: &[(&[&str], &str)] = &[
        (
            &["plan", "--scene", "/nonexistent/a\u{1b}[31mred"],
            "a\\u{1b}[31mred",
        ),
        (&["status", "--port", "/nonexistent/a\rb"], "a\\rb"),
        (
            &["plan", "--scene", "/nonexistent/\u{202e}lmth.toml"],
            "\\u{202e}lmth.toml",
        ),
        (&["plan", "--radius", "3\u{1b}[2J"], "3\\u{1b}[2J"),
        (&["plan", "--radius", "3\n\nx"], "'3\\n\\nx' for '--radius"),
        (&["plan", "--bogus\u{9b}2J"], "--bogus\\u{9b}2J"),
    ];
    for (args, shown) in cases {
        let o = run(args);
        assert!(matches!(o.status.code(), Some(1 | 2)), "{args:?}");
        let err = String::from_utf8(o.stderr).unwrap();
        assert!(err.contains(shown), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(
            !err.chars()
                .any(|c| (c.is_control() && c != '\n') || c == '\u{202e}'),
            "{args:?}: {err:?}"
        );
    }
}

#[test]
fn bad_scene_file_names_file_and_field() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plan_cli_scene");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("bad.toml");
    std::fs::write(&p, "[[device]]\ncenter_mm = [0.0, 0.0]\n").unwrap();
    let o = run(&["plan", "--scene", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(
        err.contains("bad.toml") && err.contains("center_mm"),
        "{err}"
    );
}

/// What stdout echoes from a file (a scene's name) is shown escaped on a
/// terminal, as `ls` shows such names, and kept byte for byte in a pipe:
/// a bidirectional override (a control character in a name is refused
/// by the scene's own check).
#[test]
fn a_name_is_shown_escaped_on_a_terminal_and_kept_in_a_pipe() {
    use std::io::Read as _;
    use std::process::Stdio;
    let d = scratch_dir("tty-name");
    let scene = d.join("s.toml");
    let text = std::fs::read_to_string(scene_path()).unwrap();
    let text = text.replacen("name = \"", "name = \"\\u202e", 1);
    std::fs::write(&scene, text).unwrap();
    let args = ["plan", "--scene", scene.to_str().unwrap()];
    let piped = run(&args);
    assert!(
        piped.status.success(),
        "{}",
        String::from_utf8_lossy(&piped.stderr)
    );
    let piped = String::from_utf8(piped.stdout).unwrap();
    assert!(piped.contains("\u{202e}paper"), "{piped:?}");
    let on_a_terminal = |args: &[&str]| {
        let pty = nix::pty::openpty(None, None).unwrap();
        let mut child = Command::new(lmhost())
            .args(args)
            .stdout(Stdio::from(pty.slave))
            .spawn()
            .unwrap();
        // Read as it writes (more than the terminal's buffer holds would
        // block it); the read ends with EIO once the child is gone.
        let mut master = std::fs::File::from(pty.master);
        let reader = std::thread::spawn(move || {
            let mut shown = Vec::new();
            let _ = master.read_to_end(&mut shown);
            shown
        });
        assert!(child.wait().unwrap().success());
        let shown = String::from_utf8(reader.join().unwrap()).unwrap();
        assert!(!shown.contains('\u{202e}'), "{shown:?}");
        shown
    };
    let shown = on_a_terminal(&args);
    assert!(shown.contains("\\u{202e}paper"), "{shown:?}");
    // JSON stays JSON: the same characters as JSON escapes, read back as
    // the name they are.
    let shown = on_a_terminal(&[args[0], args[1], args[2], "--json"]);
    assert!(shown.contains("\\u202epaper"), "{shown:?}");
    let v: serde_json::Value = serde_json::from_str(&shown).expect("JSON on a terminal");
    let name = v["scene"].as_str().unwrap_or_default();
    assert!(name.starts_with("\u{202e}paper"), "{v}");
    // What a terminal would act on as a command never gets that far.
    let text = std::fs::read_to_string(scene_path()).unwrap();
    std::fs::write(&scene, text.replacen("name = \"", "name = \"\\u001b[2J", 1)).unwrap();
    let refused = run(&args);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{err}");
    assert!(
        err.contains("field `name`") && err.contains("control character"),
        "{err}"
    );
}

/// A file of another kind than the flag takes says what it is and what
/// it is for (a library given as `--scene` failed on "unknown field
/// `stimulus`, expected one of `name`, `directivity`, ...").
#[test]
fn a_file_of_another_kind_says_what_it_is() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let path = |f: &str| repo.join(f).display().to_string();
    let out = scratch_dir("kinds");
    let out = out.join("x").display().to_string();
    let cases: &[(&[&str], &str)] = &[
        (
            &["plan", "--scene", &path("studies/paper-library.toml")],
            "it is a stimulus library, not a scene file (for --library)",
        ),
        (
            &["plan", "--scene", &path("studies/paper-exp1.toml")],
            "it is a study protocol, not a scene file (for `lmhost study run`",
        ),
        (
            &[
                "simulate",
                "--library",
                &path("scenes/paper.toml"),
                "--stimulus",
                "a",
                "--out",
                &out,
            ],
            "it is a scene file, not a stimulus library (for --scene)",
        ),
        (
            &["study", "check", &path("studies/paper-library.toml")],
            "it is a stimulus library, not a study protocol (for --library)",
        ),
    ];
    for (args, says) in cases {
        let err = fails(args, 2);
        assert!(err.contains(says), "{args:?}: {err}");
    }
    assert!(!Path::new(&out).exists());
}

#[test]
fn wiring_maps_every_transducer_of_a_scene_to_a_board_pin() {
    let dir = scratch_dir("wiring");
    let out = dir.join("wiring.csv");
    let o = run(&[
        "wiring",
        "--scene",
        &scene_path(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 996);
    // Positions are the scene's own, in its index order.
    let scene = run(&["scene", "--scene", &scene_path(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&scene.stdout).unwrap();
    let x0 = v["transducers"][995]["pos_mm"][0].as_f64().unwrap();
    assert!((rows[995][8].parse::<f64>().unwrap() - x0).abs() < 1e-3);
    // Sixteen boards, the last one with 36 channels, each pin used once per board.
    assert_eq!(rows[995][1], "15");
    assert_eq!(rows.iter().filter(|r| r[1] == "15").count(), 36);
    let board0: std::collections::BTreeSet<_> = rows
        .iter()
        .filter(|r| r[1] == "0")
        .map(|r| (r[3], r[4]))
        .collect();
    assert_eq!(board0.len(), 64);
    // A board larger than the breakout board's outputs is bad input.
    let o = run(&["wiring", "--channels-per-board", "65"]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).unwrap();
}
