use super::*;
use crate::lab::study::answers::Answers as _;
use crate::lab::study::observer::{Observer, Psychometric};
use crate::lab::study::procedure::tests::ends_at;

/// A staircase over `n` levels `0, 1/(n-1), …, 1`, starting at the top.
fn spec(
    n: usize,
    up: u32,
    down: u32,
    steps: &[u32],
    reversals: u32,
    last: u32,
) -> protocol::Staircase {
    protocol::Staircase {
        grid: protocol::Grid::even(n, 400),
        up,
        down,
        steps: steps.to_vec(),
        reversals,
        threshold_reversals: last,
    }
}

#[test]
fn one_up_two_down_moves_reverses_changes_step_and_ends() {
    let s = spec(11, 1, 2, &[2, 1], 3, 2);
    let mut l = Levitt::new(&s);
    assert_eq!(l.place(), Some(10));
    // Two yes: down by 2 (no reversal yet: the first move).
    assert_eq!(l.answer(true), None);
    assert_eq!(l.place(), Some(10));
    assert_eq!(l.answer(true), None);
    assert_eq!(l.place(), Some(8));
    // One no: up, a reversal at 8; the step becomes 1.
    assert_eq!(l.answer(false), None);
    assert_eq!(l.place(), Some(9));
    assert_eq!(l.reversals(), [8]);
    // Yes, no: the yes run is broken, up again (no reversal: same way).
    l.answer(true);
    l.answer(false);
    assert_eq!(l.place(), Some(10));
    assert_eq!(l.reversals(), [8]);
    // Up at the top is cut short by the grid's end, and counted once
    // that level is presented (answered).
    l.answer(false);
    assert_eq!((l.place(), l.at_limit()), (Some(10), 0));
    l.answer(true);
    assert_eq!(l.at_limit(), 1);
    // Another yes: down, a reversal at 10; two more reversals end it.
    l.answer(true);
    assert_eq!((l.place(), l.reversals()), (Some(9), &[8, 10][..]));
    l.answer(false);
    assert_eq!(l.reversals(), [8, 10, 9]);
    assert_eq!(l.place(), None);
    assert_eq!(l.answer(true), Some("3 reversals"));
    assert_eq!(l.presented(), [10, 10, 8, 9, 9, 10, 10, 10, 9]);
    // The last two reversals' mean.
    assert_eq!(l.threshold(&s.grid.values, 2), Some(0.95));
    assert_eq!(l.threshold(&s.grid.values, 9), Some(0.9));
    // Or the presentation limit.
    let mut s2 = s.clone();
    s2.grid.trials = 2;
    let mut m = Levitt::new(&s2);
    m.answer(false);
    assert_eq!(m.answer(false), Some("2 presentations"));
    assert_eq!(m.threshold(&s.grid.values, 2), None);
}

#[test]
fn the_final_reversal_moves_nowhere_and_adds_nothing_at_the_limit() {
    // Four levels from place 2, 1-up/1-down, steps 1 then 3, one reversal
    // ends it: the move after that reversal (1 + 3, cut to 3 by the grid)
    // would never be presented.
    let mut s = spec(4, 1, 1, &[1, 3], 1, 1);
    s.grid.start = 2;
    let mut l = Levitt::new(&s);
    assert_eq!(l.answer(true), None);
    assert_eq!(l.place(), Some(1));
    assert_eq!(l.answer(false), Some("1 reversals"));
    assert_eq!(
        (l.place(), l.place),
        (None, 1),
        "no step past the last level"
    );
    assert_eq!(l.at_limit(), 0, "an unpresented move is no presentation");
    assert_eq!((l.presented(), l.reversals()), (&[2, 1][..], &[1][..]));
    // The row says the same: the levels whole, nothing at the limit.
    let mut st = Staircase::new(&s, 0);
    st.respond("yes");
    let (level, why) = ends_at(&mut st, "no", "one reversal ends it");
    assert_eq!(level, 1.0 / 3.0);
    assert!(why.starts_with("1 reversals: threshold 0.3333"), "{why}");
    let mut row = Row::default();
    st.record(&mut row);
    assert_eq!(row.get(columns::STAIRCASE_LEVELS), Some("0.6667|0.3333"));
    assert_eq!(row.get(columns::STAIRCASE_AT_LIMIT), Some("0"));
}

#[test]
fn a_staircase_ending_at_the_grids_end_counts_only_presented_clamps() {
    // From the top, three "no": each asks to go up past the grid's end.
    // The second and third presentations were cut short there; the move
    // the third answer asks for ends the staircase unpresented.
    let mut s = spec(5, 1, 1, &[1], 9, 1);
    s.grid.trials = 3;
    let mut l = Levitt::new(&s);
    assert_eq!(l.answer(false), None);
    assert_eq!(l.at_limit(), 0);
    assert_eq!(l.answer(false), None);
    assert_eq!(l.at_limit(), 1);
    assert_eq!(l.answer(false), Some("3 presentations"));
    assert_eq!((l.at_limit(), l.place), (2, 4));
    assert_eq!(l.presented(), [4, 4, 4]);
    // And at the bottom, ending on the presentation limit after a move
    // down the grid cut short: the same count.
    let mut b = s.clone();
    b.grid.start = 0;
    let mut m = Levitt::new(&b);
    m.answer(true);
    m.answer(true);
    assert_eq!(m.answer(true), Some("3 presentations"));
    assert_eq!((m.at_limit(), m.presented()), (2, &[0, 0, 0][..]));
    // A trial stopped before the clamped level was presented counts none.
    let mut c = Levitt::new(&s);
    c.answer(false);
    assert_eq!(c.at_limit(), 0);
}

#[test]
fn the_procedure_presents_each_level_entry_and_records_its_state() {
    let s = spec(5, 1, 1, &[1], 2, 2);
    let mut st = Staircase::new(&s, 0);
    let p = st.next().unwrap();
    assert_eq!((p.stimulus.as_str(), p.level), ("s-1.0000", 1.0));
    let q = st.asked();
    assert_eq!(q.perceived_at, Some(1.0));
    assert_eq!(q.parse("1").unwrap(), "yes");
    assert_eq!(st.respond("yes"), Step::Next(0.75));
    assert_eq!(st.next().unwrap().stimulus, "s-0.7500");
    assert!(st.presents("s-0.2500") && !st.presents("other"));
    assert_eq!(st.respond("yes"), Step::Next(0.5));
    assert_eq!(st.respond("no"), Step::Next(0.75));
    let (level, why) = ends_at(&mut st, "yes", "two reversals end it");
    assert_eq!(level, 0.75);
    assert!(why.contains("threshold 0.6250 intensity"), "{why}");
    let mut row = Row::default();
    st.record(&mut row);
    assert_eq!(
        row.get(columns::STAIRCASE_LEVELS),
        Some("1.0000|0.7500|0.5000|0.7500")
    );
    assert_eq!(row.get(columns::STAIRCASE_ANSWERS), Some("yes|yes|no|yes"));
    assert_eq!(row.get(columns::STAIRCASE_REVERSALS), Some("0.5000|0.7500"));
    assert_eq!(row.get(columns::THRESHOLD), Some("0.625000"));
    assert_eq!(st.answers(), 4);
}

/// Runs the staircase of `s` to its end with `observer`, as the runner
/// does: each answer through the answer-source interface; the estimate
/// and the presentations.
fn run(s: &protocol::Staircase, observer: &mut Observer) -> (Option<f64>, usize) {
    let mut st = Staircase::new(s, 0);
    while !st.finished() {
        let a = observer.poll(&st.asked()).unwrap().unwrap();
        st.respond(&a);
    }
    let t = st
        .rule()
        .threshold(&s.grid.values, s.threshold_reversals as usize);
    (t, st.answers())
}

/// Mean and standard deviation of the estimates over `seeds` runs, and
/// the mean presentations (to compare with QUEST+'s).
pub(crate) fn estimates(s: &protocol::Staircase, f: Psychometric, seeds: u64) -> (f64, f64, f64) {
    let runs: Vec<(f64, usize)> = (0..seeds)
        .map(|seed| {
            let (t, n) = run(s, &mut Observer::new(f, seed));
            (t.expect("every run reverses"), n)
        })
        .collect();
    let n = runs.len() as f64;
    let mean = runs.iter().map(|r| r.0).sum::<f64>() / n;
    let sd = (runs.iter().map(|r| (r.0 - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (mean, sd, runs.iter().map(|r| r.1 as f64).sum::<f64>() / n)
}

#[test]
fn over_200_seeds_the_estimates_centre_on_the_level_the_rule_converges_to() {
    // A logistic observer, threshold 0.5 (50 %), slope 12, 2 % lapses, on
    // a grid of 0.01 from 0 to 1; steps 0.08, 0.04, 0.02, then 0.01.
    let (f, _) = Psychometric::parse("logistic:threshold=0.5,slope=12,guess=0,lapse=0.02").unwrap();
    let steps = [8, 4, 2, 1];
    // 1-up/2-down: p² = ½, p = 70.7 %; 1-up/3-down: p³ = ½, p = 79.4 %.
    for (down, p) in [(2, 0.5f64.sqrt()), (3, 0.5f64.powf(1.0 / 3.0))] {
        // 40 reversals, the last 30 averaged: with fewer, a staircase that
        // starts above threshold is still biased towards its start (16
        // reversals, the last 10: +0.009 here; see BENCHMARKS.md).
        let s = spec(101, 1, down, &steps, 40, 30);
        let target = f.level_at(p).unwrap();
        let (mean, sd, presented) = estimates(&s, f, 200);
        eprintln!(
            "{down}-down: mean {mean:.4}, sd {sd:.4}, target {target:.4} ({presented} presented)"
        );
        // The standard error of the mean is sd/√200 (under 0.002 here):
        // the centre is within 0.01 of the target, and the 50 % point
        // (0.5) is far outside that.
        assert!(
            (mean - target).abs() < 0.01,
            "{down}-down: mean {mean:.4} (sd {sd:.4}), target {target:.4}"
        );
        assert!((mean - 0.5).abs() > 0.05, "{mean}");
        assert!(sd > 0.0 && sd < 0.06, "sd {sd}");
    }
}
