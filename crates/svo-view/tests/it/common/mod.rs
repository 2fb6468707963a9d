//! Helpers shared by the viewer's integration tests.

use std::path::{Path, PathBuf};

/// The torus fixture (`fixtures/torus.obj`, copper).
pub fn torus_obj() -> PathBuf {
    svo_tests::repo_root().join("fixtures/torus.obj")
}

/// Bakes the torus fixture at depth 5 into `dir/torus.svo`.
pub fn torus_svo(dir: &Path) -> PathBuf {
    torus_svo_at(dir, 5)
}

/// Bakes the torus fixture at `depth` into `dir/torus.svo`.
pub fn torus_svo_at(dir: &Path, depth: u8) -> PathBuf {
    let mesh = svo::Mesh::load(torus_obj()).unwrap();
    let opts = svo::BakeOptions {
        depth,
        ..svo::BakeOptions::default()
    };
    let (tree, _) = svo::bake_mesh(&mesh, &opts).unwrap();
    let build = svo::io::BuildInfo {
        generator: "test".into(),
        strategy: "exact".into(),
        source_triangles: mesh.triangles.len() as u64,
        ..Default::default()
    };
    let path = dir.join("torus.svo");
    svo::io::write_file(&tree, &build, &path).unwrap();
    path
}
