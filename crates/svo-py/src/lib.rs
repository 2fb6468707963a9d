//! The Python package `svo` (distribution `svo-octree`): the library's meshes, exact bake,
//! `.svo` files, queries, rays and CPU renders for Python, NumPy arrays in and out. Every
//! call that takes time releases the GIL; every error is a Python exception carrying the
//! library's one-line message (`errors.rs`). Built with maturin (`pyproject.toml`); the
//! Python side (`python/svo/`) re-exports this module and holds its type stubs.

// Python's arguments arrive owned (PyO3 extracts them), and the error conversions are
// `map_err`'s functions.
#![allow(clippy::needless_pass_by_value)]

mod arrays;
mod bake;
mod errors;
mod mesh;
mod octree;
mod rays;
mod render;

use pyo3::prelude::*;

/// The module's Rust allocations on mimalloc (feature `mimalloc`, on by default): a bake's
/// freed buffers are kept for its next allocations, where the system allocator hands large
/// ones back to the kernel and every bake faults them in again (`docs/performance.md`).
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The compiled module, `svo._svo`; `svo` re-exports it.
#[pymodule(name = "_svo")]
fn svo_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<mesh::PyMesh>()?;
    m.add_class::<octree::PyOctree>()?;
    m.add_class::<rays::PyHits>()?;
    m.add_function(wrap_pyfunction!(bake::bake, m)?)?;
    m.add("MeshError", py.get_type::<errors::MeshError>())?;
    m.add("BakeError", py.get_type::<errors::BakeError>())?;
    m.add("FormatError", py.get_type::<errors::FormatError>())?;
    m.add("ExportError", py.get_type::<errors::ExportError>())?;
    m.add("MAX_DEPTH", svo::MAX_DEPTH)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
