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
use crate::lab::study::test_files::exp1_vibration;

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
    let protocol = exp1_vibration();
    let p = Unlinked::from_toml(&protocol, "fixture").unwrap();
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
            protocol: protocol.clone(),
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
    let out = crate::files::scratch("report-scipy");
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
    // Each section's rows: the keys that name a row, its fields that
    // equal scipy's exactly and the numbers within 1e-6 of them (a path
    // into the report's row, the fixture's key).
    for (section, len, keys, exact, numbers) in [
        // Shapiro-Wilk per condition.
        (
            "normality",
            15,
            &["condition"][..],
            &[("/n", "n")][..],
            &[("/shapiro_wilk/done/w", "w"), ("/shapiro_wilk/done/p", "p")][..],
        ),
        // Wilcoxon for the named pairs, Bonferroni within each radius, d_z
        // and the paired t-test's power.
        (
            "pairs",
            15,
            &["a", "b"],
            &[
                ("/n", "n"),
                ("/m", "m"),
                ("/wilcoxon/done/method", "method"),
            ],
            &[
                ("/wilcoxon/done/statistic", "statistic"),
                ("/wilcoxon/done/p", "p"),
                ("/p_bonferroni", "p_bonferroni"),
                ("/paired_t/done/d_z", "d_z"),
                ("/paired_t/done/power", "power"),
            ],
        ),
        // Friedman over each factor, Bonferroni within it.
        (
            "friedman",
            8,
            &["conditions"],
            &[("/n", "n"), ("/m", "m")],
            &[
                ("/friedman/done/statistic", "statistic"),
                ("/friedman/done/p", "p"),
                ("/p_bonferroni", "p_bonferroni"),
            ],
        ),
    ] {
        let rows = a[section].as_array().unwrap();
        assert_eq!(rows.len(), len, "{section}");
        for w in want[section].as_array().unwrap() {
            let named: Vec<&Value> = keys.iter().map(|k| &w[k]).collect();
            let what = format!("{section} {named:?}");
            let g = rows
                .iter()
                .find(|g| keys.iter().all(|k| g[k] == w[k]))
                .unwrap_or_else(|| panic!("no row {what}"));
            let at = |path: &str| g.pointer(path).unwrap_or_else(|| panic!("{what}: {path}"));
            for (path, k) in exact {
                assert_eq!(at(path), &w[k], "{what}: {k}");
            }
            for (path, k) in numbers {
                close(&format!("{what}: {k}"), at(path), &w[k]);
            }
        }
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
