//! Byte-identical `.svo` output whatever the thread count, on real meshes (the bunny, and a
//! textured multi-material glTF so every channel is per leaf).

use std::path::PathBuf;
use svo::io::BuildInfo;
use svo::{BakeOptions, bake_mesh};
use svo_tests::harness::{Need, Test};
use svo_tests::trial;

/// The models folder, when the bunny is in it.
fn models() -> Option<PathBuf> {
    svo_tests::model("stanford/stanford-bunny.obj")?;
    Some(svo_tests::models_dir())
}

fn bake_with(threads: usize, mesh: &svo::Mesh, depth: u8) -> Vec<u8> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let (tree, _) = pool.install(|| {
        bake_mesh(
            mesh,
            &BakeOptions {
                depth,
                ..Default::default()
            },
        )
        .unwrap()
    });
    svo::io::to_bytes(&tree, &BuildInfo::default())
}

fn same_bytes_for_1_2_and_4_threads() {
    let Some(m) = models() else { return };
    for (file, depth) in [
        ("stanford/stanford-bunny.obj", 8u8),
        ("gltf/DamagedHelmet.glb", 7),
    ] {
        let mesh = svo::Mesh::load(m.join(file)).unwrap();
        let one = bake_with(1, &mesh, depth);
        assert_eq!(one, bake_with(2, &mesh, depth), "{file}: 1 vs 2 threads");
        assert_eq!(one, bake_with(4, &mesh, depth), "{file}: 1 vs 4 threads");
    }
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![trial!(
        same_bytes_for_1_2_and_4_threads,
        Need::model("stanford/stanford-bunny.obj")
    )]
}
