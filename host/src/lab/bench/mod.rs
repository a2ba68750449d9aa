//! The bench report behind `lmhost bench`: a list of sections, each a
//! function that measures something and returns a serialisable struct plus
//! human text. Other subsystems add a section by writing a
//! `fn(&Options) -> anyhow::Result<Section>` in its own file here and one
//! line in [`SECTIONS`].
//!
//! Timings here are wall-clock medians on the current machine, one thread;
//! the criterion benches in `host/benches/` are the careful measurement.
//! Nothing here asserts a timing.

use std::time::Instant;

use serde::Serialize;

mod field;
mod planner;
mod session;
mod track;

pub use field::FieldFigures;
pub use planner::{FrameFigures, PlannerFigures, SequenceFigures, SolverFigures};

/// Report options.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options {
    /// Fewer repetitions (for tests and quick looks).
    pub quick: bool,
}

/// One section of the report.
#[derive(Debug, Clone, Serialize)]
pub struct Section {
    /// Short name (`planner`, `field`, ...).
    pub name: String,
    /// The section's figures.
    pub data: serde_json::Value,
    /// Human-readable lines.
    #[serde(skip)]
    pub text: String,
}

impl Section {
    /// A section from any serialisable figures struct.
    pub fn new(name: &str, data: &impl Serialize, text: String) -> anyhow::Result<Self> {
        Ok(Self {
            name: name.to_string(),
            data: serde_json::to_value(data)?,
            text,
        })
    }
}

/// A section producer.
pub type SectionFn = fn(&Options) -> anyhow::Result<Section>;

/// Every section, in report order: `(name, producer)`.
pub const SECTIONS: &[(&str, SectionFn)] = &[
    ("planner", planner::section),
    ("field", field::section),
    ("track", track::section),
    ("session", session::section),
];

/// Runs the sections named in `only` (all when empty), in report order.
pub fn run(opts: &Options, only: &[String]) -> anyhow::Result<Vec<Section>> {
    crate::limits::each_once("--section", "section", only)?;
    for name in only {
        if !SECTIONS.iter().any(|(n, _)| n == name) {
            let known: Vec<_> = SECTIONS.iter().map(|(n, _)| *n).collect();
            return Err(crate::InputError::new(format!(
                "unknown bench section `{name}`; known: {}",
                known.join(", ")
            ))
            .into());
        }
    }
    SECTIONS
        .iter()
        .filter(|(n, _)| only.is_empty() || only.iter().any(|o| o == n))
        .map(|(_, f)| f(opts))
        .collect()
}

/// Median time per call (s) of `f`, over `batches` batches of `reps` calls.
pub fn time_per_call(batches: usize, reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut t: Vec<f64> = (0..batches.max(1))
        .map(|_| {
            let s = Instant::now();
            for _ in 0..reps.max(1) {
                f();
            }
            s.elapsed().as_secs_f64() / reps.max(1) as f64
        })
        .collect();
    t.sort_by(f64::total_cmp);
    crate::clock::quantile(&t, 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_planner_section_reports_accuracy_and_ratio() {
        let s = run(&Options { quick: true }, &["planner".into()]).unwrap();
        assert_eq!(s.len(), 1);
        let d = &s[0].data;
        for f in d["frames"].as_array().unwrap() {
            assert!(f["max_err_lsb"].as_f64().unwrap() <= 0.51);
            assert!(f["fast_us"].as_f64().unwrap() > 0.0);
        }
        for q in d["sequences"].as_array().unwrap() {
            assert!(q["delta_ratio"].as_f64().unwrap() <= 0.5);
        }
        assert!(s[0].text.contains("frame, 4 foci"));
    }

    #[test]
    fn unknown_section_is_an_input_error() {
        let e = run(&Options { quick: true }, &["nope".into()]).unwrap_err();
        assert!(e.chain().any(|c| c.is::<crate::InputError>()));
    }
}
