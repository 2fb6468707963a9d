//! `svo.bake`: a mesh into an octree with the library's exact voxelizer, the GIL released for
//! the whole bake, refused up front (``svo.BakeError``) when it could need more memory than
//! the machine has available.

use crate::errors::{BakeError, bake_error, threads_error};
use crate::mesh::PyMesh;
use crate::octree::PyOctree;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use svo::BakeOptions;
use svo::bake::{ChannelSelection, SolidMode, Strategy};
use svo::io::BuildInfo;

/// The channels asked for: a comma-separated string (``"normal,colour"``, ``"all"``,
/// ``"none"``) or a sequence of names.
fn channels(obj: &Bound<'_, PyAny>) -> PyResult<ChannelSelection> {
    let spec = match obj.extract::<String>() {
        Ok(s) => s,
        Err(_) => obj
            .extract::<Vec<String>>()
            .map_err(|_| {
                PyTypeError::new_err("channels must be a string or a sequence of channel names")
            })?
            .join(","),
    };
    spec.parse().map_err(PyValueError::new_err)
}

/// The solid fill asked for: ``None`` or ``False`` (the surface only), ``True`` or
/// ``"closed"``, ``"vote"``.
fn solid(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<SolidMode>> {
    let Some(obj) = obj else { return Ok(None) };
    if let Ok(b) = obj.extract::<bool>() {
        return Ok(b.then_some(SolidMode::Closed));
    }
    let s: String = obj
        .extract()
        .map_err(|_| PyTypeError::new_err("solid must be None, a bool, \"closed\" or \"vote\""))?;
    s.parse().map(Some).map_err(PyValueError::new_err)
}

/// Bakes ``mesh`` into a sparse voxel octree of ``2**depth`` cells a side holding exactly
/// the cells its triangles touch.
///
/// ``mesh`` is an ``svo.Mesh`` or any object with ``vertices`` and ``faces`` (a
/// ``trimesh.Trimesh``). ``strategy``: ``"exact"`` (the default; never a cell too few or
/// too many) or one of the thesis's tests (``"aabb-plane"``, ``"aabb-plane-sat"``,
/// ``"sat-leaf"``, ``"plane-sat-leaf"``). ``solid``: fill the inside (``True`` or
/// ``"closed"`` for closed meshes, ``"vote"`` for meshes with holes). ``channels``: the
/// per-leaf attributes to compute (``"all"``, ``"none"``, or names among ``normal``,
/// ``contour``, ``colour``, ``reflectivity``, ``refractivity``, ``ior``). ``pad``: at
/// least this many empty cells around the mesh. ``lod``: give the inner nodes the filtered
/// surface of their cells (format version 4). ``threads``: worker threads (default: all
/// cores). ``max_memory``: refuse a bake whose estimated peak exceeds this many bytes
/// (default: the memory available now).
///
/// The same tree, byte for byte once saved, as ``svo-bake`` with the same settings.
#[pyfunction]
#[pyo3(signature = (mesh, depth = 8, strategy = "exact", solid = None, channels = None, pad = 0, lod = false, threads = None, max_memory = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake(
    py: Python<'_>,
    mesh: &Bound<'_, PyAny>,
    depth: i64,
    strategy: &str,
    solid: Option<&Bound<'_, PyAny>>,
    channels: Option<&Bound<'_, PyAny>>,
    pad: u32,
    lod: bool,
    threads: Option<usize>,
    max_memory: Option<u64>,
) -> PyResult<PyOctree> {
    let mesh = PyMesh::from_object(mesh)?;
    let depth = u8::try_from(depth).map_err(|_| {
        BakeError::new_err(format!("depth {depth} is outside 1..={}", svo::MAX_DEPTH))
    })?;
    let options = BakeOptions {
        depth,
        strategy: strategy
            .parse::<Strategy>()
            .map_err(PyValueError::new_err)?,
        channels: match channels {
            Some(c) => self::channels(c)?,
            None => ChannelSelection::ALL,
        },
        pad,
        max_memory: max_memory.or_else(svo::bake::available_memory),
        solid: self::solid(solid)?,
        node_attributes: lod,
    };
    let mesh = mesh.get();
    let (tree, _stats) = py
        .detach(|| svo::with_threads(threads, |_| svo::bake_mesh(&mesh.mesh, &options)))
        .map_err(threads_error)?
        .map_err(bake_error)?;
    let build = BuildInfo {
        strategy: options.strategy.name().to_string(),
        source_triangles: mesh.mesh.triangles.len() as u64,
        scene: mesh.mesh.scene.clone(),
        ..BuildInfo::new()
    };
    Ok(PyOctree::new(tree, build))
}
