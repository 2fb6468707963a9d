//! Depths 1 to 20 for a single small triangle, a thin sliver and a bundle of long thin
//! triangles: at every depth the leaves are exactly the cells the triangles touch (the exact
//! big-integer oracle of `tests/src/oracle.rs`, which shares no code with the library, descends
//! to depth 20 once and gives the touched cells of every level), the tree grows with the
//! surface (leaves about 4x per level for a triangle wider than a cell, 2x for a sliver thinner
//! than one), and nodes stay a fraction of the leaves. Memory and time are measured per leaf
//! in the benchmark report; this checks that nothing but the leaves grows.

use crate::common;
use common::oracle::{grid_triangles, touched_cells};
use glam::DVec3;
use std::collections::BTreeSet;
use svo::{BakeOptions, Mesh, bake_mesh};

const DEEPEST: u8 = 20;

/// `tris` plus a point-sized triangle at `(1, 1, 1)`, so the root is the unit cube whatever
/// the triangles span (grid coordinates are then exact binary fractions).
fn anchored(tris: &[[DVec3; 3]]) -> Mesh {
    let mut positions = vec![
        DVec3::ZERO,
        DVec3::ZERO,
        DVec3::ZERO,
        DVec3::ONE,
        DVec3::ONE,
        DVec3::ONE,
    ];
    let mut triangles = vec![[0, 1, 2], [3, 4, 5]];
    for t in tris {
        let b = positions.len() as u32;
        positions.extend_from_slice(t);
        triangles.push([b, b + 1, b + 2]);
    }
    Mesh::from_triangles(positions, triangles)
}

/// Leaves of the mesh at depths 1..=20 (the two anchor cells excluded), each depth's leaf
/// cells checked against the oracle's, with sanity checks of the tree's shape; `pieces` is
/// how many separate parts the mesh has (each needs its own path of nodes from the root).
fn leaves_per_depth(mesh: &Mesh, pieces: usize) -> Vec<usize> {
    // The root is the unit cube at every depth (the anchors), so grid coordinates at depth
    // 20 hold every shallower grid's, scaled by a power of two.
    let tris = grid_triangles(&mesh.positions, &mesh.triangles, DVec3::ZERO, 1.0, DEEPEST);
    let oracle = touched_cells(&tris, DEEPEST);
    (1..=DEEPEST)
        .map(|depth| {
            let opts = BakeOptions {
                depth,
                ..Default::default()
            };
            let (tree, _) = bake_mesh(mesh, &opts).unwrap();
            assert_eq!((tree.root.origin, tree.root.side), (DVec3::ZERO, 1.0));
            let cells: BTreeSet<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
            let want: BTreeSet<[u32; 3]> = oracle[usize::from(depth)].keys().copied().collect();
            if cells != want {
                let missing: Vec<_> = want.difference(&cells).take(4).collect();
                let extra: Vec<_> = cells.difference(&want).take(4).collect();
                panic!(
                    "depth {depth}: {} touched cells missing ({missing:?}), {} leaves not \
                     touched ({extra:?}), of {}",
                    want.difference(&cells).count(),
                    cells.difference(&want).count(),
                    want.len()
                );
            }
            let leaves = tree.leaf_count as usize;
            // Inner nodes: at most about one per leaf (a line of cells has about one parent
            // per two leaves, a grandparent per four, ...), plus a path from the root to each
            // separate part (the anchors are two more).
            assert!(
                tree.nodes.len() <= 2 * leaves + (pieces + 2) * usize::from(depth),
                "depth {depth}: {} nodes for {leaves} leaves",
                tree.nodes.len()
            );
            // The two anchors touch one cell each at the root's corners (the origin's cell
            // may also hold the triangles' cells at shallow depths).
            leaves.saturating_sub(2)
        })
        .collect()
}

fn ratios(v: &[usize], from_depth: usize) -> Vec<f64> {
    (from_depth..v.len())
        .map(|i| v[i] as f64 / v[i - 1].max(1) as f64)
        .collect()
}

#[test]
fn a_small_triangle_grows_with_its_area() {
    // Legs of 2^-12 of the root, away from the anchors and from cell corners (0.37, 0.41 and
    // 0.53 are no binary fractions): at depth 20 they span 256 cells.
    let (a, s) = (DVec3::new(0.37, 0.41, 0.53), 1.0 / 4096.0);
    let mesh = anchored(&[[a, a + DVec3::new(s, 0.0, 0.0), a + DVec3::new(0.0, s, s)]]);
    let n = leaves_per_depth(&mesh, 1);
    for w in n.windows(2) {
        assert!(w[1] >= w[0], "leaves fell with depth: {n:?}");
    }
    // Once the triangle is many cells wide, each level multiplies the leaves by about 4.
    for r in ratios(&n, 16) {
        assert!((3.5..4.5).contains(&r), "area scaling {r} in {n:?}");
    }
    assert!(n[19] > 256 * 256 / 2, "{n:?}");
}

#[test]
fn a_sliver_grows_with_its_length() {
    // 2^-6 long along x, 1e-12 wide: a line of cells at every depth. Its y and z (0.41,
    // 0.53) are no binary fraction of 20 digits, so they are inside a cell at every depth.
    let a = DVec3::new(0.3125, 0.41, 0.53);
    let mesh = anchored(&[[
        a,
        a + DVec3::new(1.0 / 64.0, 0.0, 0.0),
        a + DVec3::new(0.5 / 64.0, 1e-12, 0.0),
    ]]);
    let n = leaves_per_depth(&mesh, 1);
    for r in ratios(&n, 10) {
        assert!((1.8..2.2).contains(&r), "length scaling {r} in {n:?}");
    }
    // The sliver lies inside one row of cells (y and z strictly inside a cell at every
    // depth up to 20), so it touches exactly the cells its x-extent covers, closed.
    let cells_along = |d: u32| {
        let k = f64::from(1u32 << d);
        let (x0, x1) = (a.x * k, (a.x + 1.0 / 64.0) * k);
        // Closed cells: cell i meets [x0, x1] iff i <= x1 and i + 1 >= x0.
        (x1.floor() - (x0.ceil() - 1.0) + 1.0) as usize
    };
    assert_eq!(n[19], cells_along(20), "{n:?}");
}

#[test]
fn long_thin_triangles_cost_their_cells_only() {
    // Eight needles in different directions, about 2^-6 of the root long, 1e-9 wide.
    let mut tris = Vec::new();
    for k in 0..8 {
        let t = f64::from(k) / 8.0;
        let a = DVec3::new(0.05 + 0.1 * t, 0.1, 0.2 + 0.05 * t);
        let b = a + (DVec3::new(0.9 - 0.1 * t, 0.85, 0.7 - 0.3 * t) - a) / 64.0;
        tris.push([a, b, a + DVec3::new(0.0, 1e-9, 0.0)]);
    }
    let n = leaves_per_depth(&anchored(&tris), tris.len());
    // Lines: about 2x per level once cells are finer than the needles' spacing.
    for r in ratios(&n, 12) {
        assert!((1.8..2.2).contains(&r), "length scaling {r} in {n:?}");
    }
}
