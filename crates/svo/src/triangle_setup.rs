//! Per-triangle data in grid space, computed once before voxelization: vertices, bounds,
//! edges, plane normal, and the magnitudes that the overlap tests' error bounds need.

use crate::grid::RootCube;
use crate::mesh::Mesh;
use glam::DVec3;

/// A triangle in grid space with everything the overlap tests precompute.
#[derive(Clone, Copy, Debug)]
pub struct GridTriangle {
    /// The three vertices.
    pub v: [DVec3; 3],
    /// Bounds minimum.
    pub lo: DVec3,
    /// Bounds maximum.
    pub hi: DVec3,
    /// Edges `v1 - v0`, `v2 - v1`, `v0 - v2`.
    pub e: [DVec3; 3],
    /// Unnormalized normal `e0 x (v2 - v0)`; zero (or garbage-small) for degenerate triangles.
    pub n: DVec3,
    /// `|e0|_1 * |e2|_1`: bounds the rounding error of `n` (see [`crate::overlap`]).
    pub n_scale: f64,
}

impl GridTriangle {
    /// Sets up a triangle from grid-space vertices.
    pub fn new(v0: DVec3, v1: DVec3, v2: DVec3) -> Self {
        let e = [v1 - v0, v2 - v1, v0 - v2];
        let a = v2 - v0;
        let n = e[0].cross(a);
        let l1 = |d: DVec3| d.x.abs() + d.y.abs() + d.z.abs();
        Self {
            v: [v0, v1, v2],
            lo: v0.min(v1).min(v2),
            hi: v0.max(v1).max(v2),
            e,
            n,
            n_scale: l1(e[0]) * l1(a),
        }
    }
}

/// Maps every triangle of `mesh` into grid space at `depth` for the given root.
pub fn setup_triangles(mesh: &Mesh, root: &RootCube, depth: u8) -> Vec<GridTriangle> {
    let g: Vec<DVec3> = mesh
        .positions
        .iter()
        .map(|&p| root.to_grid(p, depth))
        .collect();
    mesh.triangles
        .iter()
        .map(|t| GridTriangle::new(g[t[0] as usize], g[t[1] as usize], g[t[2] as usize]))
        .collect()
}
