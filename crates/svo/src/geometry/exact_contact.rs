//! The exact contact test, for the cells that the floating-point tests leave in doubt.
//!
//! The plane and edge-axis tests ([`crate::geometry::overlap`]) are decided in `f64` with a
//! rigorous bound on their rounding: a separation or an overlap larger than the bound is
//! certain. A cell whose answer lies within the bound (a triangle whose plane, edge or vertex
//! passes within rounding of the cell's boundary; exact ties such as a face lying in a cell
//! face; degenerate triangles, whose normal is rounding noise) is decided here, exactly.
//!
//! Every finite `f64` is an integer times a power of two. Scaled by the power of two of the
//! smallest among the triangle's and the box's coordinates, all of them are integers, and the
//! 13 separating axes (3 box normals, the triangle's normal, the 9 products of an edge with a
//! box axis) are evaluated on those integers with no rounding: `i128` when the integers are
//! small enough that no product overflows (exact ties on grid-aligned meshes, the common
//! case), else big integers (`num-bigint`).

use glam::DVec3;
use num_bigint::BigInt;

/// `x` (finite) as `(m, e)` with `x == m * 2^e` and `m` odd (or zero).
fn integer_and_exponent(x: f64) -> (i64, i32) {
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let frac = (bits & ((1 << 52) - 1)) as i64;
    let (m, e) = if biased == 0 {
        (frac, -1074)
    } else {
        (frac | (1 << 52), biased - 1075)
    };
    if m == 0 {
        return (0, 0);
    }
    let tz = m.trailing_zeros();
    let (m, e) = (m >> tz, e + tz as i32);
    (if x.is_sign_negative() { -m } else { m }, e)
}

/// Integers with the few operations the test needs.
trait Exact: Clone + Ord {
    fn from_i64_shl(m: i64, shift: u32) -> Self;
    fn zero() -> Self;
    fn add(&self, o: &Self) -> Self;
    fn sub(&self, o: &Self) -> Self;
    fn mul(&self, o: &Self) -> Self;
    fn abs(&self) -> Self;
}

impl Exact for i128 {
    fn from_i64_shl(m: i64, shift: u32) -> Self {
        i128::from(m) << shift
    }
    fn zero() -> Self {
        0
    }
    fn add(&self, o: &Self) -> Self {
        self + o
    }
    fn sub(&self, o: &Self) -> Self {
        self - o
    }
    fn mul(&self, o: &Self) -> Self {
        self * o
    }
    fn abs(&self) -> Self {
        i128::abs(*self)
    }
}

impl Exact for BigInt {
    fn from_i64_shl(m: i64, shift: u32) -> Self {
        BigInt::from(m) << shift
    }
    fn zero() -> Self {
        BigInt::ZERO
    }
    fn add(&self, o: &Self) -> Self {
        self + o
    }
    fn sub(&self, o: &Self) -> Self {
        self - o
    }
    fn mul(&self, o: &Self) -> Self {
        self * o
    }
    fn abs(&self) -> Self {
        if self.sign() == num_bigint::Sign::Minus {
            -self
        } else {
            self.clone()
        }
    }
}

/// Every axis: [`touches_exactly`]'s `axes` for the complete test.
#[cfg(test)]
pub(crate) const ALL_AXES: u16 = (1 << 13) - 1;

/// Bit of `axes` for the triangle's normal; the edge axis `edge j x unit k` (edge `j` from
/// vertex `j` to the next) is bit `1 + 3 j + k`, the box normals bits 10 to 12.
pub(crate) const PLANE_AXIS: u16 = 1;

/// Whether no axis in `axes` separates the triangle `v` from the closed box `[m, m + s]`,
/// decided exactly (all values finite, `s >= 0`). With every axis this is whether they touch;
/// callers that know some axes do not separate (their `f64` test was beyond its rounding
/// bound) leave those out.
pub(crate) fn touches_exactly(v: &[DVec3; 3], m: DVec3, s: f64, axes: u16) -> bool {
    let values: [f64; 13] = [
        v[0].x, v[0].y, v[0].z, v[1].x, v[1].y, v[1].z, v[2].x, v[2].y, v[2].z, m.x, m.y, m.z, s,
    ];
    let parts = values.map(integer_and_exponent);
    let nonzero = || parts.iter().filter(|(i, _)| *i != 0);
    let e_min = nonzero().map(|&(_, e)| e).min().unwrap_or(0);
    // The scaled integers have at most `bits` bits; the plane test multiplies three
    // differences (each a bit more) and adds a few such products, twice: within `i128` when
    // `3 bits + 8 < 127`.
    let bits = nonzero()
        .map(|&(i, e)| (e - e_min) + (64 - i.unsigned_abs().leading_zeros()) as i32)
        .max()
        .unwrap_or(0);
    if bits <= 38 {
        sat::<i128>(&parts, e_min, axes)
    } else {
        sat::<BigInt>(&parts, e_min, axes)
    }
}

/// The 13-axis test on the scaled integers: for each axis `a`, the triangle's projections
/// `2 a.p` against the box's centre `2 a.m + s sum(a)` plus or minus `s sum(|a|)` (doubled so
/// the centre is an integer).
fn sat<T: Exact>(parts: &[(i64, i32); 13], e_min: i32, axes: u16) -> bool {
    let n: [T; 13] = parts.map(|(i, e)| T::from_i64_shl(i, (e - e_min) as u32));
    let p: [[T; 3]; 3] = std::array::from_fn(|k| std::array::from_fn(|c| n[3 * k + c].clone()));
    let m: [T; 3] = std::array::from_fn(|c| n[9 + c].clone());
    let s = n[12].clone();
    let two = |x: &T| x.add(x);
    let dot = |a: &[T; 3], b: &[T; 3]| a[0].mul(&b[0]).add(&a[1].mul(&b[1])).add(&a[2].mul(&b[2]));
    let separates = |a: &[T; 3]| {
        let [p0, p1, p2] = [0, 1, 2].map(|k| two(&dot(a, &p[k])));
        let (lo, hi) = (
            p0.clone().min(p1.clone()).min(p2.clone()),
            p0.max(p1).max(p2),
        );
        let sum = a[0].add(&a[1]).add(&a[2]);
        let abs = a[0].abs().add(&a[1].abs()).add(&a[2].abs());
        let centre = two(&dot(a, &m)).add(&s.mul(&sum));
        let rad = s.mul(&abs);
        lo > centre.add(&rad) || hi < centre.sub(&rad)
    };
    let (z, one) = (T::zero(), T::from_i64_shl(1, 0));
    let units: [[T; 3]; 3] = std::array::from_fn(|k| {
        std::array::from_fn(|c| if c == k { one.clone() } else { z.clone() })
    });
    let on = |bit: usize| axes >> bit & 1 == 1;
    if (0..3).any(|k| on(10 + k) && separates(&units[k])) {
        return false;
    }
    let d = |a: &[T; 3], b: &[T; 3]| -> [T; 3] { std::array::from_fn(|c| a[c].sub(&b[c])) };
    let cross = |a: &[T; 3], b: &[T; 3]| -> [T; 3] {
        [
            a[1].mul(&b[2]).sub(&a[2].mul(&b[1])),
            a[2].mul(&b[0]).sub(&a[0].mul(&b[2])),
            a[0].mul(&b[1]).sub(&a[1].mul(&b[0])),
        ]
    };
    let e = [d(&p[1], &p[0]), d(&p[2], &p[1]), d(&p[0], &p[2])];
    // A zero axis (a degenerate triangle's normal, an edge along a box axis) projects
    // everything to 0: it separates nothing.
    if on(0) && separates(&cross(&e[0], &e[1])) {
        return false;
    }
    !(0..9).any(|i| on(1 + i) && separates(&cross(&e[i / 3], &units[i % 3])))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_values_exactly() {
        for x in [
            0.0,
            -0.0,
            1.0,
            -3.5,
            0.1,
            1e-310,
            f64::MAX,
            f64::MIN_POSITIVE,
        ] {
            let (m, e) = integer_and_exponent(x);
            assert_eq!(m as f64 * 2f64.powi(e), x, "{x}");
        }
    }

    /// Each bit decides its own axis: a triangle beside the cell along `y` only is separated
    /// by the `y` box normal (bit 11) and by no other single axis among the box normals.
    #[test]
    fn each_axis_bit_tests_its_own_axis() {
        let v = [
            DVec3::new(0.2, 5.0, 0.2),
            DVec3::new(0.8, 5.0, 0.3),
            DVec3::new(0.5, 6.0, 0.9),
        ];
        for (bit, separated) in [(10, false), (11, true), (12, false)] {
            assert_eq!(
                touches_exactly(&v, DVec3::ZERO, 1.0, 1 << bit),
                !separated,
                "bit {bit}"
            );
        }
    }

    /// Every value an odd integer (so the same power of two, `2^0`), the largest `2^45 + 1`:
    /// the plane test's products need about 140 bits, so the big integers must decide.
    #[test]
    fn long_odd_integers_are_decided_in_big_integers() {
        let k = (1u64 << 45) as f64 + 1.0;
        let v = [
            DVec3::new(k, 1.0, 1.0),
            DVec3::new(1.0, k, 1.0),
            DVec3::new(1.0, 1.0, k),
        ];
        // The plane x + y + z = k + 2 passes far beyond the cell [1, 2]^3.
        assert!(!touches_exactly(&v, DVec3::ONE, 1.0, ALL_AXES));
        // A vertex's own cell.
        assert!(touches_exactly(&v, DVec3::new(k, 1.0, 1.0), 1.0, ALL_AXES));
    }

    #[test]
    fn small_and_big_integers_agree() {
        // Ties on a coarse lattice go through i128; the same cases offset by a value with a
        // long mantissa go through big integers and must give the same answers.
        let cases: [([DVec3; 3], DVec3); 4] = [
            // a face in the cell's face plane
            (
                [
                    DVec3::new(0.0, 0.0, 1.0),
                    DVec3::new(1.0, 0.0, 1.0),
                    DVec3::new(0.0, 1.0, 1.0),
                ],
                DVec3::ZERO,
            ),
            // an edge along the cell's edge, the rest outside
            (
                [
                    DVec3::new(0.0, 0.0, 0.0),
                    DVec3::new(0.0, 0.0, 1.0),
                    DVec3::new(-1.0, -1.0, 0.5),
                ],
                DVec3::ZERO,
            ),
            // a plane through the far corner only
            (
                [
                    DVec3::new(3.0, 0.0, 0.0),
                    DVec3::new(0.0, 3.0, 0.0),
                    DVec3::new(0.0, 0.0, 3.0),
                ],
                DVec3::ZERO,
            ),
            // a plane that misses the far corner by a quarter
            (
                [
                    DVec3::new(3.25, 0.0, 0.0),
                    DVec3::new(0.0, 3.25, 0.0),
                    DVec3::new(0.0, 0.0, 3.25),
                ],
                DVec3::ZERO,
            ),
        ];
        let expect = [true, true, true, false];
        // The complete test is all 13 axes: the plane, 9 edge axes and 3 box normals.
        assert_eq!(ALL_AXES.count_ones(), 13);
        assert_eq!(ALL_AXES >> 13, 0);
        for ((v, m), want) in cases.iter().zip(expect) {
            assert_eq!(touches_exactly(v, *m, 1.0, ALL_AXES), want, "{v:?}");
            let off = DVec3::splat(1.0 / 3.0 * 1024.0).floor() + DVec3::splat(0.5f64.powi(40));
            let moved = v.map(|p| p + off);
            // The offset is exact for these values, so the answers must not change.
            assert_eq!(
                touches_exactly(&moved, *m + off, 1.0, ALL_AXES),
                want,
                "{v:?} moved"
            );
        }
    }
}
