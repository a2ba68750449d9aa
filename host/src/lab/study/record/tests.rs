use super::*;
use crate::lab::study::design;
use crate::lab::study::protocol::Protocol;
use crate::lab::study::test_files::{scratch, studies};

fn exp1() -> (Protocol, Vec<Planned>) {
    let p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
    let plan = design::plan(&p, 7);
    (p, plan)
}

/// Experiment 1 as [`exp1`], and its `trials.csv` in a fresh scratch
/// folder `name` (removed when the guard drops).
fn exp1_trials(name: &str) -> (Protocol, Vec<Planned>, crate::files::Scratch) {
    let (p, plan) = exp1();
    (
        p,
        plan,
        crate::files::scratch_file(&format!("study-{name}"), "trials.csv"),
    )
}

/// Experiment 1's `session.json` for P01 as its first run writes it
/// (seed 7, no run recorded yet).
fn exp1_session() -> (Protocol, SessionFile) {
    let (p, plan) = exp1();
    let s = SessionFile {
        protocol_name: p.name.clone(),
        protocol_file: "x".into(),
        protocol: p.text.clone(),
        library_file: "y".into(),
        participant: "P01".into(),
        seed: 7,
        index: None,
        order: "random".into(),
        question_order: p.questions.iter().map(|q| q.id.clone()).collect(),
        columns: columns(&p.columns),
        trials: plan,
        runs: Vec::new(),
    };
    (p, s)
}

fn expect(p: &Protocol) -> Expect<'_> {
    Expect::of(p, "P01")
}

/// Trial `t`'s row as the runner writes it, every answer `answer`.
fn row(p: &Protocol, t: &Planned, answer: &str) -> String {
    let mut r = expect(p).row(t);
    for q in &p.questions {
        for c in q.columns() {
            r.set(&columns::rt_column(&c), "0.5");
            r.set(&c, answer);
        }
    }
    r.set(columns::TIME_UTC, "2026-11-26T08:41:59.123Z");
    r.set("presented_s", "0.0600");
    r.set("present_fraction", "1.0000");
    r.set(columns::ANSWERS, "5");
    line(&p.columns.fields(&r).unwrap())
}

fn file(p: &Protocol, plan: &[Planned], n: usize) -> String {
    let mut text = line(&p.columns.names()) + "\n";
    for t in &plan[..n] {
        text += &(row(p, t, "3") + "\n");
    }
    text
}

#[test]
fn a_torn_last_row_is_found_and_the_file_left_as_it_is() {
    let (p, plan, path) = exp1_trials("torn");
    let fourth = row(&p, &plan[3], "3");
    // kill -9 anywhere in the fourth row's one write.
    for cut in [1, 3, 20, fourth.len() - 1, fourth.len()] {
        let text = file(&p, &plan, 3) + &fourth[..cut];
        std::fs::write(&path, &text).unwrap();
        let t = read_trials(&path, &p.columns, &plan, &expect(&p)).unwrap();
        assert_eq!(t.rows.len(), 3, "cut at {cut}: trial 4 runs again");
        assert_eq!(t.tail, Tail::TornRow);
        assert_eq!(t.rows[2][3], plan[2].stimulus);
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            text,
            "reading changes nothing"
        );
        // 5 answers per Experiment 1 trial to skip in a responses file.
        assert_eq!(t.answers_used(&p.columns), 15);
    }
    // A header cut short, or no file: the file starts again.
    let header = line(&p.columns.names());
    for cut in [0, 5, header.len()] {
        std::fs::write(&path, &header[..cut]).unwrap();
        let t = read_trials(&path, &p.columns, &plan, &expect(&p)).unwrap();
        assert_eq!((t.rows.len(), t.tail), (0, Tail::NoHeader));
    }
    std::fs::remove_file(&path).unwrap();
    let t = read_trials(&path, &p.columns, &plan, &expect(&p)).unwrap();
    assert_eq!(t.tail, Tail::NoHeader);
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

#[test]
fn anything_but_whole_rows_and_a_provably_torn_tail_is_refused_unchanged() {
    let (p, plan, path) = exp1_trials("refused");
    let good = file(&p, &plan, 3);
    // "Not perceived" is a value of its own where the question allows it
    // (Experiment 1 allows it on every question), not where it does not.
    let na = good.replacen(",3,0.5,3,0.5", ",na,0.5,3,0.5", 1);
    std::fs::write(&path, &na).unwrap();
    let t = read_trials(&path, &p.columns, &plan, &expect(&p)).unwrap();
    assert_eq!(t.rows.len(), 3);
    let vibration = p.columns.index("vibration").unwrap();
    assert_eq!(t.rows[0][vibration], "na");
    let mut strict = p.clone();
    strict.questions[0].not_perceived = None;
    strict.columns = crate::lab::study::columns::Columns::new(
        strict
            .factors
            .iter()
            .map(|f| {
                crate::lab::study::columns::Column::new(
                    &f.name,
                    crate::lab::study::columns::Holds::Level(f.levels.clone()),
                )
            })
            .collect(),
        strict
            .questions
            .iter()
            .flat_map(crate::lab::study::protocol::Question::column_list)
            .collect(),
        None,
    )
    .unwrap();
    let e = read_trials(&path, &strict.columns, &plan, &expect(&strict))
        .unwrap_err()
        .to_string();
    assert!(e.contains("column `vibration`: `na`: give 1 to 7"), "{e}");
    let fourth = row(&p, &plan[3], "3");
    let fifth = row(&p, &plan[4], "3");
    let swapped = line(&p.columns.names()) + "\n" + &row(&p, &plan[1], "3") + "\n";
    let rows: Vec<&str> = good.lines().collect();
    for (text, needle) in [
        (
            "garbage".to_owned(),
            "line 1: not the start of this protocol's header",
        ),
        (
            "garbage\n".to_owned(),
            "line 1: the header is not this protocol's columns",
        ),
        (
            good.clone() + "garbage",
            "line 5: `garbage` is neither a whole row",
        ),
        (
            good.clone() + &fifth[..30],
            "nor the start of trial 4's row",
        ),
        (swapped, "line 2: column `trial` is `2`, but trial 1"),
        (
            good.replace(
                ",3,0.5,3,0.5,3,0.5,3,0.5,3,0.5",
                ",3,0.5,99,0.5,3,0.5,3,0.5,3,0.5",
            ),
            "column `movement`: `99`: give 1 to 7",
        ),
        (
            good.replace(
                ",3,0.5,3,0.5,3,0.5,3,0.5,3,0.5",
                ",3,0.5,x,0.5,3,0.5,3,0.5,3,0.5",
            ),
            "column `movement`: `x`",
        ),
        (
            good.replace(",0.0600,", ",inf,"),
            "column `presented_s`: `inf`",
        ),
        // Rows a run cannot write: it always stamps the time, and a share
        // of the presentation lies in 0..=1.
        (
            good.replace("2026-11-26T08:41:59.123Z", ""),
            "line 2: column `time_utc`: ``: give a time",
        ),
        (
            good.replace(",0.0600,1.0000,", ",0.0600,1.5,"),
            "line 2: column `present_fraction`: `1.5`: give a fraction from 0 to 1",
        ),
        (
            good.replace(",5,3,0.5,3", ",4,3,0.5,3"),
            "column `answers` is `4`, but the row holds 5 answers",
        ),
        (
            good.replacen("\nP01,", "\nP02,", 1),
            "column `participant` is `P02`",
        ),
        (
            format!(
                "{}\n{}\n",
                rows[..3].join("\n"),
                rows[3].replace(",3,0.5,3,0.5,3,0.5,3,0.5,3,0.5", ",3,0.5,3")
            ),
            "line 4: 26 fields, the header has 33",
        ),
        (
            good.clone() + &fourth + "\n" + &fourth + "\n",
            "line 6: column `trial` is `4`, but trial 5",
        ),
        (format!("{good}{}", "\u{fffd}"), "neither a whole row"),
    ] {
        std::fs::write(&path, &text).unwrap();
        let e = match read_trials(&path, &p.columns, &plan, &expect(&p)) {
            Ok(t) => panic!("{needle}: accepted {t:?}"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(needle), "{needle}: {e}");
        assert!(!e.contains('\n'), "{e}");
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            text,
            "left as it was"
        );
    }
    // More rows than trials.
    let one = design::plan(&p, 7)[..1].to_vec();
    std::fs::write(&path, file(&p, &plan, 2)).unwrap();
    let e = read_trials(&path, &p.columns, &one, &expect(&p)).unwrap_err();
    assert!(
        e.to_string().contains("the session has only 1 trials"),
        "{e}"
    );
    // Larger than the session could have written: refused before reading.
    std::fs::write(
        &path,
        good + &"x".repeat(p.columns.max_row_bytes() * 2) + "\n",
    )
    .unwrap();
    let e = read_trials(&path, &p.columns, &one, &expect(&p)).unwrap_err();
    assert!(e.to_string().contains("larger than"), "{e}");
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

#[test]
fn a_fifo_or_device_is_refused_at_once() {
    let (p, plan, fifo) = exp1_trials("fifo");
    nix::unistd::mkfifo(&*fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
    let e = read_trials(&fifo, &p.columns, &plan, &expect(&p)).unwrap_err();
    assert!(e.to_string().contains("FIFO"), "{e}");
    let e = read_session(&fifo).unwrap_err();
    assert!(e.to_string().contains("FIFO"), "{e}");
    let e = read_trials(Path::new("/dev/zero"), &p.columns, &plan, &expect(&p)).unwrap_err();
    assert!(e.to_string().contains("device node"), "{e}");
    let _ = std::fs::remove_dir_all(fifo.parent().unwrap());
}

#[test]
fn session_json_errors_name_the_field() {
    let d = scratch("session");
    let path = d.join("session.json");
    let (_, s) = exp1_session();
    let good = serde_json::to_string_pretty(&s).unwrap();
    std::fs::write(&path, &good).unwrap();
    assert_eq!(read_session(&path).unwrap().seed, 7);
    for (from, to, needle) in [
        ("\"seed\": 7", "\"seed\": -7", "field `seed`"),
        ("\"seed\": 7", "\"seed\": 1e400", "field `seed`"),
        (
            "\"condition\": ",
            "\"condition\": -",
            "field `trials[0].condition`",
        ),
        // A key misspelt, or renamed by an edit: refused, not ignored
        // for its default.
        ("\"order\": ", "\"ordr\": ", ": unknown field `ordr`"),
        (
            "\"runs\": []",
            "\"runs\": [], \"note\": 1",
            "unknown field `note`",
        ),
    ] {
        std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
        let e = read_session(&path).unwrap_err().to_string();
        assert!(e.contains(needle), "{to}: {e}");
        // An unknown key is named once, in serde's words.
        assert_eq!(e.matches("ordr").count(), usize::from(to.contains("ordr")));
        assert!(e.contains("session.json"), "{e}");
    }
    // A long unknown key (a paste) is cut, and said once: one line.
    let long = "k".repeat(2000);
    let edited = good.replacen("\"runs\": []", &format!("\"runs\": [], \"{long}\": 1"), 1);
    std::fs::write(&path, edited).unwrap();
    let e = read_session(&path).unwrap_err().to_string();
    assert!(e.chars().count() < 600, "{} characters: {e}", e.len());
    assert_eq!(e.matches("(2000 characters)").count(), 1, "{e}");
    // So is one holding backquotes of its own, which would split its echo
    // into pieces each short enough to stay whole.
    let long = "a `b` c ".repeat(200);
    let edited = good.replacen("\"runs\": []", &format!("\"runs\": [], \"{long}\": 1"), 1);
    std::fs::write(&path, edited).unwrap();
    let e = read_session(&path).unwrap_err().to_string();
    assert!(e.chars().count() < 600, "{} characters: {e}", e.len());
    // The kinds session.json records: factors, answers, the final depth.
    let kinds: Vec<&str> = s.columns.iter().map(|(_, k)| k.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "factor", "factor", "likert", "likert", "likert", "likert", "likert"
        ]
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn csv_lines_quote_what_needs_it_and_read_back() {
    let f = ["plain", "a,b", "say \"hi\"", "", "1|2"];
    let l = line(&f);
    assert_eq!(l, "plain,\"a,b\",\"say \"\"hi\"\"\",,1|2");
    let mut r = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(l.as_bytes());
    let back: Vec<String> = r
        .records()
        .next()
        .unwrap()
        .unwrap()
        .iter()
        .map(str::to_owned)
        .collect();
    assert_eq!(back, f);
}

#[test]
fn the_largest_session_fits_the_bounds() {
    // 1000 conditions in 10 sets, 32 Likert questions of 9 shuffled items:
    // every order in session.json as long as a protocol allows.
    let library = studies("paper-library.toml");
    let mut text = format!(
        "name = \"big\"\nlibrary = \"{}\"\nsets = 10\nstimulus = \"lms-5hz-a2\"\n\
         [timeline]\non_s = 1.0\n",
        library.display()
    );
    for f in ["a", "b", "c"] {
        let levels: Vec<String> = (0..10).map(|i| format!("\"{i}\"")).collect();
        text += &format!(
            "[[factor]]\nname = \"{f}\"\nlevels = [{}]\n",
            levels.join(", ")
        );
    }
    for q in 0..32 {
        let items: Vec<String> = (0..9).map(|i| format!("\"item{i}\"")).collect();
        text += &format!(
            "[[question]]\nid = \"q{q}\"\nkind = \"likert\"\nitems = [{}]\nshuffle = true\n",
            items.join(", ")
        );
    }
    let p = Protocol::from_toml(&text, &studies("big.toml")).unwrap();
    assert_eq!(p.trials(), crate::lab::study::protocol::MAX_TRIALS);
    let plan = design::plan(&p, 1);
    let s = SessionFile {
        protocol_name: p.name.clone(),
        protocol_file: String::new(),
        protocol: "x".repeat(1 << 20),
        library_file: String::new(),
        participant: "P01".into(),
        seed: 1,
        index: None,
        order: "random".into(),
        question_order: Vec::new(),
        columns: columns(&p.columns),
        trials: plan.clone(),
        runs: Vec::new(),
    };
    let bytes = serde_json::to_vec_pretty(&s).unwrap().len() as u64;
    assert!(bytes < MAX_SESSION_BYTES / 4, "{bytes} bytes");
    eprintln!(
        "largest session.json: {bytes} bytes; a trials.csv row at most {} bytes",
        p.columns.max_row_bytes()
    );
    // trials.csv's bound follows the protocol: here a few kB a row.
    let row = p.columns.max_row_bytes();
    assert!((1_000..20_000).contains(&row), "{row} bytes a row");
    let e = Protocol::from_toml(
        &text.replace("sets = 10", "sets = 11"),
        &studies("big.toml"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("11000 trials; at most 10000"), "{e}");
}

#[test]
fn measured_columns_are_never_below_zero_and_counts_whole() {
    let ok = |h: Holds, v: &str| h.check(v).is_ok();
    assert!(!ok(Holds::Measured, "inf") && ok(Holds::Measured, "") && ok(Holds::Measured, "1.5"));
    assert!(!ok(Holds::Measured, "-1") && ok(Holds::Measured, "0"));
    assert!(ok(Holds::Tally, "") && ok(Holds::Tally, "70527447322"));
    assert!(!ok(Holds::Tally, "-1") && !ok(Holds::Tally, "1.5"));
    assert!(!ok(Holds::Tally, "18446744073709551616"));
}

#[test]
fn session_json_values_no_run_writes_are_refused_naming_the_field() {
    let (p, good) = exp1_session();
    let at = Path::new("P01/session.json");
    good.check(&p, at).unwrap();
    // A file written before the order was recorded has none.
    let mut old = good.clone();
    old.order.clear();
    old.check(&p, at).unwrap();
    let run = |first_trial: usize, time_scale: f64| Run {
        started_unix_s: 0,
        first_trial,
        lmhost_version: "0".into(),
        device: serde_json::Value::Null,
        library: Vec::new(),
        time_scale,
        finger: "none".into(),
        scene: None,
        backend: String::new(),
        port: String::new(),
        resumed_anyway: None,
        instruments: None,
    };
    let trials = good.trials.len();
    let mut ok = good.clone();
    ok.runs = vec![run(1, 0.02), run(trials + 1, 100.0)];
    ok.check(&p, at).unwrap();
    type Edit<'a> = Box<dyn Fn(&mut SessionFile) + 'a>;
    let edits: Vec<(&str, Edit<'_>)> = vec![
        ("protocol_name", Box::new(|s| s.protocol_name += "x")),
        ("order", Box::new(|s| s.order = "sequential".into())),
        ("question_order", Box::new(|s| s.question_order.reverse())),
        ("question_order", Box::new(|s| s.question_order.clear())),
        ("columns", Box::new(|s| s.columns[0].1 = "likert".into())),
        ("columns", Box::new(|s| s.columns.pop().map_or((), drop))),
        // Exp. 1's order is random: no index picks its row.
        ("index", Box::new(|s| s.index = Some(3))),
        (
            "runs[0].first_trial",
            Box::new(move |s| s.runs = vec![run(0, 1.0)]),
        ),
        (
            "runs[1].first_trial",
            Box::new(move |s| s.runs = vec![run(1, 1.0), run(trials + 2, 1.0)]),
        ),
        (
            "runs[0].time_scale",
            Box::new(move |s| s.runs = vec![run(1, 0.0)]),
        ),
        (
            "runs[0].time_scale",
            Box::new(move |s| s.runs = vec![run(1, -1.0)]),
        ),
        (
            "runs[0].time_scale",
            Box::new(move |s| s.runs = vec![run(1, 1e308)]),
        ),
    ];
    for (field, edit) in edits {
        let mut s = good.clone();
        edit(&mut s);
        let e = s.check(&p, at).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("P01/session.json: field `{field}`: ")),
            "{field}: {e}"
        );
        assert!(!e.contains('\n') && e.len() < 300, "{e}");
    }
}

#[test]
fn a_latin_square_session_records_an_index_from_1() {
    let text = std::fs::read_to_string(studies("paper-exp1.toml"))
        .unwrap()
        .replace("sets = 2\n", "sets = 2\norder = \"latin-square\"\n");
    let p = Unlinked::from_toml(&text, "latin.toml").unwrap();
    let plan = design::plan_of(&p, 7, Some(2));
    let mut s = SessionFile {
        protocol_name: p.name.clone(),
        protocol_file: "x".into(),
        protocol: text.clone(),
        library_file: "y".into(),
        participant: "P01".into(),
        seed: 7,
        index: Some(2),
        order: "latin-square".into(),
        question_order: p.questions.iter().map(|q| q.id.clone()).collect(),
        columns: columns(&p.columns),
        trials: plan,
        runs: Vec::new(),
    };
    let at = Path::new("session.json");
    s.check(&p, at).unwrap();
    // Index 0 and index rows + 1 plan as rows 1 and 2 would: refused,
    // not read as them.
    for bad in [None, Some(0), Some(MAX_INDEX + 1)] {
        s.index = bad;
        let e = s.check(&p, at).unwrap_err().to_string();
        assert!(e.contains("field `index`"), "{bad:?}: {e}");
    }
}

#[test]
fn session_json_reads_its_own_nulls_and_refuses_a_null_for_a_key_left_out() {
    let d = scratch("session-null");
    let path = d.join("session.json");
    let (_, mut s) = exp1_session();
    s.runs = vec![Run {
        started_unix_s: 0,
        first_trial: 1,
        lmhost_version: "0".into(),
        device: serde_json::Value::Null,
        library: Vec::new(),
        time_scale: 1.0,
        finger: "none".into(),
        scene: Some(SceneRecord::of(None, None)),
        backend: String::new(),
        port: String::new(),
        resumed_anyway: None,
        instruments: None,
    }];
    // What a run writes for "none": no index, the built-in scene.
    let good = serde_json::to_value(&s).unwrap();
    assert!(good["index"].is_null() && good["runs"][0]["scene"]["path"].is_null());
    std::fs::write(&path, good.to_string()).unwrap();
    let back = read_session(&path).unwrap();
    assert_eq!((back.index, &back.runs[0].scene), (None, &s.runs[0].scene));
    // A key a run leaves out for "none" is refused as `null`, by name.
    for key in ["scene", "resumed_anyway", "instruments"] {
        let mut v = good.clone();
        v["runs"][0][key] = serde_json::Value::Null;
        std::fs::write(&path, v.to_string()).unwrap();
        let e = read_session(&path).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "field `runs[0].{key}`: {}",
                crate::json::NULL_REFUSED
            )),
            "{key}: {e}"
        );
        // Left out, it reads as none.
        v["runs"][0].as_object_mut().unwrap().remove(key);
        std::fs::write(&path, v.to_string()).unwrap();
        assert!(read_session(&path).is_ok(), "{key}");
    }
    let _ = std::fs::remove_dir_all(&d);
}
