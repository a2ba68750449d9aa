//! What the study tests share: the protocols, scratch folders, the
//! Experiment 1 answers, running `lmhost study` and reading its rows.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::link_support::lmhost;

pub fn studies(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../studies")
        .join(name)
        .display()
        .to_string()
}

/// A fresh scratch folder `name`, removed when the test passes (kept
/// for a look when it fails).
pub fn scratch(name: &str) -> Scratch {
    crate::link_support::scratch_dir(&format!("study-{name}"))
}

pub use crate::link_support::Scratch;

/// Experiment 1's answers: vibration, movement, then the three shape
/// items in the order shown; a different number on every line, and now
/// and then `na` ("could not perceive", which every question allows).
pub fn exp1_answers(dir: &Path) -> (PathBuf, Vec<String>) {
    let a: Vec<String> = (0..150)
        .map(|i| {
            if i % 23 == 4 {
                "na".to_owned()
            } else {
                ((i * 5 + i / 7) % 7 + 1).to_string()
            }
        })
        .collect();
    let p = dir.join("answers.txt");
    std::fs::write(&p, a.join("\n") + "\n").unwrap();
    (p, a)
}

/// Writes `text` as `dir/answers.txt`, a `--responses` file; its path.
pub fn answers_file(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("answers.txt");
    std::fs::write(&p, text).unwrap();
    p
}

/// [`answers_file`] for `trials` trials, trial `t` answered with
/// `per_trial[t % per_trial.len()]`, one answer a line.
pub fn cycled_answers(dir: &Path, trials: usize, per_trial: &[&[&str]]) -> PathBuf {
    let a: Vec<&str> = (0..trials)
        .flat_map(|t| per_trial[t % per_trial.len()].iter().copied())
        .collect();
    answers_file(dir, &a.join("\n"))
}

pub fn study(args: &[&str]) -> Command {
    let mut c = Command::new(lmhost());
    c.arg("study").args(args).env_remove("LMHOST_PORT");
    c
}

/// `lmhost study run PROTOCOL` for participant P01 on `port` into `out`,
/// then `extra`.
pub fn run_on(protocol: &str, port: &str, out: &Path, extra: &[&str]) -> Command {
    let mut args = vec![
        "run",
        protocol,
        "--port",
        port,
        "--participant",
        "P01",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    study(&args)
}

/// [`run_on`] with a synthetic finger at `time_scale`, then `extra`.
pub fn run_p01(
    protocol: &str,
    port: &str,
    out: &Path,
    time_scale: &str,
    extra: &[&str],
) -> Command {
    let mut args = vec!["--finger", "synthetic", "--time-scale", time_scale];
    args.extend_from_slice(extra);
    run_on(protocol, port, out, &args)
}

/// [`run_p01`] answered from the file `answers`, the trial order drawn
/// from `seed`, run to its end.
pub fn answered_p01(
    protocol: &str,
    port: &str,
    out: &Path,
    time_scale: &str,
    answers: &Path,
    seed: &str,
) -> Output {
    let answers = answers.to_str().unwrap();
    run_p01(
        protocol,
        port,
        out,
        time_scale,
        &["--responses", answers, "--seed", seed],
    )
    .output()
    .unwrap()
}

/// Runs `c` with `input` on its standard input, written from a thread of
/// its own (a write cut short by the run's end is no error here), stdout
/// discarded; its output.
pub fn with_stdin(c: &mut Command, mut input: impl std::io::Read + Send + 'static) -> Output {
    let mut child = c
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let feeder = std::thread::spawn(move || {
        let _ = std::io::copy(&mut input, &mut stdin);
    });
    let o = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    o
}

/// Kills a run (SIGKILL) that has not ended 120 s after it started, so
/// a run that stops answering fails its test rather than hangs it; told
/// with [`Watchdog::stop`] once the run has ended.
pub struct Watchdog {
    done: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<()>,
}

impl Watchdog {
    pub fn start(child: &Child) -> Watchdog {
        let done = Arc::new(AtomicBool::new(false));
        let (ended, pid) = (done.clone(), child.id().to_string());
        let thread = std::thread::spawn(move || {
            let t0 = Instant::now();
            while !ended.load(Ordering::Relaxed) {
                if t0.elapsed() > Duration::from_secs(120) {
                    let _ = Command::new("kill").args(["-9", &pid]).status();
                    return;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        });
        Watchdog { done, thread }
    }

    pub fn stop(self) {
        self.done.store(true, Ordering::Relaxed);
        self.thread.join().unwrap();
    }
}

/// Checks that a run ended as bad input (exit 2) with a last line of
/// stderr that holds each of `wants`.
#[track_caller]
pub fn ended_as_bad_input(o: &Output, wants: &[&str]) {
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    let last = e.trim().lines().last().unwrap_or_default();
    for want in wants {
        assert!(last.contains(want), "want {want:?} in the last line:\n{e}");
    }
}

/// `lmhost study run` of Experiment 1 for participant P01 with a
/// synthetic finger at `time_scale`, then `extra`.
pub fn exp1(port: &str, out: &Path, time_scale: &str, extra: &[&str]) -> Command {
    run_p01(&studies("paper-exp1.toml"), port, out, time_scale, extra)
}

pub fn run_exp1(port: &str, out: &Path, answers: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["--responses", answers.to_str().unwrap()];
    args.extend_from_slice(extra);
    exp1(port, out, "0.02", &args).output().unwrap()
}

#[track_caller]
pub fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "exit {:?}: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The stderr of a run that must have succeeded.
#[track_caller]
pub fn ok_stderr(o: &Output) -> String {
    ok(o);
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The stdout of a run that must have succeeded.
#[track_caller]
pub fn ok_stdout(o: &Output) -> String {
    ok(o);
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The stderr of a run refused as bad input (exit 2).
#[track_caller]
pub fn refused(o: &Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    err
}

/// Asserts `text` says each of `wants`.
#[track_caller]
pub fn says(text: &str, wants: &[&str]) {
    for want in wants {
        assert!(text.contains(want), "no `{want}` in: {text}");
    }
}

/// `trials.csv` as maps of column → value (no quoted fields are expected
/// in these runs).
pub fn rows(dir: &Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(dir.join("trials.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), head.len(), "{l}");
            head.iter()
                .zip(f)
                .map(|(h, v)| ((*h).to_owned(), v.to_owned()))
                .collect()
        })
        .collect()
}

/// [`rows`], asserting there are `n`.
#[track_caller]
pub fn n_rows(dir: &Path, n: usize) -> Vec<BTreeMap<String, String>> {
    let r = rows(dir);
    assert_eq!(r.len(), n, "rows in {}", dir.display());
    r
}

/// 30 rows, every condition twice, each set a permutation of the 15, the
/// answers recorded in the order given, timing from the device.
pub fn check_exp1(rows: &[BTreeMap<String, String>], answers: &[String]) {
    assert_eq!(rows.len(), 30);
    for set in ["1", "2"] {
        let mut s: Vec<&str> = rows
            .iter()
            .filter(|r| r["set"] == set)
            .map(|r| r["stimulus"].as_str())
            .collect();
        s.sort_unstable();
        s.dedup();
        assert_eq!(s.len(), 15, "set {set} is a permutation of 15");
    }
    let mut count: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r["trial"], (i + 1).to_string());
        *count.entry(r["stimulus"].as_str()).or_default() += 1;
        assert_eq!(r["stimulus"], format!("{}-a{}", r["type"], r["radius"]));
        let a = &answers[i * 5..i * 5 + 5];
        assert_eq!(r["vibration"], a[0]);
        assert_eq!(r["movement"], a[1]);
        let order: Vec<&str> = r["shape_order"].split('|').collect();
        assert_eq!(order.len(), 3);
        for (k, item) in order.iter().enumerate() {
            assert_eq!(r[&format!("shape_{item}")], a[2 + k], "trial {}", i + 1);
        }
        assert!(r["steps"].parse::<u32>().unwrap() > 0);
        assert!(r["onset_us"].parse::<u64>().unwrap() < r["offset_us"].parse::<u64>().unwrap());
        let on: f64 = r["presented_s"].parse().unwrap();
        // touch_s = 3 s at a time scale of 0.02: about 60 ms.
        assert!((0.04..1.0).contains(&on), "presented {on} s");
        assert!(r["device_presented_s"].parse::<f64>().unwrap() > 0.0);
        assert_eq!(r["on_phases"], "1");
        // Provenance: the trial's UTC time, the device's health over it,
        // a response time per answer.
        let t = &r["time_utc"];
        assert!(
            t.len() == 24 && t.starts_with("20") && t.ends_with('Z'),
            "{t}"
        );
        assert!(r["missed_deadlines"].parse::<u32>().is_ok(), "{r:?}");
        assert!(r["lease_expiries"].parse::<u32>().is_ok(), "{r:?}");
        for q in ["vibration", "movement", "shape_flat"] {
            let rt: f64 = r[&format!("{q}_rt_s")].parse().unwrap();
            assert!((0.0..600.0).contains(&rt), "{q}_rt_s {rt}");
        }
    }
    assert_eq!(count.len(), 15);
    assert!(count.values().all(|n| *n == 2), "{count:?}");
}

pub fn order(rows: &[BTreeMap<String, String>]) -> Vec<(String, String)> {
    rows.iter()
        .map(|r| (r["stimulus"].clone(), r["shape_order"].clone()))
        .collect()
}
