//! What the tests, examples and benchmarks of this repository share: where the real meshes
//! are, and what a test does when something it needs is missing (under CI it fails; elsewhere
//! it prints a notice and skips). The end-to-end tests themselves are in `tests/`.

use std::path::{Path, PathBuf};

/// The repository's root folder.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// The folder of the shared real meshes (the Stanford bunny and dragon, glTF samples):
/// `$SVO_MODELS` when set, else `../shared/models` beside the repository.
pub fn models_dir() -> PathBuf {
    match std::env::var_os("SVO_MODELS") {
        Some(d) if !d.is_empty() => PathBuf::from(d),
        _ => repo_root().join("../shared/models"),
    }
}

/// Whether this run is CI's, where nothing may be skipped: `CI` set to anything but empty,
/// `0` or `false`.
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim(), "" | "0" | "false"))
}

/// Reports that `what` is missing: a panic under CI, else a notice on stderr (the caller
/// then skips).
pub fn missing(what: &str) {
    assert!(!under_ci(), "CI needs {what}");
    eprintln!("skipped: {what} is missing");
}

/// The path of a shared mesh, `rel` inside [`models_dir`], if it exists; otherwise
/// [`missing`] (a panic under CI) and `None`.
pub fn model(rel: &str) -> Option<PathBuf> {
    let p = models_dir().join(rel);
    if p.exists() {
        Some(p)
    } else {
        missing(&format!(
            "the shared mesh {} (set SVO_MODELS to the models folder)",
            p.display()
        ));
        None
    }
}
