//! Depths 1 to 20 for a single small triangle, a thin sliver and a bundle of long thin
//! triangles: the tree grows with the surface (leaves about 4x per level for a triangle wider
//! than a cell, 2x for a sliver thinner than one), nodes stay a fraction of the leaves, and
//! every leaf is a cell the triangles touch (checked with the conservative test on its own
//! triangles, and against a direct count for the sliver). Memory and time are measured per
//! leaf in the benchmark report; this checks that nothing but the leaves grows.

use glam::DVec3;
use svo::{BakeOptions, Mesh, bake_mesh};

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

/// Leaves of the mesh at depths 1..=20 (the two anchor cells excluded), with sanity checks
/// of the tree's shape at each depth; `pieces` is how many separate parts the mesh has
/// (each needs its own path of nodes from the root).
fn leaves_per_depth(mesh: &Mesh, pieces: usize) -> Vec<usize> {
    (1..=20u8)
        .map(|depth| {
            let opts = BakeOptions {
                depth,
                ..Default::default()
            };
            let (tree, stats) = bake_mesh(mesh, &opts).unwrap();
            assert_eq!(stats.false_positives, 0);
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
