//! The exact voxelization oracle for floating-point input: which closed cells of a grid each
//! triangle touches, decided from the `f64` grid coordinates themselves, with no rounding.
//!
//! Every finite `f64` is `m * 2^e` for integers `m` and `e` (read here from its bits), so a
//! triangle's coordinates, scaled by a power of two that makes all of them integers, are big
//! integers, and the 13-axis separating-axis test of a triangle and a closed box (3 box
//! normals, the triangle's normal, 9 edge x box-axis products) is decided exactly in
//! [`num_bigint::BigInt`]. Cells are enumerated top down: a triangle that touches a closed cell
//! touches every closed cell containing it, so descending into the children of touched cells
//! only finds every touched cell at every level. Nothing here calls the library.

use glam::DVec3;
use num_bigint::BigInt;
use std::collections::BTreeMap;

/// `x` as `(m, e)` with `x == m * 2^e` exactly (`m == 0` for both zeros).
pub fn dyadic(x: f64) -> (i64, i32) {
    assert!(
        x.is_finite(),
        "the oracle takes finite coordinates, got {x}"
    );
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let frac = (bits & ((1u64 << 52) - 1)) as i64;
    let (m, e) = if exp == 0 {
        (frac, -1074)
    } else {
        (frac | (1i64 << 52), exp - 1075)
    };
    (if bits >> 63 == 1 { -m } else { m }, e)
}

type B3 = [BigInt; 3];

fn sub(a: &B3, b: &B3) -> B3 {
    [&a[0] - &b[0], &a[1] - &b[1], &a[2] - &b[2]]
}

fn cross(a: &B3, b: &B3) -> B3 {
    [
        &a[1] * &b[2] - &a[2] * &b[1],
        &a[2] * &b[0] - &a[0] * &b[2],
        &a[0] * &b[1] - &a[1] * &b[0],
    ]
}

fn dot(a: &B3, b: &B3) -> BigInt {
    &a[0] * &b[0] + &a[1] * &b[1] + &a[2] * &b[2]
}

/// One separating-axis candidate: the axis, the triangle's projection interval on it, and the
/// sums of the axis's positive and negative components (a box `[m, m + s]` projects onto
/// `[a.m + s * neg, a.m + s * pos]`).
struct Axis {
    a: B3,
    tmin: BigInt,
    tmax: BigInt,
    pos: BigInt,
    neg: BigInt,
}

/// A triangle in grid coordinates, exactly: `v * 2^shift` are integers.
pub struct ExactTriangle {
    /// The grid coordinates as given (for the exact box-axis and vertex comparisons).
    v: [DVec3; 3],
    shift: u32,
    /// The plane normal and the nine edge axes (zero axes dropped: they separate nothing).
    axes: Vec<Axis>,
}

impl ExactTriangle {
    /// The triangle with grid coordinates `v` (finite).
    pub fn new(v: [DVec3; 3]) -> Self {
        let parts: Vec<(i64, i32)> = v.iter().flat_map(DVec3::to_array).map(dyadic).collect();
        // Cell corners are integers: the scale makes every coordinate and every integer an
        // integer.
        let e_min = parts
            .iter()
            .filter(|(m, _)| *m != 0)
            .map(|&(_, e)| e)
            .min()
            .unwrap_or(0)
            .min(0);
        let shift = (-e_min) as u32;
        let big = |i: usize| {
            let (m, e) = parts[i];
            BigInt::from(m) << (e - e_min) as u32
        };
        let p: [B3; 3] = std::array::from_fn(|k| std::array::from_fn(|c| big(3 * k + c)));
        let e = [sub(&p[1], &p[0]), sub(&p[2], &p[1]), sub(&p[0], &p[2])];
        let zero = BigInt::from(0);
        let unit = |k: usize| -> B3 { std::array::from_fn(|c| BigInt::from(i32::from(c == k))) };
        let mut candidates = vec![cross(&e[0], &e[1])];
        for ej in &e {
            for k in 0..3 {
                candidates.push(cross(ej, &unit(k)));
            }
        }
        let axes = candidates
            .into_iter()
            .filter(|a| a.iter().any(|c| *c != zero))
            .map(|a| {
                let t: Vec<BigInt> = p.iter().map(|q| dot(&a, q)).collect();
                let tmin = t.iter().min().unwrap().clone();
                let tmax = t.iter().max().unwrap().clone();
                let pos = a.iter().filter(|c| **c > zero).sum();
                let neg = a.iter().filter(|c| **c < zero).sum();
                Axis {
                    a,
                    tmin,
                    tmax,
                    pos,
                    neg,
                }
            })
            .collect();
        Self { v, shift, axes }
    }

    /// Whether the triangle touches the closed cell `[m, m + s]` (integer corner, integer
    /// side), exactly.
    pub fn touches(&self, m: [i64; 3], s: i64) -> bool {
        let lo = DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64);
        let hi = lo + DVec3::splat(s as f64);
        // The box normals: comparisons of exact values (`m` and `s` are small integers).
        for k in 0..3 {
            let (vmin, vmax) = (
                self.v.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min),
                self.v
                    .iter()
                    .map(|p| p[k])
                    .fold(f64::NEG_INFINITY, f64::max),
            );
            if vmax < lo[k] || vmin > hi[k] {
                return false;
            }
        }
        // A vertex in the cell: a contact, no arithmetic needed.
        if self
            .v
            .iter()
            .any(|p| (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]))
        {
            return true;
        }
        let mb: B3 = m.map(|c| BigInt::from(c) << self.shift);
        let sb = BigInt::from(s) << self.shift;
        self.axes.iter().all(|ax| {
            let base = dot(&ax.a, &mb);
            !(ax.tmax < &base + &sb * &ax.neg || &base + &sb * &ax.pos < ax.tmin)
        })
    }
}

/// The cells each triangle touches, at every level of a tree of `depth` over the grid
/// `[0, 2^depth]^3` (`tris` in that grid's coordinates): element `l` maps each touched cell of
/// level `l` (in level-`l` cell coordinates) to the triangles touching it, ascending.
pub fn touched_cells(tris: &[[DVec3; 3]], depth: u8) -> Vec<BTreeMap<[u32; 3], Vec<u32>>> {
    let exact: Vec<ExactTriangle> = tris.iter().map(|&t| ExactTriangle::new(t)).collect();
    let mut levels = vec![BTreeMap::new(); usize::from(depth) + 1];
    let all: Vec<u32> = (0..tris.len() as u32)
        .filter(|&i| exact[i as usize].touches([0; 3], 1 << depth))
        .collect();
    descend(&exact, depth, 0, [0; 3], all, &mut levels);
    levels
}

fn descend(
    exact: &[ExactTriangle],
    depth: u8,
    level: u8,
    cell: [u32; 3],
    list: Vec<u32>,
    levels: &mut [BTreeMap<[u32; 3], Vec<u32>>],
) {
    if list.is_empty() {
        return;
    }
    if level < depth {
        let s = 1i64 << (depth - level - 1);
        for child in 0..8u32 {
            let c = [0, 1, 2].map(|k| 2 * cell[k] + ((child >> k) & 1));
            let m = c.map(|x| i64::from(x) * s);
            let sub: Vec<u32> = list
                .iter()
                .copied()
                .filter(|&t| exact[t as usize].touches(m, s))
                .collect();
            descend(exact, depth, level + 1, c, sub, levels);
        }
    }
    levels[usize::from(level)].insert(cell, list);
}

/// Grid coordinates at `depth` of a scene point in the root `(origin, side)`: the definition
/// of grid space (`(p - origin) / side * 2^depth`, in `f64`), written out here so that the
/// oracle uses the same coordinates as the voxelizer without calling it.
pub fn grid_point(p: DVec3, origin: DVec3, side: f64, depth: u8) -> DVec3 {
    (p - origin) / side * f64::from(1u32 << depth)
}

/// The grid coordinates ([`grid_point`]) of an indexed mesh's triangles.
pub fn grid_triangles(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    origin: DVec3,
    side: f64,
    depth: u8,
) -> Vec<[DVec3; 3]> {
    triangles
        .iter()
        .map(|t| t.map(|i| grid_point(positions[i as usize], origin, side, depth)))
        .collect()
}
