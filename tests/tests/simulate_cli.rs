//! `lmhost simulate` end to end: the real binary writes heatmaps, maps and
//! a summary a user can load, and refuses bad flags with exit code 2.
//!
//! The binary is built once into this test's own target dir and profile
//! (`link_support::lmhost`). Grids are small
//! so the debug binary stays quick.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod link_support;
use link_support::{json_file, lmhost, send_signal};

fn run(args: &[&str]) -> Output {
    Command::new(lmhost())
        .args(args)
        .output()
        .expect("lmhost runs")
}

fn out_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("simulate-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Runs `lmhost simulate ARGS --out DIR` into a fresh `DIR` named for
/// `name`, asserts it succeeded, and returns `DIR` and the output.
fn simulate_ok(name: &str, args: &[&str]) -> (PathBuf, Output) {
    let out = out_dir(name);
    let mut all = vec!["simulate"];
    all.extend(args);
    all.extend(["--out", out.to_str().unwrap()]);
    let o = run(&all);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (out, o)
}

/// The run's `summary.json` in `out`.
fn summary(out: &Path) -> serde_json::Value {
    json_file(out.join("summary.json"))
}

/// Shape `(rows, cols)` from an NPY header, and the f64 data.
fn read_npy(path: &Path) -> ((usize, usize), Vec<f64>) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..6], b"\x93NUMPY");
    let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
    let h = std::str::from_utf8(&b[10..10 + hl]).unwrap();
    assert!(h.contains("'descr': '<f8'"), "{h}");
    let shape = h
        .split("'shape': (")
        .nth(1)
        .unwrap()
        .split(')')
        .next()
        .unwrap();
    let dims: Vec<usize> = shape
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let data = b[10 + hl..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    ((dims[0], dims[1]), data)
}

#[test]
fn simulate_writes_maps_heatmaps_and_a_summary() {
    let (out, o) = simulate_ok(
        "single",
        &[
            "--radius",
            "3",
            "--foci",
            "4",
            "--plane-size",
            "8,6",
            "--plane-step",
            "0.5",
        ],
    );
    let stdout = String::from_utf8(o.stdout).unwrap();
    assert!(stdout.contains("force on a 15 mm disk"), "{stdout}");

    let s = summary(&out);
    assert_eq!(s["plane"]["nu"], 17);
    assert_eq!(s["plane"]["nv"], 13);
    assert_eq!(s["stimulus"]["steps"], 82);
    assert_eq!(s["stimulus"]["foci"], 4);
    assert_eq!(s["transducers"], 996);
    let peak = s["maps"]["mean_pressure"]["peak"]["value"]
        .as_f64()
        .unwrap();
    assert!(
        peak > 100.0,
        "a 996-transducer focus gives hundreds of Pa, got {peak}"
    );
    // The time-averaged LM-M at A = 3 mm peaks near the centre.
    let uv = &s["maps"]["mean_pressure"]["peak"]["uv_mm"];
    let (u, v) = (uv[0].as_f64().unwrap(), uv[1].as_f64().unwrap());
    assert!(u.hypot(v) < 2.0, "peak at ({u}, {v})");
    assert!(s["force"]["mean_n"].as_f64().unwrap() > 0.0);
    // The disk (15 mm) does not fit an 8 × 6 mm grid: said so.
    assert_eq!(s["force"]["disk_clipped"], true);

    let ((rows, cols), data) = read_npy(&out.join("mean_pressure.npy"));
    assert_eq!((rows, cols), (13, 17));
    let max = data.iter().cloned().fold(0.0, f64::max);
    assert!((max - peak).abs() <= 1e-9 * peak);
    for stem in [
        "mean_pressure",
        "lm_power",
        "pressure",
        "amplitude",
        "max_pressure",
    ] {
        let png = std::fs::read(out.join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[1..4], b"PNG", "{stem}.png");
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        assert!(svg.starts_with("<svg width=\"88.00mm\""), "{stem}.svg");
        let pdf = std::fs::read(out.join(format!("{stem}.pdf"))).unwrap();
        assert!(
            pdf.starts_with(b"%PDF-1.4") && pdf.ends_with(b"%%EOF\n"),
            "{stem}.pdf"
        );
        // 88 mm wide: 249.4 pt (to the layout's quarter point).
        assert!(
            (pdf_width_pt(&pdf) - 88.0 / 25.4 * 72.0).abs() < 0.3,
            "{stem}.pdf"
        );
        assert!(out.join(format!("{stem}.npy")).exists());
    }
}

/// The page width of a one-page PDF (pt), from its MediaBox.
fn pdf_width_pt(pdf: &[u8]) -> f64 {
    let text = String::from_utf8_lossy(pdf);
    let rest = text.split("/MediaBox [0 0 ").nth(1).expect("a MediaBox");
    rest.split(' ').next().unwrap().parse().unwrap()
}

#[test]
fn simulate_force_scales_with_the_calibration_factor() {
    let base = ["--radius", "0", "--plane-size", "16", "--plane-step", "1"];
    let mut forces = Vec::new();
    for (name, k) in [("k1", "1"), ("k3", "3")] {
        let mut args = base.to_vec();
        args.extend(["--calibration", k]);
        let (out, _) = simulate_ok(name, &args);
        let s = summary(&out);
        assert_eq!(s["force"]["disk_clipped"], false);
        forces.push(s["force"]["step0_n"].as_f64().unwrap());
    }
    assert!(forces[0] > 0.0);
    assert!((forces[1] - 3.0 * forces[0]).abs() <= 1e-12 * forces[1]);
}

#[test]
fn simulate_compare_renders_the_papers_grid() {
    let (out, _) = simulate_ok(
        "compare",
        &[
            "--compare",
            "--plane-size",
            "12",
            "--plane-step",
            "2",
            "--width-mm",
            "180",
        ],
    );
    let png = std::fs::read(out.join("compare_mean_pressure.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let svg = std::fs::read_to_string(out.join("compare_mean_pressure.svg")).unwrap();
    assert!(svg.starts_with("<svg width=\"180.00mm\""));
    assert!(svg.contains("a (mm)") && svg.contains("LM-S") && svg.contains("orbit"));
    let pdf = std::fs::read(out.join("compare_mean_pressure.pdf")).unwrap();
    assert!((pdf_width_pt(&pdf) - 180.0 / 25.4 * 72.0).abs() < 0.3);
    let s = summary(&out);
    let runs = s["compare"].as_array().unwrap();
    // Rows LM-S 5 Hz, LM-M 5 Hz, LM-S 25 Hz; columns A = 2..6 mm.
    assert_eq!(runs.len(), 15);
    let radii: Vec<f64> = runs
        .iter()
        .map(|r| r["stimulus"]["radius_mm"].as_f64().unwrap())
        .collect();
    assert_eq!(radii, [2.0, 3.0, 4.0, 5.0, 6.0].repeat(3));
    assert!(runs[..5].iter().all(|r| r["stimulus"]["foci"] == 1));
    assert!(runs[5..10].iter().all(|r| r["stimulus"]["foci"] == 4));
    assert!(runs[10..].iter().all(|r| r["stimulus"]["foci"] == 1));
    assert!(runs[10..].iter().all(|r| r["condition"]["freq_hz"] == 25.0));
    // 4 mm steps at 25 Hz: N = round(2πA / 4), 3 at A = 2 mm.
    assert_eq!(runs[10]["stimulus"]["steps"], 3);
    assert_eq!(runs[10]["stem"], "lms_25hz_2mm");
    // A wider LM-S orbit spreads the same energy: its time-averaged peak drops.
    let peak = |i: usize| {
        runs[i]["maps"]["mean_pressure"]["peak"]["value"]
            .as_f64()
            .unwrap()
    };
    assert!(peak(4) < peak(0));
}

#[test]
fn simulate_refuses_bad_planes_with_exit_code_2() {
    for bad in [
        &["--plane-step", "0"][..],
        &["--plane-step", "0.00001"][..],
        &["--plane-size", "abc"][..],
        &["--plane-axes", "1,0,0,1,0,0"][..],
        &["--alpha", "-1"][..],
    ] {
        let out = out_dir("bad");
        let mut args = vec!["simulate", "--out", out.to_str().unwrap()];
        args.extend(bad);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.starts_with("error: "), "{bad:?}: {err}");
        assert!(!err.contains("panicked"), "{bad:?}: {err}");
    }
}

#[test]
fn a_signal_while_simulate_writes_says_so_and_leaves_no_unfinished_file() {
    use std::process::Stdio;
    let out = out_dir("signal");
    let mut child = Command::new(lmhost())
        .args(["simulate", "--radius", "0", "--plane-size", "16"])
        .args(["--plane-step", "0.1", "--out", out.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The signal goes once the first output is being written (the
    // figures of the five maps take a while after that).
    let mut writing = false;
    while child.try_wait().unwrap().is_none() {
        if std::fs::read_dir(&out).is_ok_and(|mut d| d.next().is_some()) {
            writing = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert!(writing, "simulate ended before it wrote anything");
    send_signal(&child, "INT");
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    // "; unfinished outputs removed" when the signal came while a file
    // was being written (it came between two here or there).
    let last = err.lines().last().unwrap_or_default();
    assert!(
        ["", "; unfinished outputs removed"]
            .iter()
            .any(|tail| last == format!("lmhost: interrupted by SIGINT{tail}")),
        "{err}"
    );
    // A folder left empty (the signal came while its first file was being
    // written) is removed with it.
    let left: Vec<String> = std::fs::read_dir(&out)
        .into_iter()
        .flatten()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !out.exists() || !left.is_empty(),
        "{} left empty",
        out.display()
    );
    // The summary is written last: a run cut short has none.
    assert!(!left.iter().any(|n| n == "summary.json"), "{left:?}");
    assert!(!left.iter().any(|n| n.contains(".tmp")), "{left:?}");
    let _ = std::fs::remove_dir_all(&out);
}
