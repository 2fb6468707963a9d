//! The exact reference for ray traversal: where a ray first enters, and first touches, the
//! regions of a list of cells, decided in rationals from the `f32` ray itself.
//!
//! The cells come from the list a test builds its tree from, never from the tree. A cell's
//! region is its closed unit cube and, in contour mode, the slab between its two contour
//! planes, decoded here from the words as `docs/format.md` defines them: the octahedral
//! normal's unnormalized vector `m` (integers over 32767) and the planes
//! `m . (p - centre) = (2t - 1) |m|_1 / 2`, which are the format's unit-normal planes scaled
//! by `|m|_2`, so no square root is needed. Every `f32` is a dyadic rational, so the ray
//! `o + t d`, `tmin`, the cube faces and the slab planes are all exact rationals
//! ([`num_bigint::BigInt`] over a power of two or an integer), and the parameter interval
//! where the ray lies in a region, grown or shrunk by a margin, is computed exactly.
//!
//! A zero direction component stands for an infinitesimal of its sign (the tracer's
//! contract: the sign bit of `+0.0` and `-0.0` says which side of a face the ray runs on),
//! so along that axis the ray is inside `[lo, hi)` for `+0.0` and `(lo, hi]` for `-0.0`.
//!
//! Nothing here calls the library: the only use of `svo` is building the tree under test and
//! giving its leaves the words the reference decodes.

use glam::UVec3;
use num_bigint::{BigInt, Sign};
use rand::Rng;
use std::cmp::Ordering;
use std::collections::HashMap;
use svo::RootCube;
use svo::octree::{Channel, Octree, Voxel};

use crate::oracle::dyadic;

/// An exact rational `n / d`, `d > 0`.
#[derive(Clone, Debug)]
pub struct Q {
    n: BigInt,
    d: BigInt,
}

impl Q {
    /// The integer `i`.
    pub fn int(i: i64) -> Self {
        Self {
            n: BigInt::from(i),
            d: BigInt::from(1),
        }
    }

    /// The exact value of a finite `f64` (so of any `f32`).
    pub fn of(x: f64) -> Self {
        let (m, e) = dyadic(x);
        if e >= 0 {
            Self {
                n: BigInt::from(m) << e as usize,
                d: BigInt::from(1),
            }
        } else {
            Self {
                n: BigInt::from(m),
                d: BigInt::from(1) << (-e) as usize,
            }
        }
    }

    /// `self + o`.
    pub fn add(&self, o: &Self) -> Self {
        Self {
            n: &self.n * &o.d + &o.n * &self.d,
            d: &self.d * &o.d,
        }
    }

    /// `self - o`.
    pub fn sub(&self, o: &Self) -> Self {
        Self {
            n: &self.n * &o.d - &o.n * &self.d,
            d: &self.d * &o.d,
        }
    }

    /// `self * o`.
    pub fn mul(&self, o: &Self) -> Self {
        Self {
            n: &self.n * &o.n,
            d: &self.d * &o.d,
        }
    }

    /// `self / o`; `o` must not be zero.
    pub fn div(&self, o: &Self) -> Self {
        let (n, d) = (&self.n * &o.d, &self.d * &o.n);
        if d.sign() == Sign::Minus {
            Self { n: -n, d: -d }
        } else {
            Self { n, d }
        }
    }

    /// The sign.
    pub fn sign(&self) -> Sign {
        self.n.sign()
    }

    /// An approximate `f64` value (to about 60 bits), for messages and measurements.
    pub fn approx(&self) -> f64 {
        // Both sides shifted to keep 60 bits of the larger.
        let shift = |b: &BigInt| b.bits().saturating_sub(60) as usize;
        let s = shift(&self.n).max(shift(&self.d));
        let (n, d) = (&self.n >> s, &self.d >> s);
        let f = |b: BigInt| {
            let (sign, digits) = b.to_u64_digits();
            let v = digits
                .iter()
                .rev()
                .fold(0.0f64, |a, &x| a * 18_446_744_073_709_551_616.0 + x as f64);
            if sign == Sign::Minus { -v } else { v }
        };
        f(n) / f(d)
    }
}

impl PartialEq for Q {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Q {}
impl PartialOrd for Q {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Q {
    fn cmp(&self, o: &Self) -> Ordering {
        (&self.n * &o.d).cmp(&(&o.n * &self.d))
    }
}

/// A cell of the list: its minimum corner and, for contour mode, its normal and contour
/// words.
#[derive(Clone, Copy, Debug)]
pub struct RefCell {
    /// The cell.
    pub lo: UVec3,
    /// Its normal and contour words.
    pub words: (u32, u32),
}

/// The octahedral normal word's vector, times 32767: `docs/format.md`'s decoding before the
/// normalization, in integers.
pub fn octahedral(word: u32) -> [i64; 3] {
    let h = |v: u32| i64::from(v as u16 as i16).max(-32767);
    let (x, y) = (h(word & 0xFFFF), h(word >> 16));
    let z = 32767 - x.abs() - y.abs();
    let sign = |v: i64| if v >= 0 { 1 } else { -1 };
    if z < 0 {
        [(32767 - y.abs()) * sign(x), (32767 - x.abs()) * sign(y), z]
    } else {
        [x, y, z]
    }
}

/// Random normal and contour words: any pair of snorm16 halves but `-32768` is a direction
/// (one in five along +y, so its slab has faces parallel to the cell's), and a pair of
/// unorm16 fractions `near <= far`.
pub fn random_words(rng: &mut impl Rng) -> (u32, u32) {
    let (x, y) = if rng.random_bool(0.2) {
        (0.0, 1.0)
    } else {
        (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
    };
    let q = |v: f64| u32::from(((v * 32767.0).round() as i16) as u16);
    let a = rng.random_range(0.0..1.0f64);
    let b = (a + rng.random_range(0.0..0.3)).min(1.0);
    let u = |t: f64| (t * 65535.0).round() as u32;
    (q(x) | q(y) << 16, u(a) | u(b) << 16)
}

/// The cells with random words.
pub fn with_words(rng: &mut impl Rng, cells: &[UVec3]) -> Vec<RefCell> {
    cells
        .iter()
        .map(|&lo| RefCell {
            lo,
            words: random_words(rng),
        })
        .collect()
}

/// Each cell's index in the list.
pub fn index_of(cells: &[RefCell]) -> HashMap<UVec3, usize> {
    cells.iter().enumerate().map(|(i, c)| (c.lo, i)).collect()
}

/// The tree under test: the cells at `depth` in a root of side `2^depth` at the origin (so
/// scene and grid coordinates agree), each leaf given its cell's words.
pub fn tree_of(depth: u8, cells: &[RefCell]) -> Octree {
    let root = RootCube {
        origin: glam::DVec3::ZERO,
        side: f64::from(1u32 << depth),
    };
    let mut tree =
        Octree::from_cells(root, depth, cells.iter().map(|c| (c.lo, Voxel::default()))).unwrap();
    let words: HashMap<UVec3, (u32, u32)> = cells.iter().map(|c| (c.lo, c.words)).collect();
    let mut normals = vec![0; tree.leaf_count as usize];
    let mut contours = vec![0; tree.leaf_count as usize];
    for l in tree.leaves() {
        let (n, c) = words[&l.cell];
        normals[l.index as usize] = n;
        contours[l.index as usize] = c;
    }
    tree.attributes.normal = Channel::PerLeaf(normals);
    tree.attributes.contour = Channel::PerLeaf(contours);
    tree
}

/// A ray in exact form, with the `f32` values it was made from.
pub struct ExactRay {
    /// The origin, exactly.
    pub o: [Q; 3],
    /// The direction, exactly.
    pub d: [Q; 3],
    /// Per axis, the sign of the direction component, zeros included (`true`: negative).
    pub neg: [bool; 3],
    /// Where the ray starts.
    pub tmin: Q,
    /// The origin, direction and `tmin` as given.
    f32s: ([f32; 3], [f32; 3], f32),
}

impl ExactRay {
    /// The exact ray of the `f32` origin and direction, from `tmin`.
    pub fn new(o: [f32; 3], d: [f32; 3], tmin: f32) -> Self {
        Self {
            o: o.map(|v| Q::of(f64::from(v))),
            d: d.map(|v| Q::of(f64::from(v))),
            neg: d.map(f32::is_sign_negative),
            tmin: Q::of(f64::from(tmin)),
            f32s: (o, d, tmin),
        }
    }

    /// The point at `t`.
    pub fn at(&self, t: &Q) -> [Q; 3] {
        [0, 1, 2].map(|k| self.o[k].add(&self.d[k].mul(t)))
    }
}

/// A parameter interval `[a, b]`, `b == None` for no upper end.
pub struct Interval {
    /// Where it starts.
    pub a: Q,
    /// Where it ends, if it does.
    pub b: Option<Q>,
}

impl Interval {
    /// Positive length: the ray is inside, not only touching.
    pub fn entered(&self) -> bool {
        self.b.as_ref().is_none_or(|b| self.a < *b)
    }
}

/// The cell's region as linear constraints `lo <= s0 + t sd <= hi` along the line `o + t d`.
fn constraints(o: &[Q; 3], d: &[Q; 3], cell: &RefCell, contour: bool, grow: &Q) -> Vec<[Q; 4]> {
    let mut out = Vec::with_capacity(4);
    for k in 0..3 {
        let lo = Q::int(i64::from(cell.lo[k])).sub(grow);
        let hi = Q::int(i64::from(cell.lo[k]) + 1).add(grow);
        out.push([lo, hi, o[k].clone(), d[k].clone()]);
    }
    if contour {
        let m = octahedral(cell.words.0).map(Q::int);
        let l1 = Q::int(octahedral(cell.words.0).iter().map(|v| v.abs()).sum());
        let frac = |h: u32| Q::int(2 * i64::from(h & 0xFFFF) - 65535).div(&Q::int(131_070));
        let near = frac(cell.words.1).mul(&l1).sub(&grow.mul(&l1));
        let far = frac(cell.words.1 >> 16).mul(&l1).add(&grow.mul(&l1));
        let half = Q::int(1).div(&Q::int(2));
        let rel: [Q; 3] = [0, 1, 2].map(|k| o[k].sub(&Q::int(i64::from(cell.lo[k]))).sub(&half));
        let dot = |v: &[Q; 3]| m[0].mul(&v[0]).add(&m[1].mul(&v[1])).add(&m[2].mul(&v[2]));
        out.push([near, far, dot(&rel), dot(d)]);
    }
    out
}

/// Where the ray, from `tmin` on, is in `cell`'s region grown by `grow` cells (shrunk where
/// negative; the slab's planes move by `grow |m|_1` in `m`'s units, which is between `grow`
/// and `sqrt(3) grow` along the unit normal). `None` when it never is.
pub fn interval(ray: &ExactRay, cell: &RefCell, contour: bool, grow: &Q) -> Option<Interval> {
    let mut a = ray.tmin.clone();
    let mut b: Option<Q> = None;
    for (k, [lo, hi, s0, sd]) in constraints(&ray.o, &ray.d, cell, contour, grow)
        .into_iter()
        .enumerate()
    {
        if lo > hi {
            return None;
        }
        if sd.sign() == Sign::NoSign {
            // Cube axes: an infinitesimal of the zero's sign. A slab parallel to the ray:
            // the closed range.
            let inside = if k < 3 {
                if ray.neg[k] {
                    s0 > lo && s0 <= hi
                } else {
                    s0 >= lo && s0 < hi
                }
            } else {
                s0 >= lo && s0 <= hi
            };
            if !inside {
                return None;
            }
            continue;
        }
        let t1 = lo.sub(&s0).div(&sd);
        let t2 = hi.sub(&s0).div(&sd);
        let (tl, th) = if t1 <= t2 { (t1, t2) } else { (t2, t1) };
        if tl > a {
            a = tl;
        }
        if b.as_ref().is_none_or(|b| th < *b) {
            b = Some(th);
        }
    }
    b.as_ref()
        .is_none_or(|b| a <= *b)
        .then_some(Interval { a, b })
}

/// Whether the point `p` lies in the region grown by `grow`.
pub fn contains(p: &[Q; 3], cell: &RefCell, contour: bool, grow: &Q) -> bool {
    // As a line standing still: every constraint's value is its `s0`.
    let still = [Q::int(0), Q::int(0), Q::int(0)];
    constraints(p, &still, cell, contour, grow)
        .iter()
        .all(|[lo, hi, s0, _]| s0 >= lo && s0 <= hi)
}

/// A lower bound on where the ray, from `tmin` on, first comes within half a cell of the
/// cell's cube, in `f64` with room for its rounding; `None` when it stays farther away.
/// A region shrunk by any margin is entered no earlier, so the exact search can visit
/// cells in this order and stop early.
fn lower_bound(o: [f64; 3], d: [f64; 3], tmin: f64, lo: UVec3) -> Option<f64> {
    let (mut a, mut b) = (tmin, f64::INFINITY);
    for k in 0..3 {
        let (l, h) = (f64::from(lo[k]) - 0.5, f64::from(lo[k]) + 1.5);
        if d[k] == 0.0 {
            if o[k] < l || o[k] > h {
                return None;
            }
            continue;
        }
        let (t1, t2) = ((l - o[k]) / d[k], (h - o[k]) / d[k]);
        a = a.max(t1.min(t2));
        b = b.min(t1.max(t2));
    }
    // Each parameter is within 2^-51 of its own magnitude of the exact one.
    let slack = |v: f64| v.abs() * 2f64.powi(-40);
    (a - slack(a) <= b + slack(b)).then(|| a - slack(a))
}

/// The exact first entry of a ray into the cells' regions shrunk by `margin`: the least
/// entry parameter over the cells whose shrunk region the ray enters (a parameter interval
/// of positive length), with the cell's index; `None` when it enters none.
pub fn first_entry(
    ray: &ExactRay,
    cells: &[RefCell],
    contour: bool,
    margin: &Q,
) -> Option<(Q, usize)> {
    let (o, d, tmin) = ray.f32s;
    let (o, d, tmin) = (o.map(f64::from), d.map(f64::from), f64::from(tmin));
    let mut order: Vec<(f64, usize)> = cells
        .iter()
        .enumerate()
        .filter_map(|(i, c)| lower_bound(o, d, tmin, c.lo).map(|lb| (lb, i)))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let shrink = Q::int(0).sub(margin);
    let mut best: Option<(Q, usize)> = None;
    for &(lb, i) in &order {
        if let Some((b, _)) = &best
            && Q::of(lb) > *b
        {
            break;
        }
        if let Some(iv) = interval(ray, &cells[i], contour, &shrink)
            && iv.entered()
            && best.as_ref().is_none_or(|(b, _)| iv.a < *b)
        {
            best = Some((iv.a, i));
        }
    }
    best
}
