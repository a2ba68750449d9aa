//! `study report` end to end on the statistics fixture that scipy wrote
//! (`host/tests/stats/reference.json`, design "Experiment 1"): ten
//! participants' `trials.csv` files built from its answers (two sets, 14
//! "not perceived"), reported, and `stats.json` compared with scipy's
//! values (relative error ≤ 1e-6) — the report's pipeline from the files
//! to the numbers, not only the statistics functions.

use std::path::PathBuf;

use serde_json::Value;

use crate::lab::study::columns::{self, NOT_PERCEIVED};
use crate::lab::study::design;
use crate::lab::study::protocol::Unlinked;
use crate::lab::study::record::{self, Expect, SessionFile};

const PROTOCOL: &str = r#"name = "scipy-fixture"
library = "paper-library.toml"
sets = 2
stimulus = "{type}-a{radius}"

[timeline]
on_s = 1.0

[[factor]]
name = "type"
levels = ["lms-5hz", "lmm-5hz", "lms-25hz"]

[[factor]]
name = "radius"
levels = ["2", "3", "4", "5", "6"]

[[question]]
id = "vibration"
kind = "likert"
points = 7
not_perceived = "could not perceive"

[report]
friedman = ["type", "radius"]

[[report.pairs]]
factor = "type"
"#;

fn fixture() -> Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/stats/reference.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn close(what: &str, got: &Value, want: &Value) {
    let (g, w) = (got.as_f64().unwrap(), want.as_f64().unwrap());
    let rel = (g - w).abs() / w.abs().max(1e-300);
    assert!(
        rel <= 1e-6 || (g == 0.0 && w == 0.0),
        "{what}: {g} vs scipy {w}"
    );
}

/// Writes the fixture's answers as ten participants' folders under `out`.
fn write_study(out: &std::path::Path) -> usize {
    let f = fixture();
    let rows = f["design"]["rows"].as_array().unwrap();
    let p = Unlinked::from_toml(PROTOCOL, "fixture").unwrap();
    let mut na = 0;
    let mut who: Vec<&str> = rows.iter().map(|r| r[0].as_str().unwrap()).collect();
    who.dedup();
    for (k, id) in who.iter().enumerate() {
        let seed = 100 + k as u64;
        let plan = design::plan_of(&p, seed, None);
        // Each cell's answers in the fixture's order, set by set.
        let mut cells: std::collections::HashMap<String, Vec<Option<f64>>> = Default::default();
        for r in rows.iter().filter(|r| r[0] == *id) {
            cells
                .entry(r[1].as_str().unwrap().to_owned())
                .or_default()
                .push(r[2].as_f64());
        }
        let expect = Expect::of(&p, id);
        let mut text = record::line(&p.columns.names()) + "\n";
        for t in &plan {
            let name = super::condition_name(&p.conditions[t.condition]);
            let v = cells.get_mut(&name).unwrap().remove(0);
            let mut r = expect.row(t);
            r.set(columns::TIME_UTC, "2026-11-26T08:41:59.123Z");
            r.set(columns::ANSWERS, "1");
            r.set(
                "vibration",
                v.map_or(NOT_PERCEIVED.to_owned(), |x| format!("{x}")),
            );
            na += usize::from(v.is_none());
            r.set(&columns::rt_column("vibration"), "1.250");
            text += &(record::line(&p.columns.fields(&r).unwrap()) + "\n");
        }
        let dir = out.join(id);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("trials.csv"), text).unwrap();
        let s = SessionFile {
            protocol_name: p.name.clone(),
            protocol_file: "fixture.toml".into(),
            protocol: PROTOCOL.into(),
            library_file: "paper-library.toml".into(),
            participant: (*id).into(),
            seed,
            index: None,
            order: "random".into(),
            question_order: vec!["vibration".into()],
            columns: record::columns(&p.columns),
            trials: plan,
            runs: Vec::new(),
        };
        std::fs::write(
            dir.join("session.json"),
            serde_json::to_vec_pretty(&s).unwrap(),
        )
        .unwrap();
    }
    na
}

#[test]
fn the_reports_statistics_match_scipy_on_the_fixtures_study() {
    let out = std::env::temp_dir().join(format!("lmhost-report-scipy-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let na = write_study(&out);
    assert_eq!(na, 14, "the fixture's \"not perceived\" answers");
    let r = crate::lab::study::report::report(&out).unwrap();
    assert_eq!((r.participants, r.rows, r.not_perceived), (10, 300, 14));
    let stats: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    let q = &stats[0];
    assert_eq!(q["question"], "vibration");
    assert_eq!(q["not_perceived"], 14);
    let a = &q["analysis"];
    let want = &fixture()["design"]["expect"];
    // Shapiro-Wilk per condition.
    let normality = a["normality"].as_array().unwrap();
    assert_eq!(normality.len(), 15);
    for w in want["normality"].as_array().unwrap() {
        let g = normality
            .iter()
            .find(|g| g["condition"] == w["condition"])
            .unwrap();
        let what = format!("shapiro {}", w["condition"]);
        assert_eq!(g["n"], w["n"], "{what}");
        close(&what, &g["shapiro_wilk"]["done"]["w"], &w["w"]);
        close(&what, &g["shapiro_wilk"]["done"]["p"], &w["p"]);
    }
    // Wilcoxon for the named pairs, Bonferroni within each radius, d_z
    // and the paired t-test's power.
    let pairs = a["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 15);
    for w in want["pairs"].as_array().unwrap() {
        let g = pairs
            .iter()
            .find(|g| g["a"] == w["a"] && g["b"] == w["b"])
            .unwrap_or_else(|| panic!("pair {} {}", w["a"], w["b"]));
        let what = format!("wilcoxon {} {}", w["a"], w["b"]);
        assert_eq!((&g["n"], &g["m"]), (&w["n"], &w["m"]), "{what}");
        let t = &g["wilcoxon"]["done"];
        assert_eq!(t["method"], w["method"], "{what}");
        close(&what, &t["statistic"], &w["statistic"]);
        close(&what, &t["p"], &w["p"]);
        close(&what, &g["p_bonferroni"], &w["p_bonferroni"]);
        close(&what, &g["paired_t"]["done"]["d_z"], &w["d_z"]);
        close(&what, &g["paired_t"]["done"]["power"], &w["power"]);
    }
    // Friedman over each factor, Bonferroni within it.
    let friedman = a["friedman"].as_array().unwrap();
    assert_eq!(friedman.len(), 8);
    for w in want["friedman"].as_array().unwrap() {
        let g = friedman
            .iter()
            .find(|g| g["conditions"] == w["conditions"])
            .unwrap();
        let what = format!("friedman {}", w["conditions"]);
        assert_eq!((&g["n"], &g["m"]), (&w["n"], &w["m"]), "{what}");
        close(&what, &g["friedman"]["done"]["statistic"], &w["statistic"]);
        close(&what, &g["friedman"]["done"]["p"], &w["p"]);
        close(&what, &g["p_bonferroni"], &w["p_bonferroni"]);
    }
    // The same tests in stats.csv and stats.txt; the summary counts them.
    let csv = std::fs::read_to_string(out.join("stats.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 15 + 8 + 15);
    assert!(
        csv.lines()
            .any(|l| l.starts_with("vibration,wilcoxon,type at radius=2,lms-5hz/2 lmm-5hz/2,3,"))
    );
    let txt = std::fs::read_to_string(out.join("stats.txt")).unwrap();
    assert!(txt.contains("14 \"not perceived\" left out"), "{txt}");
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let head: Vec<&str> = summary.lines().next().unwrap().split(',').collect();
    let at = head.iter().position(|h| *h == "not_perceived").unwrap();
    let counted: usize = summary
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(at).unwrap().parse::<usize>().unwrap())
        .sum();
    assert_eq!(counted, 14);
    let _ = std::fs::remove_dir_all(&out);
}
