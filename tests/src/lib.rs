//! What the tests, examples, benchmarks and fuzz targets of this repository share:
//!
//! - where the real meshes are, and what a test does when something it needs is missing:
//!   [`harness`] reports it ignored, with its reason (under CI it fails);
//! - [`seeds`]: every seeded test's seeds (`SVO_TEST_SEED` moves them all) and a seeded
//!   generator; [`geometry`]: seeded random geometry on an integer lattice;
//! - the references the library is held to, sharing no code with it: [`exact_sat`] (an
//!   integer separating-axis test), [`oracle`] (the cells any `f64` triangle touches, in
//!   exact arithmetic), [`ray_reference`] and [`ray_check`] (the leaves a ray enters, in
//!   rationals, and the margin the tracer's `f32` arithmetic allows), [`spec_reader`] (a
//!   `.svo` reader written from `docs/format.md` alone) and [`conformance`] (the format's
//!   conformance corpus, encoded from the document);
//! - [`fuzz_cases`]: what the fuzz targets check, as functions the tests also run;
//! - [`node_order`]: the node orders a tree keeps, and the shape two trees share.
//!
//! The end-to-end tests themselves are in `tests/it/`.

pub mod bake_check;
pub mod conformance;
pub mod exact_sat;
pub mod fuzz_cases;
pub mod geometry;
pub mod harness;
pub mod node_order;
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

/// Reports that `what` is missing: a panic under CI, else a notice on stderr. For a part of
/// a test (an extra case on a shared mesh); a whole test that needs something goes through
/// [`harness`], which reports it ignored.
pub fn missing(what: &str) {
    assert!(!under_ci(), "CI needs {what}");
    eprintln!("notice: {what} is missing; the cases that need it are left out");
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

/// Where the bunny that `examples/scenes/pool.toml` names is found as the scene finds it:
/// in a folder of `$SVO_MODELS`, or in `../shared/models` beside the repository.
pub fn pool_scene_bunny() -> Option<PathBuf> {
    let mut folders: Vec<PathBuf> = std::env::var_os("SVO_MODELS")
        .map(|l| std::env::split_paths(&l).collect())
        .unwrap_or_default();
    folders.push(repo_root().join("../shared/models"));
    folders
        .into_iter()
        .map(|f| f.join("stanford/bun_zipper.ply"))
        .find(|p| p.is_file())
}

/// The thesis's pool scene file (`examples/scenes/pool.toml`) if its bunny is where the scene
/// looks for it ([`pool_scene_bunny`]); otherwise [`missing`] (a panic under CI) and `None`.
pub fn pool_scene() -> Option<PathBuf> {
    if pool_scene_bunny().is_some() {
        Some(repo_root().join("examples/scenes/pool.toml"))
    } else {
        missing(
            "stanford/bun_zipper.ply, which examples/scenes/pool.toml reads (set SVO_MODELS to the models folder)",
        );
        None
    }
}

/// The full path of the executable `tool` on `PATH` or in the system folders, if it is there.
pub fn find_tool(tool: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/usr/bin", "/sbin"].map(PathBuf::from))
        .map(|d| d.join(tool))
        .find(|p| p.is_file())
}
