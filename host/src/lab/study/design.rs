//! The trial order: each set a fresh seeded permutation of every condition,
//! and each shuffled question's order per trial, all from one seed.

use serde::{Deserialize, Serialize};

use super::protocol::{Condition, Protocol, Question};
use crate::rng::SplitMix64;

/// One planned trial.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Planned {
    /// 1-based trial number.
    pub trial: usize,
    /// 1-based set.
    pub set: usize,
    /// Index into the protocol's conditions.
    pub condition: usize,
    /// The library entry.
    pub stimulus: String,
    /// Per question (in protocol order): the order its items or options
    /// are shown in (indices; empty when not shuffled or not applicable).
    pub orders: Vec<Vec<usize>>,
}

/// A uniform random permutation of `0..n` (Fisher–Yates).
pub fn permutation(rng: &mut SplitMix64, n: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        v.swap(i, j);
    }
    v
}

/// The whole session's trials for `seed`.
pub fn plan(p: &Protocol, seed: u64) -> Vec<Planned> {
    plan_of(p.sets, &p.conditions, &p.questions, seed)
}

/// [`plan`] from a protocol's parts (the report has no library).
pub fn plan_of(
    sets: usize,
    conditions: &[Condition],
    questions: &[Question],
    seed: u64,
) -> Vec<Planned> {
    let mut order = SplitMix64::new(seed);
    // A second stream: option orders do not change the condition order.
    let mut options = SplitMix64::new(seed ^ 0x0F71_0A5E_ED00_0005_u64);
    let mut out = Vec::with_capacity(sets.saturating_mul(conditions.len()));
    for set in 1..=sets {
        for c in permutation(&mut order, conditions.len()) {
            let orders = questions
                .iter()
                .map(|q| {
                    if q.shuffle {
                        permutation(&mut options, q.shuffled_len())
                    } else {
                        (0..q.shuffled_len()).collect()
                    }
                })
                .collect();
            out.push(Planned {
                trial: out.len() + 1,
                set,
                condition: c,
                stimulus: conditions[c].stimulus.clone(),
                orders,
            });
        }
    }
    out
}

/// A seed from the clock (recorded, so the order can be replayed).
pub fn clock_seed() -> u64 {
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    // Small enough to type back in.
    (t.as_nanos() as u64 ^ u64::from(std::process::id())) % 1_000_000_000
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::study::test_files::studies;

    #[test]
    fn each_set_is_a_permutation_and_the_seed_fixes_the_order() {
        let p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
        let a = plan(&p, 7);
        assert_eq!(a.len(), 30);
        for set in 1..=2 {
            let mut c: Vec<usize> = a
                .iter()
                .filter(|t| t.set == set)
                .map(|t| t.condition)
                .collect();
            c.sort_unstable();
            assert_eq!(c, (0..15).collect::<Vec<_>>());
        }
        assert!(a.iter().enumerate().all(|(i, t)| t.trial == i + 1));
        for t in &a {
            assert_eq!(t.stimulus, p.conditions[t.condition].stimulus);
            let mut o = t.orders[2].clone();
            o.sort_unstable();
            assert_eq!(o, [0, 1, 2], "the shape items are a permutation");
            assert_eq!(t.orders[0], Vec::<usize>::new());
        }
        assert_eq!(a, plan(&p, 7));
        let b = plan(&p, 8);
        assert_ne!(
            a.iter().map(|t| t.condition).collect::<Vec<_>>(),
            b.iter().map(|t| t.condition).collect::<Vec<_>>()
        );
        // The two sets are drawn independently.
        let sets: Vec<Vec<usize>> = a
            .chunks(15)
            .map(|c| c.iter().map(|t| t.condition).collect())
            .collect();
        assert_ne!(sets[0], sets[1]);
        // Every order of 3 items turns up over many trials.
        let mut seen = std::collections::BTreeSet::new();
        for s in 0..20 {
            for t in plan(&p, s) {
                seen.insert(t.orders[2].clone());
            }
        }
        assert_eq!(seen.len(), 6);
    }
}
