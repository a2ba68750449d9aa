//! Tests of `columns`.

use super::*;

fn cols() -> Columns {
    Columns::new(
        vec![Column::new(
            "type",
            Holds::Level(vec!["a".into(), "b".into()]),
        )],
        vec![Column::new("vibration", Holds::Likert(7))],
        None,
    )
    .unwrap()
}

#[test]
fn rows_are_keyed_by_name_and_come_out_in_header_order() {
    let c = cols();
    assert_eq!(
        c.names()[..5],
        ["participant", "trial", "set", "stimulus", "type"]
    );
    assert_eq!(c.names().last(), Some(&"vibration"));
    let mut r = Row::default();
    r.set("vibration", "3");
    r.set(TRIAL, "2");
    r.set(TRIAL, "4");
    let f = c.fields(&r).unwrap();
    assert_eq!(f[1], "4");
    assert_eq!(f[c.index("vibration").unwrap()], "3");
    assert_eq!(f[0], "");
    // A column the header lacks is an error, not a silent drop.
    r.set("colour", "red");
    assert!(c.fields(&r).unwrap_err().contains("no column `colour`"));
    let mut r = Row::default();
    r.set("vibration", "3\n4");
    assert!(c.fields(&r).is_err());
}

#[test]
fn a_name_given_twice_is_refused() {
    let e = Columns::new(
        vec![Column::new("trial", Holds::Level(vec!["a".into()]))],
        Vec::new(),
        None,
    )
    .unwrap_err();
    assert!(e.contains("column `trial` is used twice"), "{e}");
    assert!(fixed().any(|n| n == FINAL_DEPTH));
}

#[test]
fn values_are_checked_by_what_the_column_holds() {
    let ok = |h: Holds, v: &str| h.check(v).is_ok();
    assert!(ok(Holds::Likert(7), "7") && ok(Holds::Likert(7), ""));
    assert!(!ok(Holds::Likert(7), "99") && !ok(Holds::Likert(7), "x"));
    assert!(Holds::Likert(7).check("0").unwrap_err().contains("1 to 7"));
    assert!(ok(Holds::Number(0.0, 10.0), "2.5"));
    for bad in ["inf", "NaN", "1e308", "-1", "x"] {
        assert!(!ok(Holds::Number(0.0, 10.0), bad), "{bad}");
    }
    assert!(ok(Holds::Count, "3") && !ok(Holds::Count, "0") && !ok(Holds::Count, "+3"));
    assert!(ok(Holds::Seconds, "") && ok(Holds::Seconds, "0.5|1.25"));
    assert!(!ok(Holds::Seconds, "0.5|-1") && !ok(Holds::Seconds, "1|"));
    assert!(ok(Holds::Force, "") && ok(Holds::Force, "0.42"));
    assert!(!ok(Holds::Force, "-0.1") && !ok(Holds::Force, "inf") && !ok(Holds::Force, "2000"));
    assert_eq!(Holds::Force.kind(), Some("force"));
    let o = Holds::Order(vec!["flat".into(), "convex".into()]);
    assert!(ok(o.clone(), "convex|flat") && !ok(o.clone(), "convex") && !ok(o, "flat|flat"));
    let d = Holds::Depths(0.0, 10.0);
    assert!(ok(d.clone(), "4.00|4.25") && !ok(d, "4.00|11"));
    let a = Holds::AdjustAnswers(vec!["same".into(), "weaker".into()]);
    assert!(ok(a.clone(), "weaker|same") && !ok(a, "weaker|Same"));
    assert_eq!(Holds::Likert(7).kind(), Some("likert"));
    assert_eq!(Holds::Measured.kind(), None);
}

#[test]
fn a_threshold_lies_within_its_procedures_range() {
    for (file, lo, hi) in [
        ("staircase-detection.toml", 0.05, 1.0),
        ("quest-detection.toml", f64::NAN, f64::NAN),
    ] {
        let path = crate::lab::study::test_files::studies(file);
        let text = std::fs::read_to_string(&path).unwrap();
        let p = crate::lab::study::protocol::Unlinked::from_toml(&text, file).unwrap();
        let c = &p.columns.list()[p.columns.index(THRESHOLD).unwrap()];
        let Holds::Estimate(a, b) = c.holds else {
            panic!("{file}: {:?}", c.holds)
        };
        if lo.is_finite() {
            assert_eq!((a, b), (lo, hi), "{file}");
        }
        // The levels' (or candidate thresholds') ends, as written to 6
        // decimals, and nothing: a run writes them.
        for ok in [format!("{a:.6}"), format!("{b:.6}"), String::new()] {
            c.check(&ok)
                .unwrap_or_else(|e| panic!("{file}: `{ok}`: {e}"));
        }
        // Beyond them, however finite: an edit, not a run's estimate.
        let past = format!("{:.6}", b + (b - a).max(1.0));
        for bad in [past.as_str(), "-1e308", "4294967296", "1e308", "NaN"] {
            assert!(c.check(bad).is_err(), "{file}: `{bad}` accepted");
        }
    }
}
