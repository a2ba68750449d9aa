use std::sync::Arc;

use super::*;
use crate::lab::stats::psychometric::Shape;
use crate::lab::stats::quest::{Model, Table};
use crate::lab::study::answers::Answers as _;
use crate::lab::study::observer::{Observer, Psychometric};
use crate::lab::study::procedure::tests::ends_at;

/// QUEST+ over `n` levels `0, 1/(n-1), …, 1`, weighing logistic
/// thresholds at the same places, `slopes` and a lapse rate of 0.02.
pub(crate) fn spec(n: usize, slopes: &[f64], trials: u32, stop_sd: Option<f64>) -> protocol::Quest {
    let mut grid = protocol::Grid::even(n, trials);
    let table = Arc::new(Table::new(
        &grid.values,
        Model {
            shape: Shape::Logistic,
            guess: 0.0,
            thresholds: grid.values.clone(),
            slopes: slopes.to_vec(),
            lapses: vec![0.02],
        },
    ));
    grid.start = Posterior::uniform(table.clone()).best();
    protocol::Quest {
        grid,
        table,
        stop_sd,
    }
}

#[test]
fn it_presents_the_least_entropy_level_updates_and_records_every_presentation() {
    let s = spec(11, &[12.0], 4, None);
    let mut q = Quest::new(&s, 0);
    // The uniform prior's best over symmetric thresholds is the middle.
    assert_eq!(s.grid.start, 5);
    let p = q.next().unwrap();
    assert_eq!((p.stimulus.as_str(), p.level), ("s-0.5000", 0.5));
    assert_eq!(q.asked().perceived_at, Some(0.5));
    assert_eq!(q.asked().parse("2").unwrap(), "no");
    // Not perceived at 0.5: the threshold is likely above, and so is the
    // next level; the posterior is what Bayes' rule leaves.
    let Step::Next(up) = q.respond("no") else {
        panic!("4 presentations")
    };
    assert!(up > 0.5, "{up}");
    let mut by_hand = Posterior::uniform(s.table.clone());
    by_hand.update(5, false);
    assert_eq!(q.posterior(), &by_hand);
    assert_eq!(up, s.grid.values[by_hand.best()]);
    assert!(q.threshold().0 > 0.5);
    assert!(q.presents("s-0.9000") && !q.presents("other"));
    q.respond("yes");
    q.respond("yes");
    let (level, why) = ends_at(&mut q, "no", "the fourth presentation is the last");
    assert_eq!(level, s.grid.values[q.presented()[3]]);
    assert!(why.starts_with("4 presentations: threshold 0."), "{why}");
    assert_eq!(
        q.respond("yes"),
        Step::Done,
        "an answer after the end changes nothing"
    );
    assert_eq!(q.answers(), 4);
    let mut row = Row::default();
    q.record(&mut row);
    let levels: Vec<String> = q
        .presented()
        .iter()
        .map(|&i| s.grid.labels[i].clone())
        .collect();
    assert_eq!(
        row.get(columns::QUEST_LEVELS),
        Some(levels.join("|").as_str())
    );
    assert_eq!(row.get(columns::QUEST_ANSWERS), Some("no|yes|yes|no"));
    let (mean, sd) = q.threshold();
    assert_eq!(
        row.get(columns::THRESHOLD),
        Some(format!("{mean:.6}").as_str())
    );
    assert_eq!(
        row.get(columns::THRESHOLD_SD),
        Some(format!("{sd:.6}").as_str())
    );
    assert!(sd > 0.0);
}

#[test]
fn a_posterior_sd_bound_ends_it_early() {
    let s = spec(21, &[12.0], 200, Some(0.05));
    let mut q = Quest::new(&s, 0);
    let mut o = Observer::new(
        Psychometric::parse("logistic:threshold=0.3,slope=12")
            .unwrap()
            .0,
        4,
    );
    let mut last = None;
    while !q.finished() {
        last = Some(q.respond(&o.poll(&q.asked()).unwrap().unwrap()));
    }
    let Some(Step::Last { why, .. }) = last else {
        panic!("{last:?}")
    };
    assert!(why.contains("below 0.05 intensity"), "{why}");
    assert!(q.answers() < 200 && q.threshold().1 < 0.05);
}

/// Runs QUEST+ of `s` to its end with `observer`, each answer through the
/// answer-source interface as the runner gives it; the estimate and the
/// presentations.
fn run(s: &protocol::Quest, observer: &mut Observer) -> (f64, usize) {
    let mut q = Quest::new(s, 0);
    while !q.finished() {
        let a = observer.poll(&q.asked()).unwrap().unwrap();
        q.respond(&a);
    }
    (q.threshold().0, q.answers())
}

/// Mean and SD of the estimates over `seeds` runs, and the mean
/// presentations.
pub(crate) fn estimates(s: &protocol::Quest, f: Psychometric, seeds: u64) -> (f64, f64, f64) {
    let runs: Vec<(f64, usize)> = (0..seeds)
        .map(|seed| run(s, &mut Observer::new(f, seed)))
        .collect();
    let n = runs.len() as f64;
    let mean = runs.iter().map(|r| r.0).sum::<f64>() / n;
    let sd = (runs.iter().map(|r| (r.0 - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let presented = runs.iter().map(|r| r.1 as f64).sum::<f64>() / n;
    (mean, sd, presented)
}

#[test]
fn over_200_seeds_quest_plus_centres_on_the_observers_threshold() {
    // The staircase's observer (logistic, slope 12, 2 % lapses) but with
    // its threshold off the grid's centre (0.35: the uniform prior's mean
    // and first level are 0.5), on a grid of 0.02 from 0 to 1; QUEST+
    // weighs thresholds at the grid's places, the true slope or slopes of
    // 6, 12 and 24, and 40 or 20 presentations.
    let (f, _) =
        Psychometric::parse("logistic:threshold=0.35,slope=12,guess=0,lapse=0.02").unwrap();
    // The SD bounds are about 1.4 times what it reaches: QUEST+ held at
    // its first level instead (no entropy step) spreads twice as wide.
    let cases = [
        (&[12.0][..], 40, 0.035),
        (&[6.0, 12.0, 24.0][..], 40, 0.045),
        (&[6.0, 12.0, 24.0][..], 20, 0.065),
    ];
    for (slopes, n, most) in cases {
        let s = spec(51, slopes, n, None);
        let (mean, sd, presented) = estimates(&s, f, 200);
        eprintln!(
            "slopes {slopes:?}, {n} presentations: mean {mean:.4}, sd {sd:.4} ({presented} presented)"
        );
        // The standard error of the mean is sd/√200 (under 0.005 here):
        // the centre is within 0.015 of 0.35, where the prior's mean (0.5)
        // and the observer's 70.7 % point (0.429) are far outside.
        assert!((mean - 0.35).abs() < 0.015, "mean {mean:.4} (sd {sd:.4})");
        assert!(sd > 0.0 && sd < most, "sd {sd}");
    }
}
