//! `lmhost bench`: the bench report (timings and accuracy per subsystem).

use lmhost::lab::bench::{self, Options};

/// Time and check the numeric paths; print the bench report.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print JSON: `{"sections": [{"name", "data"}, ...]}`.
    #[arg(long)]
    pub json: bool,
    /// Fewer repetitions (rougher timings, same accuracy checks).
    #[arg(long)]
    pub quick: bool,
    /// Only these sections (repeatable, each once), e.g. `--section planner`.
    #[arg(long, value_name = "NAME")]
    pub section: Vec<String>,
}

impl Args {
    /// Runs the report.
    pub fn run(self) -> anyhow::Result<()> {
        let sections = bench::run(&Options { quick: self.quick }, &self.section)?;
        if self.json {
            lmhost::outln!(
                "{}",
                serde_json::to_string(&serde_json::json!({ "sections": sections }))?
            )?;
        } else {
            for s in &sections {
                lmhost::out!("{}", s.text)?;
            }
        }
        Ok(())
    }
}
