//! `lmhost study run` / `report` end to end: the paper's Experiment 1
//! protocol on autd3's emulator and on the simulated LM device (30 trials,
//! every condition twice, each set a permutation, answers as given), a
//! `kill -9` mid-run then `--resume` giving the uninterrupted run's trials,
//! Experiment 3's adjustment loop, the report's files, answers typed as
//! single keys at a (pseudo-)terminal, and bad input refused with exit 2.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

mod link_support;
use link_support::{Sim, json_file, one_line_error};
#[allow(dead_code)]
mod study_support;
use study_support::*;

/// A scratch folder `name` holding Experiment 1's answers: the folder,
/// the answers' file and the answers.
fn exp1_scratch(name: &str) -> (Scratch, PathBuf, Vec<String>) {
    let d = scratch(name);
    let (answers, a) = exp1_answers(&d);
    (d, answers, a)
}

/// Experiment 1 run whole on `port` into `out` with seed 7 (every run of
/// it here presents the same order), the answers `a`: its rows, checked.
fn exp1_seed_7(
    port: &str,
    out: &Path,
    answers: &Path,
    a: &[String],
) -> Vec<BTreeMap<String, String>> {
    ok(&run_exp1(port, out, answers, &["--seed", "7"]));
    let r = rows(&out.join("P01"));
    check_exp1(&r, a);
    r
}

#[test]
fn exp1_on_the_emulator_records_every_trial_and_reports() {
    let (d, answers, a) = exp1_scratch("emu");
    let out = d.join("out");
    exp1_seed_7("autd3:emulator", &out, &answers, &a);
    let p = out.join("P01");
    let s = json_file(p.join("session.json"));
    assert_eq!(s["seed"], 7);
    assert_eq!(s["trials"].as_array().unwrap().len(), 30);
    assert_eq!(s["runs"][0]["time_scale"], 0.02);
    assert_eq!(s["runs"][0]["library"].as_array().unwrap().len(), 15);
    assert_eq!(s["runs"][0]["device"]["backend"], "autd3");
    assert_eq!(s["runs"][0]["backend"], "autd3");
    assert_eq!(s["runs"][0]["port"], "autd3:emulator");
    assert_eq!(s["runs"][0]["scene"]["path"], serde_json::Value::Null);
    assert!(s["runs"][0]["lmhost_version"].is_string());
    let events = std::fs::read_to_string(p.join("events.jsonl")).unwrap();
    let onsets = events
        .lines()
        .filter(|l| l.contains("\"event\":\"onset\""))
        .count();
    assert_eq!(onsets, 30);
    for l in events.lines() {
        serde_json::from_str::<serde_json::Value>(l).unwrap();
    }
    // The report: summary per condition and question, box plots.
    let o = study(&["report", out.to_str().unwrap()]).output().unwrap();
    ok(&o);
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = summary.lines();
    assert_eq!(
        lines.next().unwrap(),
        "stimulus,type,radius,question,n,not_perceived,median,q1,q3,iqr"
    );
    // 15 conditions × 5 answer columns, 2 answers each: numbers or `na`,
    // which is counted and left out.
    let body: Vec<&str> = lines.collect();
    assert_eq!(body.len(), 75);
    let field = |l: &str, i: usize| l.split(',').nth(i).unwrap().parse::<usize>().unwrap();
    assert!(body.iter().all(|l| field(l, 4) + field(l, 5) == 2));
    let na = a.iter().filter(|x| *x == "na").count();
    assert!(na > 0);
    assert_eq!(body.iter().map(|l| field(l, 5)).sum::<usize>(), na);
    // The statistics: a file each, `na` counted and left out.
    let stats = json_file(out.join("stats.json"));
    assert_eq!(stats.as_array().unwrap().len(), 5);
    let left_out: u64 = stats
        .as_array()
        .unwrap()
        .iter()
        .map(|q| q["not_perceived"].as_u64().unwrap())
        .sum();
    assert_eq!(left_out as usize, na);
    // One participant: Shapiro-Wilk has too few values, so every test
    // says why it did not run instead of a number.
    let txt = std::fs::read_to_string(out.join("stats.txt")).unwrap();
    assert!(txt.contains("no test"), "{txt}");
    let csv = std::fs::read_to_string(out.join("stats.csv")).unwrap();
    assert!(
        csv.starts_with("question,test,family,conditions,n,"),
        "{csv}"
    );
    for q in [
        "vibration",
        "movement",
        "shape_flat",
        "shape_convex",
        "shape_concave",
    ] {
        for ext in ["png", "svg", "pdf"] {
            let f = out.join(format!("box-{q}.{ext}"));
            assert!(
                std::fs::metadata(&f).unwrap().len() > 1000,
                "{}",
                f.display()
            );
        }
    }
    let svg = std::fs::read_to_string(out.join("box-vibration.svg")).unwrap();
    // The paper's words for the conditions, not their ids.
    assert!(svg.starts_with("<svg") && svg.contains("LM-S 25 Hz") && !svg.contains("lms-25hz"));
    let pdf = std::fs::read(out.join("box-vibration.pdf")).unwrap();
    assert!(pdf.starts_with(b"%PDF-1.4") && pdf.ends_with(b"%%EOF\n"));
    // One column by default, two with --width-mm 180; a width no page
    // takes is bad input, refused before anything is written.
    let width_mm = |pdf: &[u8]| -> f64 {
        let text = String::from_utf8_lossy(pdf);
        let w: f64 = text
            .split("/MediaBox [0 0 ")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        w / 72.0 * 25.4
    };
    assert!((width_mm(&pdf) - 88.0).abs() < 0.2);
    let o = study(&["report", out.to_str().unwrap(), "--width-mm", "180"])
        .output()
        .unwrap();
    ok(&o);
    let pdf = std::fs::read(out.join("box-vibration.pdf")).unwrap();
    assert!((width_mm(&pdf) - 180.0).abs() < 0.2);
    let o = study(&["report", out.to_str().unwrap(), "--width-mm", "10"])
        .output()
        .unwrap();
    says(&one_line_error(&o, 2), &["--width-mm"]);
}

/// Single keys at a terminal: a pseudo-terminal as stdin, each question
/// answered the moment it is shown by a key the scale lacks (refused) and
/// then a valid key, every answer recorded as typed, and the terminal's
/// mode (canonical, echo) back when the run ends.
#[test]
fn terminal_answers_are_single_keys_and_the_terminal_is_restored() {
    use std::io::{BufRead, BufReader, Write};

    use nix::sys::termios::{LocalFlags, tcgetattr};

    let d = scratch("tty");
    let out = d.join("out");
    let pty = nix::pty::openpty(None, None).unwrap();
    let cooked = LocalFlags::ICANON | LocalFlags::ECHO;
    assert!(tcgetattr(&pty.slave).unwrap().local_flags.contains(cooked));
    let mut child = exp1("autd3:emulator", &out, "0.02", &[])
        .stdin(Stdio::from(pty.slave.try_clone().unwrap()))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // A run that stops answering is killed, so the test fails, not hangs.
    let watchdog = Watchdog::start(&child);
    let mut keys = std::fs::File::from(pty.master);
    let (mut typed, mut refused, mut log) = (Vec::new(), 0, Vec::new());
    for line in BufReader::new(child.stderr.take().unwrap()).lines() {
        let line = line.unwrap();
        if line.starts_with("  `9` is not an answer") {
            refused += 1;
        }
        if !line.starts_with(' ') && line.ends_with(']') && line.contains("[1 = ") {
            // Every 17th answer is "not perceived", typed as `na`.
            if typed.len() % 17 == 2 {
                keys.write_all(b"9na").unwrap();
                typed.push("na".to_owned());
            } else {
                let k = b'1' + (typed.len() * 3 % 7) as u8;
                keys.write_all(&[b'9', k]).unwrap();
                typed.push((k as char).to_string());
            }
        }
        log.push(line);
    }
    let status = child.wait().unwrap();
    watchdog.stop();
    assert!(status.success(), "{status}: {}", log.join("\n"));
    assert_eq!(typed.len(), 150, "5 questions × 30 trials");
    // The participant's screen names no stimulus (the event log does).
    for l in log
        .iter()
        .filter(|l| l.starts_with("trial ") || l.ends_with(']'))
    {
        assert!(!l.contains("-a2") && !l.contains("hz-a"), "{l}");
    }
    assert_eq!(refused, 150, "every `9` refused on a 7-point scale");
    check_exp1(&rows(&out.join("P01")), &typed);
    assert!(
        tcgetattr(&pty.slave).unwrap().local_flags.contains(cooked),
        "the terminal is left in raw mode"
    );
}

#[test]
fn exp1_on_the_simulated_lm_device_gives_the_same_order() {
    let sim = Sim::start(&[]);
    let (d, answers, a) = exp1_scratch("sim");
    let out = d.join("out");
    let r = exp1_seed_7(&sim.port, &out, &answers, &a);
    // The same seed on another device: the same order.
    let e = exp1_seed_7("autd3:emulator", &d.join("emu"), &answers, &a);
    assert_eq!(order(&r), order(&e));
    let s = std::fs::read_to_string(out.join("P01/session.json")).unwrap();
    assert!(s.contains("\"backend\": \"lm-firmware\""), "{s}");
}

#[test]
fn kill_9_then_resume_gives_the_uninterrupted_trials() {
    let (d, answers, a) = exp1_scratch("resume");
    let w = exp1_seed_7("autd3:emulator", &d.join("whole"), &answers, &a);
    let out = d.join("out");
    let mut child = exp1(
        "autd3:emulator",
        &out,
        "0.1",
        &["--responses", answers.to_str().unwrap(), "--seed", "7"],
    )
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let csv = out.join("P01/trials.csv");
    let t0 = Instant::now();
    while std::fs::read_to_string(&csv).map_or(0, |s| s.lines().count()) < 6 {
        assert!(t0.elapsed() < Duration::from_secs(30), "no progress");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let before = rows(&out.join("P01")).len();
    assert!((5..30).contains(&before), "{before} rows before the kill");
    // Without --resume the participant's folder is refused.
    let e = one_line_error(&run_exp1("autd3:emulator", &out, &answers, &[]), 2);
    assert!(e.contains("--resume"), "{e}");
    // A different seed on --resume is refused too.
    let o = run_exp1(
        "autd3:emulator",
        &out,
        &answers,
        &["--resume", "--seed", "8"],
    );
    assert_eq!(o.status.code(), Some(2));
    // The killed run ran at a time scale of 0.1: resuming at 0.02 is
    // another rig, refused with one line naming what differs, files as
    // they were.
    let e = one_line_error(
        &run_exp1("autd3:emulator", &out, &answers, &["--resume"]),
        2,
    );
    assert!(
        e.contains("the time scale (0.1 then, 0.02 now)") && e.contains("--resume-anyway"),
        "{e}"
    );
    assert_eq!(rows(&out.join("P01")).len(), before);
    let o = run_exp1(
        "autd3:emulator",
        &out,
        &answers,
        &["--resume", "--resume-anyway"],
    );
    says(
        &ok_stderr(&o),
        &[&format!("resuming at trial {}", before + 1)],
    );
    let r = rows(&out.join("P01"));
    check_exp1(&r, &a);
    let keep = |rows: &[BTreeMap<String, String>]| -> Vec<Vec<String>> {
        let cols = [
            "trial",
            "set",
            "stimulus",
            "vibration",
            "movement",
            "shape_flat",
            "shape_convex",
            "shape_concave",
            "shape_order",
        ];
        rows.iter()
            .map(|r| cols.iter().map(|c| r[*c].clone()).collect())
            .collect()
    };
    assert_eq!(keep(&r), keep(&w));
    let s = json_file(out.join("P01/session.json"));
    assert_eq!(s["runs"].as_array().unwrap().len(), 2);
    assert_eq!(s["runs"][1]["first_trial"], before + 1);
    let anyway = s["runs"][1]["resumed_anyway"].as_str().unwrap();
    assert!(anyway.contains("time scale"), "{anyway}");
    assert!(s["runs"][0].get("resumed_anyway").is_none());
}

#[test]
fn exp3_runs_its_adjustment_loop_and_logs_every_depth() {
    let d = scratch("exp3");
    // Per trial: same | stronger, same | weaker, weaker, same.
    let answers = cycled_answers(
        &d,
        30,
        &[&["same"], &["stronger", "same"], &["2", "weaker", "3"]],
    );
    let out = d.join("out");
    let o = answered_p01(
        &studies("paper-exp3.toml"),
        "autd3:emulator",
        &out,
        "0.01",
        &answers,
        "3",
    );
    says(
        &ok_stderr(&o),
        &[
            "next depth 3.75 mm (stronger)",
            "next depth 4.50 mm (weaker)",
        ],
    );
    let r = n_rows(&out.join("P01"), 30);
    for (i, row) in r.iter().enumerate() {
        let (n, depths, last, answers) = match i % 3 {
            0 => ("0", "4.00", "4.00", "same"),
            1 => ("1", "4.00|3.75", "3.75", "stronger|same"),
            _ => ("2", "4.00|4.25|4.50", "4.50", "weaker|weaker|same"),
        };
        assert_eq!(row["adjustments"], n);
        assert_eq!(row["depths_mm"], depths);
        assert_eq!(row["final_depth_mm"], last);
        assert_eq!(row["adjust_answers"], answers);
        // One on-phase per answer: the stimulus repeats on/off until "same".
        assert_eq!(
            row["on_phases"],
            (n.parse::<usize>().unwrap() + 1).to_string()
        );
    }
    let events = std::fs::read_to_string(out.join("P01/events.jsonl")).unwrap();
    let depths = events
        .lines()
        .filter(|l| l.contains("\"event\":\"depth\""))
        .count();
    assert_eq!(depths, 30 + 10 + 20);
    assert!(events.contains("\"gate\":\"untracked\""));
    let o = study(&["report", out.join("P01").to_str().unwrap()])
        .output()
        .unwrap();
    ok(&o);
    let summary = std::fs::read_to_string(out.join("P01/summary.csv")).unwrap();
    assert_eq!(summary.lines().count(), 16);
    assert!(summary.contains(",final_depth_mm,2,"), "{summary}");
    assert!(out.join("P01/box-final_depth_mm.svg").exists());
}

#[test]
fn bad_input_is_one_line_and_exit_2_before_the_device_opens() {
    let d = scratch("bad");
    let out = d.join("out");
    let lines = |o: &Output| String::from_utf8_lossy(&o.stderr).trim().to_owned();
    // A bad answer names its line, checked before the device opens.
    let answers = answers_file(&d, "3\n4\n5\n9\n");
    let o = run_exp1("autd3:emulator", &out, &answers, &["--seed", "1"]);
    let e = one_line_error(&o, 2);
    assert!(
        e.contains("answers.txt line 4: `9` is not an answer"),
        "{e}"
    );
    assert!(!out.join("P01").exists(), "nothing written");
    // Too few answers: the line where they end.
    std::fs::write(&answers, "3\n".repeat(149)).unwrap();
    let o = run_exp1("autd3:emulator", &out, &answers, &["--seed", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", lines(&o));
    assert!(lines(&o).contains("ended at line 150"), "{}", lines(&o));
    // A protocol naming a stimulus the library lacks: refused before the
    // port is even opened (a port that does not exist).
    let text = std::fs::read_to_string(studies("paper-exp1.toml"))
        .unwrap()
        .replace("\"2\", \"3\"", "\"2\", \"9\"")
        .replace("paper-library.toml", &studies("paper-library.toml"));
    let proto = d.join("p.toml");
    std::fs::write(&proto, text).unwrap();
    let o = study(&[
        "run",
        proto.to_str().unwrap(),
        "--port",
        "/dev/nonexistent-lm",
        "--participant",
        "P02",
        "--out",
        out.to_str().unwrap(),
        "--finger",
        "synthetic",
        "--responses",
        answers.to_str().unwrap(),
    ])
    .output()
    .unwrap();
    let e = one_line_error(&o, 2);
    assert!(
        e.contains("p.toml: line") && e.contains("`lms-5hz-a9`"),
        "{e}"
    );
    // --resume with nothing to resume, then with another protocol.
    let resume3 = |out: &Path| {
        run_on(
            &studies("paper-exp3.toml"),
            "autd3:emulator",
            out,
            &[
                "--finger",
                "synthetic",
                "--responses",
                answers.to_str().unwrap(),
                "--resume",
            ],
        )
        .output()
        .unwrap()
    };
    let o = resume3(&out);
    assert_eq!(o.status.code(), Some(2));
    assert!(lines(&o).contains("nothing to resume"), "{}", lines(&o));
    std::fs::create_dir_all(out.join("P01")).unwrap();
    let session = serde_json::json!({
        "protocol_name": "paper-exp1", "protocol_file": "x", "protocol": "name = \"paper-exp1\"",
        "library_file": "y", "participant": "P01", "seed": 1, "question_order": [],
        "columns": [], "trials": [], "runs": [],
    });
    std::fs::write(out.join("P01/session.json"), session.to_string()).unwrap();
    let o = resume3(&out);
    assert_eq!(o.status.code(), Some(2));
    assert!(lines(&o).contains("another protocol"), "{}", lines(&o));
}
