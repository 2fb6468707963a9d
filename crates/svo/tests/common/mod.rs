//! Shared helpers for the integration tests: an exact integer SAT reference and seeded
//! random geometry.
#![allow(dead_code)]

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Coordinates in the exact tests are integers divided by this.
pub const DENOM: f64 = 16.0;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

type I3 = [i128; 3];

fn sub(a: I3, b: I3) -> I3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: I3, b: I3) -> I3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: I3, b: I3) -> i128 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Which axes of the 13-axis SAT do not separate, computed exactly in integers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RefSat {
    pub boxes: bool,
    pub plane: bool,
    pub edges: bool,
}

impl RefSat {
    pub fn overlap(self) -> bool {
        self.boxes && self.plane && self.edges
    }
}

/// Exact SAT of the triangle `v` and the closed box `[m, m + s]`, all integers.
pub fn ref_sat(v: [I3; 3], m: I3, s: i128) -> RefSat {
    let corners: Vec<I3> = (0..8)
        .map(|i| {
            [
                m[0] + s * ((i >> 2) & 1),
                m[1] + s * ((i >> 1) & 1),
                m[2] + s * (i & 1),
            ]
        })
        .collect();
    let separated = |a: I3| -> bool {
        if a == [0, 0, 0] {
            return false;
        }
        let tp: Vec<i128> = v.iter().map(|&p| dot(a, p)).collect();
        let bp: Vec<i128> = corners.iter().map(|&p| dot(a, p)).collect();
        let (tmin, tmax) = (*tp.iter().min().unwrap(), *tp.iter().max().unwrap());
        let (bmin, bmax) = (*bp.iter().min().unwrap(), *bp.iter().max().unwrap());
        tmax < bmin || bmax < tmin
    };
    let units = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    let boxes = !units.iter().any(|&u| separated(u));
    let n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
    let plane = !separated(n);
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    let edges = !e
        .iter()
        .any(|&ej| units.iter().any(|&u| separated(cross(ej, u))));
    RefSat {
        boxes,
        plane,
        edges,
    }
}

/// Integer point to f64 grid coordinates.
pub fn to_f(p: I3) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) / DENOM
}

/// A random integer point in `[lo, hi]^3`.
pub fn rand_point(r: &mut ChaCha8Rng, lo: i128, hi: i128) -> I3 {
    [
        r.random_range(lo..=hi),
        r.random_range(lo..=hi),
        r.random_range(lo..=hi),
    ]
}

/// A random triangle of a few kinds: general, near a cell, degenerate (segment or point),
/// axis-aligned, or sliver.
pub fn rand_triangle(r: &mut ChaCha8Rng, lo: i128, hi: i128) -> [I3; 3] {
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
        &|_, _| {},
    )
    .unwrap()
}
