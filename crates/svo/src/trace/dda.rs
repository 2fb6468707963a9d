//! The dense-grid baseline: Amanatides and Woo's voxel walk (the 2019 report's ray marching)
//! over an occupancy bit grid of the same cells, entered by a ray/AABB cast.
//!
//! It is the yardstick the octree must beat, and a second, independent walk to check it
//! against. The report's precision fixes are built in rather than patched: the walk starts
//! in the cell that the *plane parameters* say contains the entry point (not
//! `floor(o + t d)`, which can land outside the grid or in the wrong cell at a boundary;
//! the report shrank its box by 0.0001 instead), and each boundary parameter is computed from
//! its integer plane as `(p - o) / d` rather than accumulated step by step (the accumulated
//! sum drifts, the report's "depth" bug). The planes, ties and entry faces follow the same
//! rules as [`crate::trace::traverse`], so both walks hand the *same* leaf entries to the
//! same callbacks, and must agree hit for hit.
//!
//! Memory is one bit per cell, so the grid is limited to depth [`MAX_DDA_DEPTH`] (128 MiB).

use crate::octree::tree::Octree;
use crate::trace::grid_ray::{GridRay, MirroredRay};
use crate::trace::traverse::{LeafEntry, Traversal};
use glam::{IVec3, UVec3};
use thiserror::Error;

/// The deepest tree a dense grid is built for: `1024^3` bits.
pub const MAX_DDA_DEPTH: u8 = 10;

/// Errors of the dense grid.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DdaError {
    /// The tree is too deep for a dense grid.
    #[error("a dense grid of depth {0} would need {bytes} bytes; the limit is depth {max}", bytes = (1u64 << (3 * u32::from(*.0))) / 8, max = MAX_DDA_DEPTH)]
    TooDeep(u8),
}

/// Occupancy bits of every cell of a tree, with the tree's leaf indices on demand.
#[derive(Clone, Debug)]
pub struct DenseGrid {
    depth: u8,
    n: u32,
    bits: Vec<u64>,
}

impl DenseGrid {
    /// The occupancy grid of `tree`'s leaves.
    pub fn new(tree: &Octree) -> Result<Self, DdaError> {
        if tree.depth > MAX_DDA_DEPTH || tree.depth == 0 {
            return Err(DdaError::TooDeep(tree.depth));
        }
        let n = 1u32 << tree.depth;
        let mut bits = vec![0u64; ((n as usize).pow(3)).div_ceil(64)];
        for l in tree.leaves() {
            let i = Self::index_of(n, l.cell);
            bits[i / 64] |= 1 << (i % 64);
        }
        Ok(Self {
            depth: tree.depth,
            n,
            bits,
        })
    }

    #[inline]
    fn index_of(n: u32, c: UVec3) -> usize {
        ((c.x as usize * n as usize) + c.y as usize) * n as usize + c.z as usize
    }

    /// Whether cell `c` is occupied.
    #[inline]
    pub fn occupied(&self, c: UVec3) -> bool {
        let i = Self::index_of(self.n, c);
        self.bits[i / 64] >> (i % 64) & 1 == 1
    }

    /// The depth of the tree it was built from.
    pub fn depth(&self) -> u8 {
        self.depth
    }

    /// Bytes of the bit grid.
    pub fn bytes(&self) -> usize {
        self.bits.len() * 8
    }
}

/// Walks `grid` along `ray` for parameters in `[tmin, tmax]`, calling `on_leaf` for each
/// occupied cell front to back until it returns `Some`. Leaf indices come from `tree` (the
/// tree the grid was built from), looked up only for occupied cells. Each cell visited is a
/// step.
pub fn traverse_dda<T>(
    grid: &DenseGrid,
    tree: &Octree,
    ray: &GridRay,
    tmin: f32,
    tmax: f32,
    max_steps: u32,
    mut on_leaf: impl FnMut(&LeafEntry) -> Option<T>,
) -> Traversal<T> {
    let mut out = Traversal {
        hit: None,
        steps: 0,
        capped: false,
    };
    let n = grid.n;
    let Some(r) = MirroredRay::new(ray, n) else {
        return out;
    };
    // Mirrored space, as in the octree: every coordinate below is a mirrored cell or plane,
    // and the walk goes towards +x, +y, +z.
    let t_of = |p: UVec3| r.t_planes(p);
    let Some((_, _, enter)) = r.root_entry(tmin, tmax) else {
        return out;
    };
    // The start cell: on each axis the last plane crossed at or before `enter` (ties go to
    // the far side, as the octree's first-child rule does).
    let mut cell = IVec3::ZERO;
    for axis in 0..3 {
        let t_axis = |k: u32| {
            let mut p = UVec3::ZERO;
            p[axis] = k;
            t_of(p)[axis]
        };
        // Binary search for the largest k in [0, n) with t(k) <= enter.
        let (mut lo, mut hi) = (0u32, n - 1);
        while lo < hi {
            let mid = (lo + hi).div_ceil(2);
            if t_axis(mid) <= enter {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        cell[axis] = lo as i32;
    }
    loop {
        let c = cell.as_uvec3();
        let c0 = t_of(c);
        let c1 = t_of(c + UVec3::ONE);
        out.steps += 1;
        if out.steps > max_steps {
            out.capped = true;
            return out;
        }
        let t_enter = c0.max_element().max(tmin);
        if t_enter > tmax {
            return out;
        }
        let t_exit = c1.min_element().min(tmax);
        let real = r.unmirror_cell(c);
        if t_exit >= t_enter
            && grid.occupied(real)
            && let Some(leaf) = tree.leaf_at(real)
        {
            let e = LeafEntry {
                leaf,
                cell: real,
                side: 1,
                t_enter,
                t_exit,
                entry_normal: r.entry_normal_of(c0, tmin),
                exit_normal: r.exit_normal_of(c1),
            };
            if let Some(h) = on_leaf(&e) {
                out.hit = Some(h);
                return out;
            }
        }
        // Cross every plane at the smallest exit parameter together.
        let m = c1.min_element();
        for axis in 0..3 {
            if c1[axis] == m {
                cell[axis] += 1;
            }
        }
        if cell.max_element() >= n as i32 {
            return out;
        }
    }
}
