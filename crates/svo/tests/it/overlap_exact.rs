//! Each overlap test against the exact integer SAT reference, on seeded random triangles and
//! cells and on hand-made edge cases (faces, edges, corners, axis-aligned, degenerate).

use crate::common;
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

/// Large triangles whose plane passes within rounding of a cell corner `P` far from their
/// first vertex: `P` is the centroid of the vertices as written (`P + a`, `P + b`, `P - a - b`,
/// each rounded to `f64`), with `a` and `b` up to half a million cells long. Only the plane
/// decides the two cells of the eight around `P` that lie wholly on either side of it in
/// exact arithmetic (the box axes, the vertices and the edges are far away), and there the
/// computed plane value's rounding grows with the distance `|P - v0|`: a rounding bound that
/// did not grow with it (the `reach` in the library's `plane_tolerance`) would
/// let the float test decide these cells, sometimes wrongly. Every cell around `P` must equal
/// the oracle, and the sample must contain cases where the plain float sign is wrong.
#[test]
fn near_ties_far_from_the_first_vertex_equal_the_oracle() {
    use common::oracle::ExactTriangle;
    use glam::DVec3;
    let mut r = rng(0x5eed_0f4a);
    let vec = |r: &mut rand_chacha::ChaCha8Rng| {
        let mut d = DVec3::new(
            r.random_range(-5.0e5..5.0e5),
            r.random_range(-5.0e5..5.0e5),
            r.random_range(-5.0e5..5.0e5),
        );
        // Now and then one or two short components, so that `|d|_1` and other combinations of
        // the components (a sum of products, a product) differ.
        match r.random_range(0..4) {
            0 => d[r.random_range(0..3)] = r.random_range(-1.0..1.0),
            1 => {
                let keep = r.random_range(0..3);
                for k in (0..3).filter(|&k| k != keep) {
                    d[k] = r.random_range(-1e-6..1e-6);
                }
            }
            _ => {}
        }
        d
    };
    let (mut cells, mut float_wrong, mut ties) = (0, 0, 0);
    for _ in 0..600 {
        let p = [0; 3].map(|_| r.random_range(0..1i64 << 20));
        let pf = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        let (a, b) = (vec(&mut r), vec(&mut r));
        let v = [pf + a, pf + b, pf - a - b];
        let t = GridTriangle::new(v[0], v[1], v[2]);
        let exact = ExactTriangle::new(v);
        for child in 0..8 {
            let o = [0, 1, 2].map(|k| i64::from((child >> k) & 1));
            let m = [0, 1, 2].map(|k| p[k] - o[k]);
            let mf = DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64);
            let want = exact.touches(m, 1);
            assert_eq!(
                triangle_box_overlap(&t, mf, 1.0),
                want,
                "cell {m:?} of the triangle {v:?}"
            );
            assert!(
                !want || plane_overlaps(&t, mf, 1.0),
                "plane test rejects a touched cell {m:?} of {v:?}"
            );
            cells += 1;
            // The cells wholly on one side of the plane but for the corner `P`: their
            // plane interval ends at `n.(P - v0)`, computed here as the library's float
            // test computes it, with no rounding bound.
            let n = t.n;
            let toward = (0..3).all(|k| (n[k] >= 0.0) == (o[k] == 0));
            let away = (0..3).all(|k| (n[k] >= 0.0) == (o[k] == 1));
            if toward || away {
                ties += 1;
                let base = n.dot(pf - v[0]);
                let float = if toward { base <= 0.0 } else { base >= 0.0 };
                float_wrong += usize::from(float != want);
            }
        }
    }
    assert_eq!(cells, 4800);
    assert!(ties >= 1000, "{ties} tie cells");
    // The sample must hold cells that the plain float sign decides wrongly (the ones a
    // rounding bound too small for the distance would get wrong; 374 of 1,200 here).
    assert!(
        float_wrong >= 100,
        "{float_wrong} of {ties} tie cells decided wrongly by floats"
    );
}
