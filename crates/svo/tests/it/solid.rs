//! Solid voxelization against a brute-force oracle: every cell of the grid is in the solid
//! tree exactly when a triangle touches it (a surface leaf) or its centre has winding number
//! one (an interior leaf), for closed meshes in general position and with their vertices,
//! edges and faces on the column lines and cell planes; the vote mode fills meshes with
//! holes; solid trees render exactly like their surfaces; open meshes and oversized fills
//! are refused.
#![cfg(feature = "solid")]

use crate::common;

use glam::{DMat3, DVec3, UVec3};
use rand::Rng;
use std::collections::BTreeSet;
use svo::bake::{BakeError, BakeOptions, SolidMode, bake_mesh};
use svo::mesh::Mesh;
use svo::octree::{NO_NORMAL, Octree};

fn torus() -> Mesh {
    Mesh::load(svo_tests::repo_root().join("fixtures/torus.obj")).unwrap()
}

/// Appends `b`'s triangles to `a`.
fn join(mut a: Mesh, b: &Mesh) -> Mesh {
    let off = a.positions.len() as u32;
    a.positions.extend(&b.positions);
    a.triangles
        .extend(b.triangles.iter().map(|t| t.map(|i| i + off)));
    if !a.triangle_materials.is_empty() {
        a.triangle_materials.resize(a.triangles.len(), 0);
    }
    a
}

/// `m` with two small closed tetrahedra at `0` and `side`, so the root cube is `[0, side]^3`
/// and scene coordinates are grid coordinates at depth `log2(side)`.
fn pinned(m: Mesh, side: f64) -> Mesh {
    let tet = |o: DVec3, s: f64| {
        Mesh::from_triangles(
            vec![o, o + DVec3::X * s, o + DVec3::Y * s, o + DVec3::Z * s],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        )
    };
    let m = join(m, &tet(DVec3::ZERO, 0.25));
    join(m, &tet(DVec3::splat(side), -0.25))
}

/// `m` scaled to fit a ball of radius `r` around `centre`, rotated by `rot`.
fn placed(m: &Mesh, rot: DMat3, centre: DVec3, r: f64) -> Mesh {
    let (lo, hi) = m.bounds().unwrap();
    let c = (lo + hi) / 2.0;
    let s = r / ((hi - lo).length() / 2.0);
    let mut out = m.clone();
    for p in &mut out.positions {
        *p = centre + rot * ((*p - c) * s);
    }
    out
}

fn random_rotation(rng: &mut impl Rng) -> DMat3 {
    let axis = DVec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    )
    .normalize();
    DMat3::from_axis_angle(axis, rng.random_range(0.0..std::f64::consts::TAU))
}

/// The generalized winding number of `m` at `p` (solid angles, Van Oosterom and Strackee).
fn winding(m: &Mesh, p: DVec3) -> f64 {
    let mut w = 0.0;
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize] - p);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        w += 2.0 * num.atan2(den);
    }
    w / (4.0 * std::f64::consts::PI)
}

fn bake(m: &Mesh, depth: u8, solid: Option<SolidMode>) -> Octree {
    let opts = BakeOptions {
        depth,
        solid,
        ..BakeOptions::default()
    };
    bake_mesh(m, &opts).unwrap().0
}

fn cells(t: &Octree) -> BTreeSet<[u32; 3]> {
    t.leaves().map(|l| l.cell.to_array()).collect()
}

/// Checks `solid` (a bake of `m` at `depth`, root `[0, 2^depth]^3`) against the oracle: the
/// surface leaves, plus every other cell whose centre has winding number one under `truth`
/// (`m` itself, or the closed mesh `m` was cut from). Returns the interior leaves.
fn check_against_oracle(m: &Mesh, truth: &Mesh, depth: u8, solid: &Octree, what: &str) -> usize {
    let surface = bake(m, depth, None);
    assert_eq!(solid.root.origin, DVec3::ZERO, "{what}: root not pinned");
    assert_eq!(
        solid.root.side,
        f64::from(1u32 << depth),
        "{what}: root not pinned"
    );
    solid.validate().unwrap();
    let side = 1u32 << depth;
    let mut interior = 0;
    for x in 0..side {
        for y in 0..side {
            for z in 0..side {
                let c = UVec3::new(x, y, z);
                let in_surface = surface.leaf_at(c).is_some();
                let leaf = solid.leaf_at(c);
                if in_surface {
                    let i = leaf.unwrap_or_else(|| panic!("{what}: surface cell {c} lost"));
                    assert!(!solid.attributes.is_interior(i as usize), "{what}: {c}");
                    continue;
                }
                let w = winding(truth, c.as_dvec3() + 0.5);
                assert!(
                    (w - w.round()).abs() < 0.2,
                    "{what}: winding number {w} at the centre of untouched cell {c}"
                );
                let inside = w.round() != 0.0;
                assert_eq!(leaf.is_some(), inside, "{what}: cell {c}, winding {w}");
                if let Some(i) = leaf {
                    assert!(solid.attributes.is_interior(i as usize), "{what}: {c}");
                    interior += 1;
                }
            }
        }
    }
    interior
}

#[test]
fn closed_meshes_in_general_position_fill_exactly() {
    let mut rng = common::rng(0x5011D);
    let depth = 5;
    let n = 32.0;
    let shapes = [
        ("box", Mesh::cuboid(DVec3::ZERO, DVec3::new(1.0, 0.7, 0.4))),
        ("sphere", Mesh::sphere(DVec3::ZERO, 1.0, 4)),
    ];
    for (name, shape) in &shapes {
        for k in 0..4 {
            let rot = random_rotation(&mut rng);
            let c = DVec3::new(
                rng.random_range(13.0..19.0),
                rng.random_range(13.0..19.0),
                rng.random_range(13.0..19.0),
            );
            let m = pinned(placed(shape, rot, c, rng.random_range(5.0..12.0)), n);
            let what = format!("{name} #{k}");
            let solid = bake(&m, depth, Some(SolidMode::Closed));
            let interior = check_against_oracle(&m, &m, depth, &solid, &what);
            assert!(interior > 10, "{what}: only {interior} interior cells");
            // The vote mode agrees on closed meshes.
            assert_eq!(
                cells(&solid),
                cells(&bake(&m, depth, Some(SolidMode::Vote))),
                "{what}: vote differs"
            );
        }
    }
}

#[test]
fn faces_edges_and_vertices_on_column_lines_and_cell_planes() {
    let depth = 4;
    let n = 16.0;
    let cases = [
        // Faces through the cell centres' planes, edges along column lines.
        (
            "half-integer box",
            Mesh::cuboid(DVec3::splat(2.5), DVec3::new(9.5, 11.5, 7.5)),
        ),
        // Faces on cell planes.
        (
            "integer box",
            Mesh::cuboid(DVec3::splat(3.0), DVec3::new(12.0, 9.0, 13.0)),
        ),
        // A sphere with poles on column lines (centre at a cell centre) and its octant
        // vertices' diagonals through column points.
        ("centred sphere", Mesh::sphere(DVec3::splat(8.5), 5.0, 3)),
        // An octahedron with every vertex at a cell centre.
        (
            "octahedron",
            Mesh::sphere(DVec3::new(7.5, 8.5, 6.5), 5.0, 1),
        ),
    ];
    for (name, m) in cases {
        let m = pinned(m, n);
        let solid = bake(&m, depth, Some(SolidMode::Closed));
        let interior = check_against_oracle(&m, &m, depth, &solid, name);
        assert!(interior > 0, "{name}");
        assert_eq!(
            cells(&solid),
            cells(&bake(&m, depth, Some(SolidMode::Vote))),
            "{name}: vote differs"
        );
    }
}

#[test]
fn a_nonconvex_closed_mesh_fills_exactly() {
    let m = pinned(
        placed(
            &torus(),
            DMat3::from_rotation_x(0.3),
            DVec3::splat(8.0),
            7.0,
        ),
        16.0,
    );
    assert_eq!(m.open_edges(), 0);
    let solid = bake(&m, 4, Some(SolidMode::Closed));
    let interior = check_against_oracle(&m, &m, 4, &solid, "torus");
    assert!(interior > 10, "{interior}");
}

#[test]
fn open_meshes_are_refused_unless_voted() {
    let closed = pinned(
        Mesh::cuboid(DVec3::new(3.3, 2.6, 4.1), DVec3::new(12.7, 13.2, 11.9)),
        16.0,
    );
    let mut open = closed.clone();
    open.triangles.remove(11); // one triangle of the z = hi face
    let opts = BakeOptions {
        depth: 4,
        solid: Some(SolidMode::Closed),
        ..BakeOptions::default()
    };
    match bake_mesh(&open, &opts) {
        Err(e @ BakeError::OpenMesh { open_edges: 3 }) => {
            let msg = e.to_string();
            assert!(
                msg.contains("3 open edges") && msg.contains("the vote fills meshes with holes"),
                "{msg}"
            );
        }
        other => panic!("{:?}", other.map(|(_, s)| s.leaves)),
    }
    // Voting: the columns through the hole abstain; the other two axes see a closed box.
    let solid = bake(&open, 4, Some(SolidMode::Vote));
    let interior = check_against_oracle(&open, &closed, 4, &solid, "box with a hole");
    assert!(interior > 100, "{interior}");
}

#[test]
fn voting_fills_a_torus_with_holes() {
    let closed = pinned(
        placed(
            &torus(),
            DMat3::from_rotation_x(0.3),
            DVec3::splat(8.0),
            7.0,
        ),
        16.0,
    );
    let mut open = closed.clone();
    // Cut four patches of neighbouring triangles out, on both sides of the tube.
    for start in [100usize, 2000, 5000, 8000] {
        open.triangles.drain(start..start + 6);
        open.triangle_materials.drain(start..start + 6);
    }
    assert!(open.open_edges() > 0);
    let solid = bake(&open, 4, Some(SolidMode::Vote));
    check_against_oracle(&open, &closed, 4, &solid, "torus with holes");
}

#[test]
fn interior_leaves_carry_their_material_and_no_normal() {
    let mut m = pinned(Mesh::sphere(DVec3::splat(8.0), 6.0, 4), 16.0);
    m.materials = vec![svo::Material {
        name: "glass".into(),
        colour: [0.2, 0.6, 0.9, 1.0],
        refractivity: 0.8,
        ior: 1.45,
        ..svo::Material::default()
    }];
    m.triangle_materials = vec![0; m.triangles.len()];
    let surface = bake(&m, 4, None);
    let solid = bake(&m, 4, Some(SolidMode::Closed));
    let a = &solid.attributes;
    // One material: the constant channels stay constant; normals become per leaf.
    assert_eq!(a.colour, surface.attributes.colour);
    assert_eq!(a.ior, surface.attributes.ior);
    assert!(a.normal.is_per_leaf() && a.contour.is_per_leaf());
    for l in solid.leaves() {
        let i = l.index as usize;
        match surface.leaf_at(l.cell) {
            Some(j) => {
                assert_eq!(a.get(i), surface.attributes.get(j as usize), "{}", l.cell);
            }
            None => {
                assert_eq!(a.normal.get(i), Some(NO_NORMAL));
                assert_eq!(a.get(i).normal, None);
                // The whole cell: near plane at 0, far at 1 (docs/format.md).
                assert_eq!(a.contour.get(i), Some(0xFFFF_0000));
            }
        }
    }
}

#[test]
fn fills_that_would_not_fit_are_refused() {
    let m = Mesh::cuboid(DVec3::ZERO, DVec3::ONE);
    let depth = 7;
    let surface = BakeOptions {
        depth,
        ..BakeOptions::default()
    };
    let surface_bytes = svo::bake::estimate_bake(&m, &surface).unwrap().bytes;
    // Enough for the surface, far too little for 128^3 interior cells.
    let opts = BakeOptions {
        depth,
        solid: Some(SolidMode::Closed),
        max_memory: Some((surface_bytes * 2.0) as u64),
        ..BakeOptions::default()
    };
    match bake_mesh(&m, &opts) {
        Err(BakeError::TooLarge { leaves, .. }) => assert!(leaves >= 126f64.powi(3), "{leaves}"),
        other => panic!("{:?}", other.map(|(_, s)| s.leaves)),
    }
}

#[cfg(all(feature = "trace", feature = "reference"))]
#[test]
fn solid_trees_render_exactly_like_their_surfaces() {
    use svo::render::Camera;
    use svo::render::OctreeSurfaces;
    use svo::render::Sky;
    use svo::render::render;
    use svo::render::{Phong, PointLight};
    use svo::render::{TraceOptions, Tracer};
    use svo::trace::HitMode;
    let mut m = torus();
    for mat in &mut m.materials {
        mat.refractivity = 0.6;
        mat.reflectivity = 0.2;
        mat.ior = 1.33;
    }
    for mode in [HitMode::Cube, HitMode::Contour] {
        let surface = bake(&m, 6, None);
        let solid = bake(&m, 6, Some(SolidMode::Closed));
        assert!(solid.leaf_count > surface.leaf_count * 2);
        let (lo, hi) = surface.occupied_bounds();
        let cam = Camera::framing(lo, hi, 80, 60, 40.0);
        let light = PointLight {
            position: cam.eye + DVec3::new(0.0, 10.0, 0.0),
            colour: glam::Vec3::ONE,
            intensity: 100.0,
        };
        let frame = |t: &Octree| {
            let tracer = Tracer::new(
                OctreeSurfaces::new(t, mode),
                &[light],
                Sky::default(),
                Phong::default(),
                TraceOptions {
                    mode,
                    ..TraceOptions::default()
                },
            );
            render(&tracer, &cam).unwrap()
        };
        let (a, b) = (frame(&surface), frame(&solid));
        assert!(a.stats.primary_hits > 500);
        assert_eq!(a.colour, b.colour, "{mode:?}");
        assert_eq!(a.depth, b.depth, "{mode:?}");
        assert_eq!(a.normal, b.normal, "{mode:?}");
        // The exact mode (the leaves' triangles) too: interior leaves have none.
        let exact = |t: &Octree| {
            let tracer = Tracer::new(
                svo::render::exact_surfaces(t, &m).unwrap(),
                &[light],
                Sky::default(),
                Phong::default(),
                TraceOptions {
                    mode: HitMode::Exact,
                    ..TraceOptions::default()
                },
            );
            render(&tracer, &cam).unwrap()
        };
        let (a, b) = (exact(&surface), exact(&solid));
        assert!(a.stats.primary_hits > 500);
        assert_eq!(a.colour, b.colour, "exact");
        assert_eq!(a.depth, b.depth, "exact");
    }
}
