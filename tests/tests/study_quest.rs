//! `lmhost study` with QUEST+, end to end on the simulated device answered
//! by a simulated observer (checked and reported), and an adaptive trial
//! cut short mid-way continued by `--resume` from its logged presentations
//! (QUEST+ and the staircase).

use std::collections::BTreeMap;
use std::path::Path;

mod link_support;
use link_support::Sim;
#[allow(dead_code)]
mod study_support;
use study_support::*;

fn observer_run(
    protocol: &str,
    port: &str,
    out: &Path,
    observer: &str,
    extra: &[&str],
) -> std::process::Output {
    let mut args = vec![
        "--time-scale",
        "0.01",
        "--seed",
        "1",
        "--observer",
        observer,
    ];
    args.extend_from_slice(extra);
    run_on(&studies(protocol), port, out, &args)
        .output()
        .unwrap()
}

fn list(row: &BTreeMap<String, String>, column: &str) -> Vec<String> {
    row[column].split('|').map(str::to_owned).collect()
}

#[test]
fn quest_plus_runs_on_the_simulated_device_and_check_and_report_show_it() {
    let sim = Sim::start(&[]);
    let d = scratch("quest");
    let out = d.join("out");
    let o = study(&["check", &studies("quest-detection.toml")])
        .output()
        .unwrap();
    says(
        &ok_stdout(&o),
        &[
            "procedure: QUEST+ over 20 levels of intensity",
            "39 thresholds",
        ],
    );
    let o = observer_run(
        "quest-detection.toml",
        &sim.port,
        &out,
        "logistic:threshold=0.4,slope=15,lapse=0.02,seed=5",
        &[],
    );
    says(&ok_stderr(&o), &["40 presentations: threshold"]);
    let r = n_rows(&out.join("P01"), 2);
    for row in &r {
        let levels = list(row, "quest_levels");
        let answers = list(row, "quest_answers");
        assert_eq!((levels.len(), answers.len()), (40, 40));
        assert_eq!(row["answers"], "40");
        // Both trials start at the prior's best, the condition's entry.
        assert_eq!(row["stimulus"], format!("lms-5hz-i{}", levels[0]));
        // It moves: not one level throughout.
        assert!(levels.iter().any(|l| *l != levels[0]), "{levels:?}");
        let t: f64 = row["threshold"].parse().unwrap();
        let sd: f64 = row["threshold_sd"].parse().unwrap();
        // The observer's threshold is 0.4; the grid's step 0.05.
        assert!((0.3..0.5).contains(&t), "threshold {t}");
        assert!(sd > 0.0 && sd < 0.1, "sd {sd}");
        assert!(row["on_phases"].parse::<usize>().unwrap() >= 40);
    }
    let o = study(&["report", out.join("P01").to_str().unwrap()])
        .output()
        .unwrap();
    ok(&o);
    let summary = std::fs::read_to_string(out.join("P01/summary.csv")).unwrap();
    let line = summary
        .lines()
        .find(|l| l.contains(",threshold,"))
        .unwrap_or_else(|| panic!("{summary}"));
    assert!(line.starts_with("lms-5hz-i"), "{line}");
    assert!(line.contains(",threshold,2,0,"), "{line}");
}

/// Cuts participant folder `dir` back to what a kill in trial `trial`
/// after its `k`-th answer leaves: trials.csv without that trial's row,
/// events.jsonl up to that answer's level line and half of the next line.
fn cut_mid_trial(dir: &Path, trial: usize, k: usize) -> Vec<(String, String)> {
    let csv = dir.join("trials.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let kept: Vec<&str> = text.lines().take(trial).collect();
    std::fs::write(&csv, kept.join("\n") + "\n").unwrap();
    let events = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
    let mut out = String::new();
    let mut answered = Vec::new();
    let mut lines = events.lines();
    for l in lines.by_ref() {
        out += l;
        out.push('\n');
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        if v["event"] == "level" && v["trial"] == trial && v["answer"].is_string() {
            answered.push((
                v["answer"].as_str().unwrap().to_owned(),
                v["level_intensity"].to_string(),
            ));
            if answered.len() == k {
                break;
            }
        }
    }
    let next = lines.next().unwrap();
    out += &next[..next.len() / 2];
    std::fs::write(dir.join("events.jsonl"), out).unwrap();
    answered
}

#[test]
fn an_adaptive_trial_cut_short_continues_at_its_logged_state_on_resume() {
    let sim = Sim::start(&[]);
    let d = scratch("midtrial");
    for (protocol, levels, answers) in [
        ("quest-detection.toml", "quest_levels", "quest_answers"),
        (
            "staircase-detection.toml",
            "staircase_levels",
            "staircase_answers",
        ),
    ] {
        let out = d.join(protocol);
        let first = "logistic:threshold=0.4,slope=15,lapse=0.02,seed=5";
        ok(&observer_run(protocol, &sim.port, &out, first, &[]));
        let dir = out.join("P01");
        let whole = rows(&dir);
        // Killed in trial 2 after its 15th answer, the 16th cut mid-line.
        let k = 15;
        let logged = cut_mid_trial(&dir, 2, k);
        assert_eq!(logged.len(), k);
        // Another observer from here on: a restarted trial would not give
        // the logged answers again.
        let o = observer_run(
            protocol,
            &sim.port,
            &out,
            "logistic:threshold=0.4,slope=15,lapse=0.02,seed=77",
            &["--resume"],
        );
        ok(&o);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("resumed after 15 presentations"),
            "{protocol}: {err}"
        );
        let again = rows(&dir);
        assert_eq!(again.len(), 2);
        assert_eq!(again[0], whole[0], "{protocol}: trial 1 as it was");
        let (l, a) = (list(&again[1], levels), list(&again[1], answers));
        // The logged presentations once each, then the rest: the first
        // k + 1 levels and k answers are the cut run's, and the row counts
        // every answer once.
        let (wl, wa) = (list(&whole[1], levels), list(&whole[1], answers));
        assert_eq!(l[..=k], wl[..=k], "{protocol}");
        assert_eq!(a[..k], wa[..k], "{protocol}");
        let answers_logged: Vec<&str> = logged.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(a[..k], answers_logged[..], "{protocol}");
        assert_eq!(l.len(), a.len());
        assert_eq!(again[1]["answers"], a.len().to_string());
        if protocol.starts_with("quest") {
            assert_eq!(a.len(), 40, "QUEST+ ends after 40 presentations");
        }
        let events = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
        assert!(
            events.contains("\"resumed_presentations\":15"),
            "{protocol}"
        );
        // A log that does not follow from its answers is refused, and
        // nothing changes.
        cut_mid_trial(&dir, 2, 3);
        let events = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
        let at = events.rfind("\"answer\":\"").unwrap() + 10;
        let flipped = if events[at..].starts_with("yes") {
            events[..at].to_owned() + "no" + &events[at + 3..]
        } else {
            events[..at].to_owned() + "yes" + &events[at + 2..]
        };
        std::fs::write(dir.join("events.jsonl"), &flipped).unwrap();
        let o = observer_run(protocol, &sim.port, &out, first, &["--resume"]);
        assert_eq!(o.status.code(), Some(2), "{protocol}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("do not follow from its answers"), "{err}");
        assert_eq!(
            std::fs::read_to_string(dir.join("events.jsonl")).unwrap(),
            flipped
        );
    }
}
