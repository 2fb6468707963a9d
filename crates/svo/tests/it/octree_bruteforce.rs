//! The whole octree against brute force (every cell x every triangle, exact integer SAT) on
//! small seeded meshes, for every strategy at several depths: exact strategies give exactly
//! the touched cells with exactly the touching triangles; the others give supersets.

use crate::common;
use common::*;
use glam::{DVec3, UVec3};
use rand::Rng;
use std::collections::{BTreeMap, BTreeSet};
use svo::Strategy;
use svo::bake::voxelize_mesh;
use svo::mesh::Mesh;

/// A random mesh on the 1/16 lattice inside `[0, 4]^3`, with two tiny triangles pinning the
/// bounds to exactly that cube (so grid space is an exact scaling of the lattice).
fn lattice_mesh(seed: u64, n: usize) -> (Mesh, Vec<[[i128; 3]; 3]>) {
    let mut r = rng(seed);
    let mut tris = vec![
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
        [[64, 64, 64], [63, 64, 64], [64, 63, 64]],
    ];
    for _ in 0..n {
        let t = rand_triangle(&mut r, 0, 64).map(|p| p.map(|c| c.clamp(0, 64)));
        // keep a share of the triangles small, like a real mesh
        if r.random_bool(0.5) {
            let c = t[0];
            let shrink = |p: [i128; 3]| {
                [
                    c[0] + (p[0] - c[0]) / 8,
                    c[1] + (p[1] - c[1]) / 8,
                    c[2] + (p[2] - c[2]) / 8,
                ]
            };
            tris.push([c, shrink(t[1]), shrink(t[2])]);
        } else {
            tris.push(t);
        }
    }
    let mut mesh = Mesh::default();
    for t in &tris {
        let b = mesh.positions.len() as u32;
        mesh.positions.extend(t.iter().map(|&p| to_f(p)));
        mesh.triangles.push([b, b + 1, b + 2]);
    }
    (mesh, tris)
}

#[test]
fn octree_equals_brute_force_for_every_strategy() {
    for seed in 0..6u64 {
        let (mesh, tris) = lattice_mesh(100 + seed, 12 + 4 * seed as usize);
        for depth in 1..=5u8 {
            let expect = lattice_brute_force(&tris, depth);
            for strategy in Strategy::ALL {
                let (root, leaves) = voxelize_mesh(&mesh, depth, strategy).unwrap();
                assert_eq!(root.origin, DVec3::ZERO);
                assert_eq!(root.side, 4.0);
                let got: BTreeMap<[u32; 3], BTreeSet<u32>> = (0..leaves.cells.len())
                    .map(|i| {
                        (
                            leaves.cells[i],
                            leaves.triangles(i).iter().copied().collect(),
                        )
                    })
                    .collect();
                assert_eq!(got.len(), leaves.cells.len(), "duplicate leaf cells");
                if strategy.is_exact() {
                    assert_eq!(got, expect, "seed {seed} depth {depth} {strategy}");
                } else {
                    for (cell, ts) in &expect {
                        let g = got
                            .get(cell)
                            .unwrap_or_else(|| panic!("{strategy} missed {cell:?}"));
                        assert!(g.is_superset(ts), "{strategy} lost triangles at {cell:?}");
                    }
                }
            }
        }
    }
}

/// The bake's false-positive count for an inexact strategy is exactly the cells it keeps
/// that the brute force says no triangle touches.
#[test]
fn inexact_strategies_count_their_false_positives() {
    let mut seen = 0;
    for seed in 0..4u64 {
        let (mesh, tris) = lattice_mesh(300 + seed, 16);
        for depth in 2..=5u8 {
            let expect = lattice_brute_force(&tris, depth);
            for strategy in Strategy::ALL {
                let opts = svo::BakeOptions {
                    depth,
                    strategy,
                    ..Default::default()
                };
                let (tree, stats) = svo::bake_mesh(&mesh, &opts).unwrap();
                let extra = tree
                    .leaves()
                    .filter(|l| !expect.contains_key(&l.cell.to_array()))
                    .count();
                assert_eq!(
                    stats.false_positives, extra,
                    "seed {seed} depth {depth} {strategy}"
                );
                seen += extra;
            }
        }
    }
    assert!(
        seen > 0,
        "the meshes made no false positive: the test checks nothing"
    );
}

/// Hand-made soups the random meshes rarely make: the same triangle three times (two with
/// their vertices rotated or reversed), needles spanning the whole root along its diagonal
/// and along a face, a fin of four triangles sharing one edge (non-manifold), a near-
/// collinear triangle, and an open strip; every strategy against the brute force at depths
/// 1 to 5, each triangle's own cells included.
#[test]
fn duplicate_needle_and_non_manifold_triangles_equal_brute_force() {
    let t = |a: [i128; 3], b: [i128; 3], c: [i128; 3]| [a, b, c];
    let mut tris = vec![
        // Pin the root to [0, 4]^3 exactly.
        t([0, 0, 0], [1, 0, 0], [0, 1, 0]),
        t([64, 64, 64], [63, 64, 64], [64, 63, 64]),
        // Duplicates.
        t([5, 7, 9], [40, 12, 30], [20, 50, 11]),
        t([40, 12, 30], [20, 50, 11], [5, 7, 9]),
        t([20, 50, 11], [40, 12, 30], [5, 7, 9]),
        // Needles: the root's diagonal, and along the face z = 0 at y = 32 (a cell boundary).
        t([0, 0, 0], [64, 64, 64], [64, 64, 63]),
        t([0, 32, 0], [64, 32, 0], [64, 33, 0]),
        // Near-collinear: the third vertex one lattice step off the line.
        t([3, 3, 3], [61, 35, 19], [32, 19, 12]),
    ];
    // A fin: four triangles around the edge (16, 16, 16)-(48, 16, 16).
    for apex in [[32, 40, 16], [32, 16, 40], [32, 0, 16], [32, 16, 0]] {
        tris.push(t([16, 16, 16], [48, 16, 16], apex));
    }
    // An open strip of triangles along x on the plane y = 48.
    for k in 0..6 {
        let x = 8 * k;
        tris.push(t([x, 48, 10], [x + 8, 48, 10], [x, 48, 30]));
        tris.push(t([x + 8, 48, 10], [x + 8, 48, 30], [x, 48, 30]));
    }
    let mut mesh = Mesh::default();
    for tri in &tris {
        let b = mesh.positions.len() as u32;
        mesh.positions.extend(tri.iter().map(|&p| to_f(p)));
        mesh.triangles.push([b, b + 1, b + 2]);
    }
    for depth in 1..=5u8 {
        let expect = lattice_brute_force(&tris, depth);
        for strategy in Strategy::ALL {
            let (_, leaves) = voxelize_mesh(&mesh, depth, strategy).unwrap();
            let got: BTreeMap<[u32; 3], BTreeSet<u32>> = (0..leaves.cells.len())
                .map(|i| {
                    (
                        leaves.cells[i],
                        leaves.triangles(i).iter().copied().collect(),
                    )
                })
                .collect();
            if strategy.is_exact() {
                assert_eq!(got, expect, "depth {depth} {strategy}");
            } else {
                for (cell, ts) in &expect {
                    assert!(
                        got.get(cell).is_some_and(|g| g.is_superset(ts)),
                        "depth {depth} {strategy} lost {cell:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn tree_structure_matches_leaf_cells() {
    let (mesh, _) = lattice_mesh(42, 40);
    for depth in 1..=6u8 {
        let opts = svo::BakeOptions {
            depth,
            ..Default::default()
        };
        let (tree, _) = svo::bake_mesh(&mesh, &opts).unwrap();
        tree.validate().unwrap();
        let (_, leaves) = voxelize_mesh(&mesh, depth, Strategy::Exact).unwrap();
        // Iteration yields leaf indices in array order with the voxelizer's cells.
        let it: Vec<_> = tree.leaves().collect();
        assert_eq!(it.len(), leaves.cells.len());
        for (i, l) in it.iter().enumerate() {
            assert_eq!(l.index as usize, i);
            assert_eq!(l.cell.to_array(), leaves.cells[i]);
            assert_eq!(tree.leaf_at(l.cell), Some(l.index));
        }
        // Cells that are not leaves are not found.
        let set: BTreeSet<[u32; 3]> = leaves.cells.iter().copied().collect();
        let n = 1u32 << depth;
        for x in 0..n.min(16) {
            for y in 0..n.min(16) {
                for z in 0..n.min(16) {
                    let c = UVec3::new(x, y, z);
                    assert_eq!(tree.leaf_at(c).is_some(), set.contains(&c.to_array()));
                }
            }
        }
        assert_eq!(tree.leaf_at(UVec3::splat(n)), None);
    }
}

#[test]
fn degenerate_triangles_mark_their_cells() {
    // A mesh of only a segment and a point still voxelizes: the root comes from their bounds.
    let mesh = Mesh::from_triangles(
        vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(0.5, 0.5, 0.5),
            DVec3::new(0.25, 0.75, 0.5),
        ],
        vec![[0, 1, 2], [3, 3, 3]],
    );
    let (_, leaves) = voxelize_mesh(&mesh, 3, Strategy::Exact).unwrap();
    let cells: BTreeSet<[u32; 3]> = leaves.cells.iter().copied().collect();
    // The diagonal passes through the 8 diagonal cells and touches their corner neighbours.
    for i in 0..8 {
        assert!(cells.contains(&[i, i, i]), "diagonal cell {i}");
    }
    // The point (0.25, 0.75, 0.5) sits on the corner of cells (2,6,4) and neighbours.
    assert!(cells.contains(&[2, 6, 4]) && cells.contains(&[1, 5, 3]));
}

#[test]
fn axis_aligned_box_fitting_the_root_exactly() {
    // The faces of a box that is the root cube: every boundary cell, no interior cell
    // (cuda_voxelizer's known bug drops the far faces).
    let p: Vec<DVec3> = (0..8)
        .map(|i| {
            DVec3::new(
                f64::from(i >> 2 & 1),
                f64::from(i >> 1 & 1),
                f64::from(i & 1),
            )
        })
        .collect();
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let tris: Vec<[u32; 3]> = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    let mesh = Mesh::from_triangles(p, tris);
    for depth in 1..=6u8 {
        let (_, leaves) = voxelize_mesh(&mesh, depth, Strategy::Exact).unwrap();
        let n = 1u32 << depth;
        let boundary = |c: &[u32; 3]| c.iter().any(|&v| v == 0 || v == n - 1);
        assert!(
            leaves.cells.iter().all(boundary),
            "interior cell at depth {depth}"
        );
        let expect = u64::from(n).pow(3) - u64::from(n).saturating_sub(2).pow(3);
        assert_eq!(leaves.cells.len() as u64, expect, "depth {depth}");
    }
}

#[test]
fn exact_scale_and_offset_give_identical_cells() {
    // Power-of-two scales and offsets keep every coordinate exact, so the cells, contacts
    // on cell faces included, must be identical.
    let (mesh, _) = lattice_mesh(9, 30);
    let (_, base) = voxelize_mesh(&mesh, 6, Strategy::Exact).unwrap();
    for (scale, offset) in [
        (2f64.powi(-20), 0.0),
        (2f64.powi(20), 0.0),
        (1.0, 2f64.powi(20)),
        (2f64.powi(-10), -2f64.powi(10)),
    ] {
        let mut m = mesh.clone();
        for p in &mut m.positions {
            *p = *p * scale + DVec3::splat(offset);
        }
        let (_, l) = voxelize_mesh(&m, 6, Strategy::Exact).unwrap();
        assert_eq!(l.cells, base.cells, "scale {scale} offset {offset}");
        assert_eq!(l.tris, base.tris, "scale {scale} offset {offset}");
    }
}

#[test]
fn generic_mesh_cells_survive_scale_and_offset() {
    // A mesh with generic coordinates under scales of 1e-6 and 1e6 and offsets of 1e7 with
    // a small extent, as georeferenced data has: the bake's cells are exactly the oracle's
    // for the coordinates the transform produced. A scaling rounds a coordinate by about
    // 1e-14 of a cell at depth 6, far below a contact's distance from a tie, so the cells are
    // the untransformed mesh's. An offset of 1e7 rounds each coordinate by up to 1e-9 (about
    // 1e-5 of a cell when the extent is 1e-2, and 6e-8 when it is 1), and a contact that
    // close to a tie may flip: at most one cell in 5,000 of the 48,300 may differ (0 to 2
    // over the seeds a soak tried).
    let mut r = rng(77);
    let mut mesh = Mesh::default();
    for i in 0..60u32 {
        for _ in 0..3 {
            mesh.positions.push(DVec3::new(
                r.random::<f64>(),
                r.random::<f64>(),
                r.random::<f64>(),
            ));
        }
        mesh.triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let (_, base) = voxelize_mesh(&mesh, 6, Strategy::Exact).unwrap();
    let base_cells: BTreeSet<[u32; 3]> = base.cells.iter().copied().collect();
    for (scale, offset, may_flip) in [
        (1e-6, 0.0, false),
        (1e6, 0.0, false),
        (1e-2, 1e7, true),
        (1.0, -1e7, true),
    ] {
        let mut m = mesh.clone();
        for p in &mut m.positions {
            *p = *p * scale + DVec3::splat(offset);
        }
        let (root, l) = voxelize_mesh(&m, 6, Strategy::Exact).unwrap();
        let tris = oracle::grid_triangles(&m.positions, &m.triangles, root.origin, root.side, 6);
        let want: BTreeSet<[u32; 3]> = oracle::touched_cells(&tris, 6)[6].keys().copied().collect();
        let cells: BTreeSet<[u32; 3]> = l.cells.iter().copied().collect();
        assert_eq!(
            cells, want,
            "scale {scale} offset {offset}: not the oracle's cells"
        );
        let moved = cells.symmetric_difference(&base_cells).count();
        let allowed = if may_flip { base_cells.len() / 5000 } else { 0 };
        assert!(
            moved <= allowed,
            "scale {scale} offset {offset}: {moved} of {} cells differ from the untransformed mesh's",
            base_cells.len()
        );
    }
}
