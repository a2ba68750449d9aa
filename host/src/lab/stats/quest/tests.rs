use super::*;

/// Levels 0 and 1; thresholds 0.5, 1 and 1.5; a logistic of slope 2 ln 9
/// without guesses or lapses, so that at level 1 the three functions say
/// "perceived" with 0.9, 0.5 and 0.1 (e^(-ln 9 · 2 · 0.5) = 1/9), and at
/// level 0 with 0.1, 1/82 and 1/730.
fn table() -> Arc<Table> {
    Arc::new(Table::new(
        &[0.0, 1.0],
        Model {
            shape: Shape::Logistic,
            guess: 0.0,
            thresholds: vec![0.5, 1.0, 1.5],
            slopes: vec![2.0 * 9f64.ln()],
            lapses: vec![0.0],
        },
    ))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

#[test]
fn a_two_level_three_threshold_example_as_computed_by_hand() {
    let t = table();
    let want = [[0.1, 1.0 / 82.0, 1.0 / 730.0], [0.9, 0.5, 0.1]];
    for (i, row) in want.iter().enumerate() {
        for (j, &p) in row.iter().enumerate() {
            assert!(close(t.p_yes(i, j), p), "level {i}, threshold {j}");
        }
    }
    let mut q = Posterior::uniform(t);
    // Level 1: "yes" with probability (0.9 + 0.5 + 0.1) / 3 = ½ and then
    // the posterior 0.6, 1/3, 1/15; "no" the mirror image: both leave
    // H = -(0.6 ln 0.6 + ⅓ ln ⅓ + 1/15 ln 1/15) = 0.853236.
    let h1 = -(0.6 * 0.6f64.ln()
        + (1.0f64 / 3.0) * (1.0f64 / 3.0).ln()
        + (1.0 / 15.0) * (1.0f64 / 15.0).ln());
    assert!(
        close(q.expected_entropy(1), h1),
        "{}",
        q.expected_entropy(1)
    );
    assert!((h1 - 0.853_236).abs() < 1e-6);
    // Level 0: "yes" (p = 0.037855) would say much, but "no" is likely
    // and leaves nearly the prior: 1.071328, against ln 3 = 1.098612
    // before.
    assert!((q.expected_entropy(0) - 1.071_328).abs() < 1e-6);
    assert_eq!(q.best(), 1);
    q.update(1, true);
    for (w, want) in q.weights().iter().zip([0.6, 1.0 / 3.0, 1.0 / 15.0]) {
        assert!(close(*w, want), "{:?}", q.weights());
    }
    // Mean 0.6·0.5 + ⅓·1 + 1/15·1.5 = 0.7333; SD √(0.6·0.25 + ⅓ + 1/15·2.25 - 0.7333²).
    let (mean, sd) = q.threshold();
    assert!(close(mean, 0.3 + 1.0 / 3.0 + 0.1));
    assert!(close(sd, (0.15 + 1.0 / 3.0 + 0.15 - mean * mean).sqrt()));
    assert!((sd - 0.309_121).abs() < 1e-6);
    // Then "no" at level 0: weights × (0.9, 81/82, 729/730), normalised.
    q.update(0, false);
    let u = [
        0.6 * 0.9,
        (1.0 / 3.0) * 81.0 / 82.0,
        (1.0 / 15.0) * 729.0 / 730.0,
    ];
    let s: f64 = u.iter().sum();
    for (w, u) in q.weights().iter().zip(u) {
        assert!(close(*w, u / s), "{:?}", q.weights());
    }
}

#[test]
fn the_posterior_stays_normalised_through_answers_the_model_calls_impossible() {
    // A Weibull without guesses says a level of 0 is never perceived.
    let t = Arc::new(Table::new(
        &[0.0, 0.5, 1.0],
        Model {
            shape: Shape::Weibull,
            guess: 0.0,
            thresholds: vec![0.25, 0.5, 0.75],
            slopes: vec![3.0, 6.0],
            lapses: vec![0.0, 0.02],
        },
    ));
    assert_eq!(t.model().params(), 12);
    assert_eq!(t.model().param(7), (0.5, 6.0, 0.02));
    assert_eq!(t.model().param(9), (0.75, 3.0, 0.02));
    let mut q = Posterior::uniform(t);
    for _ in 0..2000 {
        q.update(0, true);
        q.update(2, false);
    }
    let sum: f64 = q.weights().iter().sum();
    assert!((sum - 1.0).abs() < 1e-9 && q.weights().iter().all(|w| w.is_finite()));
    let (m, sd) = q.threshold();
    assert!(m.is_finite() && sd.is_finite());
    assert!(q.best() < 3);
}

#[test]
fn the_threshold_estimate_sharpens_around_a_consistent_observer() {
    // Answers from a noiseless observer at 0.42: perceived at or above.
    let values: Vec<f64> = (0..=20).map(|i| i as f64 / 20.0).collect();
    let t = Arc::new(Table::new(
        &values,
        Model {
            shape: Shape::Logistic,
            guess: 0.0,
            thresholds: (0..=100).map(|i| i as f64 / 100.0).collect(),
            slopes: vec![20.0],
            lapses: vec![0.02],
        },
    ));
    let mut q = Posterior::uniform(t);
    let sd0 = q.threshold().1;
    for _ in 0..30 {
        let i = q.best();
        q.update(i, values[i] >= 0.42);
    }
    let (m, sd) = q.threshold();
    assert!((m - 0.42).abs() < 0.05, "{m}");
    assert!(sd < sd0 / 3.0, "{sd} from {sd0}");
}
