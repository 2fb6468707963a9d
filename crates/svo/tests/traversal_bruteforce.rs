//! The octree traversal against brute force: every ray against every leaf's cube or contour
//! slab, in `f64`, on seeded random trees and rays, including axis-parallel rays with `+0.0`
//! and `-0.0` components, rays through lattice corners and edges, rays along cell faces,
//! rays starting inside the root and inside leaves, and a sparse deep tree.
//!
//! What is checked, for each ray: let `T_in` be the nearest parameter where the ray is inside
//! some leaf's region shrunk by `delta` (it really enters the leaf), and `T_touch` the nearest
//! where it touches some leaf's region grown by `delta`. `delta` is `DELTA` cells plus
//! `f32`'s relative precision (a few ulps) times the distance the ray travels: a ray
//! parameter near `t` is only known to `t * 2^-23`, so a ray from 30,000 cells away places
//! its points to about 0.01 cells, and the contour test on such rays can be no finer. The traversal's hit `t` must satisfy
//! `T_touch <= t <= T_in` (within `f32` rounding), the point at `t` must lie in the reported
//! leaf's region, and a ray with a finite `T_in` must hit and never be capped. So no leaf the
//! ray enters is missed, and nothing that it does not touch is hit.
#![cfg(feature = "trace")]

mod common;

use glam::{DVec3, UVec3, Vec3};
use rand::Rng;
use svo::RootCube;
use svo::octree::{Channel, Octree, Voxel};
use svo::trace::{GridRay, HitMode, MAX_STEPS, cast};

const DELTA: f64 = 1e-4;

/// A leaf's region for the reference: the cube and, in contour mode, the slab.
struct Region {
    lo: DVec3,
    hi: DVec3,
    slab: Option<(DVec3, f64, f64)>,
}

impl Region {
    /// The parameter interval where the ray is inside the region grown by `g` (negative:
    /// shrunk), intersected with `[tmin, inf)`.
    fn interval(&self, o: DVec3, d: DVec3, tmin: f64, g: f64) -> Option<(f64, f64)> {
        let (mut a, mut b) = (tmin, f64::INFINITY);
        let mut clip = |s0: f64, sd: f64, lo: f64, hi: f64| {
            // lo <= s0 + t sd <= hi
            if lo > hi {
                a = f64::INFINITY;
            } else if sd == 0.0 {
                if s0 < lo || s0 > hi {
                    a = f64::INFINITY;
                }
            } else {
                let (t1, t2) = ((lo - s0) / sd, (hi - s0) / sd);
                a = a.max(t1.min(t2));
                b = b.min(t1.max(t2));
            }
        };
        for k in 0..3 {
            clip(o[k], d[k], self.lo[k] - g, self.hi[k] + g);
        }
        if let Some((n, near, far)) = self.slab {
            let c = (self.lo + self.hi) * 0.5;
            clip(n.dot(o - c), n.dot(d), near - g, far + g);
        }
        // Strictly inside the shrunk region needs a positive-length interval; touching the
        // grown one needs only a point.
        let ok = if g < 0.0 { a < b } else { a <= b };
        ok.then_some((a, b))
    }

    fn contains(&self, p: DVec3, g: f64) -> bool {
        let inside_box = (0..3).all(|k| p[k] >= self.lo[k] - g && p[k] <= self.hi[k] + g);
        inside_box
            && self.slab.is_none_or(|(n, near, far)| {
                let s = n.dot(p - (self.lo + self.hi) * 0.5);
                s >= near - g && s <= far + g
            })
    }
}

/// A stored normal word as the format defines it (docs/format.md: octahedral, two snorm16
/// halves, x low), decoded here in `f64` rather than with the library's decoder.
fn decode_normal(w: u32) -> DVec3 {
    let h = |v: u32| (f64::from(v as u16 as i16) / 32767.0).clamp(-1.0, 1.0);
    let (x, y) = (h(w & 0xFFFF), h(w >> 16));
    let z = 1.0 - x.abs() - y.abs();
    let n = if z < 0.0 {
        DVec3::new(
            (1.0 - y.abs()) * x.signum(),
            (1.0 - x.abs()) * y.signum(),
            z,
        )
    } else {
        DVec3::new(x, y, z)
    };
    n.normalize()
}

fn regions(tree: &Octree, mode: HitMode) -> Vec<(u32, Region)> {
    tree.leaves()
        .map(|l| {
            let lo = l.cell.as_dvec3();
            let slab = (mode == HitMode::Contour).then(|| {
                let word = |c: &Channel<u32>| match c {
                    Channel::PerLeaf(v) => v[l.index as usize],
                    Channel::Constant(v) => *v,
                    Channel::Absent => unreachable!(),
                };
                let n = decode_normal(word(&tree.attributes.normal));
                let cw = word(&tree.attributes.contour);
                // The cell spans [-e, e] along the unit normal; the planes are fractions of it.
                let e = 0.5 * (n.x.abs() + n.y.abs() + n.z.abs());
                let frac = |h: u32| f64::from(h & 0xFFFF) / 65535.0;
                (
                    n,
                    (2.0 * frac(cw) - 1.0) * e,
                    (2.0 * frac(cw >> 16) - 1.0) * e,
                )
            });
            (
                l.index,
                Region {
                    lo,
                    hi: lo + DVec3::ONE,
                    slab,
                },
            )
        })
        .collect()
}

fn tree_of(depth: u8, cells: &[UVec3]) -> Octree {
    let root = RootCube {
        origin: DVec3::ZERO,
        side: f64::from(1u32 << depth),
    };
    Octree::from_cells(root, depth, cells.iter().map(|&c| (c, Voxel::default()))).unwrap()
}

/// Gives every leaf a random normal and a random contour slab.
fn with_random_contours(mut tree: Octree, rng: &mut impl Rng) -> Octree {
    let n = tree.leaf_count as usize;
    let mut normals = Vec::with_capacity(n);
    let mut contours = Vec::with_capacity(n);
    for _ in 0..n {
        // An octahedral word (docs/format.md): any pair of snorm16 halves is a direction.
        // Some are +y: their slabs have faces parallel to the cell's.
        let (x, y) = if rng.random_bool(0.2) {
            (0.0, 1.0)
        } else {
            (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
        };
        let q = |v: f64| u32::from(((v * 32767.0).round() as i16) as u16);
        let w = q(x) | q(y) << 16;
        // The planes as unorm16 fractions of the cell's extent along the normal, near <= far.
        let a = rng.random_range(0.0..1.0f64);
        let b = (a + rng.random_range(0.0..0.3)).min(1.0);
        let u = |t: f64| (t * 65535.0).round() as u32;
        normals.push(w);
        contours.push(u(a) | u(b) << 16);
    }
    tree.attributes.normal = Channel::PerLeaf(normals);
    tree.attributes.contour = Channel::PerLeaf(contours);
    tree
}

fn random_cells(rng: &mut impl Rng, depth: u8, density: f64) -> Vec<UVec3> {
    let side = 1u32 << depth;
    let mut cells = Vec::new();
    for x in 0..side {
        for y in 0..side {
            for z in 0..side {
                if rng.random_bool(density) {
                    cells.push(UVec3::new(x, y, z));
                }
            }
        }
    }
    cells
}

fn signed_zero(rng: &mut impl Rng) -> f32 {
    if rng.random_bool(0.5) { 0.0 } else { -0.0 }
}

/// A ray of one of the families the module doc lists, with its `tmin`.
fn random_ray(rng: &mut impl Rng, n: f32) -> (GridRay, f32) {
    let inside = |rng: &mut dyn rand::RngCore| {
        Vec3::new(
            rng.random_range(0.0..n),
            rng.random_range(0.0..n),
            rng.random_range(0.0..n),
        )
    };
    let unit = |rng: &mut dyn rand::RngCore| loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length() > 0.1 && v.length() < 1.0 {
            break v.normalize();
        }
    };
    let lattice = |rng: &mut dyn rand::RngCore| {
        let k = n as i32;
        Vec3::new(
            rng.random_range(-2..=k + 2) as f32,
            rng.random_range(-2..=k + 2) as f32,
            rng.random_range(-2..=k + 2) as f32,
        )
    };
    match rng.random_range(0..7) {
        // From outside towards a point inside.
        0 => {
            let target = inside(rng);
            let o = Vec3::splat(n * 0.5) + unit(rng) * n * 1.5;
            (
                GridRay {
                    origin: o,
                    dir: target - o,
                },
                0.0,
            )
        }
        // From inside, any direction, sometimes starting later along the ray.
        1 => {
            let tmin = if rng.random_bool(0.3) {
                rng.random_range(0.0..n)
            } else {
                0.0
            };
            (
                GridRay {
                    origin: inside(rng),
                    dir: unit(rng),
                },
                tmin,
            )
        }
        // Axis-parallel: one non-zero component, the others signed zeros.
        2 => {
            let axis = rng.random_range(0..3);
            let mut d = Vec3::new(signed_zero(rng), signed_zero(rng), signed_zero(rng));
            d[axis] = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let mut o = inside(rng);
            o[axis] = if d[axis] > 0.0 { -1.0 } else { n + 1.0 };
            // Often exactly on a cell face or edge.
            for k in 0..3 {
                if k != axis && rng.random_bool(0.5) {
                    o[k] = o[k].floor();
                }
            }
            (GridRay { origin: o, dir: d }, 0.0)
        }
        // Along a face: two non-zero components, the origin on a lattice plane.
        3 => {
            let axis = rng.random_range(0..3);
            let mut d = unit(rng);
            d[axis] = signed_zero(rng);
            let mut o = inside(rng);
            o[axis] = rng.random_range(0..=n as u32) as f32;
            (GridRay { origin: o, dir: d }, 0.0)
        }
        // Through lattice corners and edges: integer origin, small integer direction.
        4 => {
            let mut d = Vec3::new(
                rng.random_range(-2..=2) as f32,
                rng.random_range(-2..=2) as f32,
                rng.random_range(-2..=2) as f32,
            );
            if d == Vec3::ZERO {
                d.x = 1.0;
            }
            for k in 0..3 {
                if d[k] == 0.0 {
                    d[k] = signed_zero(rng);
                }
            }
            (
                GridRay {
                    origin: lattice(rng),
                    dir: d,
                },
                0.0,
            )
        }
        // Exact diagonals through the root's corners.
        5 => {
            let s = |rng: &mut dyn rand::RngCore| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let d = Vec3::new(s(rng), s(rng), s(rng));
            let o = Vec3::splat(n * 0.5) - d * n;
            (GridRay { origin: o, dir: d }, 0.0)
        }
        // Tiny (denormal-ish) components.
        _ => {
            let mut d = unit(rng);
            d[rng.random_range(0..3)] = if rng.random_bool(0.5) { 1e-30 } else { -1e-30 };
            (
                GridRay {
                    origin: inside(rng),
                    dir: d,
                },
                0.0,
            )
        }
    }
}

/// Checks one ray; returns whether it hit.
fn check_ray(
    tree: &Octree,
    regs: &[(u32, Region)],
    ray: &GridRay,
    tmin: f32,
    mode: HitMode,
) -> bool {
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let tmin64 = f64::from(tmin);
    let scale = d.length().max(1e-30);
    // How far the ray travels before leaving the root, in cells, bounds the f32 error.
    let side = f64::from(1u32 << tree.depth);
    let travel = (o - DVec3::splat(side * 0.5)).length() + side;
    let delta = DELTA + 4e-7 * travel;
    let g = delta / scale; // delta as a ray parameter
    let mut t_in = f64::INFINITY;
    let mut t_touch = f64::INFINITY;
    for (_, r) in regs {
        if let Some((a, _)) = r.interval(o, d, tmin64, -delta) {
            t_in = t_in.min(a);
        }
        if let Some((a, _)) = r.interval(o, d, tmin64, delta) {
            t_touch = t_touch.min(a);
        }
    }
    let res = cast(tree, ray, tmin, f32::INFINITY, mode, None, MAX_STEPS);
    assert!(!res.capped, "capped: {ray:?}");
    match res.hit {
        None => {
            if t_in.is_finite() {
                for (i, r) in regs {
                    if let Some(iv) = r.interval(o, d, tmin64, -delta) {
                        eprintln!(
                            "entered leaf {i} {:?} interval {iv:?} slab {:?}",
                            r.lo, r.slab
                        );
                    }
                }
                svo::trace::traverse(tree, ray, tmin, f32::INFINITY, MAX_STEPS, |e| {
                    eprintln!("visit {e:?}");
                    None::<()>
                });
            }
            assert!(
                t_in.is_infinite(),
                "{mode:?}: missed a leaf entered at t = {t_in}: {ray:?} tmin {tmin}"
            )
        }
        Some(h) => {
            let t = f64::from(h.t);
            let tol = 1e-5 * (1.0 + t.abs()) + g;
            assert!(
                t <= t_in + tol && t >= t_touch - tol,
                "{mode:?}: hit at {t}, but entered at {t_in}, touched at {t_touch}: {ray:?} tmin {tmin} leaf {}",
                h.leaf
            );
            let (_, reg) = regs.iter().find(|(i, _)| *i == h.leaf).unwrap();
            assert!(
                reg.contains(o + d * t, delta + 1e-5),
                "{mode:?}: hit point outside leaf {}: {ray:?}, t {t}",
                h.leaf
            );
            assert_eq!(tree.leaf_at(h.cell), Some(h.leaf), "cell and leaf disagree");
        }
    }
    res.hit.is_some()
}

#[test]
fn traversal_equals_brute_force_on_random_trees() {
    let mut rng = common::rng(0x7ACE);
    let mut rays = 0;
    let mut hits = [0usize; 2];
    for depth in 1..=5u8 {
        for &density in &[0.02, 0.15, 0.5, 0.95] {
            let cells = random_cells(&mut rng, depth, density);
            if cells.is_empty() {
                continue;
            }
            let tree = with_random_contours(tree_of(depth, &cells), &mut rng);
            let n = (1u32 << depth) as f32;
            for (mi, mode) in [HitMode::Cube, HitMode::Contour].into_iter().enumerate() {
                let regs = regions(&tree, mode);
                // Fewer rays where each costs a brute force over 30,000 leaves.
                let count = if depth == 5 { 150 } else { 600 };
                for _ in 0..count {
                    let (ray, tmin) = random_ray(&mut rng, n);
                    hits[mi] += usize::from(check_ray(&tree, &regs, &ray, tmin, mode));
                    rays += 1;
                }
            }
        }
    }
    // The families must exercise both outcomes.
    assert!(
        hits[0] > rays / 8 && hits[1] > rays / 10,
        "hits {hits:?} of {rays}"
    );
}

#[test]
fn deep_sparse_tree() {
    let mut rng = common::rng(0xDEE9);
    let depth = 16u8;
    let side = 1u32 << depth;
    // Clusters of cells around random centres, plus scattered ones.
    let mut cells = Vec::new();
    for _ in 0..12 {
        let c = UVec3::new(
            rng.random_range(4..side - 4),
            rng.random_range(4..side - 4),
            rng.random_range(4..side - 4),
        );
        for _ in 0..40 {
            cells.push(
                c + UVec3::new(
                    rng.random_range(0..4),
                    rng.random_range(0..4),
                    rng.random_range(0..4),
                ) - UVec3::splat(2),
            );
        }
    }
    let tree = with_random_contours(tree_of(depth, &cells), &mut rng);
    let centres: Vec<Vec3> = cells.iter().map(|c| c.as_vec3() + 0.5).collect();
    for mode in [HitMode::Cube, HitMode::Contour] {
        let regs = regions(&tree, mode);
        let mut hit = 0;
        for i in 0..2000 {
            // Aim at a cluster so rays hit; from far outside or from inside the root.
            let target = centres[rng.random_range(0..centres.len())]
                + Vec3::new(
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                );
            let o = if i % 2 == 0 {
                Vec3::new(
                    rng.random_range(0.0..side as f32),
                    rng.random_range(0.0..side as f32),
                    rng.random_range(0.0..side as f32),
                )
            } else {
                target
                    + Vec3::new(
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-50.0..50.0),
                    )
            };
            let mut d = target - o;
            if i % 7 == 0 {
                // Axis-parallel towards the target.
                let k = d.abs().max_position();
                let keep = d[k];
                d = Vec3::new(
                    signed_zero(&mut rng),
                    signed_zero(&mut rng),
                    signed_zero(&mut rng),
                );
                d[k] = keep;
            }
            hit += usize::from(check_ray(
                &tree,
                &regs,
                &GridRay { origin: o, dir: d },
                0.0,
                mode,
            ));
        }
        assert!(hit > 200, "{mode:?}: only {hit} hits");
    }
}

#[test]
fn full_tree_every_axis_parallel_ray_hits_the_first_cell() {
    // A full 8^3 grid: an axis-parallel ray from outside through any cell centre or along
    // any lattice line hits at the root face, whatever the zero signs.
    let depth = 3u8;
    let n = 8u32;
    let cells: Vec<UVec3> = (0..n * n * n)
        .map(|i| UVec3::new(i / 64, i / 8 % 8, i % 8))
        .collect();
    let tree = tree_of(depth, &cells);
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            for a in 0..=2 * n {
                for b in 0..=2 * n {
                    for zs in [0.0f32, -0.0] {
                        let mut o = Vec3::splat(0.0);
                        let mut d = Vec3::splat(zs);
                        d[axis] = sign;
                        o[axis] = if sign > 0.0 { -3.0 } else { n as f32 + 3.0 };
                        o[(axis + 1) % 3] = a as f32 * 0.5;
                        o[(axis + 2) % 3] = b as f32 * 0.5;
                        let r = cast(
                            &tree,
                            &GridRay { origin: o, dir: d },
                            0.0,
                            f32::INFINITY,
                            HitMode::Cube,
                            None,
                            MAX_STEPS,
                        );
                        // On the root's boundary a zero whose sign points outwards stands
                        // for a ray that leaves the root: it must miss. Every other ray hits.
                        let outward = |v: u32| {
                            (v == 0 && zs.is_sign_negative())
                                || (v == 2 * n && zs.is_sign_positive())
                        };
                        if outward(a) || outward(b) {
                            assert!(r.hit.is_none(), "hit {o} {d}");
                            continue;
                        }
                        let h = r.hit.unwrap_or_else(|| panic!("miss {o} {d}"));
                        assert_eq!(h.t, 3.0, "{o} {d}");
                        let mut want = Vec3::ZERO;
                        want[axis] = -sign;
                        assert_eq!(h.normal, want);
                    }
                }
            }
        }
    }
}

#[test]
fn invalid_rays_miss_without_panicking() {
    let tree = tree_of(2, &[UVec3::new(1, 1, 1)]);
    for (o, d) in [
        (Vec3::NAN, Vec3::X),
        (Vec3::ZERO, Vec3::ZERO),
        (Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0)),
        (Vec3::splat(f32::INFINITY), Vec3::ONE),
        (Vec3::splat(-1e30), Vec3::ONE),
        (Vec3::splat(1e30), Vec3::splat(1e-30)),
    ] {
        let r = cast(
            &tree,
            &GridRay { origin: o, dir: d },
            0.0,
            f32::INFINITY,
            HitMode::Cube,
            None,
            MAX_STEPS,
        );
        assert!(!r.capped);
        // A far but valid ray may hit; only non-finite input is guaranteed to miss.
        if !(o.is_finite() && d.is_finite() && d != Vec3::ZERO) {
            assert!(r.hit.is_none());
        }
    }
}

#[test]
fn step_cap_is_reported() {
    let cells: Vec<UVec3> = (0..16u32).map(|x| UVec3::new(x, 3, 3)).collect();
    let tree = tree_of(4, &cells);
    let ray = GridRay {
        origin: Vec3::new(-1.0, 3.5, 3.5),
        dir: Vec3::X,
    };
    // Decline every leaf: the ray walks all 16 and some empty siblings.
    let all = svo::trace::traverse(&tree, &ray, 0.0, f32::INFINITY, MAX_STEPS, |_| None::<()>);
    assert!(!all.capped && all.hit.is_none() && all.steps >= 16);
    let capped = svo::trace::traverse(&tree, &ray, 0.0, f32::INFINITY, 5, |_| None::<()>);
    assert!(capped.capped && capped.steps == 6);
}
