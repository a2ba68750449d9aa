//! Blocks end to end: `studies/exp1-with-practice.toml` (a practice block,
//! a break, then Experiment 1) on the simulated device. The practice rows
//! are in trials.csv, marked, and left out of the report; the break is
//! logged; `study check` prints the blocks and each trial's.

mod link_support;
use link_support::Sim;
#[allow(dead_code)]
mod study_support;
use study_support::*;

#[test]
fn a_practice_block_and_a_break_run_before_the_main_block_and_stay_out_of_the_report() {
    let protocol = studies("exp1-with-practice.toml");
    // No latin-square order: a participant's number changes nothing, and
    // is refused; the seed draws the main block's random order.
    let o = study(&["check", &protocol, "--participant", "2"])
        .output()
        .unwrap();
    says(
        &refused(&o),
        &["--participant 2 picks a row of a latin-square order"],
    );
    let o = study(&["check", &protocol, "--seed", "4"])
        .output()
        .unwrap();
    says(
        &ok_stdout(&o),
        &[
            "blocks: 2; trials: 33",
            "block 1 `practice` (practice",
            "then a 60 s break",
            "\n1 practice 1 lms-5hz/4 lms-5hz-a4\n",
            "\n33 main 2 ",
        ],
    );

    let sim = Sim::start(&[]);
    let d = scratch("blocks");
    let out = d.join("out");
    // Five answers a trial (vibration, movement, three shape items).
    let a: Vec<String> = (0..33 * 5).map(|i| ((i * 3) % 7 + 1).to_string()).collect();
    let answers = answers_file(&d, &(a.join("\n") + "\n"));
    let o = answered_p01(&protocol, &sim.port, &out, "0.02", &answers, "4");
    says(
        &ok_stderr(&o),
        &[
            "block `practice` (practice): 3 trials: Practice:",
            "break: 1.2 s",
        ],
    );
    let r = n_rows(&out.join("P01"), 33);
    for (i, row) in r.iter().enumerate() {
        let (block, practice) = if i < 3 {
            ("practice", "1")
        } else {
            ("main", "0")
        };
        assert_eq!(row["block"], block, "row {i}");
        assert_eq!(row["practice"], practice, "row {i}");
        assert_eq!(row["trial"], (i + 1).to_string());
    }
    let types: Vec<&str> = r[..3].iter().map(|x| x["type"].as_str()).collect();
    assert_eq!(types, ["lms-5hz", "lmm-5hz", "lms-25hz"]);
    assert!(r[..3].iter().all(|x| x["radius"] == "4"));
    // The break sits between the last practice trial and the first main one.
    let events = std::fs::read_to_string(out.join("P01/events.jsonl")).unwrap();
    let kinds: Vec<String> = events
        .lines()
        .filter_map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).ok()?;
            let e = v["event"].as_str()?;
            matches!(e, "block" | "break" | "trial").then(|| match e {
                "trial" => format!("trial {}", v["trial"]),
                _ => format!("{e} {}", v["block"].as_str().unwrap()),
            })
        })
        .collect();
    assert_eq!(
        kinds[..7],
        [
            "block practice",
            "trial 1",
            "trial 2",
            "trial 3",
            "break practice",
            "block main",
            "trial 4"
        ]
    );
    // The report: 30 trials, the practice left out and said so.
    let o = study(&["report", out.to_str().unwrap()]).output().unwrap();
    says(
        &ok_stderr(&o),
        &["1 participants, 30 trials summarised (3 practice trials left out)"],
    );
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    // lms-5hz at 4 mm was presented three times (once in practice); its
    // summary counts the two main-block answers only.
    let head: Vec<&str> = summary.lines().next().unwrap().split(',').collect();
    let n_at = head.iter().position(|h| *h == "n").unwrap();
    let line: Vec<&str> = summary
        .lines()
        .find(|l| l.starts_with("lms-5hz-a4,") && l.contains(",vibration,"))
        .unwrap_or_else(|| panic!("{summary}"))
        .split(',')
        .collect();
    assert_eq!(line[n_at], "2", "{line:?}");
}
