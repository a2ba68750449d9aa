//! `lmhost study check`: a protocol checked whole (its library included)
//! and its trial plan in words, without a device: the counts, the
//! procedure, and the order a participant gets (every participant's row
//! of a Latin square, or one participant's trials).

use std::fmt::Write as _;

use super::design::{self, Order};
use super::protocol::Protocol;
use crate::error::InputError;

/// Refuses a participant's number (`study check --participant`) for a
/// protocol with no latin-square order, whose trials it would not change,
/// as `study run --index` is refused.
pub fn check_participant(p: &Protocol, index: Option<usize>) -> Result<(), InputError> {
    match index {
        Some(i) if !design::orders_by_index(p) => Err(InputError::new(format!(
            "--participant {i} picks a row of a latin-square order, and study protocol {} has none: every participant gets the same trials (leave --participant out)",
            p.path.display()
        ))),
        _ => Ok(()),
    }
}

/// The plan of `p` as lines of text: with `index`, participant `index`'s
/// trials (for a random order, those of `seed`); without, for a Latin
/// square, each participant's order until the square repeats.
pub fn outline(p: &Protocol, index: Option<usize>, seed: Option<u64>) -> String {
    let mut s = String::new();
    let n = p.conditions.len();
    let name = |c: usize| p.conditions[c].levels.join("/");
    // Writing to a String cannot fail.
    let _ = writeln!(s, "protocol `{}`: valid", p.name);
    let _ = writeln!(
        s,
        "library: {} ({} entries)",
        p.library_path.display(),
        p.library.entries.len()
    );
    let factors: Vec<String> = p
        .factors
        .iter()
        .map(|f| format!("{} ({})", f.name, f.levels.join(", ")))
        .collect();
    let _ = writeln!(s, "factors: {}", factors.join("; "));
    if p.blocks.is_empty() {
        let _ = writeln!(
            s,
            "conditions: {n}; sets: {}; trials: {}; order: {}",
            p.sets,
            p.trials(),
            p.order.name()
        );
    } else {
        let _ = writeln!(
            s,
            "conditions: {n}; blocks: {}; trials: {}",
            p.blocks.len(),
            p.trials()
        );
    }
    for (i, b) in p.blocks.iter().enumerate() {
        let _ = writeln!(
            s,
            "block {} `{}`{}: {} conditions ({}); sets: {}; trials: {}; order: {}{}",
            i + 1,
            b.name,
            if b.practice {
                " (practice: in trials.csv, not in the report)"
            } else {
                ""
            },
            b.conditions.len(),
            b.conditions
                .iter()
                .map(|&c| name(c))
                .collect::<Vec<_>>()
                .join(" "),
            b.sets,
            b.trials(),
            b.order.name(),
            if b.break_s > 0.0 {
                format!("; then a {} s break", crate::limits::show(b.break_s))
            } else {
                String::new()
            }
        );
    }
    if let Some(a) = &p.adjustment {
        let _ = writeln!(
            s,
            "procedure: method of adjustment from {} mm in {} mm steps, at most {} adjustments",
            a.start_mm, a.step_mm, a.max
        );
    }
    if let Some(c) = &p.staircase {
        let steps: Vec<String> = c.steps.iter().map(u32::to_string).collect();
        let _ = writeln!(
            s,
            "procedure: {}-up/{}-down staircase over {} levels of {} ({} to {}), from {}, steps {} grid places, ending after {} reversals or {} presentations; threshold: mean of the last {} reversals",
            c.up,
            c.down,
            c.grid.values.len(),
            c.grid.unit,
            c.grid.labels[0],
            c.grid.labels[c.grid.labels.len() - 1],
            c.grid.labels[c.grid.start],
            steps.join(", "),
            c.reversals,
            c.grid.trials,
            c.threshold_reversals
        );
    }
    if let Some(q) = &p.quest {
        let m = q.model();
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| crate::limits::show(*x))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            s,
            "procedure: QUEST+ over {} levels of {} ({} to {}), from {} (the prior's best); {} functions weighed: {} thresholds from {} to {}, slopes {}, lapse rates {}, guess rate {}; ending after {} presentations{}; threshold: posterior mean and SD",
            q.grid.values.len(),
            q.grid.unit,
            q.grid.labels[0],
            q.grid.labels[q.grid.labels.len() - 1],
            q.grid.labels[q.grid.start],
            m.shape.name(),
            m.thresholds.len(),
            crate::limits::show(m.thresholds[0]),
            crate::limits::show(m.thresholds[m.thresholds.len() - 1]),
            list(&m.slopes),
            list(&m.lapses),
            crate::limits::show(m.guess),
            q.grid.trials,
            q.stop_sd
                .map(|b| format!(
                    " or once the threshold's posterior SD is below {b} {}",
                    q.grid.unit
                ))
                .unwrap_or_default()
        );
    }
    let questions: Vec<String> = p.questions.iter().map(|q| q.id.clone()).collect();
    let _ = writeln!(
        s,
        "questions after each trial: {}",
        if questions.is_empty() {
            "none".to_owned()
        } else {
            questions.join(", ")
        }
    );
    // Each run of trials: the protocol's, or each block's.
    let all: Vec<usize> = (0..n).collect();
    let runs: Vec<(Option<&str>, Order, &[usize])> = if p.blocks.is_empty() {
        vec![(None, p.order, &all)]
    } else {
        p.blocks
            .iter()
            .map(|b| (Some(b.name.as_str()), b.order, b.conditions.as_slice()))
            .collect()
    };
    let latin = index.is_none() && runs.iter().any(|r| r.1 == Order::LatinSquare);
    let random = seed.is_none()
        && runs
            .iter()
            .any(|r| matches!(r.1, Order::Random | Order::FullRandom));
    if latin {
        for (block, _, these) in runs.iter().filter(|r| r.1 == Order::LatinSquare) {
            let m = these.len();
            let rows = design::latin_square_rows(m);
            let _ = writeln!(
                s,
                "balanced Latin square{}: participant N gets row (N - 1) mod {rows} in every set:",
                block
                    .map(|b| format!(" of block `{b}`"))
                    .unwrap_or_default()
            );
            for r in 0..rows {
                let row: Vec<String> = design::latin_square_row(m, r)
                    .into_iter()
                    .map(|c| name(these[c]))
                    .collect();
                let _ = writeln!(s, "participant {}: {}", r + 1, row.join(" "));
            }
        }
    }
    if random {
        let _ = writeln!(
            s,
            "the order is drawn from the run's seed (recorded): give --seed N to see one"
        );
    }
    if !latin && !random {
        let plan = design::plan_for(p, seed.unwrap_or(0), index);
        let who = match index {
            Some(i) => format!("participant {i}"),
            None => "every participant".into(),
        };
        let _ = writeln!(
            s,
            "trials of {who}{}: trial {}set condition stimulus",
            match seed.filter(|_| {
                runs.iter()
                    .any(|r| matches!(r.1, Order::Random | Order::FullRandom))
            }) {
                Some(x) => format!(" (seed {x})"),
                None => String::new(),
            },
            if p.blocks.is_empty() { "" } else { "block " }
        );
        for t in plan {
            let block = match p.blocks.get(t.block.wrapping_sub(1)) {
                Some(b) => format!("{} ", b.name),
                None => String::new(),
            };
            let _ = writeln!(
                s,
                "{} {block}{} {} {}",
                t.trial,
                t.set,
                name(t.condition),
                t.stimulus
            );
        }
    }
    s
}
