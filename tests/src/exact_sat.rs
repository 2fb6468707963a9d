//! The exact reference for voxelization tests and the fuzzer: the 13-axis separating-axis
//! test of a triangle and a closed box in `i128` integers, and the brute-force cell set of
//! triangles on a lattice. Shared by `crates/svo/tests` and `fuzz/` (included by path), so it
//! depends on nothing but `std`.

use std::collections::{BTreeMap, BTreeSet};

/// An integer point.
pub type I3 = [i128; 3];

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
    /// The three box axes do not separate.
    pub boxes: bool,
    /// The triangle's plane does not separate.
    pub plane: bool,
    /// The nine edge-cross axes do not separate.
    pub edges: bool,
}

impl RefSat {
    /// No axis separates: the triangle and the box overlap.
    pub fn overlap(self) -> bool {
        self.boxes && self.plane && self.edges
    }
}

/// Whether axis `a` separates the triangle `v` from the closed box `[m, m + s]` (a zero axis
/// separates nothing). The box projects onto `[a.m + neg, a.m + pos]` with `pos` and `neg`
/// the sums of the axis's positive and negative components times `s`.
fn separated(v: [I3; 3], m: I3, s: i128, a: I3) -> bool {
    if a == [0, 0, 0] {
        return false;
    }
    let tp = v.map(|p| dot(a, p));
    let (tmin, tmax) = (tp.iter().min().unwrap_or(&0), tp.iter().max().unwrap_or(&0));
    let base = dot(a, m);
    let pos: i128 = a.iter().map(|&c| c.max(0) * s).sum();
    let neg: i128 = a.iter().map(|&c| c.min(0) * s).sum();
    *tmax < base + neg || base + pos < *tmin
}

const UNITS: [I3; 3] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];

/// The triangle's nine edge axes `e_j x unit_k`.
fn edge_axes(v: [I3; 3]) -> impl Iterator<Item = I3> {
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    e.into_iter()
        .flat_map(|ej| UNITS.iter().map(move |&u| cross(ej, u)))
}

/// Exact SAT of the triangle `v` and the closed box `[m, m + s]`, all integers.
pub fn ref_sat(v: [I3; 3], m: I3, s: i128) -> RefSat {
    let sep = |a: I3| separated(v, m, s, a);
    RefSat {
        boxes: !UNITS.iter().any(|&u| sep(u)),
        plane: !sep(cross(sub(v[1], v[0]), sub(v[2], v[0]))),
        edges: !edge_axes(v).any(sep),
    }
}

/// Whether the triangle `v` and the closed box `[m, m + s]` overlap: [`ref_sat`]'s answer,
/// stopping at the first separating axis (the box axes, then the plane, which rejects most
/// cells near a large triangle, then the edges).
pub fn ref_overlap(v: [I3; 3], m: I3, s: i128) -> bool {
    let sep = |a: I3| separated(v, m, s, a);
    !UNITS.iter().any(|&u| sep(u))
        && !sep(cross(sub(v[1], v[0]), sub(v[2], v[0])))
        && !edge_axes(v).any(sep)
}

/// Every cell of a tree of `depth` over the root `[0, 64]^3` (lattice units) that each
/// triangle touches, with the triangles touching it: every cell against every triangle
/// near its bounds, exactly.
pub fn lattice_brute_force(tris: &[[I3; 3]], depth: u8) -> BTreeMap<[u32; 3], BTreeSet<u32>> {
    // Grid cell size in lattice units: the root [0, 64] holds 2^depth cells.
    let side = 1i128 << depth;
    let mut out: BTreeMap<[u32; 3], BTreeSet<u32>> = BTreeMap::new();
    for (ti, t) in tris.iter().enumerate() {
        // scale the lattice by 2^depth so that a cell is 64 units
        let v = t.map(|p| p.map(|c| c * side));
        let lo: Vec<i128> = (0..3)
            .map(|k| v.iter().map(|p| p[k]).min().unwrap_or(0))
            .collect();
        let hi: Vec<i128> = (0..3)
            .map(|k| v.iter().map(|p| p[k]).max().unwrap_or(0))
            .collect();
        let range = |k: usize| ((lo[k] / 64 - 1).max(0))..=((hi[k] / 64 + 1).min(side - 1));
        for x in range(0) {
            for y in range(1) {
                for z in range(2) {
                    if ref_overlap(v, [x * 64, y * 64, z * 64], 64) {
                        out.entry([x as u32, y as u32, z as u32])
                            .or_default()
                            .insert(ti as u32);
                    }
                }
            }
        }
    }
    out
}
