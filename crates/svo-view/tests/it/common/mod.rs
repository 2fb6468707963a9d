//! Helpers shared by the viewer's integration tests.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock, PoisonError};
use svo_tests::harness::Need;
use svo_view::gpu_context::GpuContext;

/// One device for the whole test binary (opening one per test costs time on lavapipe),
/// taken in turn; `Err` says why there is none.
pub fn gpu_context() -> Result<MutexGuard<'static, GpuContext>, String> {
    static CTX: OnceLock<Result<Mutex<GpuContext>, String>> = OnceLock::new();
    let ctx = CTX.get_or_init(|| match GpuContext::new() {
        Ok(c) => {
            eprintln!("GPU tests on {}", c.adapter_name());
            Ok(Mutex::new(c))
        }
        Err(e) => Err(e.to_string()),
    });
    match ctx {
        Ok(m) => Ok(m.lock().unwrap_or_else(PoisonError::into_inner)),
        Err(e) => Err(e.clone()),
    }
}

/// A GPU adapter (lavapipe where there is no GPU).
pub fn gpu_need() -> Need {
    Need::new(
        "a GPU adapter (lavapipe: apt-get install mesa-vulkan-drivers)",
        || gpu_context().map(drop),
    )
}

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
