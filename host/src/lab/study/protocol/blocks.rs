//! A protocol's blocks (`[[block]]`): runs of trials one after another,
//! each over its own set of conditions (a subset of the factors' levels),
//! with its own sets and order; a practice block's rows are written (with
//! `practice = 1`) and left out of `study report`; a block may end with a
//! break, the array silent. A protocol without blocks is one block of
//! every condition, its `sets` and `order`.

use toml::Spanned;

use super::errors::Errors;
use super::file::{BlockFile, Label};
use super::{Condition, Factor, MAX_TRIALS, Order};
use crate::error::InputError;

/// Most blocks in a protocol.
pub const MAX_BLOCKS: usize = 32;

/// One block of trials.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// Its name (the `block` column).
    pub name: String,
    /// Practice: its rows say so and the report leaves them out.
    pub practice: bool,
    /// Sets: each every one of its conditions once.
    pub sets: usize,
    /// How its conditions are ordered within a set.
    pub order: Order,
    /// Its conditions: indices into the protocol's, in protocol order.
    pub conditions: Vec<usize>,
    /// Seconds of silence after it, before the next block (0: none).
    pub break_s: f64,
    /// Shown to the participant as it starts.
    pub text: Option<String>,
}

impl Block {
    /// Trials in the block.
    pub fn trials(&self) -> usize {
        self.conditions.len() * self.sets
    }
}

/// Checks the `[[block]]` tables against the factors and conditions
/// (`sets` and `order`: the protocol's, a block's defaults).
pub(super) fn check(
    blocks: Vec<Spanned<BlockFile>>,
    factors: &[Factor],
    conditions: &[Condition],
    sets: usize,
    order: Order,
    e: &Errors,
) -> Result<Vec<Block>, InputError> {
    if blocks.len() > MAX_BLOCKS {
        return Err(e.bad(format!("{} blocks; at most {MAX_BLOCKS}", blocks.len())));
    }
    let mut out: Vec<Block> = Vec::with_capacity(blocks.len());
    for b in blocks {
        let span = b.span();
        let b = b.into_inner();
        let name = e.unique("block", &b.name, out.iter().map(|x| x.name.as_str()))?;
        // Per factor, the levels the block keeps (all when not named).
        let mut keep: Vec<Option<Vec<String>>> = vec![None; factors.len()];
        for (factor, levels) in &b.levels {
            let Some(k) = factors.iter().position(|f| &f.name == factor) else {
                return Err(e.at(
                    levels.span(),
                    factor,
                    format!(
                        "block `{name}`: `{}` is not a factor (factors: {})",
                        factor.escape_debug(),
                        crate::error::some_of(factors.iter().map(|f| f.name.as_str()), ", ")
                    ),
                ));
            };
            let given: Vec<String> = levels
                .get_ref()
                .iter()
                .map(|l: &Label| l.0.clone())
                .collect();
            if given.is_empty() {
                return Err(e.at(
                    levels.span(),
                    factor,
                    format!("block `{name}`: give at least one level of `{factor}`"),
                ));
            }
            if let Some(l) = given.iter().find(|l| !factors[k].levels.contains(l)) {
                return Err(e.at(
                    levels.span(),
                    factor,
                    format!(
                        "block `{name}`: `{l}` is not a level of `{factor}` ({})",
                        crate::error::some_of(&factors[k].levels, ", ")
                    ),
                ));
            }
            keep[k] = Some(given);
        }
        let conditions: Vec<usize> = conditions
            .iter()
            .enumerate()
            .filter(|(_, c)| {
                c.levels
                    .iter()
                    .zip(&keep)
                    .all(|(l, k)| k.as_ref().is_none_or(|k| k.contains(l)))
            })
            .map(|(i, _)| i)
            .collect();
        out.push(Block {
            name,
            practice: b.practice,
            sets: b.sets.map_or(sets, |s| s.0),
            order: b.order.map_or(order, Order::from),
            conditions,
            break_s: b.break_s.0,
            text: b.text.map(|t| t.0),
        });
        let total: usize = out.iter().map(Block::trials).sum();
        if total > MAX_TRIALS {
            return Err(e.at(
                span,
                "block",
                format!("the blocks make {total} trials; at most {MAX_TRIALS} fit one session"),
            ));
        }
    }
    if !out.is_empty() && out.iter().all(|b| b.practice) {
        return Err(
            e.bad("every block is a practice block: the report would have nothing to report")
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::Unlinked;
    use crate::lab::study::design;
    use crate::lab::study::test_files::studies;

    const BLOCKS: &str = r#"
[[block]]
name = "practice"
practice = true
sets = 1
order = "sequential"
levels = { radius = ["3"] }
break_s = 20
text = "Three practice trials first."

[[block]]
name = "main"
"#;

    /// Experiment 1 (types lms-5hz, lmm-5hz, lms-25hz; radii 2 to 6; two
    /// sets in random order) and `extra`.
    fn parse(extra: &str) -> Result<Unlinked, String> {
        let base = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
        Unlinked::from_toml(&format!("{base}{extra}"), "blocks.toml").map_err(|e| e.to_string())
    }

    fn plan(u: &Unlinked, seed: u64) -> Vec<design::Planned> {
        design::plan_of(u, seed, None)
    }

    #[test]
    fn blocks_run_in_turn_each_over_its_conditions_sets_and_order() {
        let u = parse(BLOCKS).unwrap();
        assert_eq!(u.blocks.len(), 2);
        let (practice, main) = (&u.blocks[0], &u.blocks[1]);
        // Radius 3 of each type.
        assert_eq!(practice.conditions, [1, 6, 11]);
        assert_eq!((practice.sets, practice.break_s), (1, 20.0));
        assert!(practice.practice && !main.practice);
        // The main block takes the protocol's sets, order and every condition.
        assert_eq!((main.sets, main.conditions.len()), (2, 15));
        assert_eq!(main.order, super::Order::Random);
        let names = u.columns.names();
        assert_eq!(
            names[..6],
            [
                "participant",
                "trial",
                "set",
                "block",
                "practice",
                "stimulus"
            ]
        );
        for seed in [1, 2, 3] {
            let p = plan(&u, seed);
            assert_eq!(p.len(), 3 + 30);
            assert!(p.iter().enumerate().all(|(i, t)| t.trial == i + 1));
            // Practice first, in the file's order, then the main block.
            let first: Vec<(usize, bool, usize)> = p[..3]
                .iter()
                .map(|t| (t.block, t.practice, t.condition))
                .collect();
            assert_eq!(first, [(1, true, 1), (1, true, 6), (1, true, 11)]);
            for set in 1..=2 {
                let mut c: Vec<usize> = p[3..]
                    .iter()
                    .filter(|t| t.set == set)
                    .map(|t| t.condition)
                    .collect();
                assert!(p[3..].iter().all(|t| t.block == 2 && !t.practice));
                c.sort_unstable();
                assert_eq!(c, (0..15).collect::<Vec<_>>());
            }
        }
        // The seed still decides the main block's order.
        let order = |s| plan(&u, s).iter().map(|t| t.condition).collect::<Vec<_>>();
        assert_ne!(order(1), order(2));
        // Without blocks the plan is what it always was.
        let plain = parse("").unwrap();
        assert!(plain.blocks.is_empty());
        assert!(plan(&plain, 5).iter().all(|t| t.block == 1 && !t.practice));
        assert!(!plain.columns.names().contains(&"block"));
    }

    #[test]
    fn bad_blocks_are_one_line_errors() {
        for (extra, needle) in [
            (
                "[[block]]\nname = \"a\"\nlevels = { colour = [\"red\"] }\n",
                "`colour` is not a factor (factors: type, radius)",
            ),
            (
                "[[block]]\nname = \"a\"\nlevels = { radius = [\"7\"] }\n",
                "`7` is not a level of `radius` (2, 3, 4, 5, 6)",
            ),
            (
                "[[block]]\nname = \"a\"\nlevels = { radius = [] }\n",
                "give at least one level of `radius`",
            ),
            (
                "[[block]]\nname = \"a\"\n[[block]]\nname = \"a\"\n",
                "block `a` is given twice",
            ),
            (
                "[[block]]\nname = \"a\"\npractice = true\n",
                "every block is a practice block",
            ),
            ("[[block]]\nname = \"a\"\nbreak_s = -1\n", "break_s"),
            ("[[block]]\nname = \"a\"\nsets = 0\n", "sets"),
            (
                "[[block]]\nname = \"a\"\nrepeat = 2\n",
                "unknown field `repeat`",
            ),
            (
                "[[block]]\nname = \"a\"\nsets = 100\n[[block]]\nname = \"b\"\nsets = 100\n[[block]]\nname = \"c\"\nsets = 100\n[[block]]\nname = \"d\"\nsets = 100\n[[block]]\nname = \"e\"\nsets = 100\n[[block]]\nname = \"f\"\nsets = 100\n[[block]]\nname = \"g\"\nsets = 100\n[[block]]\nname = \"h\"\nsets = 100\n[[block]]\nname = \"i\"\nsets = 100\n[[block]]\nname = \"j\"\nsets = 100\n[[block]]\nname = \"k\"\nsets = 100\n[[block]]\nname = \"l\"\nsets = 100\n[[block]]\nname = \"m\"\nsets = 100\n[[block]]\nname = \"n\"\nsets = 100\n[[block]]\nname = \"o\"\nsets = 100\n[[block]]\nname = \"p\"\nsets = 100\n[[block]]\nname = \"q\"\nsets = 100\n",
                "at most 10000 fit one session",
            ),
        ] {
            let e = parse(extra).expect_err(extra);
            assert!(e.contains(needle), "{extra}: {e}");
            assert!(e.starts_with("study protocol blocks.toml"), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
