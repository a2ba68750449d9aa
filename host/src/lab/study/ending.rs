//! How a study run that stopped early says so: what happened, that the
//! array is silent, what is kept and how to continue (a run stopped in its
//! set-up changed no file).

use std::path::Path;

use super::{RunOptions, RunReport};
use crate::error::InputError;

/// How to continue `o`'s run.
pub(super) fn resume_hint(o: &RunOptions) -> String {
    format!(
        "lmhost study run {} --participant {} --out {} --resume (and the same --port, --finger, --responses, --stage and --gauge)",
        o.protocol.display(),
        o.participant,
        o.out.display()
    )
}

/// The error of a run stopped during its set-up (before any of its files
/// changed): what it was doing, `then` (what holds of the device), and
/// what is kept.
pub(super) fn set_up_stopped(
    e: &crate::stop::SetUpInterrupted,
    o: &RunOptions,
    then: &str,
) -> anyhow::Error {
    let kept = if o.resume {
        format!("no file changed; continue with: {}", resume_hint(o))
    } else {
        "nothing was written; run it again (without --resume)".to_owned()
    };
    anyhow::anyhow!("{e}; {then}; {kept}")
}

/// The error of a run that stopped early (`interrupted`: by a stop, else
/// by `e`): what happened, that the array is silent, what is kept and how
/// to continue.
pub(super) fn stopped(
    e: anyhow::Error,
    interrupted: bool,
    o: &RunOptions,
    report: &RunReport,
    trials: &Path,
) -> anyhow::Error {
    let done = report.first - 1 + report.ran;
    let what = if interrupted {
        crate::stop::interrupted()
    } else {
        crate::error::one_line(&e)
    };
    let kept = if done == 0 {
        "no trial is finished".to_owned()
    } else {
        format!(
            "trials 1..={done} of {} are in {}",
            report.trials,
            trials.display()
        )
    };
    let msg = format!(
        "{what}; the array is silent; {kept}; continue with: {}",
        resume_hint(o)
    );
    if e.chain().any(|c| c.is::<InputError>()) {
        InputError::new(msg).into()
    } else {
        anyhow::anyhow!(msg)
    }
}
