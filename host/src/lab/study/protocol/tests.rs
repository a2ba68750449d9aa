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
    let base = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
    let path = studies("test.toml");
    for (from, to, needle) in [
        ("sets = 2", "sets = 0", "line 22, field `sets`"),
        ("sets = 2", "sets = 2\ncolour = 1", "unknown field `colour`"),
        (
            "\"2\", \"3\"",
            "\"7\", \"3\"",
            "stimulus `lms-5hz-a7`, which is not in",
        ),
        (
            "{type}-a{radius}",
            "{type}-a{size}",
            "`{size}`, which is not a factor",
        ),
        (
            "points = 7\nlow = \"not",
            "points = 12\nlow = \"not",
            "line 43, field `question[0].points`",
        ),
        (
            "id = \"movement\"\nkind = \"likert\"\npoints = 7",
            "id = \"movement\"\nkind = \"likert\"\npoints = 1",
            "line 52, field `question[1].points`: question `movement`",
        ),
        (
            "kind = \"likert\"\npoints = 7\nlow = \"does",
            "kind = \"number\"\npoints = 7\nlow = \"does",
            "does not apply",
        ),
        (
            "library = \"paper-library.toml\"",
            "library = \"nope.toml\"",
            "field `library`",
        ),
        (
            "while_touching = true",
            "while_touching = false",
            "give `on_s`",
        ),
        ("iti_s = 1.0", "iti_s = -1", "field `timeline.iti_s`"),
        ("id = \"movement\"", "id = \"vibration\"", "given twice"),
        (
            "id = \"movement\"",
            "id = \"trial\"",
            "column `trial` is used twice",
        ),
        (
            "gate = \"tracked\"",
            "gate = \"loose\"",
            "unknown variant `loose`",
        ),
        (
            "not_perceived = \"could not perceive the stimulus\"",
            "not_perceived = \"\"",
            "field `question[0].not_perceived`",
        ),
        (
            "alpha = 0.05",
            "alpha = 1.5",
            "field `report.alpha`: 1.5 is not a significance level",
        ),
        (
            "friedman = [\"type\", \"radius\"]",
            "friedman = [\"type\", \"colour\"]",
            "`colour` is not a factor (the factors: type, radius)",
        ),
        (
            "factor = \"type\"\n",
            "factor = \"type\"\npairs = [[\"lms-5hz\", \"lm-x\"]]\n",
            "`lm-x` is not a level of factor `type`",
        ),
        (
            "repeats = \"mean\"",
            "repeats = \"mode\"",
            "unknown variant `mode`",
        ),
    ] {
        assert!(base.contains(from), "{from}");
        let text = base.replacen(from, to, 1);
        let e = Protocol::from_toml(&text, &path).unwrap_err().to_string();
        assert!(e.contains(needle), "{to}: {e}");
        assert!(e.starts_with("study protocol "), "{e}");
        assert!(e.contains("test.toml"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
    let base = std::fs::read_to_string(studies("paper-exp3.toml")).unwrap();
    let text = base.replacen("off_s = 2.0", "off_s = 2.0\nrepeat = 3", 1);
    let e = Protocol::from_toml(&text, &path).unwrap_err().to_string();
    assert!(e.contains("field `timeline.repeat`"), "{e}");
    let text = base.replacen("same = \"same\"", "same = \"weaker\"", 1);
    assert!(Protocol::from_toml(&text, &path).is_err());
}

fn refused(text: &str) -> String {
    let e = Protocol::from_toml(text, &studies("test.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("study protocol ") && !e.contains('\n'), "{e}");
    e
}

#[test]
fn answer_labels_are_told_apart_as_answers_are_matched() {
    let exp1 = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
    let exp3 = std::fs::read_to_string(studies("paper-exp3.toml")).unwrap();
    // The adjustment's labels get the choice options' checks, and both
    // are told apart ignoring case, as answers are matched.
    for (from, to, needle) in [
        (
            "same = \"same\"",
            "same = \"Stronger\"",
            "line 44, field `adjustment.same`: `Stronger` and `stronger`",
        ),
        (
            "same = \"same\"",
            "same = \"3\"",
            "line 44, field `adjustment.same`: `3` is a number",
        ),
        (
            "weaker = \"weaker\"",
            "weaker = \"+2\"",
            "field `adjustment.weaker`: `+2` is a number",
        ),
        ("same = \"same\"", "same = \"a|b\"", "holds `|`"),
        ("same = \"same\"", "same = \" same\"", "spaces at an end"),
        ("same = \"same\"", "same = \"\"", "field `adjustment.same`"),
    ] {
        assert!(exp3.contains(from));
        let e = refused(&exp3.replacen(from, to, 1));
        assert!(e.contains(needle), "{to}: {e}");
    }
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
    for (from, to, needle) in [
        (
            "sets = 2",
            "sets = 1e3",
            "line 22, field `sets`: invalid type: floating point",
        ),
        (
            "sets = 2",
            "sets = 99999999999999999999",
            "line 22, field `sets`",
        ),
        ("sets = 2", "sets = -1", "line 22, field `sets`"),
        (
            "iti_s = 1.0",
            "iti_s = inf",
            "field `timeline.iti_s`: inf is out of range",
        ),
        (
            "iti_s = 1.0",
            "iti_s = nan",
            "field `timeline.iti_s`: NaN is out of range",
        ),
        (
            "touch_s = 3.0",
            "touch_s = 1e308",
            "field `timeline.touch_s`: 1e308 is out of range",
        ),
        (
            "points = 7\nlow = \"not",
            "points = 4294967296\nlow = \"not",
            "line 43, field `question[0].points`",
        ),
    ] {
        assert!(exp1.contains(from), "{from}");
        let e = refused(&exp1.replacen(from, to, 1));
        assert!(e.contains(needle), "{to}: {e}");
    }
    let exp3 = std::fs::read_to_string(studies("paper-exp3.toml")).unwrap();
    for (from, to, needle) in [
        (
            "max_mm = 10.0",
            "max_mm = 1e308",
            "field `adjustment.max_mm`: 1e308 is out of range",
        ),
        (
            "start_mm = 4.0",
            "start_mm = 40.0",
            "field `adjustment.start_mm`: give min_mm <= start_mm",
        ),
        (
            "max = 20",
            "max = 0",
            "field `adjustment.max`: 0 is out of range 1..=1000",
        ),
        (
            "step_mm = 0.25",
            "step_mm = -0.25",
            "field `adjustment.step_mm`",
        ),
    ] {
        assert!(exp3.contains(from), "{from}");
        let e = refused(&exp3.replacen(from, to, 1));
        assert!(e.contains(needle), "{to}: {e}");
    }
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
    let base = std::fs::read_to_string(studies("staircase-detection.toml")).unwrap();
    for (from, to, needle) in [
        (
            "start = \"1.00\"",
            "start = \"1.10\"",
            "field `staircase.start`",
        ),
        (
            "steps = [4, 2, 1]",
            "steps = [0]",
            "field `staircase.steps`",
        ),
        ("steps = [4, 2, 1]", "steps = [20]", "1 to 19 grid places"),
        ("down = 2", "down = 0", "field `staircase.down`"),
        (
            "threshold_reversals = 8",
            "threshold_reversals = 13",
            "1..=12",
        ),
        ("no = \"no\"", "no = \"YES\"", "must differ"),
        ("[\"0.05\", \"0.10\"", "[\"0.10\", \"0.05\"", "ascending"),
        ("[\"0.05\"", "[\"low\"", "not a finite number"),
        ("-i{level}", "-i", "put `{level}`"),
        ("[\"0.05\"", "[\"0.01\"", "`lms-5hz-i0.01`, which is not in"),
        ("on_s = 1.0", "", "give `on_s`"),
        (
            "off_s = 0.5",
            "off_s = 0.5\nrepeat = 2",
            "[staircase] trial repeats",
        ),
        (
            "\n[staircase]",
            "\n[adjustment]\nstart_mm = 1.0\n\n[staircase]",
            "[adjustment] or [staircase], not both",
        ),
    ] {
        let text = base.replacen(from, to, 1);
        assert_ne!(text, base, "{from}");
        let e = refused(&text);
        assert!(e.contains(needle), "{from} → {to}: {e}");
    }
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
    let base = std::fs::read_to_string(studies("quest-detection.toml")).unwrap();
    for (from, to, needle) in [
        ("slopes = [7.5, 15.0, 30.0]", "", "missing field `slopes`"),
        (
            "slopes = [7.5, 15.0, 30.0]",
            "slopes = [0.0]",
            "field `quest.slopes`: 0: give slopes above 0",
        ),
        (
            "slopes = [7.5, 15.0, 30.0]",
            "slopes = []",
            "0 values: give 1 to 20",
        ),
        (
            "lapses = [0.0, 0.02, 0.05]",
            "lapses = [0.5]",
            "field `quest.lapses`: 0.5: give lapse rates from 0, below 0.5",
        ),
        (
            "guess = 0.0",
            "guess = 0.96",
            "field `quest.guess`: 0.96 is out of range",
        ),
        (
            "thresholds = [0.05, 0.075",
            "thresholds = [0.075, 0.05",
            "ascending",
        ),
        (
            "shape = \"logistic\"",
            "shape = \"probit\"",
            "unknown variant `probit`",
        ),
        ("trials = 40", "trials = 0", "field `quest.trials`"),
        (
            "trials = 40",
            "trials = 40\nstop_sd = -1",
            "field `quest.stop_sd`",
        ),
        (
            "trials = 40",
            "trials = 40\nstart = \"0.50\"",
            "unknown field `start`",
        ),
        ("no = \"no\"", "no = \"YES\"", "must differ"),
        ("-i{level}", "-i", "put `{level}`"),
        (
            "[\"0.05\"",
            "[\"0.01\"",
            "the quest names stimulus `lms-5hz-i0.01`",
        ),
        (
            "off_s = 0.5",
            "off_s = 0.5\nrepeat = 2",
            "[quest] trial repeats",
        ),
        (
            "\n[quest]",
            "\n[staircase]\nlevels = [\"0.05\", \"0.10\"]\n\n[quest]",
            "one of [adjustment], [staircase] and [quest]",
        ),
    ] {
        let text = base.replacen(from, to, 1);
        assert_ne!(text, base, "{from}");
        let e = refused(&text);
        assert!(e.contains(needle), "{from} → {to}: {e}");
    }
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
