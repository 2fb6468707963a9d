//! The bake held to the exact oracle ([`crate::oracle`]): the cells a bake keeps are exactly
//! those its triangles touch, every strategy's triangle lists agree, and the size estimate's
//! bound holds.

use crate::oracle::{grid_triangles, touched_cells};
use std::collections::{BTreeMap, BTreeSet};
use svo::bake::voxelize_mesh;
use svo::{BakeOptions, Mesh, Strategy, bake_mesh};

/// Bakes `mesh` at `depth` and checks it against the oracle; returns the number of cells.
/// The size estimate's `max_leaves` must be at least the oracle's leaf count for every mesh;
/// where `general` (no triangle laid along cell faces and edges, which touch more cells than
/// their area and perimeter count), so must its `leaves`.
pub fn check(mesh: &Mesh, depth: u8, what: &str, general: bool) -> usize {
    let (tree, _) = bake_mesh(
        mesh,
        &BakeOptions {
            depth,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{what}: {e}"));
    let (origin, side) = (tree.root.origin, tree.root.side);
    let tris = grid_triangles(&mesh.positions, &mesh.triangles, origin, side, depth);
    let oracle = touched_cells(&tris, depth);
    let want = &oracle[usize::from(depth)];
    let got: BTreeSet<[u32; 3]> = tree.leaves().map(|l| l.cell.to_array()).collect();
    let want_cells: BTreeSet<[u32; 3]> = want.keys().copied().collect();
    assert_eq!(
        got.len(),
        tree.leaf_count as usize,
        "{what}: duplicate leaves"
    );
    compare_cells(&got, &want_cells, &format!("{what}, bake at depth {depth}"));
    let opts = BakeOptions {
        depth,
        ..Default::default()
    };
    let estimate = svo::bake::estimate_bake(mesh, &opts).unwrap();
    let touched = want_cells.len() as f64;
    assert!(
        estimate.max_leaves >= touched && estimate.max_leaves >= estimate.leaves,
        "{what}: at most {} leaves (estimated {}), the oracle finds {touched}",
        estimate.max_leaves,
        estimate.leaves
    );
    assert!(
        !general || estimate.leaves >= touched,
        "{what}: estimated {} leaves, the oracle finds {touched}",
        estimate.leaves
    );

    for strategy in Strategy::ALL {
        let (root, leaves) = voxelize_mesh(mesh, depth, strategy).unwrap();
        assert_eq!((root.origin, root.side), (origin, side), "{what}: root");
        let lists: BTreeMap<[u32; 3], Vec<u32>> = leaves
            .cells
            .iter()
            .enumerate()
            .map(|(i, &c)| (c, leaves.triangles(i).to_vec()))
            .collect();
        let label = format!("{what}, {strategy} at depth {depth}");
        if strategy.is_exact() {
            if &lists != want {
                let cells: BTreeSet<[u32; 3]> = lists.keys().copied().collect();
                compare_cells(&cells, &want_cells, &label);
                let (c, l) = lists.iter().find(|(c, l)| want.get(*c) != Some(l)).unwrap();
                panic!("{label}: cell {c:?} lists {l:?}, the oracle {:?}", want[c]);
            }
        } else {
            for (c, l) in want {
                let mine = lists.get(c).map_or(&[][..], Vec::as_slice);
                assert!(
                    l.iter().all(|t| mine.contains(t)),
                    "{label}: cell {c:?} lacks some of {l:?}"
                );
            }
        }
    }
    want.len()
}

/// Panics naming up to five missing and five extra cells unless `got` is `want`.
pub fn compare_cells(got: &BTreeSet<[u32; 3]>, want: &BTreeSet<[u32; 3]>, what: &str) {
    let missing: Vec<_> = want.difference(got).take(5).collect();
    let extra: Vec<_> = got.difference(want).take(5).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "{what}: {} cells touched but missing (e.g. {missing:?}), {} kept but not touched \
         (e.g. {extra:?}) of {}",
        want.difference(got).count(),
        got.difference(want).count(),
        want.len()
    );
}
