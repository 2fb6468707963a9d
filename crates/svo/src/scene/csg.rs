//! Boolean operations between closed meshes for scene files (`[[csg]]`), through the
//! Manifold kernel (`manifold-rs`, which vendors Manifold's C++ sources; cargo feature
//! `csg`, off by default, so users who do not need CSG compile no C++).
//!
//! Manifold works in `f32` here (the binding's mesh type), so CSG results carry `f32`
//! positions; the rest of the bake stays `f64`. Inputs must be closed, consistently oriented
//! manifolds: Manifold turns anything else into an empty solid, which is reported as an
//! error naming the operand, rather than baked as nothing.

use crate::mesh::triangle_mesh::Mesh;
use crate::scene::file::CsgOp;
use glam::DVec3;

/// Manifold's solid of `m` (positions to `f32`); empty when `m` is not a closed manifold.
fn to_manifold(m: &Mesh) -> manifold_rs::Manifold {
    // Manifold wants shared vertices: merge those at equal positions (meshes split them
    // along seams), and leave out triangles that collapse.
    let (positions, triangles) = crate::mesh::closed::welded(m);
    let vertices: Vec<f32> = positions
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let indices: Vec<u32> = triangles
        .iter()
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
        .flatten()
        .copied()
        .collect();
    manifold_rs::Mesh::new(&vertices, &indices).to_manifold()
}

/// `a op b`, as a plain mesh without materials.
pub(crate) fn boolean(a: &Mesh, b: &Mesh, op: CsgOp) -> Result<Mesh, String> {
    let (ma, mb) = (to_manifold(a), to_manifold(b));
    for (m, mesh, which) in [(&ma, a, "a"), (&mb, b, "b")] {
        if m.is_empty() && !mesh.triangles.is_empty() {
            return Err(format!(
                "operand {which} is not a closed manifold ({} open edges after merging \
                 vertices; Manifold needs closed, consistently oriented meshes)",
                crate::mesh::closed::open_edges(mesh)
            ));
        }
    }
    let r = match op {
        CsgOp::Union => ma.union(&mb),
        CsgOp::Intersection => ma.intersection(&mb),
        CsgOp::Difference => ma.difference(&mb),
    };
    let out = r.to_mesh();
    let stride = out.num_props().max(3) as usize;
    let v = out.vertices();
    let positions: Vec<DVec3> = v
        .chunks_exact(stride)
        .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
        .collect();
    let idx = out.indices();
    let triangles: Vec<[u32; 3]> = idx
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .filter(|t| t.iter().all(|&i| (i as usize) < positions.len()))
        .collect();
    Ok(Mesh::from_triangles(positions, triangles))
}
