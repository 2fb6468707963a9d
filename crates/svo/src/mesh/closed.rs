//! Whether a mesh is closed: once vertices at the same position are merged, every edge is
//! shared by an even number of triangles. That is the condition under which "inside" by
//! crossing parity is well defined (the triangles bound a volume mod 2), so solid
//! voxelization checks it before filling.

use crate::mesh::triangle_mesh::Mesh;
use glam::DVec3;
use std::collections::HashMap;

/// The mesh with vertices at equal positions merged (`-0.0` equals `0.0`): the distinct
/// positions, and the triangles over them (an index out of range becomes `u32::MAX`).
#[cfg_attr(not(feature = "csg"), allow(dead_code))]
pub(crate) fn welded(mesh: &Mesh) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut ids: HashMap<[u64; 3], u32> = HashMap::with_capacity(mesh.positions.len());
    let mut positions = Vec::new();
    let mut map = Vec::with_capacity(mesh.positions.len());
    for p in &mesh.positions {
        // Adding +0.0 turns -0.0 into +0.0 and leaves everything else alone.
        let q = *p + DVec3::ZERO;
        let key = [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()];
        let next = ids.len() as u32;
        let id = *ids.entry(key).or_insert(next);
        if id == next {
            positions.push(q);
        }
        map.push(id);
    }
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| map.get(i as usize).copied().unwrap_or(u32::MAX)))
        .collect();
    (positions, triangles)
}

/// The number of open edges: undirected edges (between distinct merged vertices) used by an
/// odd number of triangles. Zero for a closed mesh. See [`Mesh::open_edges`].
///
/// Vertices are merged by exact position (`-0.0` equals `0.0`), so meshes that split
/// vertices along UV or normal seams, as glTF and OBJ files do, count as closed when their
/// surface is. Degenerate triangles count with their edges: one with two equal vertices adds
/// the same edge twice, which changes nothing.
pub(crate) fn open_edges(mesh: &Mesh) -> usize {
    let (_, triangles) = welded(mesh);
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(triangles.len() * 3);
    for w in &triangles {
        for j in 0..3 {
            let (a, b) = (w[j], w[(j + 1) % 3]);
            if a != b {
                edges.push((a.min(b), a.max(b)));
            }
        }
    }
    edges.sort_unstable();
    let mut open = 0;
    let mut start = 0;
    while start < edges.len() {
        let end = start + edges[start..].partition_point(|&e| e == edges[start]);
        open += (end - start) % 2;
        start = end;
    }
    open
}

impl Mesh {
    /// The number of open edges: edges used by an odd number of triangles once vertices at
    /// the same position are merged (`-0.0` equals `0.0`). Zero for a closed mesh, whose
    /// inside is well defined (what a closed solid bake requires). Meshes that split vertices
    /// along UV or normal seams count as closed when their surface is.
    pub fn open_edges(&self) -> usize {
        open_edges(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> Mesh {
        Mesh::from_triangles(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        )
    }

    #[test]
    fn closed_open_and_split_vertices() {
        let mut m = tetra();
        assert_eq!(open_edges(&m), 0);
        m.triangles.pop();
        assert_eq!(open_edges(&m), 3);
        // Split every vertex (one copy per triangle, one at -0.0): still closed.
        let t = tetra();
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for tri in &t.triangles {
            let base = positions.len() as u32;
            for &i in tri {
                positions.push(-t.positions[i as usize]);
            }
            triangles.push([base, base + 1, base + 2]);
        }
        assert_eq!(open_edges(&Mesh::from_triangles(positions, triangles)), 0);
        // A zero-area triangle with a repeated vertex adds nothing.
        let mut d = tetra();
        d.triangles.push([0, 0, 3]);
        assert_eq!(open_edges(&d), 0);
    }
}
