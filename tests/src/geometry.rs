//! Seeded random geometry on an integer lattice (the exact tests' coordinates are integers
//! over [`DENOM`]), a bake at a depth, and the area of a triangle clipped to a cell, written
//! apart from the library's clipping as a reference.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Coordinates in the exact tests are integers divided by this.
pub const DENOM: f64 = 16.0;

/// The generator for `seed`, or for `seed` mixed with `SVO_TEST_SEED` when that is set.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(crate::seeds::seed(seed))
}

/// Integer point to f64 grid coordinates.
pub fn to_f(p: crate::exact_sat::I3) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / DENOM
}

/// A random integer point in `[lo, hi]^3`.
pub fn rand_point(r: &mut ChaCha8Rng, lo: i128, hi: i128) -> crate::exact_sat::I3 {
    [
        r.random_range(lo..=hi),
        r.random_range(lo..=hi),
        r.random_range(lo..=hi),
    ]
}

/// A random triangle of a few kinds: general, near a cell, degenerate (segment or point),
/// axis-aligned, or sliver.
pub fn rand_triangle(r: &mut ChaCha8Rng, lo: i128, hi: i128) -> [crate::exact_sat::I3; 3] {
    let a = rand_point(r, lo, hi);
    match r.random_range(0..6) {
        0 | 1 => [a, rand_point(r, lo, hi), rand_point(r, lo, hi)],
        2 => {
            // segment: third vertex on the line through the first two
            let b = rand_point(r, lo, hi);
            let t = r.random_range(-2..=2);
            [
                a,
                b,
                [
                    a[0] + t * (b[0] - a[0]),
                    a[1] + t * (b[1] - a[1]),
                    a[2] + t * (b[2] - a[2]),
                ],
            ]
        }
        3 => [a, a, a],
        4 => {
            // axis-aligned: all on one coordinate plane
            let k = r.random_range(0..3);
            let mut b = rand_point(r, lo, hi);
            let mut c = rand_point(r, lo, hi);
            b[k] = a[k];
            c[k] = a[k];
            [a, b, c]
        }
        _ => {
            // sliver: nearly collinear
            let b = rand_point(r, lo, hi);
            let mut c = [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2];
            let k = r.random_range(0..3);
            c[k] += 1;
            [a, b, c]
        }
    }
}

/// Bakes `mesh` at `depth` with the default options.
pub fn bake_at(mesh: &svo::Mesh, depth: u8) -> (svo::Octree, svo::BakeStats) {
    svo::bake_mesh(
        mesh,
        &svo::BakeOptions {
            depth,
            ..Default::default()
        },
    )
    .unwrap()
}

/// The area of the part of triangle `tri` inside the unit cube `[0, 1]^3` ([`clipped_polygon`]).
pub fn clipped_area(tri: [DVec3; 3]) -> f64 {
    let poly = clipped_polygon(tri);
    let mut twice = DVec3::ZERO;
    for i in 1..poly.len().saturating_sub(1) {
        twice += (poly[i] - poly[0]).cross(poly[i + 1] - poly[0]);
    }
    twice.length() / 2.0
}

/// The part of triangle `tri` inside the unit cube `[0, 1]^3`: the polygon clipped against
/// the cube's six planes (Sutherland-Hodgman), in `f64`; empty where it misses the cube.
/// Written here, apart from the library's clipping, as a reference.
pub fn clipped_polygon(tri: [DVec3; 3]) -> Vec<DVec3> {
    let mut poly: Vec<DVec3> = tri.to_vec();
    for axis in 0..3 {
        for (bound, keep_below) in [(0.0, false), (1.0, true)] {
            let inside = |p: DVec3| {
                if keep_below {
                    p[axis] <= bound
                } else {
                    p[axis] >= bound
                }
            };
            let mut out = Vec::with_capacity(poly.len() + 1);
            for i in 0..poly.len() {
                let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                if inside(a) {
                    out.push(a);
                }
                if inside(a) != inside(b) {
                    let t = (bound - a[axis]) / (b[axis] - a[axis]);
                    let mut p = a + (b - a) * t;
                    p[axis] = bound;
                    out.push(p);
                }
            }
            poly = out;
            if poly.is_empty() {
                return poly;
            }
        }
    }
    poly
}
