//! Estimating a bake's size before running it, so absurd depths are refused with a number
//! instead of exhausting memory.
//!
//! A triangle of area `A` (in cells squared) with unit normal `n` and perimeter `P` (in cells)
//! touches about `A * |n|_1` cells across its face plus up to `P` along its edges; the sum over
//! triangles (capped by the grid's `8^depth` cells) over-estimates the leaves of general
//! meshes, because neighbours share cells, but not of triangles laid along cell faces and
//! edges, which touch the cells on both sides. A bound that holds for every mesh comes from
//! volume: each cell a closed triangle `S` touches lies in `S` grown by one cell along each
//! axis, `S + [-1, 1]^3`, and the cells do not overlap, so they are at most its volume,
//! `2 A |n|_1 + 4 (w_x + w_y + w_z) + 8` (`w` the triangle's extents; exact for a square on
//! a cell face). Every decision about memory (the refusal, the switch to parts, the parts'
//! sizes) takes that bound, at a peak of 32 bytes a leaf (the leaf's cell, its
//! triangle list, node share and attribute arrays) plus the per-triangle setup.

use crate::geometry::grid::RootCube;
use crate::mesh::triangle_mesh::Mesh;
use glam::DVec3;

/// Peak bytes of the bake per leaf (cell, triangle list, nodes, channels, scratch), charged
/// on the bound `max_leaves`.
pub(crate) const BYTES_PER_LEAF: f64 = 32.0;
/// Peak bytes per leaf that the inner nodes' attributes add to a part of a bake in parts (a
/// node's values and its place in level order, about a node for every three leaves).
#[cfg(feature = "io")]
pub(crate) const NODE_BYTES_PER_LEAF: f64 = 8.0;
/// Peak bytes per input triangle (grid-space setup and attribute inputs).
pub(crate) const BYTES_PER_TRIANGLE: f64 = 240.0;

/// Bytes of memory available to a new process (Linux's `MemAvailable` in `/proc/meminfo`),
/// if known: the limit a program that bakes meshes of any size gives
/// [`crate::BakeOptions::max_memory`], so a depth that the machine cannot hold is refused
/// before it starts. `None` elsewhere.
pub fn available_memory() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = s.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// A bake's size, estimated before baking ([`crate::bake::estimate_bake`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Leaves: above the true count for general meshes; below it can happen where
    /// triangles lie along cell faces and edges (they touch the cells on both sides).
    pub leaves: f64,
    /// At least the true count, for every mesh: what a triangle's volume bound allows
    /// (about twice `leaves` for triangles many cells wide, more for small ones).
    pub max_leaves: f64,
    /// Peak memory in bytes, for `max_leaves` leaves.
    pub bytes: f64,
}

/// The cells a triangle with corners `a`, `b`, `c` (in cells) touches, about: `A * |n|_1`
/// across its face (half the cross product's L1 norm: no square root), its perimeter along
/// its edges, and one.
pub(crate) fn triangle_cells(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let n = (b - a).cross(c - a);
    let area_l1 = 0.5 * (n.x.abs() + n.y.abs() + n.z.abs());
    let perimeter = (b - a).length() + (c - b).length() + (a - c).length();
    area_l1 + perimeter + 1.0
}

/// At least the cells a triangle with corners `a`, `b`, `c` (in cells) touches: the volume of
/// the triangle grown by one cell along each axis (see the module's overview), with a margin
/// for the rounding of its terms.
pub(crate) fn triangle_cells_bound(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let n = (b - a).cross(c - a);
    let extent = a.max(b).max(c) - a.min(b).min(c);
    let volume = (n.x.abs() + n.y.abs() + n.z.abs()) + 4.0 * (extent.x + extent.y + extent.z) + 8.0;
    volume * (1.0 + 1e-9)
}

/// Estimates the leaves and peak memory of baking `mesh` at `depth` in `root`.
pub(crate) fn estimate(mesh: &Mesh, root: &RootCube, depth: u8) -> Estimate {
    let scale = (1u64 << depth) as f64 / root.side;
    // Coordinates relative to the root, which round least.
    let cells = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| {
            (mesh.positions.get(i as usize).copied().unwrap_or_default() - root.origin) * scale
        });
        (triangle_cells(a, b, c), triangle_cells_bound(a, b, c))
    };
    // Fixed chunks summed in order: the same sums whatever the thread count.
    const CHUNK: usize = 8192;
    let chunk_sum = |c: &[[u32; 3]]| {
        c.iter()
            .map(cells)
            .fold((0.0, 0.0), |(e, m), (a, b)| (e + a, m + b))
    };
    #[cfg(feature = "parallel")]
    let sums: Vec<(f64, f64)> = {
        use rayon::prelude::*;
        mesh.triangles.par_chunks(CHUNK).map(chunk_sum).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let sums: Vec<(f64, f64)> = mesh.triangles.chunks(CHUNK).map(chunk_sum).collect();
    let leaves: f64 = sums.iter().map(|s| s.0).sum();
    let max_leaves: f64 = sums.iter().map(|s| s.1).sum();
    let grid = 8f64.powi(i32::from(depth));
    let leaves = leaves.min(grid);
    let max_leaves = max_leaves.min(grid);
    Estimate {
        leaves,
        max_leaves,
        bytes: max_leaves * BYTES_PER_LEAF + mesh.triangles.len() as f64 * BYTES_PER_TRIANGLE,
    }
}
