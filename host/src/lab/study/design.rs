//! The trial order, by the protocol's `order`: each set a fresh seeded
//! permutation of every condition (`random`, the default), every set in
//! the file's order (`sequential`), all sets' trials shuffled together
//! (`full-random`), or each set in the participant's row of a balanced
//! Latin square (`latin-square`, by the participant's index); and each
//! shuffled question's order per trial, all from one seed.

use serde::{Deserialize, Serialize};

pub use super::protocol::Order;
use super::protocol::{
    MAX_BLOCKS, MAX_CONDITIONS, MAX_OPTIONS, MAX_SETS, MAX_TRIALS, Protocol, Unlinked,
};
use crate::rng::SplitMix64;

/// One planned trial.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Planned {
    /// 1-based trial number.
    #[serde(deserialize_with = "crate::whole::field::<_, _, 1, { MAX_TRIALS as u64 }>")]
    pub trial: usize,
    /// 1-based set (within its block).
    #[serde(deserialize_with = "crate::whole::field::<_, _, 1, { MAX_SETS as u64 }>")]
    pub set: usize,
    /// 1-based block (1 where the protocol has none).
    #[serde(
        default = "first_block",
        deserialize_with = "crate::whole::field::<_, _, 1, { MAX_BLOCKS as u64 }>"
    )]
    pub block: usize,
    /// Whether it is a practice trial (left out of the report).
    #[serde(default)]
    pub practice: bool,
    /// Index into the protocol's conditions.
    #[serde(deserialize_with = "crate::whole::field::<_, _, 0, { MAX_CONDITIONS as u64 - 1 }>")]
    pub condition: usize,
    /// The library entry.
    pub stimulus: String,
    /// Per question (in protocol order): the order its items or options
    /// are shown in (indices; empty when not shuffled or not applicable).
    #[serde(deserialize_with = "crate::whole::rows::<_, _, 0, { MAX_OPTIONS as u64 - 1 }>")]
    pub orders: Vec<Vec<usize>>,
}

fn first_block() -> usize {
    1
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

/// Row `row` (0-based) of the balanced Latin square of `n` conditions
/// (Williams 1949): every condition once in each place over `n` rows and
/// every condition just before every other once; with an odd `n`, the
/// odd rows are reversed and it takes `2n` rows to balance (each twice).
pub fn latin_square_row(n: usize, row: usize) -> Vec<usize> {
    // 0, 1, n-1, 2, n-2, …
    let (mut lo, mut hi) = (0, 0);
    let mut v: Vec<usize> = (0..n)
        .map(|i| {
            let x = if i < 2 || i % 2 == 1 {
                lo += 1;
                lo - 1
            } else {
                hi += 1;
                n - hi
            };
            (x + row) % n
        })
        .collect();
    if n % 2 == 1 && row % 2 == 1 {
        v.reverse();
    }
    v
}

/// Rows a balanced Latin square of `n` conditions needs.
pub fn latin_square_rows(n: usize) -> usize {
    if n % 2 == 1 { 2 * n } else { n }
}

/// The whole session's trials for `seed` (a `latin-square` protocol needs
/// [`plan_for`] and the participant's index).
pub fn plan(p: &Protocol, seed: u64) -> Vec<Planned> {
    plan_for(p, seed, None)
}

/// The whole session's trials for `seed` and the participant's 1-based
/// `index` (which row of the Latin square; `None` reads as 1).
pub fn plan_for(p: &Protocol, seed: u64, index: Option<usize>) -> Vec<Planned> {
    plan_of(p, seed, index)
}

/// Whether the participant's index changes `p`'s trials: a `latin-square`
/// order, of the protocol or (with blocks, which replace it) of a block.
pub fn orders_by_index(p: &Unlinked) -> bool {
    if p.blocks.is_empty() {
        p.order == Order::LatinSquare
    } else {
        p.blocks.iter().any(|b| b.order == Order::LatinSquare)
    }
}

/// [`plan_for`] from the protocol without its library (the report's).
pub fn plan_of(p: &Unlinked, seed: u64, index: Option<usize>) -> Vec<Planned> {
    let (conditions, questions) = (&p.conditions, &p.questions);
    let mut order = SplitMix64::new(seed);
    // A second stream: option orders do not change the condition order.
    let mut options = SplitMix64::new(seed ^ 0x0F71_0A5E_ED00_0005_u64);
    let all: Vec<usize> = (0..conditions.len()).collect();
    // (block, practice, sets, order, its conditions).
    let runs: Vec<(usize, bool, usize, Order, &[usize])> = if p.blocks.is_empty() {
        vec![(1, false, p.sets, p.order, &all)]
    } else {
        p.blocks
            .iter()
            .enumerate()
            .map(|(i, b)| (i + 1, b.practice, b.sets, b.order, b.conditions.as_slice()))
            .collect()
    };
    // (block, practice, set, condition), in the order run.
    let mut sequence: Vec<(usize, bool, usize, usize)> = Vec::new();
    for (block, practice, sets, how, these) in runs {
        let n = these.len();
        let mut run: Vec<(usize, bool, usize, usize)> = Vec::with_capacity(sets.saturating_mul(n));
        for set in 1..=sets {
            let within = match how {
                Order::Random => permutation(&mut order, n),
                Order::Sequential | Order::FullRandom => (0..n).collect(),
                Order::LatinSquare => {
                    let row = index.unwrap_or(1).saturating_sub(1) % latin_square_rows(n);
                    latin_square_row(n, row)
                }
            };
            run.extend(within.into_iter().map(|c| (block, practice, set, these[c])));
        }
        if how == Order::FullRandom {
            let p = permutation(&mut order, run.len());
            run = p.into_iter().map(|i| run[i]).collect();
        }
        sequence.extend(run);
    }
    let mut out = Vec::with_capacity(sequence.len());
    for (block, practice, set, c) in sequence {
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
            block,
            practice,
            condition: c,
            stimulus: conditions[c].stimulus.clone(),
            orders,
        });
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

    /// Each place holds every condition equally often, and every ordered
    /// pair of different conditions is adjacent equally often, over the
    /// square's rows.
    fn balanced(rows: &[Vec<usize>], n: usize) -> bool {
        let k = rows.len() / n;
        let mut place = vec![vec![0; n]; n];
        let mut next = vec![vec![0; n]; n];
        for r in rows {
            for (i, &c) in r.iter().enumerate() {
                place[i][c] += 1;
            }
            for w in r.windows(2) {
                next[w[0]][w[1]] += 1;
            }
        }
        place.iter().flatten().all(|&x| x == k)
            && (0..n).all(|a| (0..n).all(|b| a == b || next[a][b] == k))
    }

    #[test]
    fn latin_square_rows_are_balanced_for_even_and_odd_counts() {
        for n in 2..=12 {
            let rows: Vec<Vec<usize>> = (0..latin_square_rows(n))
                .map(|r| latin_square_row(n, r))
                .collect();
            assert_eq!(rows.len(), if n % 2 == 0 { n } else { 2 * n });
            assert!(balanced(&rows, n), "n = {n}: {rows:?}");
        }
        // The first n rows of an odd square alone are not balanced: the
        // reversed rows are needed.
        let odd: Vec<Vec<usize>> = (0..5).map(|r| latin_square_row(5, r)).collect();
        assert!(!balanced(&odd, 5));
        assert_eq!(latin_square_row(4, 0), [0, 1, 3, 2]);
    }

    #[test]
    fn each_order_plans_as_named() {
        let mut p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
        let conditions = |v: &[Planned]| v.iter().map(|t| t.condition).collect::<Vec<_>>();
        p.order = Order::Sequential;
        let s = plan(&p, 3);
        assert_eq!(conditions(&s), (0..15).chain(0..15).collect::<Vec<_>>());
        p.order = Order::LatinSquare;
        let a = plan_for(&p, 3, Some(2));
        let row = latin_square_row(15, 1);
        assert_eq!(conditions(&a[..15]), row);
        assert_eq!(conditions(&a[15..]), row);
        // Participant 32 gets row 1 again (30 rows for 15 conditions).
        assert_eq!(conditions(&plan_for(&p, 9, Some(32))), conditions(&a));
        p.order = Order::FullRandom;
        let f = plan(&p, 3);
        let mut c = conditions(&f);
        // The sets mix: some condition comes twice in the first half.
        let first: std::collections::BTreeSet<usize> = c[..15].iter().copied().collect();
        assert!(first.len() < 15, "{c:?}");
        c.sort_unstable();
        assert_eq!(c, (0..15).flat_map(|i| [i, i]).collect::<Vec<_>>());
        assert!(f.iter().enumerate().all(|(i, t)| t.trial == i + 1));
        // Random stays as it was: a permutation per set, whether planned
        // with the library or from the protocol alone (as the report does).
        p.order = Order::Random;
        assert_eq!(plan(&p, 7), plan_of(&p.checked, 7, None));
    }

    #[test]
    fn only_a_latin_square_is_ordered_by_the_participants_index() {
        let mut p = Protocol::load(&studies("paper-exp1.toml")).unwrap();
        for (order, by_index) in [
            (Order::LatinSquare, true),
            (Order::Random, false),
            (Order::Sequential, false),
            (Order::FullRandom, false),
        ] {
            p.order = order;
            assert_eq!(orders_by_index(&p.checked), by_index, "{order:?}");
            // Where it is not, the index changes no trial.
            if !by_index {
                assert_eq!(plan_for(&p, 5, Some(3)), plan_for(&p, 5, None));
            }
        }
    }
}
