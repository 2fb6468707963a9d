//! Each overlap test against the exact integer SAT reference, on seeded random triangles and
//! cells and on hand-made edge cases (faces, edges, corners, axis-aligned, degenerate).

mod common;
use common::*;
use svo::voxelize::{
    GridTriangle, aabb_overlaps, edges_overlap, plane_overlaps, triangle_box_overlap, vertex_inside,
};

fn check(v: [[i128; 3]; 3], m: [i128; 3], s: i128) {
    let t = GridTriangle::new(to_f(v[0]), to_f(v[1]), to_f(v[2]));
    let (mf, sf) = (to_f(m), s as f64 / DENOM);
    let r = ref_sat(v, m, s);
    assert_eq!(
        aabb_overlaps(&t, mf, sf),
        r.boxes,
        "box axes: {v:?} cell {m:?}+{s}"
    );
    assert_eq!(
        plane_overlaps(&t, mf, sf),
        r.plane,
        "plane axis: {v:?} cell {m:?}+{s}"
    );
    assert_eq!(
        edges_overlap(&t, mf, sf),
        r.edges,
        "edge axes: {v:?} cell {m:?}+{s}"
    );
    assert_eq!(
        triangle_box_overlap(&t, mf, sf),
        r.overlap(),
        "13 axes: {v:?} cell {m:?}+{s}"
    );
    if vertex_inside(&t, mf, sf) {
        assert!(
            r.overlap(),
            "vertex inside but no overlap: {v:?} cell {m:?}+{s}"
        );
    }
}

#[test]
fn random_triangles_match_exact_reference() {
    let mut r = rng(0x5eed_0001);
    let mut overlaps = 0;
    for _ in 0..200_000 {
        let v = rand_triangle(&mut r, -40, 72);
        let s = 16 * (1 << r.random_range(0..3));
        let m = [
            r.random_range(-2..3) * 16,
            r.random_range(-2..3) * 16,
            r.random_range(-2..3) * 16,
        ];
        check(v, m, s);
        overlaps += usize::from(ref_sat(v, m, s).overlap());
    }
    // The sample must exercise both answers.
    assert!(
        overlaps > 20_000 && overlaps < 180_000,
        "{overlaps} overlaps"
    );
}

use rand::Rng;

#[test]
fn contacts_on_faces_edges_and_corners() {
    let m = [0, 0, 0];
    let s = 16;
    // A triangle lying in each face plane of the cell, one just outside.
    for k in 0..3 {
        for &plane in &[0i128, 16, -1, 17] {
            let mut a = [4, 4, 4];
            let mut b = [12, 4, 4];
            let mut c = [4, 12, 12];
            a[k] = plane;
            b[k] = plane;
            c[k] = plane;
            check([a, b, c], m, s);
        }
    }
    // Touching an edge only, and a corner only, from outside.
    check([[16, 16, -8], [16, 16, 24], [40, 40, 8]], m, s);
    check([[16, 16, 16], [30, 20, 20], [20, 30, 20]], m, s);
    check([[17, 16, 16], [30, 20, 20], [20, 30, 20]], m, s);
    // A big triangle whose plane cuts only the corner.
    check([[-8, 24, 24], [24, -8, 24], [24, 24, -8]], m, s);
    check([[0, 16, 16], [16, 0, 16], [16, 16, 0]], m, s);
    check([[-1, 16, 16], [16, -1, 16], [16, 16, -1]], m, s);
    // Needle through the cell, needle grazing an edge, point on a corner.
    check([[-100, 8, 8], [200, 8, 8], [200, 8, 8]], m, s);
    check([[-100, 16, 0], [200, 16, 0], [50, 16, 0]], m, s);
    check([[16, 16, 16], [16, 16, 16], [16, 16, 16]], m, s);
    check([[16, 16, 17], [16, 16, 17], [16, 16, 17]], m, s);
}

#[test]
fn exhaustive_small_lattice() {
    // Every triangle with vertices on a coarse lattice around the unit cell hits every
    // contact case there is at that resolution.
    let pts: Vec<[i128; 3]> = (0..27)
        .map(|i| [(i / 9) * 16 - 8, ((i / 3) % 3) * 16 - 8, (i % 3) * 16 - 8])
        .collect();
    let mut r = rng(7);
    for _ in 0..40_000 {
        let v = [
            pts[r.random_range(0..27)],
            pts[r.random_range(0..27)],
            pts[r.random_range(0..27)],
        ];
        check(v, [0, 0, 0], 16);
        check(v, [-8, -8, -8], 16);
    }
}

#[test]
fn huge_and_tiny_magnitudes_stay_conservative() {
    // Far from the origin and tiny: the tests must still never reject a touching cell.
    for &scale in &[1e-300, 1e-30, 1e-6, 1.0, 1e6, 1e15, 1e100, 1e300] {
        let f = |x: f64, y: f64, z: f64| glam::DVec3::new(x, y, z) * scale;
        // Lies in the face x = 1 (cell [0, 1]).
        let t = GridTriangle::new(f(1.0, 0.2, 0.3), f(1.0, 0.9, 0.1), f(1.0, 0.5, 0.9));
        assert!(
            triangle_box_overlap(&t, f(0.0, 0.0, 0.0), scale),
            "scale {scale}"
        );
        // Just outside.
        let t = GridTriangle::new(f(1.5, 0.2, 0.3), f(1.5, 0.9, 0.1), f(1.5, 0.5, 0.9));
        assert!(
            !triangle_box_overlap(&t, f(0.0, 0.0, 0.0), scale),
            "scale {scale}"
        );
    }
    // A cell far from the origin (depth-20 grid coordinates) with a triangle through its corner.
    let base = glam::DVec3::splat(1_048_575.0);
    let t = GridTriangle::new(
        base + glam::DVec3::new(1.0, 1.0, 0.0),
        base + glam::DVec3::new(1.0, 0.0, 1.0),
        base + glam::DVec3::new(0.0, 1.0, 1.0),
    );
    assert!(triangle_box_overlap(&t, base, 1.0));
    // Near-collinear sliver with area ~1e-30 still marks the cells along it.
    let t = GridTriangle::new(
        glam::DVec3::new(-1.0, 0.5, 0.5),
        glam::DVec3::new(2.0, 0.5, 0.5),
        glam::DVec3::new(0.5, 0.5 + 1e-30, 0.5),
    );
    assert!(triangle_box_overlap(&t, glam::DVec3::ZERO, 1.0));
}
