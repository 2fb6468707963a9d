//! The dense-grid DDA against the octree traversal: both must hand the same leaf entries, in
//! the same order, with the same parameters, to a callback that declines every leaf, and
//! so agree on every cube and contour hit, on seeded random trees and rays (including
//! axis-parallel rays with signed zeros and rays through lattice corners). The two walks
//! share the mirrored ray, so each DDA hit is also checked on its own against the exact
//! reference of `tests/src/ray_check.rs`, built from the cell list.
#![cfg(feature = "trace")]

use crate::common;

use common::ray_check::{Worst, check_hit};
use common::ray_reference::{RefCell, index_of, tree_of, with_words};
use glam::{DVec3, UVec3, Vec3};
use rand::Rng;
use svo::RootCube;
use svo::octree::{Octree, Voxel};
use svo::trace::{
    DenseGrid, GridRay, HitMode, LeafEntry, MAX_DDA_DEPTH, MAX_STEPS, leaf_hit, traverse,
    traverse_dda,
};

fn random_cells(rng: &mut impl Rng, depth: u8, density: f64) -> Vec<RefCell> {
    let side = 1u32 << depth;
    let mut cells = vec![UVec3::ZERO];
    for x in 0..side {
        for y in 0..side {
            for z in 0..side {
                if (x, y, z) != (0, 0, 0) && rng.random_bool(density) {
                    cells.push(UVec3::new(x, y, z));
                }
            }
        }
    }
    with_words(rng, &cells)
}

fn component(rng: &mut impl Rng) -> f32 {
    match rng.random_range(0..6) {
        0 => 0.0,
        1 => -0.0,
        2 => rng.random_range(-2..=2) as f32,
        _ => rng.random_range(-1.0..1.0),
    }
}

fn random_ray(rng: &mut impl Rng, n: f32) -> GridRay {
    let lattice = rng.random_bool(0.3);
    let coord = |rng: &mut dyn rand::RngCore| {
        if lattice {
            rng.random_range(-2..=(n as i32 + 2)) as f32
        } else {
            rng.random_range(-0.5 * n..1.5 * n)
        }
    };
    let origin = Vec3::new(coord(rng), coord(rng), coord(rng));
    let mut dir = Vec3::new(component(rng), component(rng), component(rng));
    if dir == Vec3::ZERO {
        dir.x = -1.0;
    }
    GridRay { origin, dir }
}

#[test]
fn dda_and_octree_visit_the_same_leaves() {
    let mut rng = common::rng(0xDDA);
    let mut compared = 0usize;
    let mut hits = 0usize;
    let mut worst = Worst::default();
    for depth in 1..=6u8 {
        for &density in &[0.03, 0.3, 0.9] {
            let cells = random_cells(&mut rng, depth, density);
            let index = index_of(&cells);
            let tree = tree_of(depth, &cells);
            let grid = DenseGrid::new(&tree).unwrap();
            let n = (1u32 << depth) as f32;
            for _ in 0..800 {
                let ray = random_ray(&mut rng, n);
                let tmin = if rng.random_bool(0.2) {
                    rng.random_range(0.0..n)
                } else {
                    0.0
                };
                let mut a: Vec<LeafEntry> = Vec::new();
                let mut b: Vec<LeafEntry> = Vec::new();
                let ta = traverse(&tree, &ray, tmin, f32::INFINITY, MAX_STEPS, |e| {
                    a.push(*e);
                    None::<()>
                });
                let tb = traverse_dda(&grid, &tree, &ray, tmin, f32::INFINITY, MAX_STEPS, |e| {
                    b.push(*e);
                    None::<()>
                });
                assert!(!ta.capped && !tb.capped);
                assert_eq!(a, b, "depth {depth} density {density} {ray:?} tmin {tmin}");
                compared += a.len();
                for mode in [HitMode::Cube, HitMode::Contour] {
                    let ho = traverse(&tree, &ray, tmin, f32::INFINITY, MAX_STEPS, |e| {
                        leaf_hit(&tree, &ray, e, mode)
                    });
                    let hd =
                        traverse_dda(&grid, &tree, &ray, tmin, f32::INFINITY, MAX_STEPS, |e| {
                            leaf_hit(&tree, &ray, e, mode)
                        });
                    assert_eq!(ho.hit, hd.hit, "{mode:?} {ray:?}");
                    hits += usize::from(check_hit(
                        &cells,
                        &index,
                        &ray,
                        tmin,
                        n,
                        mode,
                        hd.hit.map(|h| (h.t, h.cell)),
                        &mut worst,
                    ));
                }
            }
        }
    }
    assert!(
        compared > 20_000 && hits > 4_000,
        "compared {compared} entries, {hits} hits"
    );
}

#[test]
fn too_deep_for_a_dense_grid_is_an_error() {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: 1.0,
    };
    let tree =
        Octree::from_cells(root, MAX_DDA_DEPTH + 1, [(UVec3::ZERO, Voxel::default())]).unwrap();
    let e = DenseGrid::new(&tree).unwrap_err();
    assert!(e.to_string().contains("depth 11"), "{e}");
}
