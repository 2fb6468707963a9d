//! The voxelizer against the exact big-integer oracle (`tests/src/oracle.rs`, which shares no
//! code with the library) on floating-point input: seeded random meshes with full-precision
//! coordinates, triangles built to pass within rounding of cell corners, edges and faces,
//! `-0.0`, slivers, huge and tiny scales, and the shared real meshes. The bake's leaves (the
//! default strategy, sliced bottom levels) and every exact strategy's per-cell triangle lists
//! must equal the oracle's cell for cell; the inexact strategies must contain them.

use crate::common;
use common::rng;
use glam::DVec3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use svo::Mesh;
use svo_tests::bake_check::check;

/// The triangles as a mesh, with two point-sized triangles at `(0, 0, 0)` and `(1, 1, 1)` so
/// that the root is exactly the unit cube: grid coordinates are then the scene coordinates
/// times `2^depth`, exactly, and a tie built in scene units is a tie in the grid.
fn pinned(tris: &[[DVec3; 3]]) -> Mesh {
    let mut all = vec![[DVec3::ZERO; 3], [DVec3::ONE; 3]];
    all.extend_from_slice(tris);
    soup(&all)
}

fn soup(tris: &[[DVec3; 3]]) -> Mesh {
    let positions: Vec<DVec3> = tris.iter().flatten().copied().collect();
    let triangles = (0..tris.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    Mesh::from_triangles(positions, triangles)
}

/// A coordinate with a full 53-bit mantissa (a decimal fraction, rounded).
fn decimal(r: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    let k: u32 = r.random_range(0..1_000_000);
    lo + (hi - lo) * (f64::from(k) * 1e-6) + 1e-7 / 3.0
}

fn decimal_point(r: &mut ChaCha8Rng, lo: f64, hi: f64) -> DVec3 {
    DVec3::new(decimal(r, lo, hi), decimal(r, lo, hi), decimal(r, lo, hi))
}

/// `x` moved by `k` units in the last place (towards +inf for `k > 0`).
fn ulps(x: f64, k: i32) -> f64 {
    let mut y = x;
    for _ in 0..k.unsigned_abs() {
        y = if k > 0 { y.next_up() } else { y.next_down() };
    }
    y
}

#[test]
fn random_full_precision_meshes_equal_the_oracle() {
    let mut r = rng(0xac1e_0001);
    let mut cells = 0;
    for case in 0..40 {
        let n = r.random_range(1..12);
        let tris: Vec<[DVec3; 3]> = (0..n)
            .map(|_| {
                let a = decimal_point(&mut r, -3.7, 5.3);
                match r.random_range(0..4) {
                    // small, medium and long triangles
                    0 => [
                        a,
                        a + decimal_point(&mut r, -0.3, 0.3),
                        a + decimal_point(&mut r, -0.3, 0.3),
                    ],
                    1 => [
                        a,
                        decimal_point(&mut r, -3.7, 5.3),
                        decimal_point(&mut r, -3.7, 5.3),
                    ],
                    // a sliver: the third vertex a hair off the first edge's midpoint
                    2 => {
                        let b = decimal_point(&mut r, -3.7, 5.3);
                        [a, b, (a + b) / 2.0 + DVec3::splat(1e-9)]
                    }
                    // a segment with its middle vertex rounded onto it
                    _ => {
                        let b = decimal_point(&mut r, -3.7, 5.3);
                        [a, b, a + (b - a) * 0.3]
                    }
                }
            })
            .collect();
        let depth = 1 + (case % 6) as u8;
        // Decimal coordinates fall on cell faces and edges at these depths, so only the
        // estimate's bound, not the estimate itself, is held to the oracle.
        cells += check(&soup(&tris), depth, &format!("random case {case}"), false);
    }
    assert!(cells > 2_000, "{cells} cells");
}

/// Triangles whose plane, edges or vertices pass within a few ulps of cell corners, cell
/// edges and cell faces of a depth-`depth` grid over the unit cube, on both sides.
fn near_ties(r: &mut ChaCha8Rng, depth: u8, count: usize) -> Vec<[DVec3; 3]> {
    let cells = f64::from(1u32 << depth);
    let lattice = |r: &mut ChaCha8Rng| f64::from(r.random_range(1..(1u32 << depth))) / cells;
    let corner = |r: &mut ChaCha8Rng| DVec3::new(lattice(r), lattice(r), lattice(r));
    let small = |r: &mut ChaCha8Rng| decimal_point(r, -0.4 / cells, 0.4 / cells);
    (0..count)
        .map(|_| match r.random_range(0..5) {
            // A plane through a cell corner: the third vertex is the corner reflected through
            // the first two's midpoint, rounded, so the plane misses the corner by rounding.
            0 => {
                let c = corner(r);
                let (u, v) = (small(r), small(r));
                [c + u, c + v, c - u - v]
            }
            // An edge along a cell edge's line, its ends nudged by a few ulps.
            1 => {
                let c = corner(r);
                let k = r.random_range(0..3);
                let mut a = c;
                let mut b = c;
                a[k] += 0.3 / cells;
                b[k] -= 0.7 / cells;
                let j = (k + 1) % 3;
                a[j] = ulps(a[j], r.random_range(-2..=2));
                b[j] = ulps(b[j], r.random_range(-2..=2));
                [a, b, c + small(r)]
            }
            // A vertex a few ulps either side of a cell face, the others outside the cell.
            2 => {
                let c = corner(r);
                let k = r.random_range(0..3);
                let mut a = c + small(r);
                a[k] = ulps(c[k], r.random_range(-3..=3));
                let mut b = c + small(r);
                let mut d = c + small(r);
                b[k] = c[k] - 0.5 / cells;
                d[k] = c[k] - 0.25 / cells;
                [a, b, d]
            }
            // An edge through a cell corner, rounded: the midpoint of two points symmetric
            // about the corner.
            3 => {
                let c = corner(r);
                let u = small(r);
                [c + u, c - u, c + small(r) * 3.0]
            }
            // A triangle in a cell face's plane, its offset a few ulps either way.
            _ => {
                let c = corner(r);
                let k = r.random_range(0..3);
                let off = ulps(c[k], r.random_range(-2..=2));
                let mut t = [c + small(r) * 2.0, c + small(r) * 2.0, c + small(r) * 2.0];
                for p in &mut t {
                    p[k] = off;
                }
                t
            }
        })
        .collect()
}

#[test]
fn near_ties_at_corners_edges_and_faces_equal_the_oracle() {
    let mut r = rng(0xac1e_0002);
    for case in 0..60 {
        let depth = 2 + (case % 5) as u8;
        let tris = near_ties(&mut r, depth, 12);
        check(
            &pinned(&tris),
            depth,
            &format!("near-tie case {case}"),
            false,
        );
    }
}

#[test]
fn negative_zero_slivers_and_extreme_scales_equal_the_oracle() {
    let mut r = rng(0xac1e_0003);
    for case in 0..12 {
        let depth = 3 + (case % 3) as u8;
        let mut tris = near_ties(&mut r, depth, 8);
        // -0.0 and +0.0 on the root's minimum faces, and a sliver of width 1e-300.
        tris.push([
            DVec3::new(-0.0, 0.25, 0.5),
            DVec3::new(0.0, 0.75, 0.5),
            DVec3::new(-0.0, 0.5, -0.0),
        ]);
        tris.push([
            DVec3::new(0.1, 0.2, 0.3),
            DVec3::new(0.9, 0.8, 0.7),
            DVec3::new(0.5, 0.5, 0.5 + 1e-300),
        ]);
        check(&pinned(&tris), depth, &format!("-0.0 case {case}"), false);
        // The same triangles scaled by powers of two (grid coordinates unchanged) and by
        // decimal factors (the root's side is then no power of two and grid coordinates round).
        for scale in [
            2f64.powi(-1000),
            2f64.powi(-500),
            2f64.powi(500),
            2f64.powi(1000),
            1e-300,
            3.7e-200,
            1e200,
            1e300,
        ] {
            let scaled: Vec<[DVec3; 3]> = pinned(&tris)
                .triangles
                .iter()
                .enumerate()
                .map(|(i, _)| {
                    if i < 2 {
                        [DVec3::splat((i as f64) * scale); 3]
                    } else {
                        tris[i - 2].map(|p| p * scale)
                    }
                })
                .collect();
            check(
                &soup(&scaled),
                depth,
                &format!("case {case} scaled by {scale:e}"),
                false,
            );
        }
    }
}

/// The oracle itself against the `i128` reference on lattice triangles (where both are exact
/// by construction): the same answer for every cell.
#[test]
fn the_oracle_agrees_with_the_integer_reference_on_lattices() {
    use common::oracle::ExactTriangle;
    use common::{DENOM, rand_triangle, ref_overlap, to_f};
    let mut r = rng(0xac1e_0004);
    let mut touching = 0;
    for _ in 0..3_000 {
        let v = rand_triangle(&mut r, -24, 88);
        // Grid cells of side 16 lattice units (one grid unit).
        let exact = ExactTriangle::new(v.map(to_f));
        for x in -2..5i64 {
            for y in -2..5i64 {
                let z = r.random_range(-2..5i64);
                let m = [x, y, z];
                let lattice = m.map(|c| i128::from(c) * DENOM as i128);
                let want = ref_overlap(v, lattice, DENOM as i128);
                assert_eq!(exact.touches(m, 1), want, "{v:?} cell {m:?}");
                touching += usize::from(want);
            }
        }
    }
    assert!(touching > 3_000, "{touching}");
}
