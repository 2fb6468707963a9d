//! Baking a mesh into an [`Octree`]: root cube, size estimate, voxelization, attributes and
//! contours, with timings and statistics for the summary.

use crate::attributes::ChannelSelection;
use crate::attributes::leaf_attributes::{AttributeInputs, ContourStats};
use crate::attributes::node_attributes::node_attributes;
use crate::bake::estimate::{Estimate, estimate};
use crate::geometry::grid::RootCube;
use crate::geometry::triangle_setup::{setup_triangles_in_order, spatial_order};
use crate::mesh::triangle_mesh::{Mesh, MeshError};
use crate::octree::level_order::{into_level_order, keeps_level_order};
use crate::octree::tree::{ChannelKind, ChannelStorage, LeafAttributes, Octree};
use crate::solid::mode::SolidMode;
use crate::voxelize::build::{self as octree_build, LeafTriangles};
use crate::voxelize::strategy::Strategy;
use std::time::Instant;
use thiserror::Error;

/// Errors of baking.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum BakeError {
    /// The mesh is invalid.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The depth is 0 or beyond [`crate::MAX_DEPTH`].
    #[error("depth {depth} is outside 1..={max}", max = crate::MAX_DEPTH)]
    Depth {
        /// The requested depth.
        depth: u8,
    },
    /// The memory the bake may need exceeds the limit.
    #[error(
        "depth {depth} could make up to {leaves:.3e} leaves and need up to {gib:.1} GiB, more than the {limit_gib:.1} GiB allowed"
    )]
    TooLarge {
        /// The requested depth.
        depth: u8,
        /// The most leaves the bake can make ([`Estimate::max_leaves`](crate::bake::Estimate)).
        leaves: f64,
        /// Peak memory for that many leaves, GiB.
        gib: f64,
        /// The limit, GiB.
        limit_gib: f64,
    },
    /// The bake could make more leaves than one tree in memory holds (2^31).
    #[error(
        "depth {depth} could make up to {leaves:.3e} leaves, more than one tree in memory holds \
         (2^31): bake to .svo in parts (past 2^31 leaves the file is format version 3), or at a lower depth"
    )]
    TooManyLeaves {
        /// The requested depth.
        depth: u8,
        /// The most leaves the bake can make ([`Estimate::max_leaves`](crate::bake::Estimate)).
        leaves: f64,
    },
    /// A closed-mesh solid bake of a mesh with open edges.
    #[error(
        "the mesh is not closed: {open_edges} open edges (edges used by an odd number of triangles), \
         so its inside is not defined: the closed fill needs a closed mesh, the vote fills meshes with holes"
    )]
    OpenMesh {
        /// Edges used by an odd number of triangles.
        open_edges: usize,
    },
    /// A solid bake without the `solid` cargo feature.
    #[error("solid voxelization needs svo's `solid` cargo feature")]
    SolidUnavailable,
    /// Contours need the normal channel.
    #[error("the contour channel needs the normal channel")]
    ContourWithoutNormal,
}

/// What to bake.
#[derive(Clone, Debug)]
pub struct BakeOptions {
    /// Levels below the root (`1..=`[`crate::MAX_DEPTH`]).
    pub depth: u8,
    /// Where the overlap tests run.
    pub strategy: Strategy,
    /// The attribute channels to compute.
    pub channels: ChannelSelection,
    /// At least this many empty cells around the mesh on every side.
    pub pad: u32,
    /// Refuse when the estimated peak memory exceeds this many bytes.
    pub max_memory: Option<u64>,
    /// Fill the inside of the mesh with interior leaves (the `solid` feature), deciding the
    /// inside as the [`SolidMode`] says.
    pub solid: Option<SolidMode>,
    /// Give the inner nodes the attributes of the surface inside their cells
    /// above the leaf parents ([`Octree::node_attributes`]): the level of detail a renderer
    /// stops at, stored by format version 4. Not made for solid bakes.
    pub node_attributes: bool,
}

impl Default for BakeOptions {
    fn default() -> Self {
        Self {
            depth: 8,
            strategy: Strategy::Exact,
            channels: ChannelSelection::ALL,
            pad: 0,
            max_memory: None,
            solid: None,
            node_attributes: false,
        }
    }
}

/// The bake's phases, for progress reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Building the tree.
    Voxelize,
    /// Attributes and contours.
    Attributes,
    /// Filling the inside (solid bakes).
    Solid,
    /// Baking parts, one after another (a bake in bounded memory): the fraction of parts done.
    Part,
    /// Merging the parts into the file.
    Merge,
}

/// Statistics of one bake.
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct BakeStats {
    /// Input triangles.
    pub triangles: usize,
    /// Input triangles with zero area (kept: they mark the cells they touch).
    pub degenerate_triangles: usize,
    /// Tree depth.
    pub depth: u8,
    /// Strategy name.
    pub strategy: String,
    /// Whether the strategy is exact.
    pub exact: bool,
    /// Root cube origin.
    pub root_origin: [f64; 3],
    /// Root cube side.
    pub root_side: f64,
    /// Leaf cell side, scene units.
    pub cell_size: f64,
    /// Nodes.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Leaves estimated before the bake.
    pub estimated_leaves: f64,
    /// The most leaves the bake could make, known before it ([`crate::bake::Estimate`]).
    pub max_leaves: f64,
    /// Triangle/cell overlap tests run: the tests of children and cells the voxelizer
    /// decided by testing. Contacts it proved without a test are not counted: a triangle
    /// whose bounds lie inside one child (filed there by the split's shortcut) and a sliced
    /// part whose centroid lies well inside its cell.
    pub overlap_tests: u64,
    /// Triangle/leaf pairs kept.
    pub leaf_triangle_pairs: usize,
    /// Leaves that no triangle touches (an inexact strategy's false positives, counted with
    /// the exact test on each leaf's triangles); zero for exact strategies.
    pub false_positives: usize,
    /// Seconds spent voxelizing.
    pub voxelize_s: f64,
    /// Seconds spent on attributes.
    pub attributes_s: f64,
    /// Seconds spent on contours.
    pub contours_s: f64,
    /// Seconds spent on the inner nodes' contours and channels after the build, and on putting
    /// the nodes in level order (their other values are made during the build, within
    /// `voxelize_s` and `attributes_s`).
    pub node_attributes_s: f64,
    /// The solid mode, when the inside was filled.
    pub solid: Option<String>,
    /// Interior leaves added by the solid fill (included in `leaves`).
    pub interior_leaves: usize,
    /// Seconds spent filling the inside.
    pub solid_s: f64,
    /// Contour thickness in cells, when contours were made.
    pub contour_thickness: Option<ContourStats>,
    /// Bytes of nodes and per-leaf arrays in memory.
    pub payload_bytes: usize,
    /// Channels and how they are stored (`per-leaf`, `constant`).
    pub channels: Vec<(String, String)>,
}

/// Checks the options against the mesh and returns the root cube with the bake's estimated
/// size (refused when it exceeds `opts.max_memory`).
pub(crate) fn prepare(mesh: &Mesh, opts: &BakeOptions) -> Result<(RootCube, Estimate), BakeError> {
    if !(1..=crate::MAX_DEPTH).contains(&opts.depth) {
        return Err(BakeError::Depth { depth: opts.depth });
    }
    if opts.channels.has(ChannelKind::Contour) && !opts.channels.has(ChannelKind::Normal) {
        return Err(BakeError::ContourWithoutNormal);
    }
    let (lo, hi) = mesh.validated_bounds()?;
    match opts.solid {
        Some(_) if cfg!(not(feature = "solid")) => return Err(BakeError::SolidUnavailable),
        Some(SolidMode::Closed) => {
            let open_edges = crate::mesh::closed::open_edges(mesh);
            if open_edges > 0 {
                return Err(BakeError::OpenMesh { open_edges });
            }
        }
        _ => {}
    }
    let root = RootCube::around(lo, hi, opts.depth, opts.pad);
    let est = estimate(mesh, &root, opts.depth);
    if let Some(limit) = opts.max_memory
        && est.bytes > limit as f64
    {
        const GIB: f64 = (1u64 << 30) as f64;
        return Err(BakeError::TooLarge {
            depth: opts.depth,
            leaves: est.max_leaves,
            gib: est.bytes / GIB,
            limit_gib: limit as f64 / GIB,
        });
    }
    Ok((root, est))
}

/// The leaves a bake of `mesh` with `opts` would make, estimated and bounded, and its peak
/// memory for the bound (of the surface; a solid fill adds its interior), after the same
/// checks the bake makes, but without its memory limit.
pub fn estimate_bake(mesh: &Mesh, opts: &BakeOptions) -> Result<Estimate, BakeError> {
    let opts = BakeOptions {
        max_memory: None,
        ..opts.clone()
    };
    prepare(mesh, &opts).map(|(_, est)| est)
}

/// Voxelizes only: the root cube, and the leaf cells (in leaf order) with the mesh triangles
/// that touch each, without attributes, for comparing strategies or hitting the triangles
/// themselves.
pub fn voxelize_mesh(
    mesh: &Mesh,
    depth: u8,
    strategy: Strategy,
) -> Result<(RootCube, LeafTriangles), BakeError> {
    let opts = BakeOptions {
        depth,
        strategy,
        ..BakeOptions::default()
    };
    let (root, _) = prepare(mesh, &opts)?;
    Ok((root, voxelize_mesh_in(mesh, &root, depth, strategy)))
}

/// Voxelizes only, in a given root cube (the one of an existing tree, so that the leaves
/// line up with its): the leaf cells in leaf order with their mesh triangles, ascending.
/// The mesh must be valid ([`Mesh::validate`]) and `depth` in `1..=MAX_DEPTH`.
pub(crate) fn voxelize_mesh_in(
    mesh: &Mesh,
    root: &RootCube,
    depth: u8,
    strategy: Strategy,
) -> LeafTriangles {
    let order = spatial_order(mesh, root);
    let tris = setup_triangles_in_order(mesh, root, depth, &order);
    let mut leaves = octree_build::voxelize(&tris, depth, strategy, &|_| {});
    // Back to mesh triangle indices, ascending within each leaf.
    let mut start = 0;
    for &end in &leaves.ends {
        let list = &mut leaves.tris[start..end as usize];
        for t in list.iter_mut() {
            *t = order[*t as usize];
        }
        list.sort_unstable();
        start = end as usize;
    }
    leaves
}

/// Bakes a mesh into an octree with the attributes and contours `opts` asks for, and the
/// bake's statistics.
///
/// The default options give a depth-8 tree (a `256^3` grid over the mesh's bounding cube),
/// the exact strategy (exactly the cells the triangles touch) and every channel the mesh
/// needs (channels that are the same for every leaf are stored once).
///
/// ```
/// use svo::{BakeOptions, Mesh, MeshFormat, bake_mesh};
/// let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
/// let mesh = Mesh::from_bytes(obj, MeshFormat::Obj)?;
/// let (tree, stats) = bake_mesh(&mesh, &BakeOptions { depth: 4, ..Default::default() })?;
/// assert_eq!(tree.leaf_count as usize, stats.leaves);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// The bake allocates a few buffers the size of the mesh and of the leaves (about 14 MB for
/// the 69k-triangle bunny at depth 8). The library leaves the allocator to its user; glibc's
/// returns such buffers to the kernel when they are freed, so a program that bakes again
/// faults them in again. A caching allocator (`svo-bake` links mimalloc) made repeated
/// depth-8 bunny bakes about 15% faster (`docs/performance.md`, "Bake").
pub fn bake_mesh(mesh: &Mesh, opts: &BakeOptions) -> Result<(Octree, BakeStats), BakeError> {
    bake_mesh_with_progress(mesh, opts, &|_, _| {})
}

/// [`bake_mesh`], calling `progress(phase, fraction)` as the bake goes (from worker threads).
pub fn bake_mesh_with_progress(
    mesh: &Mesh,
    opts: &BakeOptions,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<(Octree, BakeStats), BakeError> {
    let (mut tree, stats) = bake_for_file(mesh, opts, progress)?;
    tree.refresh_bounds();
    Ok((tree, stats))
}

/// [`bake_mesh_with_progress`] for a tree that goes to a file: without the nodes' bounds
/// (bits 8-31 of `info` zero), which only a traversal uses and the file does not store.
pub(crate) fn bake_for_file(
    mesh: &Mesh,
    opts: &BakeOptions,
    progress: &(dyn Fn(Phase, f64) + Sync),
) -> Result<(Octree, BakeStats), BakeError> {
    let (root, est) = prepare(mesh, opts)?;
    if est.max_leaves > crate::octree::validate::MAX_LEAVES as f64 {
        return Err(BakeError::TooManyLeaves {
            depth: opts.depth,
            leaves: est.max_leaves,
        });
    }
    let t0 = Instant::now();
    let order = spatial_order(mesh, &root);
    let tris = setup_triangles_in_order(mesh, &root, opts.depth, &order);
    let with_nodes = opts.node_attributes && opts.solid.is_none();
    let inputs = AttributeInputs::new(mesh, &tris, &order, opts.channels);
    let (nodes, node_values, values, tests) = octree_build::voxelize_with_attributes(
        &inputs,
        opts.depth,
        opts.strategy,
        with_nodes,
        &|f| progress(Phase::Voxelize, f),
    );
    let wall = t0.elapsed();
    let (pairs, false_positives) = (values.pairs, values.false_positives as usize);
    let leaf_count = values.len();
    progress(Phase::Attributes, 0.0);
    // The attributes' last serial step (the contour statistics) and the count of degenerate
    // triangles (a pass over all the triangle records) run side by side.
    let count_degenerate = || tris.iter().filter(|t| t.n == glam::DVec3::ZERO).count();
    #[cfg(feature = "parallel")]
    let ((attributes, rep), degenerate) =
        rayon::join(|| inputs.finish(values, wall), count_degenerate);
    #[cfg(not(feature = "parallel"))]
    let ((attributes, rep), degenerate) = (inputs.finish(values, wall), count_degenerate());
    progress(Phase::Attributes, 1.0);
    // The shares are rounded, so their sum may pass the wall time by a nanosecond.
    let voxelize_s = wall
        .saturating_sub(rep.attributes)
        .saturating_sub(rep.contours)
        .as_secs_f64();
    let t_nodes = Instant::now();
    let node_attributes = if with_nodes {
        node_attributes(&nodes, &node_values, &attributes)
    } else {
        LeafAttributes::default()
    };
    drop(node_values);
    let mut tree = Octree {
        root,
        depth: opts.depth,
        nodes,
        leaf_count: leaf_count as u32,
        attributes,
        node_attributes,
    };
    if keeps_level_order(&tree) {
        into_level_order(&mut tree);
    }
    let node_attributes_s = t_nodes.elapsed().as_secs_f64();
    let (mut interior_leaves, mut solid_s) = (0, 0.0);
    if let Some(mode) = opts.solid {
        let t = Instant::now();
        progress(Phase::Solid, 0.0);
        let (solid, added) = fill_solid(mesh, tree, mode, opts)?;
        tree = solid;
        interior_leaves = added;
        solid_s = t.elapsed().as_secs_f64();
        progress(Phase::Solid, 1.0);
    }
    let a = &tree.attributes;
    let channels = a
        .storage()
        .into_iter()
        .filter(|(_, s)| *s != ChannelStorage::Absent)
        .map(|(k, s)| (k.name().to_string(), s.name().to_string()))
        .collect();
    let stats = BakeStats {
        triangles: mesh.triangles.len(),
        degenerate_triangles: degenerate,
        depth: opts.depth,
        strategy: opts.strategy.name().to_string(),
        exact: opts.strategy.is_exact(),
        root_origin: root.origin.to_array(),
        root_side: root.side,
        cell_size: root.cell_size(opts.depth),
        nodes: tree.nodes.len(),
        leaves: tree.leaf_count as usize,
        estimated_leaves: est.leaves,
        max_leaves: est.max_leaves,
        overlap_tests: tests,
        leaf_triangle_pairs: pairs as usize,
        false_positives,
        voxelize_s,
        attributes_s: rep.attributes.as_secs_f64(),
        contours_s: rep.contours.as_secs_f64(),
        node_attributes_s,
        solid: opts.solid.map(|m| m.name().to_string()),
        interior_leaves,
        solid_s,
        contour_thickness: rep.contour_stats,
        payload_bytes: tree.payload_bytes(),
        channels,
    };
    // The build's temporaries (grid-space triangles, unit normals) run to hundreds of MB
    // for large meshes; unmapping them takes tens of ms, which nobody needs to wait for.
    // Small ones are dropped here: a thread costs more than freeing them.
    drop(inputs);
    if tris.len() > 1 << 16 {
        drop_in_background((tris, order));
    }
    Ok((tree, stats))
}

/// The surface tree with the inside of `mesh` added as interior leaves, and how many.
#[cfg(feature = "solid")]
fn fill_solid(
    mesh: &Mesh,
    surface: Octree,
    mode: SolidMode,
    opts: &BakeOptions,
) -> Result<(Octree, usize), BakeError> {
    use crate::solid::fill::{FillLimit, interior_cells, merge_interior};
    let (cells, _) = interior_cells(
        mesh,
        &surface.root,
        surface.depth,
        mode,
        &surface,
        opts.max_memory,
    )
    .map_err(|FillLimit::TooMany { cells, bytes }| {
        const GIB: f64 = (1u64 << 30) as f64;
        BakeError::TooLarge {
            depth: opts.depth,
            leaves: cells,
            gib: bytes / GIB,
            limit_gib: opts.max_memory.unwrap_or(0) as f64 / GIB,
        }
    })?;
    if cells.is_empty() {
        return Ok((surface, 0));
    }
    let tree = merge_interior(&surface, mesh, &cells);
    drop_in_background(surface);
    Ok((tree, cells.len()))
}

#[cfg(not(feature = "solid"))]
fn fill_solid(
    _: &Mesh,
    _: Octree,
    _: SolidMode,
    _: &BakeOptions,
) -> Result<(Octree, usize), BakeError> {
    Err(BakeError::SolidUnavailable)
}

/// Drops `value` on a short-lived thread: freeing hundreds of MB of pages costs tens of
/// milliseconds that the caller need not wait for. If no thread can be started, the closure,
/// and with it the value, is dropped here by `spawn`'s error path.
pub(crate) fn drop_in_background<T: Send + 'static>(value: T) {
    let _ = std::thread::Builder::new()
        .name("svo-drop".into())
        .spawn(move || drop(value));
}
