//! Cross-crate tests live in `tests/*.rs` beside this file; this library only hosts shared helpers.

use std::path::PathBuf;

/// The repository root.
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `tests/assets` in the repository (the test asset library), overridable with `KLOUB_SHARED_ASSETS`.
pub fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS").map(PathBuf::from).unwrap_or_else(|| repo_root().join("tests/assets"))
}
