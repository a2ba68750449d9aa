//! Experiment 3 with its instruments, end to end: `lmhost study run
//! --stage sim --gauge sim` pushes the simulated gauge into the simulated
//! finger pad in step with each on-phase, records the force at the depth
//! the participant chose (`force_n`, the series beside `trials.csv`),
//! `study report` summarises it in newtons, and a stage that falls silent
//! mid-trial leaves the device silent with one line and exit 1.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Output;

mod link_support;
use link_support::{Sim, json, send_signal};
#[allow(dead_code)]
mod study_support;
use study_support::*;

/// Per trial: same | weaker, same | stronger, stronger, same.
fn answers(d: &Path) -> std::path::PathBuf {
    cycled_answers(
        d,
        30,
        &[
            &["same"],
            &["weaker", "same"],
            &["stronger", "stronger", "same"],
        ],
    )
}

fn exp3(port: &str, out: &Path, answers: &Path, stage: &str) -> Output {
    run_p01(
        &studies("paper-exp3.toml"),
        port,
        out,
        "0.02",
        &[
            "--responses",
            answers.to_str().unwrap(),
            "--seed",
            "3",
            "--stage",
            stage,
            "--gauge",
            "sim",
            "--stage-speed",
            "50",
        ],
    )
    .output()
    .unwrap()
}

/// Answers from the file `answers`, the stage and gauge twins, and `more`.
fn with_twins<'a>(answers: &'a Path, more: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "--responses",
        answers.to_str().unwrap(),
        "--stage",
        "sim",
        "--gauge",
        "sim",
    ];
    args.extend_from_slice(more);
    args
}

fn num(row: &BTreeMap<String, String>, c: &str) -> f64 {
    row[c]
        .parse()
        .unwrap_or_else(|_| panic!("{c} = {:?}", row[c]))
}

#[test]
fn exp3_with_the_twins_records_a_force_that_rises_with_depth() {
    let d = scratch("exp3-push");
    let answers = answers(&d);
    let out = d.join("out");
    ok(&exp3("autd3:emulator", &out, &answers, "sim"));
    let p = out.join("P01");
    let r = rows(&p);
    assert_eq!(r.len(), 30);
    let s = std::fs::read_to_string(p.join("session.json")).unwrap();
    assert!(s.contains("simulated stage, gauge on sim"), "{s}");
    let mut by_depth: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for (i, row) in r.iter().enumerate() {
        let (depth, answers) = match i % 3 {
            0 => ("4.00", 1),
            1 => ("4.25", 2),
            _ => ("3.50", 3),
        };
        assert_eq!(row["final_depth_mm"], depth);
        let f = num(row, "force_n");
        assert!(f > 0.0, "trial {}: force {f}", i + 1);
        by_depth.entry(depth.to_owned()).or_default().push(f);
        // A response time per adjustment answer.
        let rts: Vec<f64> = row["adjust_rt_s"]
            .split('|')
            .map(|s| s.parse().unwrap())
            .collect();
        assert_eq!(rts.len(), answers, "{}", row["adjust_rt_s"]);
        assert!(rts.iter().all(|&s| s >= 0.0));
        // The series beside the rows: time from the on-phase's onset, and
        // its median is the row's force.
        let series =
            std::fs::read_to_string(p.join(format!("force-trial-{:03}.csv", i + 1))).unwrap();
        let mut lines = series.lines();
        assert_eq!(lines.next(), Some("t_s,force_n"));
        let mut v: Vec<(f64, f64)> = lines
            .map(|l| {
                let (t, f) = l.split_once(',').unwrap();
                (t.parse().unwrap(), f.parse().unwrap())
            })
            .collect();
        // 2 s × 0.02 at 50 Hz: 2 readings.
        assert_eq!(v.len(), 2, "{series}");
        assert!(
            v.iter().all(|&(t, _)| (-0.01..0.2).contains(&t)),
            "{series}"
        );
        v.sort_by(|a, b| a.1.total_cmp(&b.1));
        let median = (v[0].1 + v[1].1) / 2.0;
        assert!((median - f).abs() < 0.0011, "{median} vs {f}");
        // One on-phase per answer, and one recorded.
        assert_eq!(row["on_phases"], (answers + 1).to_string());
    }
    // Deeper pushes press harder: every force at 3.5 mm below every one at
    // 4 mm, below every one at 4.25 mm.
    let range = |k: &str| {
        let v = &by_depth[k];
        (
            v.iter().copied().fold(f64::MAX, f64::min),
            v.iter().copied().fold(f64::MIN, f64::max),
        )
    };
    let (a, b, c) = (range("3.50"), range("4.00"), range("4.25"));
    assert!(a.1 < b.0 && b.1 < c.0, "{a:?} {b:?} {c:?}");
    // The report: force_n per condition, in newtons.
    ok(&study(&["report", p.to_str().unwrap()]).output().unwrap());
    let summary = std::fs::read_to_string(p.join("summary.csv")).unwrap();
    let forces: Vec<&str> = summary
        .lines()
        .filter(|l| l.contains(",force_n,"))
        .collect();
    assert_eq!(forces.len(), 15, "{summary}");
    assert!(p.join("box-force_n.svg").exists());
}

#[test]
fn a_stage_that_falls_silent_mid_trial_leaves_the_device_silent() {
    let sim = Sim::start(&[]);
    let d = scratch("exp3-silent");
    let answers = answers(&d);
    let out = d.join("out");
    // Trial 1 (same): rest, in, back, in (recorded), back = 5 moves;
    // trial 2's push starts and the stage answers no more.
    let o = exp3(&sim.port, &out, &answers, "sim:fail-after=5");
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    let e = errors[0];
    says(
        e,
        &[
            "moving to 9 mm: sim-stage: no reply",
            "stage NOT back at rest",
            "the array is silent",
            "trials 1..=1 of 30",
        ],
    );
    assert!(!err.contains("panicked"), "{err}");
    n_rows(&out.join("P01"), 1);
    let st = json(&["status", "--port", &sim.port, "--json"]);
    assert_eq!(st["state"], "Stopped", "{st}");
    assert_eq!(st["mute_reason"], "stopped", "{st}");
}

#[test]
fn ctrl_c_mid_push_still_brings_the_stage_back() {
    use std::io::{BufRead, BufReader};
    let d = scratch("exp3-int");
    let answers = answers(&d);
    let out = d.join("out");
    // At full time scale: a 2 s on-phase with the probe in the finger.
    let mut child = run_on(
        &studies("paper-exp3.toml"),
        "autd3:emulator",
        &out,
        &with_twins(&answers, &["--finger", "synthetic"]),
    )
    .stderr(std::process::Stdio::piped())
    .spawn()
    .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    while !seen.contains("depth 4.00 mm") {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "ended: {seen}");
        seen.push_str(&line);
    }
    // The stage is on its way in (0.8 s) or pushing (2 s).
    std::thread::sleep(std::time::Duration::from_millis(1200));
    send_signal(&child, "INT");
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success(), "{rest}");
    assert!(
        rest.contains("interrupted by SIGINT (stage back at rest at 5 mm); the array is silent"),
        "{rest}"
    );
}

/// An on-phase the device cannot present (scaled under one step at its
/// 1 kHz update limit, 1 ms) is refused by `study check` and by `study
/// run` before anything is written, naming `on_s` and its scaled value:
/// it ran the trials before the gauge's first series failed.
#[test]
fn an_on_phase_under_one_device_step_is_refused_by_study_check_and_run() {
    let protocol = studies("paper-exp3.toml");
    let said = "the timeline's on_s 2 s × --time-scale 0.0004 = 0.0008 s is shorter than one step at the device's update limit (the scene's min_dwell_ms, 1 ms)";
    let o = study(&["check", &protocol, "--time-scale", "0.0004"])
        .output()
        .unwrap();
    ended_as_bad_input(&o, &[said, "give a --time-scale of at least 0.0005"]);
    assert_eq!(
        String::from_utf8_lossy(&o.stderr).lines().count(),
        1,
        "{o:?}"
    );
    // The scale the runs here use is one the device presents.
    ok(&study(&["check", &protocol, "--time-scale", "0.02"])
        .output()
        .unwrap());
    let d = scratch("exp3-short-on");
    let answers = answers(&d);
    let out = d.join("out");
    let o = run_p01(
        &protocol,
        "autd3:emulator",
        &out,
        "0.0004",
        &with_twins(&answers, &[]),
    )
    .output()
    .unwrap();
    ended_as_bad_input(&o, &[said]);
    assert!(!out.join("P01").exists(), "{o:?}");
}
