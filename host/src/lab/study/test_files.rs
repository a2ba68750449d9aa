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
    let d = std::env::temp_dir().join(format!("lmhost-study-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
