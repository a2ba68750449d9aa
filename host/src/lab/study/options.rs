//! What `lmhost study run` is asked to do and what a run did: the
//! options the CLI fills (finger, answers, instruments) and the report it
//! prints.

use std::path::PathBuf;

use crate::device::link::PortSpec;
use crate::error::InputError;

/// Where the finger comes from.
pub enum FingerSource {
    /// None: the protocol may not wait for the finger.
    None,
    /// A finger at the scene's centre that touches for each trial and
    /// leaves between trials.
    Synthetic,
    /// Tracked centroids (a file, stdin, UDP: `lmhost track --json`'s
    /// lines) through a filter; the finger is present when they say so.
    Samples {
        /// The reader thread.
        feed: crate::sense::stream::run::Threaded,
        /// The plausibility gate its samples pass before the filter
        /// (boxed: the other sources carry nothing).
        intake: Box<crate::sense::stream::intake::Intake>,
        /// The centroid filter.
        filter: Box<dyn crate::sense::stream::filter::Filter + Send>,
        /// What it is, for `session.json`.
        name: String,
    },
}

impl FingerSource {
    fn name(&self) -> String {
        match self {
            Self::None => "none".into(),
            Self::Synthetic => "synthetic".into(),
            Self::Samples { name, .. } => name.clone(),
        }
    }
}

impl std::fmt::Debug for FingerSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// Where answers come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AnswerSource {
    /// A file of one answer per line in the order asked (`-`: stdin).
    File(PathBuf),
    /// The terminal (single keys) when stdin is one, else stdin's lines as
    /// they arrive.
    Interactive,
    /// A simulated observer ([`super::observer::Observer::parse`]'s text):
    /// answers a procedure's "perceived?" questions only.
    Observer(String),
}

/// What `lmhost study run` was asked to do.
#[derive(Debug)]
pub struct RunOptions {
    /// The protocol file.
    pub protocol: PathBuf,
    /// The device.
    pub port: PortSpec,
    /// The scene file (default: the built-in scene).
    pub scene: Option<PathBuf>,
    /// The participant's id (a folder name).
    pub participant: String,
    /// The study's output folder.
    pub out: PathBuf,
    /// The order's seed (default: from the clock; recorded).
    pub seed: Option<u64>,
    /// The participant's 1-based index (a Latin square's row; recorded).
    pub index: Option<usize>,
    /// Answers.
    pub answers: AnswerSource,
    /// The finger.
    pub finger: FingerSource,
    /// Multiplies every duration.
    pub time_scale: f64,
    /// Continue an interrupted run.
    pub resume: bool,
    /// Continue it on a rig that differs from the last run's (recorded).
    pub resume_anyway: bool,
    /// Serve the live view here (its participant's page answers unless
    /// answers come from a file).
    pub view: Option<std::net::SocketAddr>,
    /// Experiment 3's stage and gauge (`--stage`, `--gauge`), pushing in
    /// step with the on-phases.
    pub instruments: Option<super::push::PushOptions>,
    /// What a program that runs the study in process takes part in (the
    /// Python package's `lmhost.Study`); the CLI leaves it empty.
    pub hooks: Hooks,
}

/// A finished trial's row: `(column, value)` in `trials.csv`'s header
/// order, as written.
pub type RowFields = Vec<(String, String)>;

/// A program's part in a run: its own answers, and each row as it is
/// written.
#[derive(Default)]
pub struct Hooks {
    /// Answers every question in place of [`RunOptions::answers`] (which
    /// must then be [`AnswerSource::Interactive`]).
    pub answers: Option<Box<dyn super::answers::Answers + Send>>,
    /// Called with each trial's row once it is on disk (synced), before
    /// the next trial starts.
    pub rows: Option<Box<dyn FnMut(RowFields) + Send>>,
}

impl std::fmt::Debug for Hooks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Hooks")
            .field("answers", &self.answers.is_some())
            .field("rows", &self.rows.is_some())
            .finish()
    }
}

/// What a run did.
#[derive(Debug, Clone, Default)]
pub struct RunReport {
    /// The participant's folder.
    pub dir: PathBuf,
    /// Trials in the session.
    pub trials: usize,
    /// The first trial this run presented (1-based).
    pub first: usize,
    /// Trials this run finished.
    pub ran: usize,
    /// The seed.
    pub seed: u64,
    /// Seconds each trial took from its start to its row on disk.
    pub trial_s: Vec<f64>,
    /// Host-timed on-time per trial, s.
    pub presented_s: Vec<f64>,
    /// Switch latencies seen, ms.
    pub switch_ms: Vec<f64>,
    /// Uploads during the run (`preloaded` events) and their mean time, s.
    pub uploads: usize,
    /// Mean upload time, s.
    pub upload_mean_s: f64,
}

/// A participant id: 1 to 64 letters, digits, `-`, `_`, `.` (not only dots).
pub fn check_participant(id: &str) -> Result<(), InputError> {
    if id.is_empty()
        || id.len() > 64
        || id.chars().all(|c| c == '.')
        || !id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(InputError::new(format!(
            "--participant `{}`: give 1 to 64 letters, digits, `-`, `_` or `.` (it names a folder)",
            id.escape_debug()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn participant_ids_name_a_folder() {
        for ok in ["P01", "s-3_a.b"] {
            assert!(check_participant(ok).is_ok());
        }
        for bad in ["", "..", "a/b", "a b", &"x".repeat(65)] {
            assert!(check_participant(bad).is_err(), "{bad}");
        }
    }
}
