//! `lmhost study` beyond the paper's designs, end to end: a staircase on
//! the simulated device answered by a simulated observer (then cut,
//! resumed and reported), `study check`'s balanced Latin square with
//! `study run` needing the participant's index, and `study schema`.

use std::collections::BTreeMap;

mod link_support;
use link_support::Sim;
#[allow(dead_code)]
mod study_support;
use study_support::*;

#[test]
fn a_staircase_runs_on_the_simulated_device_with_a_simulated_observer() {
    let sim = Sim::start(&[]);
    let d = scratch("staircase");
    let out = d.join("out");
    let protocol = studies("staircase-detection.toml");
    // Participant S01 at 1 % of the protocol's times, answered by `observer`.
    let run = |observer: &str, extra: &[&str]| {
        let mut args = vec![
            "run",
            &protocol,
            "--port",
            &sim.port,
            "--participant",
            "S01",
            "--out",
            out.to_str().unwrap(),
            "--time-scale",
            "0.01",
            "--observer",
            observer,
        ];
        args.extend_from_slice(extra);
        study(&args).output().unwrap()
    };
    let o = run(
        "logistic:threshold=0.4,slope=15,lapse=0.02,seed=5",
        &["--seed", "1"],
    );
    says(&ok_stderr(&o), &["12 reversals: threshold"]);
    let r = n_rows(&out.join("S01"), 2);
    for row in &r {
        let levels: Vec<f64> = row["staircase_levels"]
            .split('|')
            .map(|v| v.parse().unwrap())
            .collect();
        let answers: Vec<&str> = row["staircase_answers"].split('|').collect();
        assert_eq!(levels.len(), answers.len());
        assert_eq!(levels[0], 1.0, "it starts at the top");
        // 1-up/2-down: two yes move down, one no moves up.
        for i in 1..levels.len() {
            if answers[i - 1] == "no" {
                assert!(levels[i] > levels[i - 1] || levels[i] == 1.0, "{row:?}");
            }
        }
        assert_eq!(row["staircase_reversals"].split('|').count(), 12);
        // An on-phase per answer, each of its level's entry (and, on a
        // loaded machine, a phase begun before an answer switched levels).
        let phases: usize = row["on_phases"].parse().unwrap();
        assert!(phases >= levels.len(), "{phases} on-phases");
        assert_eq!(row["answers"], levels.len().to_string());
        // The observer's 70.7 % point is 0.46; the grid's step is 0.05.
        let t: f64 = row["threshold"].parse().unwrap();
        assert!((0.3..0.65).contains(&t), "threshold {t}");
    }
    // Cut to the first row, as a kill between trials leaves it: --resume
    // checks the row (its answers are the staircase's) and runs the second.
    let csv = out.join("S01/trials.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let kept: Vec<&str> = text.lines().take(2).collect();
    std::fs::write(&csv, kept.join("\n") + "\n").unwrap();
    let o = run(
        "logistic:threshold=0.4,slope=15,lapse=0.02,seed=6",
        &["--resume"],
    );
    ok(&o);
    let again = n_rows(&out.join("S01"), 2);
    assert_eq!(again[0], r[0]);
    ok(&study(&["report", out.join("S01").to_str().unwrap()])
        .output()
        .unwrap());
    let events = std::fs::read_to_string(out.join("S01/events.jsonl")).unwrap();
    assert!(
        events.contains("\"stimulus\":\"lms-5hz-i0.50\""),
        "other levels played"
    );
    assert!(events.contains("\"level_intensity\":"));
    // Not a staircase's question: the observer has no answer to it.
    let o = study(&[
        "run",
        &studies("paper-exp1.toml"),
        "--port",
        &sim.port,
        "--participant",
        "S02",
        "--out",
        out.to_str().unwrap(),
        "--observer",
        "logistic:threshold=0.4,slope=15",
    ])
    .output()
    .unwrap();
    says(&refused(&o), &["has no [staircase]"]);
    let o = run("probit:threshold=1", &["--seed", "1"]);
    says(&refused(&o), &["`probit` is not a shape"]);
}

/// Every place holds each condition equally often and each ordered pair
/// is adjacent equally often over `rows`.
fn balanced(rows: &[Vec<String>]) -> bool {
    let mut place: BTreeMap<(usize, &str), usize> = BTreeMap::new();
    let mut next: BTreeMap<(&str, &str), usize> = BTreeMap::new();
    for r in rows {
        for (i, c) in r.iter().enumerate() {
            *place.entry((i, c)).or_default() += 1;
        }
        for w in r.windows(2) {
            *next.entry((&w[0], &w[1])).or_default() += 1;
        }
    }
    let n = rows[0].len();
    let k = rows.len() / n;
    place.len() == n * n
        && place.values().all(|&x| x == k)
        && next.len() == n * (n - 1)
        && next.values().all(|&x| x == k)
}

#[test]
fn study_check_prints_a_balanced_latin_square_and_run_needs_the_index() {
    let d = scratch("latin");
    std::fs::copy(studies("paper-library.toml"), d.join("paper-library.toml")).unwrap();
    let exp1 = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
    // 15 conditions (odd: 30 rows) and 4 (even: 4 rows).
    let odd = exp1.replacen("sets = 2", "sets = 1\norder = \"latin-square\"", 1);
    let even = odd[..odd.find("\n[report]").unwrap()]
        .replacen(
            "\"lms-5hz\", \"lmm-5hz\", \"lms-25hz\"",
            "\"lms-5hz\", \"lmm-5hz\"",
            1,
        )
        .replacen("\"2\", \"3\", \"4\", \"5\", \"6\"", "\"2\", \"3\"", 1);
    for (name, text, n, rows) in [("odd", &odd, 15, 30), ("even", &even, 4, 4)] {
        let p = d.join(format!("{name}.toml"));
        std::fs::write(&p, text).unwrap();
        let o = study(&["check", p.to_str().unwrap()]).output().unwrap();
        ok(&o);
        let out = String::from_utf8_lossy(&o.stdout);
        let square: Vec<Vec<String>> = out
            .lines()
            .filter_map(|l| l.strip_prefix("participant "))
            .map(|l| {
                l.split_once(": ")
                    .unwrap()
                    .1
                    .split(' ')
                    .map(str::to_owned)
                    .collect()
            })
            .collect();
        assert_eq!(square.len(), rows, "{out}");
        assert!(square.iter().all(|r| r.len() == n));
        assert!(balanced(&square), "{name}: {out}");
        // One participant's trials follow their row.
        let o = study(&["check", p.to_str().unwrap(), "--participant", "2"])
            .output()
            .unwrap();
        ok(&o);
        let trials: Vec<String> = String::from_utf8_lossy(&o.stdout)
            .lines()
            .skip_while(|l| !l.starts_with("trials of participant 2"))
            .skip(1)
            .map(|l| l.split(' ').nth(2).unwrap().to_owned())
            .collect();
        assert_eq!(trials, square[1]);
    }
    // A Latin-square run needs the participant's index.
    let o = study(&[
        "run",
        d.join("even.toml").to_str().unwrap(),
        "--port",
        "autd3:emulator",
        "--participant",
        "P01",
        "--out",
        d.join("out").to_str().unwrap(),
        "--finger",
        "synthetic",
    ])
    .output()
    .unwrap();
    says(&refused(&o), &["give --index N"]);
    let o = study(&["check", d.join("missing.toml").to_str().unwrap()])
        .output()
        .unwrap();
    refused(&o);
}

#[test]
fn study_schema_prints_the_committed_schemas() {
    // The copies in docs/schema/ are what the binary prints, byte for byte
    // (a library test keeps them generated from the types).
    let docs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/schema");
    for format in ["protocol", "library"] {
        let o = study(&["schema", format]).output().unwrap();
        ok(&o);
        let want = std::fs::read(docs.join(format!("{format}.schema.json"))).unwrap();
        assert!(o.stdout == want, "{format}: differs from docs/schema");
    }
    let o = study(&["schema", "scene"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(o.stdout.is_empty());
}
