//! Per-triangle data in grid space, computed once before voxelization: vertices, bounds,
//! edges, plane normal, and the magnitudes that the overlap tests' error bounds need.

use crate::geometry::grid::RootCube;
use crate::mesh::triangle_mesh::Mesh;
use glam::DVec3;

/// A triangle in grid space with what the overlap tests precompute (112 bytes: the bake
/// allocates one per input triangle, so it is kept small; the bounds are recomputed from the
/// vertices where needed, [`GridTriangle::lo`], which is exact).
#[derive(Clone, Copy, Debug)]
pub struct GridTriangle {
    /// The three vertices.
    pub v: [DVec3; 3],
    /// Unnormalized normal `(v1 - v0) x (v2 - v0)`; zero (or rounding-small) for degenerate
    /// triangles.
    pub n: DVec3,
    /// `|v1 - v0|_1 * |v2 - v0|_1`: bounds the rounding error of `n` (see `overlap.rs`).
    pub n_scale: f64,
    /// `TOLERANCE * (4 M + 2)` with `M` the largest vertex coordinate magnitude (at least
    /// 1): times an edge axis's L1 norm, it bounds the rounding error of an edge-axis test.
    pub edge_tol: f64,
}

/// The 2D components of the axis `e x unit_k` (the component along `k` is zero) and the
/// indices of the coordinates they multiply.
#[inline]
pub(crate) fn edge_axis(e: DVec3, k: usize) -> (f64, f64, usize, usize) {
    match k {
        0 => (e.z, -e.y, 1, 2),
        1 => (-e.z, e.x, 0, 2),
        _ => (e.y, -e.x, 0, 1),
    }
}

impl GridTriangle {
    /// Sets up a triangle from grid-space vertices.
    pub fn new(v0: DVec3, v1: DVec3, v2: DVec3) -> Self {
        let (e0, a) = (v1 - v0, v2 - v0);
        let l1 = |d: DVec3| d.x.abs() + d.y.abs() + d.z.abs();
        let m = v0.abs().max(v1.abs()).max(v2.abs()).max_element().max(1.0);
        Self {
            v: [v0, v1, v2],
            n: e0.cross(a),
            n_scale: l1(e0) * l1(a),
            edge_tol: crate::geometry::overlap::TOLERANCE * (4.0 * m + 2.0),
        }
    }

    /// Bounds minimum.
    #[inline]
    pub fn lo(&self) -> DVec3 {
        self.v[0].min(self.v[1]).min(self.v[2])
    }

    /// Bounds maximum.
    #[inline]
    pub fn hi(&self) -> DVec3 {
        self.v[0].max(self.v[1]).max(self.v[2])
    }

    /// Edge `j`: `v[j+1] - v[j]` (cyclic).
    #[inline]
    pub fn edge(&self, j: usize) -> DVec3 {
        self.v[if j == 2 { 0 } else { j + 1 }] - self.v[j]
    }
}

/// Grid-space triangles for the mesh triangles `order[0], order[1], ...`, built in parallel
/// (feature `parallel`).
pub(crate) fn setup_triangles_in_order(
    mesh: &Mesh,
    root: &RootCube,
    depth: u8,
    order: &[u32],
) -> Vec<GridTriangle> {
    let make = |&i: &u32| {
        let t = mesh.triangles[i as usize];
        let g = |k: usize| root.to_grid(mesh.positions[t[k] as usize], depth);
        GridTriangle::new(g(0), g(1), g(2))
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        order.par_iter().with_min_len(4096).map(make).collect()
    }
    #[cfg(not(feature = "parallel"))]
    order.iter().map(make).collect()
}

/// Spreads the low 21 bits of `v` to every third bit (bit `b` to bit `3b`).
#[inline]
pub(crate) const fn spread3(v: u64) -> u64 {
    let mut x = v & 0x1F_FFFF;
    x = (x | x << 32) & 0x1F_0000_0000_FFFF;
    x = (x | x << 16) & 0x1F_0000_FF00_00FF;
    x = (x | x << 8) & 0x100F_00F0_0F00_F00F;
    x = (x | x << 4) & 0x10C3_0C30_C30C_30C3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// A permutation of the mesh's triangles by the Morton order of the cell of a `32^3` grid
/// over the root that holds their centroid (ties in mesh order), so that the triangles of a
/// node sit near each other in memory. `order[k]` is the mesh index of the `k`-th triangle
/// in spatial order.
///
/// A stable counting sort by the 15-bit cell code: two passes over the triangles. A finer
/// order buys nothing: a cell of this grid holds a few hundred triangles even for meshes
/// of a million, whose records fit in the cache together, and the build's own splits order
/// the lists within it (a full comparison sort by a 30-bit code took 2.5 ms of a 69 ms
/// depth-8 bunny bake on two threads).
pub(crate) fn spatial_order(mesh: &Mesh, root: &RootCube) -> Vec<u32> {
    const BITS: u32 = 5;
    let scale = f64::from(1u32 << BITS) / root.side;
    let top = f64::from((1u32 << BITS) - 1);
    let code = |t: &[u32; 3]| -> u16 {
        let c = (mesh.positions[t[0] as usize]
            + mesh.positions[t[1] as usize]
            + mesh.positions[t[2] as usize])
            / 3.0;
        let g = (c - root.origin) * scale;
        let q = |x: f64| {
            if x.is_finite() {
                x.clamp(0.0, top) as u64
            } else {
                0
            }
        };
        (spread3(q(g.x)) << 2 | spread3(q(g.y)) << 1 | spread3(q(g.z))) as u16
    };
    #[cfg(feature = "parallel")]
    let codes: Vec<u16> = {
        use rayon::prelude::*;
        mesh.triangles
            .par_iter()
            .with_min_len(4096)
            .map(code)
            .collect()
    };
    #[cfg(not(feature = "parallel"))]
    let codes: Vec<u16> = mesh.triangles.iter().map(code).collect();
    let mut start = vec![0u32; (1 << (3 * BITS)) + 1];
    for &c in &codes {
        start[usize::from(c) + 1] += 1;
    }
    let mut run = 0;
    for s in start.iter_mut() {
        run += *s;
        *s = run;
    }
    let mut order = vec![0u32; codes.len()];
    for (i, &c) in codes.iter().enumerate() {
        let slot = &mut start[usize::from(c)];
        order[*slot as usize] = i as u32;
        *slot += 1;
    }
    order
}
