//! The trial order: each set a fresh seeded permutation of every condition,
//! and each shuffled question's order per trial, all from one seed.

use serde::{Deserialize, Serialize};

use super::protocol::Protocol;
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
    let mut order = SplitMix64::new(seed);
    // A second stream: option orders do not change the condition order.
    let mut options = SplitMix64::new(seed ^ 0x0F71_0A5E_ED00_0005_u64);
    let mut out = Vec::with_capacity(p.trials());
    for set in 1..=p.sets {
        for c in permutation(&mut order, p.conditions.len()) {
            let orders = p
                .questions
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
                stimulus: p.conditions[c].stimulus.clone(),
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
