//! What the tests, examples, benchmarks and fuzz targets of this repository share:
//!
//! - where the real meshes are, and what a test does when something it needs is missing
//!   (under CI it fails; elsewhere it prints a notice and skips);
//! - [`seeds`]: every seeded test's seeds (`SVO_TEST_SEED` moves them all) and a seeded
//!   generator; [`geometry`]: seeded random geometry on an integer lattice;
//! - the references the library is held to, sharing no code with it: [`exact_sat`] (an
//!   integer separating-axis test), [`oracle`] (the cells any `f64` triangle touches, in
//!   exact arithmetic), [`ray_reference`] and [`ray_check`] (the leaves a ray enters, in
//!   rationals, and the margin the tracer's `f32` arithmetic allows), [`spec_reader`] (a
//!   `.svo` reader written from `docs/format.md` alone) and [`conformance`] (the format's
//!   conformance corpus, encoded from the document);
//! - [`fuzz_cases`]: what the fuzz targets check, as functions the tests also run.
//!
//! The end-to-end tests themselves are in `tests/it/`.

pub mod conformance;
pub mod exact_sat;
pub mod fuzz_cases;
pub mod geometry;
pub mod oracle;
pub mod ray_check;
pub mod ray_reference;
pub mod seeds;
pub mod spec_reader;

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

/// The thesis's pool scene file (`examples/scenes/pool.toml`) if the bunny it names by a
/// path relative to itself (`../shared/models` beside the repository, whatever
/// `$SVO_MODELS` says) is there; otherwise [`missing`] (a panic under CI) and `None`.
pub fn pool_scene() -> Option<PathBuf> {
    let root = repo_root();
    let bunny = root.join("../shared/models/stanford/bun_zipper.ply");
    if bunny.exists() {
        Some(root.join("examples/scenes/pool.toml"))
    } else {
        missing(&format!(
            "{}, which examples/scenes/pool.toml reads (clone the repository beside shared/)",
            bunny.display()
        ));
        None
    }
}
