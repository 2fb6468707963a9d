//! The bake's bottom levels slice triangles through the grid (`geometry/grid_slice.rs`) and
//! decide the doubtful cells with the exact test; the voxelizer alone tests every candidate
//! cell. Both must give the same cells and contacts: against the exact integer brute force
//! on lattice meshes (where contacts on faces, edges and corners are exact ties), against
//! each other on generic, axis-aligned, huge and offset meshes at depths up to 9, with and
//! without channels, and the leaves' normals against per-contact clipping (the tests' own
//! clipping).

use crate::common;
use common::*;
use glam::{DVec3, Vec3};
use rand::Rng;
use std::collections::{BTreeMap, BTreeSet};
use svo::mesh::Mesh;
use svo::{BakeOptions, Strategy, bake_mesh};

fn mesh_of(tris: &[[DVec3; 3]]) -> Mesh {
    let mut m = Mesh::default();
    for t in tris {
        let b = m.positions.len() as u32;
        m.positions.extend_from_slice(t);
        m.triangles.push([b, b + 1, b + 2]);
    }
    m
}

/// The baked tree's cells and contact count against the voxelizer's leaves, and each
/// leaf's normal against the area-weighted normal from clipping every contact.
fn check_against_voxelizer(mesh: &Mesh, depth: u8, what: &str) -> usize {
    let opts = BakeOptions {
        depth,
        ..Default::default()
    };
    let (tree, stats) = bake_mesh(mesh, &opts).unwrap();
    let (root, leaves) = svo::bake::voxelize_mesh(mesh, depth, Strategy::Exact).unwrap();
    let expect: BTreeMap<[u32; 3], usize> = (0..leaves.cells.len())
        .map(|i| (leaves.cells[i], i))
        .collect();
    let got: BTreeSet<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
    let want: BTreeSet<[u32; 3]> = expect.keys().copied().collect();
    // Both decide every doubtful contact exactly, so they agree cell for cell (and both
    // agree with the exact oracle: `exact_oracle.rs`).
    let extra: Vec<_> = got.difference(&want).take(5).collect();
    let missing: Vec<_> = want.difference(&got).take(5).collect();
    assert!(
        extra.is_empty() && missing.is_empty(),
        "{what} at depth {depth}: cells beyond the voxelizer's {extra:?}, missing {missing:?}"
    );
    assert_eq!(
        stats.leaf_triangle_pairs,
        leaves.tris.len(),
        "{what}: contacts differ at depth {depth}"
    );
    assert_voxel_set_alone(mesh, depth, &got, stats.leaf_triangle_pairs, what);
    // Normals: clip each contact to its cell and weigh the unit normals by the areas.
    let mut worst = 0.0f64;
    for leaf in tree.leaves() {
        let i = expect[&leaf.cell.to_array()];
        let m = leaf.cell.as_dvec3();
        let mut s = DVec3::ZERO;
        let mut wsum = 0.0;
        let mut units = Vec::new();
        for &t in leaves.triangles(i) {
            let tri = mesh.triangles[t as usize]
                .map(|k| root.to_grid(mesh.positions[k as usize], depth) - m);
            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            let a = clipped_area(tri);
            if n.length() > 0.0 {
                s += n.normalize() * a;
                units.push(n.normalize());
            }
            wsum += a;
        }
        // Only leaves with a well-defined weighted normal: opposite sheets that cancel, and
        // contacts of no area, take fallbacks whose choice rounding may flip.
        if wsum <= 1e-9 || s.length() < 0.5 * wsum {
            continue;
        }
        let want = s.normalize();
        let got: Vec3 = tree.attributes.get(leaf.index as usize).normal.unwrap();
        // 2 asin(chord / 2) in f64: acos of a dot product near 1 has no precision.
        let chord = (got.as_dvec3().normalize() - want).length();
        let angle = 2.0 * (chord / 2.0).asin();
        worst = worst.max(angle);
    }
    // The octahedral snorm16 encoding alone is within 0.004 degrees.
    assert!(
        worst.to_degrees() < 0.01,
        "{what}: normal off by {} degrees at depth {depth}",
        worst.to_degrees()
    );
    tree.leaf_count as usize
}

/// Checks the baked tree's cells and contact count against the brute force.
fn check_lattice(tris: &[[I3; 3]], depth: u8, what: &str) {
    let mesh = mesh_of(&tris.iter().map(|t| t.map(to_f)).collect::<Vec<_>>());
    let expect = lattice_brute_force(tris, depth);
    let opts = BakeOptions {
        depth,
        ..Default::default()
    };
    let (tree, stats) = bake_mesh(&mesh, &opts).unwrap();
    let got: BTreeSet<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
    let want: BTreeSet<[u32; 3]> = expect.keys().copied().collect();
    let missed: Vec<_> = want.difference(&got).collect();
    let extra: Vec<_> = got.difference(&want).collect();
    assert!(
        missed.is_empty() && extra.is_empty(),
        "{what} depth {depth}: missed {missed:?}, extra {extra:?}"
    );
    let pairs: usize = expect.values().map(BTreeSet::len).sum();
    assert_eq!(stats.leaf_triangle_pairs, pairs, "{what} depth {depth}");
    assert_voxel_set_alone(&mesh, depth, &want, pairs, what);
}

/// The bake without channels (which slices without keeping the parts' areas or points)
/// makes the cells `cells` and `pairs` contacts too.
fn assert_voxel_set_alone(
    mesh: &Mesh,
    depth: u8,
    cells: &BTreeSet<[u32; 3]>,
    pairs: usize,
    what: &str,
) {
    let opts = BakeOptions {
        depth,
        channels: svo::ChannelSelection::NONE,
        ..Default::default()
    };
    let (tree, stats) = bake_mesh(mesh, &opts).unwrap();
    let got: BTreeSet<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
    assert!(
        &got == cells,
        "{what} depth {depth}: the bake without channels differs"
    );
    assert_eq!(
        stats.leaf_triangle_pairs, pairs,
        "{what} depth {depth}, no channels"
    );
}

/// Two contacts that an earlier slicing lost (found by fuzzing and by the tree-structure
/// test): a vertical triangle whose edge runs exactly along a cell edge (the cut points on
/// it round a hair off the edge, so the diagonal neighbour touched along the edge got no
/// part), and a near-degenerate sliver whose long edge passes exactly through a cell corner.
#[test]
fn contacts_along_cell_edges_and_at_corners() {
    let pin = [
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
        [[64, 64, 64], [63, 64, 64], [64, 63, 64]],
    ];
    let mut edge = pin.to_vec();
    edge.push([[0, 0, 0], [64, 0, 7], [47, 61, 10]]);
    edge.push([[20, 64, 16], [60, 0, 16], [60, 0, 64]]);
    for depth in 1..=6 {
        check_lattice(&edge, depth, "edge along a cell edge");
    }
    let mut corner = pin.to_vec();
    corner.push([[62, 5, 42], [32, 15, 17], [47, 10, 30]]);
    for depth in 1..=7 {
        check_lattice(&corner, depth, "sliver through a corner");
    }
}

#[test]
fn lattice_meshes_equal_the_brute_force() {
    for seed in 0..16u64 {
        let mut r = rng(500 + seed);
        let mut tris: Vec<[I3; 3]> = vec![
            [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
            [[64, 64, 64], [63, 64, 64], [64, 63, 64]],
        ];
        for _ in 0..14 {
            tris.push(rand_triangle(&mut r, 0, 64).map(|p| p.map(|c| c.clamp(0, 64))));
        }
        for depth in 1..=6u8 {
            check_lattice(&tris, depth, &format!("seed {seed}"));
        }
    }
}

#[test]
fn generic_meshes_match_the_voxelizer() {
    let mut leaves = 0;
    for seed in 0..6u64 {
        let mut r = rng(700 + seed);
        let mut tris = Vec::new();
        for k in 0..60 {
            let c = DVec3::new(r.random(), r.random(), r.random());
            // Small, medium and root-spanning triangles.
            let size = [0.01, 0.1, 0.8][k % 3];
            tris.push([0; 3].map(|_| {
                c + DVec3::new(
                    r.random_range(-size..size),
                    r.random_range(-size..size),
                    r.random_range(-size..size),
                )
            }));
        }
        let mesh = mesh_of(&tris);
        for depth in [3u8, 4, 6, 8] {
            leaves += check_against_voxelizer(&mesh, depth, &format!("seed {seed}"));
        }
        // The same mesh far from the origin and at a huge scale.
        let far = mesh_of(
            &tris
                .iter()
                .map(|t| t.map(|p| p * 1e5 + DVec3::splat(3.3e7)))
                .collect::<Vec<_>>(),
        );
        leaves += check_against_voxelizer(&far, 7, &format!("seed {seed}, far"));
    }
    assert!(leaves > 10_000, "{leaves} leaves: the meshes are too small");
}

/// Geometry on the grid's planes: a box whose faces lie on cell faces, triangles along
/// cell edges and through cell corners, a fan around a grid vertex, and needles along the
/// grid lines, at depths where they cross many bottom blocks.
#[test]
fn grid_aligned_geometry_matches_the_voxelizer() {
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let mut tris = Vec::new();
    // The root is [0, 64]^3 (pinned by two specks); at depth 6 a cell is 1 unit.
    tris.push([v(0.0, 0.0, 0.0), v(0.5, 0.0, 0.0), v(0.0, 0.5, 0.0)]);
    tris.push([
        v(64.0, 64.0, 64.0),
        v(63.5, 64.0, 64.0),
        v(64.0, 63.5, 64.0),
    ]);
    // A box [8, 40] x [16, 48] x [24, 56], two triangles per face.
    let (lo, hi) = (v(8.0, 16.0, 24.0), v(40.0, 48.0, 56.0));
    for axis in 0..3 {
        for side in [lo[axis], hi[axis]] {
            let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f64, b: f64| {
                let mut p = DVec3::ZERO;
                p[axis] = side;
                p[u] = a;
                p[w] = b;
                p
            };
            let (a0, a1, b0, b1) = (lo[u], hi[u], lo[w], hi[w]);
            tris.push([corner(a0, b0), corner(a1, b0), corner(a1, b1)]);
            tris.push([corner(a0, b0), corner(a1, b1), corner(a0, b1)]);
        }
    }
    // Diagonals through cell corners and along cell edges.
    tris.push([v(2.0, 2.0, 2.0), v(30.0, 30.0, 30.0), v(30.0, 30.0, 2.0)]);
    tris.push([v(3.0, 5.0, 7.0), v(33.0, 5.0, 7.0), v(33.0, 5.0, 37.0)]);
    tris.push([
        v(10.0, 10.0, 10.0),
        v(50.0, 10.0, 10.0),
        v(50.0, 10.5, 10.0),
    ]);
    // A fan around the grid vertex (32, 32, 32).
    for k in 0..8 {
        let a = f64::from(k) * std::f64::consts::FRAC_PI_4;
        let b = a + std::f64::consts::FRAC_PI_4;
        let c = v(32.0, 32.0, 32.0);
        tris.push([
            c,
            c + v(a.cos(), a.sin(), 0.3) * 9.0,
            c + v(b.cos(), b.sin(), -0.2) * 9.0,
        ]);
    }
    // Half-integer planes, and a triangle touching cells only at a vertex on a corner.
    tris.push([v(4.5, 4.5, 60.0), v(60.5, 4.5, 60.0), v(4.5, 60.5, 60.0)]);
    tris.push([
        v(20.0, 20.0, 20.0),
        v(19.5, 19.0, 19.25),
        v(19.0, 19.5, 19.75),
    ]);
    let mesh = mesh_of(&tris);
    for depth in [5u8, 6, 7, 8, 9] {
        check_against_voxelizer(&mesh, depth, "grid-aligned");
    }
}

/// Vertices a hair beyond a cell face (1e-11 cells: outside the cell by far more than the
/// exact test's rounding bound, yet within the slicing's tolerance): the slicing gives the
/// cell across the face a part, and the exact test that decides it must also reject it on
/// the box's own axis (an earlier version asked only the plane and the nine edge axes, which
/// do not separate such a cell, and kept a cell that no triangle touches; the bunny at
/// depth 8 has a vertex 6e-6 cells off a face that way).
#[test]
fn vertices_a_hair_beyond_a_cell_face_add_no_cell() {
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    // The root is [0, 16]^3 (pinned by two specks); at depth 4 a cell is 1 unit.
    let specks = vec![
        [v(0.0, 0.0, 0.0), v(0.25, 0.0, 0.0), v(0.0, 0.25, 0.0)],
        [
            v(16.0, 16.0, 16.0),
            v(15.75, 16.0, 16.0),
            v(16.0, 15.75, 16.0),
        ],
    ];
    let fan = [
        v(5.361730004688534, 7.749002883769322, 10.158677961965054),
        v(5.083860525758029, 10.003198479116747, 8.512835663684427),
        v(5.185800807969207, 12.252461480163646, 10.129082396161834),
        v(5.169358826967408, 10.014707865818025, 11.7897224773441),
    ];
    for hair in [1e-11, -1e-11, 1e-13] {
        let mut tris = specks.clone();
        // Triangles around a vertex just beyond (or before) the face x = 5 of the cell
        // (4, 10, 10), reaching away from it along x, and their mirror images across the
        // face y = 10.
        let apex = v(5.0 + hair, 10.006486875317108, 10.148812773364);
        for k in 0..4 {
            tris.push([apex, fan[k], fan[(k + 1) % 4]]);
            let flip = |p: DVec3| v(p.x, 20.0 - p.y, p.z);
            tris.push([flip(apex), flip(fan[k]), flip(fan[(k + 1) % 4])]);
        }
        let mesh = mesh_of(&tris);
        for depth in [4u8, 5, 6] {
            check_against_voxelizer(&mesh, depth, &format!("hair {hair:e}"));
        }
    }
}
