//! What the benches share: the meshes they run on.

use std::path::PathBuf;

/// The committed torus fixture always, and the Stanford bunny when the shared models folder
/// (`SVO_MODELS`, else `../shared/models`) has it (a notice otherwise).
pub fn bench_meshes() -> Vec<(&'static str, PathBuf)> {
    let mut meshes = vec![("torus", svo_tests::repo_root().join("fixtures/torus.obj"))];
    let bunny = svo_tests::models_dir().join("stanford/stanford-bunny.obj");
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
