//! Files the study's tests share.

use std::path::{Path, PathBuf};

/// A protocol of `studies/`.
pub(crate) fn studies(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../studies")
        .join(name)
}

/// A fresh scratch folder.
pub(crate) fn scratch(name: &str) -> PathBuf {
    crate::files::scratch(&format!("study-{name}"))
}
