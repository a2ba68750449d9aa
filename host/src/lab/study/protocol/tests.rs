use super::*;
use crate::lab::study::test_files::studies;

#[test]
fn the_paper_protocols_have_15_conditions_in_2_sets() {
    let p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
    assert_eq!(p.conditions.len(), 15);
    assert_eq!(p.trials(), 30);
    assert_eq!(p.conditions[0].stimulus, "lms-5hz-a2");
    assert_eq!(p.conditions[14].stimulus, "lms-25hz-a6");
    assert_eq!(p.conditions[5].levels, ["lmm-5hz", "2"]);
    assert!(p.timeline.while_touching && p.adjustment.is_none());
    let q: Vec<String> = p.questions.iter().flat_map(|q| q.columns()).collect();
    assert_eq!(
        q,
        [
            "vibration",
            "movement",
            "shape_flat",
            "shape_convex",
            "shape_concave"
        ]
    );
    // As the paper: "could not perceive" on every question; Wilcoxon
    // between the types at each radius, Friedman over both factors.
    assert!(p.questions.iter().all(|q| q.not_perceived.is_some()));
    assert_eq!(p.report.friedman, ["type", "radius"]);
    assert_eq!(p.report.pairs.len(), 1);
    assert_eq!(p.report.pairs[0].pairs.len(), 3);
    let d = crate::lab::study::analysis::design(&p.report, &p.factors, &p.conditions);
    assert_eq!(d.pairs.len(), 5);
    assert_eq!(d.pairs[0].name, "type at radius=2");
    assert_eq!(
        d.pairs[0].pairs[0],
        ("lms-5hz/2".to_owned(), "lmm-5hz/2".to_owned())
    );
    assert_eq!(d.friedman[0].groups.len(), 5);
    assert_eq!(d.friedman[1].groups[0].len(), 5);
    let p3 = Protocol::load(&studies("paper-exp3.toml")).unwrap();
    // Without [report]: Friedman over every factor of 3 levels or more,
    // no pairs.
    assert_eq!(p3.report.friedman, ["type", "radius"]);
    assert!(p3.report.pairs.is_empty());
    let a = p3.adjustment.as_ref().unwrap();
    assert_eq!((a.step_mm, a.max, a.start_mm), (0.25, 20, 4.0));
    assert_eq!(p3.timeline.on_s, Some(2.0));
    assert_eq!(p3.timeline.off_s, 2.0);
    assert_eq!(p3.timeline.gate, Some(crate::lab::session::Gate::Untracked));
}

#[test]
fn bad_protocols_are_one_line_errors_naming_file_line_and_field() {
    refused_cases("bad");
    let exp3 = std::fs::read_to_string(studies("paper-exp3.toml")).unwrap();
    refused(&exp3.replacen("same = \"same\"", "same = \"weaker\"", 1));
}

/// The error `text` is refused with: one line that names the file.
fn refused(text: &str) -> String {
    let e = Protocol::from_toml(text, &studies("test.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("study protocol ") && !e.contains('\n'), "{e}");
    assert!(e.contains("test.toml"), "{e}");
    e
}

/// A case of `refused.toml`.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    protocol: String,
    from: String,
    to: String,
    error: String,
}

/// Each case of `refused.toml`'s `group`: its protocol with the first
/// `from` made `to` is refused with an error that says the case's words.
fn refused_cases(group: &str) {
    let mut groups: std::collections::HashMap<String, Vec<Case>> =
        toml::from_str(include_str!("refused.toml")).unwrap();
    let cases = groups.remove(group).unwrap_or_default();
    assert!(!cases.is_empty(), "no case in group `{group}`");
    for c in cases {
        let base = std::fs::read_to_string(studies(&c.protocol)).unwrap();
        let case = format!("{group}: {} {:?} → {:?}", c.protocol, c.from, c.to);
        assert!(base.contains(&c.from) && c.from != c.to, "{case}");
        let e = refused(&base.replacen(&c.from, &c.to, 1));
        assert!(e.contains(&c.error), "{case}: {e}");
    }
}

#[test]
fn answer_labels_are_told_apart_as_answers_are_matched() {
    let exp1 = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
    // The adjustment's labels get the choice options' checks, and both
    // are told apart ignoring case, as answers are matched.
    refused_cases("labels");
    let choice = "[[question]]\nid = \"pick\"\nkind = \"choice\"\noptions = ";
    for (options, needle) in [
        (
            "[\"Same\", \"same\"]",
            "`same` and `Same` are the same answer",
        ),
        ("[\"flat\", \"2\"]", "`2` is a number"),
        ("[\"flat\", \"a|b\"]", "holds `|`"),
        ("[\"flat\"]", "give 2 to 9 options"),
    ] {
        let e = refused(&format!("{exp1}\n{choice}{options}\n"));
        assert!(e.contains(needle), "{options}: {e}");
        assert!(e.contains("field `question[3].options`"), "{e}");
    }
    let p = Protocol::from_toml(
        &format!("{exp1}\n{choice}[\"Flat\", \"convex-ish\", \"1.5\"]\n"),
        &studies("test.toml"),
    )
    .unwrap();
    assert_eq!(p.questions.len(), 4);
}

#[test]
fn counts_are_checked_not_wrapped() {
    let exp1 = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
    // 64 two-level factors: 2^64 conditions, which wrap to 0 unchecked.
    let mut text = exp1.replace(
        "stimulus = \"{type}-a{radius}\"",
        "stimulus = \"lms-5hz-a2\"",
    );
    for i in 0..64 {
        text += &format!("\n[[factor]]\nname = \"f{i}\"\nlevels = [\"a\", \"b\"]\n");
    }
    let e = refused(&text);
    assert!(e.contains("conditions; a protocol has 1 to 1000"), "{e}");
    // Numbers that do not fit name their field and line.
    refused_cases("counts");
    let number = "[[question]]\nid = \"guess\"\nkind = \"number\"\n";
    let e = refused(&format!("{exp1}\n{number}max = 1e308\n"));
    assert!(
        e.contains("field `question[3].max`: 1e308 is out of range"),
        "{e}"
    );
    let p = Protocol::from_toml(&format!("{exp1}\n{number}"), &studies("test.toml")).unwrap();
    assert_eq!(
        p.questions[3].kind,
        Kind::Number {
            min: -MAX_NUMBER,
            max: MAX_NUMBER
        }
    );
}

#[test]
fn the_staircase_protocol_names_an_entry_per_level_and_bad_tables_are_refused() {
    let p = Protocol::load(&studies("staircase-detection.toml")).unwrap();
    let s = p.staircase.as_ref().unwrap();
    assert_eq!(s.grid.values.len(), 20);
    assert_eq!(
        (s.up, s.down, s.reversals, s.threshold_reversals),
        (1, 2, 12, 8)
    );
    assert_eq!(s.steps, [4, 2, 1]);
    assert_eq!(s.grid.start, 19);
    assert_eq!(s.grid.entries[0][0], "lms-5hz-i0.05");
    // The condition's own stimulus is the start level's entry.
    assert_eq!(p.conditions[0].stimulus, "lms-5hz-i1.00");
    assert!(
        p.columns
            .index(crate::lab::study::columns::THRESHOLD)
            .is_some()
    );
    refused_cases("staircase");
    let base = std::fs::read_to_string(studies("staircase-detection.toml")).unwrap();
    let text = base
        .replacen("name = \"type\"", "name = \"level\"", 1)
        .replacen("{type}-", "", 1);
    assert!(refused(&text).contains("rename the factor"));
}

#[test]
fn every_shipped_protocol_and_its_library_load() {
    // Each protocol in studies/ (a file with `[timeline]`) checks whole,
    // its library included: a field the types no longer take fails here.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let path = e.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        if path.extension().is_some_and(|x| x == "toml") && text.contains("\n[timeline]") {
            Protocol::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            n += 1;
        }
    }
    assert!(n >= 4, "{n} protocols");
}

#[test]
fn the_quest_protocol_plans_its_table_once_and_bad_tables_are_refused() {
    let p = Protocol::load(&studies("quest-detection.toml")).unwrap();
    let q = p.quest.as_ref().unwrap();
    assert_eq!(q.grid.values.len(), 20);
    let m = q.model();
    assert_eq!(
        (m.thresholds.len(), m.slopes.len(), m.lapses.len()),
        (39, 3, 3)
    );
    assert_eq!(q.table.levels(), 20);
    assert_eq!(q.grid.trials, 40);
    assert_eq!(q.stop_sd, None);
    // The first level is the uniform prior's best, and the condition's
    // own stimulus is its entry.
    let best = crate::lab::stats::quest::Posterior::uniform(q.table.clone()).best();
    assert_eq!(q.grid.start, best);
    assert_eq!(p.conditions[0].stimulus, q.grid.entries[0][q.grid.start]);
    use crate::lab::study::columns::{QUEST_ANSWERS, QUEST_LEVELS, THRESHOLD, THRESHOLD_SD};
    for c in [QUEST_LEVELS, QUEST_ANSWERS, THRESHOLD, THRESHOLD_SD] {
        assert!(p.columns.index(c).is_some(), "{c}");
    }
    refused_cases("quest");
    let base = std::fs::read_to_string(studies("quest-detection.toml")).unwrap();
    // Too many functions to weigh: 39 thresholds × 20 slopes × 20 lapses.
    let many = |n: usize, x: f64| {
        let v: Vec<String> = (0..n).map(|i| format!("{}", x * (1 + i) as f64)).collect();
        v.join(", ")
    };
    let text = base
        .replacen("[7.5, 15.0, 30.0]", &format!("[{}]", many(20, 1.0)), 1)
        .replacen("[0.0, 0.02, 0.05]", &format!("[{}]", many(20, 0.01)), 1);
    assert!(refused(&text).contains("15600 functions to weigh: at most 5000"));
    // A Weibull's thresholds are above 0.
    let text = base
        .replacen("shape = \"logistic\"", "shape = \"weibull\"", 1)
        .replacen("thresholds = [0.05,", "thresholds = [0.0, 0.05,", 1);
    assert!(refused(&text).contains("a Weibull's thresholds are above 0"));
}
