//! What the benches share: the meshes they run on.

use std::path::{Path, PathBuf};

/// The committed torus fixture always, and the Stanford bunny when `../shared/models` is
/// present (a notice otherwise).
pub fn bench_meshes() -> Vec<(&'static str, PathBuf)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut meshes = vec![("torus", root.join("fixtures/torus.obj"))];
    let bunny = root.join("../shared/models/stanford/stanford-bunny.obj");
    if bunny.exists() {
        meshes.push(("bunny", bunny));
    } else {
        eprintln!(
            "notice: bunny not found at {}; benching the torus only",
            bunny.display()
        );
    }
    meshes
}
