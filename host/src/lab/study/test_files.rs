//! Files the study's tests share.

use std::path::{Path, PathBuf};

/// A protocol of `studies/`.
pub(crate) fn studies(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../studies")
        .join(name)
}

/// Experiment 1 (`paper-exp1.toml`) with its first question only,
/// `vibration`: the one the report's tests and figures are checked on.
pub(crate) fn exp1_vibration() -> String {
    let text = std::fs::read_to_string(studies("paper-exp1.toml")).unwrap();
    let (head, rest) = text
        .split_once("\n[[question]]\nid = \"movement\"")
        .unwrap();
    let report = rest.find("\n[report]").unwrap();
    format!("{head}{}", &rest[report..])
}

/// A fresh scratch folder.
pub(crate) fn scratch(name: &str) -> crate::files::Scratch {
    crate::files::scratch(&format!("study-{name}"))
}
