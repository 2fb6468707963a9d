//! Four rays through the octree in one walk: [`traverse_packet`] hands each ray (lane) the
//! leaves, entries, step counts and cap that [`crate::trace::traverse`] would hand it alone,
//! but reads each node once for all the lanes that enter it.
//!
//! The lanes must share the mirror mask (the signs of their directions: rays of neighbouring
//! pixels, shadow rays toward one light, reflections off one flat surface); a packet whose
//! lanes do not is walked one ray after another. In the mirrored space every lane's walk
//! through a node visits a chain of children whose indices only gain bits
//! ([`crate::trace::traverse`]: the next child sets the crossed axes' bits), so the increasing
//! numeric order of child indices is front to back for every lane at once. A node's
//! children are therefore visited in that order, each by the lanes whose chain contains it:
//!
//! - each lane's chain through the node (which children it visits, where it enters and
//!   leaves each) is computed when the packet enters the node, by the single walk's own
//!   steps (`first_child`, `next_child`) on that lane's planes, so every parameter is the
//!   same bit for bit;
//! - a lane counts a step for each child of its chain as the single walk does (absent
//!   children included), stops at the step cap, past its `tmax`, or when its callback returns
//!   a value, and the packet goes on with the others.
//!
//! The independent lanes also give the processor four chains of dependent arithmetic to
//! overlap where a single ray has one.

use crate::octree::bounds;
use crate::octree::tree::Octree;
use crate::trace::cone::{Cone, node_distance};
use crate::trace::grid_ray::{GridRay, MirroredRay};
use crate::trace::traverse::{LeafEntry, Traversal, WalkNodes, node_entry, traverse_from};
use glam::{BVec4A, UVec3, Vec3, Vec3A, Vec4};

/// Rays in a packet.
pub const LANES: usize = 4;

/// A node (of a tree's array or a graph, [`WalkNodes`]) being walked by the packet, one SIMD
/// lane per ray.
#[derive(Clone, Copy, Debug)]
struct Frame<N> {
    node: N,
    /// Mirrored minimum corner, in leaf cells.
    corner: UVec3,
    /// The lanes whose chain through the node has a child left ...
    chain: BVec4A,
    /// ... that child's bits (x, y, z) ...
    bx: BVec4A,
    by: BVec4A,
    bz: BVec4A,
    /// ... and where the lane enters it (at least its tmin).
    enter: Vec4,
}

impl<N: Copy> Frame<N> {
    /// A frame of `node`, no lane in it.
    const fn of(node: N) -> Self {
        Self {
            node,
            corner: UVec3::ZERO,
            chain: BVec4A::FALSE,
            bx: BVec4A::FALSE,
            by: BVec4A::FALSE,
            bz: BVec4A::FALSE,
            enter: Vec4::ZERO,
        }
    }
}

/// The lanes of each 4-bit mask (bit `l` for lane `l`).
const LANE_MASKS: [BVec4A; 16] = {
    let mut t = [BVec4A::FALSE; 16];
    let mut b = 0;
    while b < 16 {
        t[b] = BVec4A::new(b & 1 != 0, b & 2 != 0, b & 4 != 0, b & 8 != 0);
        b += 1;
    }
    t
};

/// Plane parameters of the lanes on the three axes.
#[derive(Clone, Copy, Debug)]
struct Planes {
    x: Vec4,
    y: Vec4,
    z: Vec4,
}

/// The lanes' rays in the shared mirrored space.
struct Lanes {
    ox: Vec4,
    oy: Vec4,
    oz: Vec4,
    ix: Vec4,
    iy: Vec4,
    iz: Vec4,
    tmin: Vec4,
    tmax: Vec4,
}

impl Lanes {
    /// Every lane's [`MirroredRay::t_planes`] at mirrored planes `p`, bit for bit.
    #[inline]
    fn planes(&self, any: &MirroredRay, p: UVec3) -> Planes {
        let real = any.real_planes(p);
        Planes {
            x: (Vec4::splat(real.x) - self.ox) * self.ix,
            y: (Vec4::splat(real.y) - self.oy) * self.iy,
            z: (Vec4::splat(real.z) - self.oz) * self.iz,
        }
    }
}

/// Traverses `tree` along each lane of `rays` in `active` (bit `l` for lane `l`) for
/// parameters in `[tmin[l], tmax[l]]`, calling `on_leaf(l, entry)` for the leaves that lane
/// passes through, front to back, until it returns `Some`; at most `max_steps` children
/// examined per lane. Lane `l`'s outcome, its callbacks and their order equal those of
/// [`crate::trace::traverse`] for ray `l` alone; callbacks of different lanes interleave.
/// Lanes outside `active` are not traced (no hit, no steps). The lanes count their steps in
/// `f32`, exact below 2^24; a cap of 2^24 steps or more walks the lanes one at a time.
pub fn traverse_packet<T>(
    tree: &Octree,
    rays: &[GridRay; LANES],
    tmin: [f32; LANES],
    tmax: [f32; LANES],
    active: u8,
    max_steps: u32,
    on_leaf: impl FnMut(usize, &LeafEntry) -> Option<T>,
) -> [Traversal<T>; LANES] {
    let exact = [Cone::EXACT; LANES];
    traverse_packet_with::<true, T>(tree, rays, exact, tmin, tmax, active, max_steps, on_leaf)
}

/// [`traverse_packet`] with lane `l` walked as [`crate::trace::traverse_cone`] walks it with
/// `cones[l]` (an inner node where the lane's cone stops it handed over in place of its
/// leaves), and with `NORMALS` false for callbacks that read no entry normals: the entries'
/// `entry_normal` and `exit_normal` are then zero where the lanes walk together (a packet
/// whose lanes are walked one at a time still gets them). Everything else is the same bit
/// for bit.
#[allow(clippy::too_many_arguments)]
pub(crate) fn traverse_packet_with<const NORMALS: bool, T>(
    tree: &Octree,
    rays: &[GridRay; LANES],
    cones: [Cone; LANES],
    tmin: [f32; LANES],
    tmax: [f32; LANES],
    active: u8,
    max_steps: u32,
    on_leaf: impl FnMut(usize, &LeafEntry) -> Option<T>,
) -> [Traversal<T>; LANES] {
    let d = tree.depth;
    traverse_packet_on::<NORMALS, _, T>(
        tree, d, rays, cones, tmin, tmax, active, max_steps, on_leaf,
    )
}

/// [`traverse_packet_with`] on the nodes of `nodes` (a tree's array, or a graph: the same
/// walk, [`WalkNodes`]) of a tree of `depth` levels.
#[allow(clippy::too_many_arguments)]
pub(crate) fn traverse_packet_on<const NORMALS: bool, W: WalkNodes, T>(
    nodes: &W,
    depth: u8,
    rays: &[GridRay; LANES],
    cones: [Cone; LANES],
    tmin: [f32; LANES],
    tmax: [f32; LANES],
    active: u8,
    max_steps: u32,
    on_leaf: impl FnMut(usize, &LeafEntry) -> Option<T>,
) -> [Traversal<T>; LANES] {
    let lanes = (rays, cones, tmin, tmax, active, max_steps);
    if depth <= 4 {
        walk::<4, NORMALS, W, T>(nodes, depth, lanes, on_leaf)
    } else if depth <= 12 {
        walk::<12, NORMALS, W, T>(nodes, depth, lanes, on_leaf)
    } else {
        walk::<32, NORMALS, W, T>(nodes, depth, lanes, on_leaf)
    }
}

/// The lanes' rays, cones, parameter ranges, which are traced, and the step cap.
type LaneArgs<'a> = (
    &'a [GridRay; LANES],
    [Cone; LANES],
    [f32; LANES],
    [f32; LANES],
    u8,
    u32,
);

fn nothing<T>() -> [Traversal<T>; LANES] {
    std::array::from_fn(|_| Traversal {
        hit: None,
        steps: 0,
        capped: false,
    })
}

/// Whether glam's `Vec4::min` and `max` are SSE's `minps` and `maxps`, which return the
/// second operand unless the first is smaller (or larger): the single walk's
/// `if a < b { a } else { b }` and its twin lane by lane, `-0.0` and `0.0` included. Other
/// targets' vector minimum may take `-0.0` as the smaller, so there [`min4`] and [`max4`]
/// compare and select.
const SSE_MIN_MAX: bool = cfg!(all(
    any(target_arch = "x86", target_arch = "x86_64"),
    target_feature = "sse2"
));

/// The single walk's minimum `if a < b { a } else { b }`, lane by lane ([`SSE_MIN_MAX`]).
#[inline]
fn min4(a: Vec4, b: Vec4) -> Vec4 {
    if SSE_MIN_MAX {
        a.min(b)
    } else {
        Vec4::select(a.cmplt(b), a, b)
    }
}

/// The single walk's maximum `if a > b { a } else { b }`, lane by lane ([`SSE_MIN_MAX`]).
#[inline]
fn max4(a: Vec4, b: Vec4) -> Vec4 {
    if SSE_MIN_MAX {
        a.max(b)
    } else {
        Vec4::select(a.cmpgt(b), a, b)
    }
}

#[inline]
fn lane(v: Vec4, l: usize) -> f32 {
    v.to_array()[l]
}

/// The first child of every lane entering at `t` (`first_child` per lane): the axes whose
/// mid plane is at or before `t`.
#[inline]
fn first_bits<N>(f: &mut Frame<N>, tm: &Planes, t: Vec4) {
    f.bx = tm.x.cmple(t);
    f.by = tm.y.cmple(t);
    f.bz = tm.z.cmple(t);
}

fn walk<const STACK: usize, const NORMALS: bool, W: WalkNodes, T>(
    nodes: &W,
    tree_depth: u8,
    (rays, cones, tmin, tmax, active, max_steps): LaneArgs<'_>,
    mut on_leaf: impl FnMut(usize, &LeafEntry) -> Option<T>,
) -> [Traversal<T>; LANES] {
    let mut out = nothing();
    let depth = usize::from(tree_depth);
    if depth == 0 || depth > usize::from(crate::MAX_DEPTH) {
        return out;
    }
    let n = 1u32 << depth;
    let Some(root) = nodes.root() else {
        return out;
    };
    if W::mask(root) == 0 {
        return out;
    }
    // The lanes that enter the root, with their mirrored rays and entries.
    let mut r: [Option<MirroredRay>; LANES] = [None; LANES];
    let mut enter = [0.0f32; LANES];
    let mut lanes = 0u8;
    let mut first: Option<MirroredRay> = None;
    let mut mixed = false;
    for l in 0..LANES {
        if active >> l & 1 == 0 {
            continue;
        }
        let Some(m) = MirroredRay::new(&rays[l], n) else {
            continue;
        };
        let Some((_, _, e)) = m.root_entry(tmin[l], tmax[l]) else {
            continue;
        };
        mixed |= first.is_some_and(|f| f.mask != m.mask);
        first.get_or_insert(m);
        r[l] = Some(m);
        enter[l] = e;
        lanes |= 1 << l;
    }
    let Some(any) = first else {
        return out;
    };
    if mixed || max_steps >= 1 << 24 {
        // Lanes in different octants have different front-to-back orders: one at a time
        // (and so are caps beyond the packet's f32 step counters).
        for (l, o) in out.iter_mut().enumerate() {
            if lanes >> l & 1 != 0 {
                let (ray, cone) = (&rays[l], cones[l]);
                *o = traverse_from(
                    nodes,
                    tree_depth,
                    ray,
                    None,
                    cone,
                    tmin[l],
                    tmax[l],
                    max_steps,
                    |e| on_leaf(l, e),
                )
                .unwrap_or_else(Traversal::missed);
            }
        }
        return out;
    }
    let mask = any.mask;
    let swap = bounds::swap_mask(mask);
    // The lanes whose cones may stop them at an inner node.
    let coarse = (0..LANES).fold(0u8, |m, l| m | u8::from(!cones[l].is_exact()) << l) & lanes;
    // Lanes not traced get a harmless ray (the first lane's), masked out of every decision.
    let get = |l: usize| r[l].unwrap_or(any);
    let v =
        |f: &dyn Fn(&MirroredRay) -> f32| Vec4::new(f(&get(0)), f(&get(1)), f(&get(2)), f(&get(3)));
    let ls = Lanes {
        ox: v(&|m| m.o.x),
        oy: v(&|m| m.o.y),
        oz: v(&|m| m.o.z),
        ix: v(&|m| m.inv.x),
        iy: v(&|m| m.inv.y),
        iz: v(&|m| m.inv.z),
        tmin: Vec4::from_array(tmin),
        tmax: Vec4::from_array(tmax),
    };
    let bits = |b: u8| LANE_MASKS[usize::from(b & 15)];
    let mut alive = bits(lanes);
    // Steps are counted in f32 lanes, exact below 2^24 (larger caps were walked above).
    let mut steps = Vec4::ZERO;
    let mut capped = BVec4A::FALSE;
    let cap = Vec4::splat(max_steps as f32);
    // The node being walked lives in locals; the stack holds its ancestors (`len - 1`).
    let mut stack = [Frame::of(root); STACK];
    let mut half = n / 2;
    let mut tm = ls.planes(&any, UVec3::splat(half));
    let mut t1 = ls.planes(&any, UVec3::splat(n));
    let mut f = Frame {
        chain: alive,
        enter: Vec4::from_array(enter),
        ..Frame::of(root)
    };
    first_bits(&mut f, &tm, Vec4::from_array(enter));
    let mut len = 1usize;
    'walk: loop {
        let walking = f.chain & alive;
        if !walking.any() {
            // Back to the nearest ancestor with a walking lane; the planes of those passed
            // on the way are not needed.
            loop {
                len -= 1;
                if len == 0 {
                    break 'walk;
                }
                f = stack[len - 1];
                half *= 2;
                if (f.chain & alive).any() {
                    break;
                }
            }
            let corner = f.corner;
            tm = ls.planes(&any, corner + UVec3::splat(half));
            t1 = ls.planes(&any, corner + UVec3::splat(2 * half));
            continue;
        }
        // The lowest child a walking lane visits next: the lanes at it step together. The
        // lowest index is the least (x, y, z) bits in that order, found on the lanes' bit masks.
        let (mut at_bits, mut c) = (walking.bitmask(), 0u8);
        for (b, bit) in [(f.bx, 4u8), (f.by, 2), (f.bz, 1)] {
            let low = at_bits & !b.bitmask();
            if low != 0 {
                at_bits = low;
            } else {
                c |= bit;
            }
        }
        let at = LANE_MASKS[at_bits as usize];
        // The single walk's step, on every lane (used where `at`).
        let c1 = Planes {
            x: Vec4::select(f.bx, t1.x, tm.x),
            y: Vec4::select(f.by, t1.y, tm.y),
            z: Vec4::select(f.bz, t1.z, tm.z),
        };
        // The single walk's minimum and maximum, lane by lane ([`min4`], [`max4`]).
        let m = min4(min4(c1.x, c1.y), c1.z);
        let (tx, ty, tz) = (c1.x.cmpeq(m), c1.y.cmpeq(m), c1.z.cmpeq(m));
        let leaves_node = (f.bx & tx) | (f.by & ty) | (f.bz & tz);
        let t_enter = f.enter;
        f.bx |= at & tx;
        f.by |= at & ty;
        f.bz |= at & tz;
        f.chain &= !(at & leaves_node);
        f.enter = Vec4::select(at, max4(m, ls.tmin), f.enter);
        steps += Vec4::select(at, Vec4::ONE, Vec4::ZERO);
        let over = at & steps.cmpgt(cap);
        if over.any() {
            capped |= over;
            alive &= !over;
        }
        let real = c ^ mask;
        let node = f.node;
        let child_mask = W::mask(node);
        if child_mask >> real & 1 == 0 {
            continue;
        }
        let stepping = at & alive;
        // Front to back: a lane past its tmax is done.
        let past = stepping & t_enter.cmpgt(ls.tmax);
        alive &= !past;
        let t_exit = min4(m, ls.tmax);
        let enters = stepping & !past & !t_exit.cmplt(t_enter);
        if !enters.any() {
            continue;
        }
        let rank = crate::octree::tree::slot_of(child_mask, real);
        let origin = f.corner + super::traverse::child_bits(c) * half;
        if let Some(base) = W::leaf_base(node) {
            let enters = enters.bitmask();
            for l in 0..LANES {
                let Some(ray) = r[l].as_ref().filter(|_| enters >> l & 1 != 0) else {
                    continue;
                };
                let (entry_normal, exit_normal) = if NORMALS {
                    let c1 = Vec3A::new(lane(c1.x, l), lane(c1.y, l), lane(c1.z, l));
                    (
                        ray.entry_normal_of(ray.t_planes(origin), tmin[l]),
                        ray.exit_normal_of(c1),
                    )
                } else {
                    (Vec3::ZERO, Vec3::ZERO)
                };
                let entry = LeafEntry {
                    leaf: W::leaf_of(node, base, rank),
                    cell: ray.unmirror_cell(origin),
                    side: 1,
                    t_enter: lane(t_enter, l),
                    t_exit: lane(t_exit, l),
                    entry_normal,
                    exit_normal,
                };
                if let Some(h) = on_leaf(l, &entry) {
                    out[l].hit = Some(h);
                    alive &= !bits(1 << l);
                }
            }
            continue;
        }
        // A malformed tree deeper than its depth cannot overflow the stack.
        if len == STACK || half < 2 {
            continue;
        }
        let Some(child) = nodes.child(node, real, rank) else {
            continue;
        };
        // The single walk's test of the box of the child's leaves, on every lane.
        let mut enters = enters;
        let boxed = W::leaf_box(child);
        let leaf_box = (boxed != 0).then(|| {
            let (lo, hi) = bounds::cell_box(bounds::mirrored(boxed << 8, swap), origin, half);
            (ls.planes(&any, lo), ls.planes(&any, hi))
        });
        if let Some((b0, b1)) = &leaf_box {
            let first = max4(max4(max4(b0.x, b0.y), b0.z), t_enter);
            let last = min4(min4(min4(b1.x, b1.y), b1.z), t_exit);
            enters &= !last.cmplt(first);
            if !enters.any() {
                continue;
            }
        }
        let may_stop = coarse & enters.bitmask() as u8;
        if may_stop != 0 && !W::is_leaf_parent(child) {
            // The single walk's stop at a node as wide as the lane's cone (traverse.rs).
            let mut stopped = 0u8;
            for l in 0..LANES {
                let Some(ray) = r[l].as_ref().filter(|_| may_stop >> l & 1 != 0) else {
                    continue;
                };
                let cell = ray.flip(origin, half);
                if !cones[l].stops_at(half, node_distance(rays[l].origin, cell, half)) {
                    continue;
                }
                stopped |= 1 << l;
                let of_lane = |p: &Planes| Vec3A::new(lane(p.x, l), lane(p.y, l), lane(p.z, l));
                let bounds = match &leaf_box {
                    Some((b0, b1)) => (of_lane(b0), of_lane(b1)),
                    None => (ray.t_planes(origin), of_lane(&c1)),
                };
                let stop = (W::child_index(node, rank), cell, half);
                let Some(entry) = node_entry(ray, stop, bounds, (tmin[l], tmax[l]), NORMALS) else {
                    continue;
                };
                if let Some(h) = on_leaf(l, &entry) {
                    out[l].hit = Some(h);
                    alive &= !bits(1 << l);
                }
            }
            enters &= !bits(stopped);
            if !enters.any() {
                continue;
            }
        }
        half /= 2;
        t1 = c1;
        tm = ls.planes(&any, origin + UVec3::splat(half));
        stack[len - 1] = f;
        f = Frame {
            corner: origin,
            chain: enters,
            enter: t_enter,
            ..Frame::of(child)
        };
        first_bits(&mut f, &tm, t_enter);
        len += 1;
    }
    for (l, o) in out.iter_mut().enumerate() {
        o.steps = lane(steps, l) as u32;
        o.capped = capped.bitmask() >> l & 1 != 0;
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::octree::{RootCube, Voxel};
    use crate::trace::traverse::traverse_cone;
    use crate::trace::traverse::{MAX_STEPS, traverse};
    use glam::{DVec3, Vec3};

    /// What a lane saw: its entries in order, and its outcome.
    type Seen = (Vec<LeafEntry>, Option<u32>, u32, bool);

    fn alone(
        tree: &Octree,
        ray: &GridRay,
        tmin: f32,
        tmax: f32,
        max_steps: u32,
        stop: &dyn Fn(&LeafEntry) -> bool,
    ) -> Seen {
        let mut seen = Vec::new();
        let t = traverse(tree, ray, tmin, tmax, max_steps, |e| {
            seen.push(*e);
            stop(e).then_some(e.leaf)
        });
        (seen, t.hit, t.steps, t.capped)
    }

    fn packed(
        tree: &Octree,
        rays: &[GridRay; LANES],
        tmin: [f32; LANES],
        tmax: [f32; LANES],
        active: u8,
        max_steps: u32,
        stop: &dyn Fn(&LeafEntry) -> bool,
    ) -> [Seen; LANES] {
        packed_with::<true>(tree, rays, tmin, tmax, active, max_steps, stop)
    }

    /// What each lane of the packet walk on the graph of a tree of `depth` levels saw.
    fn packed_on_graph(
        dag: &crate::dag::DagTree,
        depth: u8,
        p: &Packet,
        stop: &dyn Fn(&LeafEntry) -> bool,
    ) -> [Seen; LANES] {
        let mut seen: [Vec<LeafEntry>; LANES] = Default::default();
        let t = traverse_packet_on::<true, _, _>(
            dag,
            depth,
            &p.rays,
            [Cone::EXACT; LANES],
            p.tmin,
            p.tmax,
            p.active,
            p.max_steps,
            |l, e| {
                seen[l].push(*e);
                stop(e).then_some(e.leaf)
            },
        );
        std::array::from_fn(|l| (seen[l].clone(), t[l].hit, t[l].steps, t[l].capped))
    }

    /// What each lane of the packet walk saw, with or without the entries' normals.
    fn packed_with<const NORMALS: bool>(
        tree: &Octree,
        rays: &[GridRay; LANES],
        tmin: [f32; LANES],
        tmax: [f32; LANES],
        active: u8,
        max_steps: u32,
        stop: &dyn Fn(&LeafEntry) -> bool,
    ) -> [Seen; LANES] {
        let mut seen: [Vec<LeafEntry>; LANES] = Default::default();
        let t = traverse_packet_with::<NORMALS, _>(
            tree,
            rays,
            [Cone::EXACT; LANES],
            tmin,
            tmax,
            active,
            max_steps,
            |l, e| {
                seen[l].push(*e);
                stop(e).then_some(e.leaf)
            },
        );
        std::array::from_fn(|l| {
            (
                std::mem::take(&mut seen[l]),
                t[l].hit,
                t[l].steps,
                t[l].capped,
            )
        })
    }

    /// Four rays to walk together, their ranges, the lanes that walk and the step cap.
    struct Packet {
        rays: [GridRay; LANES],
        tmin: [f32; LANES],
        tmax: [f32; LANES],
        active: u8,
        max_steps: u32,
    }

    /// Four rays of one kind (primary, shadow, axis-parallel, lattice to lattice or any), in
    /// a root of `2^depth` cells, with their `tmin` and `tmax`.
    fn random_packet(
        next: &mut dyn FnMut() -> u64,
        unit: &mut dyn FnMut() -> f64,
        depth: u8,
    ) -> Packet {
        let n = (1u32 << depth) as f32;
        let mut f = || unit() as f32;
        let point = |f: &mut dyn FnMut() -> f32| Vec3::new(f() * n, f() * n, f() * n);
        let lattice = |k: u64| (k % ((1u64 << depth) + 5)) as f32 - 2.0;
        let signed_zero = |k: u64| if k & 1 == 0 { 0.0 } else { -0.0 };
        let kind = next() % 5;
        let eye = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5).normalize_or_zero() * n * 1.7
            + Vec3::splat(n * 0.5);
        let target = point(&mut f);
        let mut rays = [GridRay {
            origin: Vec3::ZERO,
            dir: Vec3::X,
        }; LANES];
        let mut tmin = [0.0f32; LANES];
        let mut tmax = [f32::INFINITY; LANES];
        for l in 0..LANES {
            rays[l] = match kind {
                // Primary rays: one eye, nearby directions.
                0 => GridRay {
                    origin: eye,
                    dir: target - eye + Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5) * n * 0.1,
                },
                // Shadow rays: nearby origins inside, toward one point.
                1 => {
                    let o = target + Vec3::new(f(), f(), f()) * 2.0;
                    GridRay {
                        origin: o,
                        dir: eye - o,
                    }
                }
                // Axis-parallel with signed zeros.
                2 => {
                    let mut d = Vec3::new(
                        signed_zero(next()),
                        signed_zero(next()),
                        signed_zero(next()),
                    );
                    d.x = if kind & 1 == 0 { 1.0 } else { -1.0 };
                    let o = Vec3::new(-1.0, lattice(next()), lattice(next()));
                    GridRay { origin: o, dir: d }
                }
                // Lattice points to lattice points: edges and corners.
                3 => {
                    let o = Vec3::new(lattice(next()), lattice(next()), lattice(next()));
                    let mut d = Vec3::new(
                        1.0 + (next() % 3) as f32,
                        1.0 + (next() % 3) as f32,
                        (next() % 3) as f32,
                    );
                    if d.z == 0.0 {
                        d.z = signed_zero(next());
                    }
                    GridRay { origin: o, dir: d }
                }
                // Anything: random origins and directions (often mixed octants).
                _ => GridRay {
                    origin: point(&mut f),
                    dir: Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5),
                },
            };
            if next().is_multiple_of(4) {
                tmin[l] = f() * 0.5;
            }
            if next().is_multiple_of(4) {
                tmax[l] = tmin[l] + f() * 2.0;
            }
        }
        let active = if next().is_multiple_of(5) {
            (next() % 16) as u8
        } else {
            0b1111
        };
        let max_steps = if next().is_multiple_of(6) {
            (next() % 12) as u32
        } else if next().is_multiple_of(10) {
            // Beyond the packet's step counters: walked one lane at a time.
            u32::MAX
        } else {
            MAX_STEPS
        };
        Packet {
            rays,
            tmin,
            tmax,
            active,
            max_steps,
        }
    }

    /// Checks lane `l` of the packet walks (`got` with normals, `bare` without) against the
    /// single walk, which it returns.
    fn check_lane(
        l: usize,
        tree: &Octree,
        p: &Packet,
        stop: &dyn Fn(&LeafEntry) -> bool,
        got: &[Seen; LANES],
        bare: &[Seen; LANES],
    ) -> Seen {
        let Packet {
            rays,
            tmin,
            tmax,
            active,
            max_steps,
        } = p;
        let (active, max_steps) = (*active, *max_steps);
        let want = if active >> l & 1 != 0 {
            alone(tree, &rays[l], tmin[l], tmax[l], max_steps, stop)
        } else {
            (Vec::new(), None, 0, false)
        };
        assert_eq!(
            got[l], want,
            "depth {}, lane {l} of {rays:?} in [{tmin:?}, {tmax:?}], \
             {max_steps} steps",
            tree.depth
        );
        // Without normals: the same but for the normals, which are zero
        // where the lanes walk together.
        let strip = |s: &Seen| {
            let mut s = s.clone();
            for e in &mut s.0 {
                e.entry_normal = Vec3::ZERO;
                e.exit_normal = Vec3::ZERO;
            }
            s
        };
        assert_eq!(strip(&bare[l]), strip(&want), "without normals, lane {l}");
        let mixed = (0..LANES).any(|k| {
            active >> k & 1 != 0
                && rays[k].dir.is_negative_bitmask() != rays[l].dir.is_negative_bitmask()
        });
        if !mixed && max_steps < 1 << 24 {
            assert!(
                bare[l]
                    .0
                    .iter()
                    .all(|e| e.entry_normal == Vec3::ZERO && e.exit_normal == Vec3::ZERO),
                "no normals made, lane {l}"
            );
        }
        want
    }

    /// A cube of `2^depth` cells a side with each cell present with probability `density`,
    /// or `None` when no cell is.
    pub(crate) fn random_tree(
        depth: u8,
        density: f64,
        unit: &mut impl FnMut() -> f64,
    ) -> Option<Octree> {
        let side = 1u32 << depth;
        let mut cells = Vec::new();
        for x in 0..side {
            for y in 0..side {
                for z in 0..side {
                    if unit() < density {
                        cells.push((UVec3::new(x, y, z), Voxel::default()));
                    }
                }
            }
        }
        let root = RootCube {
            origin: DVec3::ZERO,
            side: f64::from(side),
        };
        (!cells.is_empty()).then(|| Octree::from_cells(root, depth, cells).unwrap())
    }

    /// Every lane of seeded random packets sees what the single walk sees: the same entries
    /// in the same order (parameters, cells, normals bit for bit), the same hit, steps and
    /// cap. Packets of rays from one point (primary rays), from nearby points toward one
    /// point (shadow rays), axis-parallel rays with signed zeros on cell faces, rays between
    /// lattice points (through edges and corners), rays from inside with later `tmin` and
    /// nearer `tmax`, lanes switched off, lanes in other octants (walked one at a time),
    /// step caps that stop lanes midway, and callbacks that stop at chosen leaves. The packet
    /// walk on the tree's graph ([`crate::dag::DagTree`]) sees the same.
    #[test]
    fn every_lane_sees_what_the_single_walk_sees() {
        let mut next = svo_tests::seeds::xorshift(0xBA_C4E7);
        let mut unit = svo_tests::seeds::unit_f64(0x51_DE);
        let mut compared = 0usize;
        let mut hits = 0usize;
        let mut graphs = 0usize;
        for depth in 1..=6u8 {
            for density in [0.02, 0.2, 0.7] {
                let Some(tree) = random_tree(depth, density, &mut unit) else {
                    continue;
                };
                let graph = (depth >= 2).then(|| crate::dag::DagTree::from_tree(&tree).unwrap());
                for _ in 0..150 {
                    let p = random_packet(&mut next, &mut unit, depth);
                    let k = next() % 4;
                    let stop = move |e: &LeafEntry| k != 0 && u64::from(e.leaf) % 4 == k;
                    let (rays, tmin, tmax) = (&p.rays, p.tmin, p.tmax);
                    let got = packed(&tree, rays, tmin, tmax, p.active, p.max_steps, &stop);
                    let bare =
                        packed_with::<false>(&tree, rays, tmin, tmax, p.active, p.max_steps, &stop);
                    for l in 0..LANES {
                        let want = check_lane(l, &tree, &p, &stop, &got, &bare);
                        compared += 1;
                        hits += usize::from(want.1.is_some());
                    }
                    // The same walk on the tree's graph: the same entries and outcomes.
                    if let Some(dag) = &graph {
                        assert_eq!(packed_on_graph(dag, depth, &p, &stop), got, "graph");
                        graphs += 1;
                    }
                }
            }
        }
        assert!(
            compared > 8_000 && hits > 500 && graphs > 1_500,
            "{compared} lanes, {hits} hits, {graphs} packets on graphs"
        );
    }

    /// Lanes with cones (some exact, some wide enough to stop at nodes of 4 to 32 cells)
    /// see what [`traverse_cone`] alone sees for their ray and cone: the same leaves and
    /// inner nodes, in the same order, with the same entries, outcomes and steps.
    #[test]
    fn lanes_with_cones_see_what_the_single_walk_with_its_cone_sees() {
        let mut next = svo_tests::seeds::xorshift(0xC0_4E58);
        let mut unit = svo_tests::seeds::unit_f64(0xC0_4E);
        let (mut compared, mut nodes) = (0usize, 0usize);
        for depth in 3..=6u8 {
            for density in [0.05, 0.3, 0.8] {
                let Some(tree) = random_tree(depth, density, &mut unit) else {
                    continue;
                };
                for _ in 0..150 {
                    let p = random_packet(&mut next, &mut unit, depth);
                    let cones: [Cone; LANES] = std::array::from_fn(|_| match next() % 4 {
                        0 => Cone::EXACT,
                        1 => Cone {
                            width: unit() as f32 * 24.0,
                            spread: 0.0,
                        },
                        _ => Cone {
                            width: unit() as f32 * 4.0,
                            spread: unit() as f32 * 0.5,
                        },
                    });
                    let k = next() % 3;
                    // Some leaves and some nodes stop a lane.
                    let stop = move |e: &LeafEntry| u64::from(e.leaf) % 3 == k;
                    let (rays, tmin, tmax) = (&p.rays, p.tmin, p.tmax);
                    let mut seen: [Vec<LeafEntry>; LANES] = Default::default();
                    let got = traverse_packet_with::<true, _>(
                        &tree,
                        rays,
                        cones,
                        tmin,
                        tmax,
                        p.active,
                        p.max_steps,
                        |l, e| {
                            seen[l].push(*e);
                            stop(e).then_some(e.leaf)
                        },
                    );
                    for l in 0..LANES {
                        let mut want = Vec::new();
                        let w = if p.active >> l & 1 != 0 {
                            traverse_cone(
                                &tree,
                                &rays[l],
                                cones[l],
                                tmin[l],
                                tmax[l],
                                p.max_steps,
                                |e| {
                                    want.push(*e);
                                    stop(e).then_some(e.leaf)
                                },
                            )
                        } else {
                            Traversal {
                                hit: None,
                                steps: 0,
                                capped: false,
                            }
                        };
                        assert_eq!(
                            (&seen[l], got[l].hit, got[l].steps, got[l].capped),
                            (&want, w.hit, w.steps, w.capped),
                            "depth {depth}, lane {l} of {rays:?}, cones {cones:?}"
                        );
                        compared += 1;
                        nodes += want.iter().filter(|e| e.side > 1).count();
                    }
                }
            }
        }
        assert!(
            compared > 5_000 && nodes > 1_000,
            "{compared} lanes, {nodes} nodes"
        );
    }

    /// Deep trees (depth 30, cells at far corners) and rays from far outside with tiny
    /// direction components: every lane equals the single walk.
    #[test]
    fn deep_trees_and_extreme_rays_equal_the_single_walk() {
        let far = (1u32 << 30) - 1;
        let root = RootCube {
            origin: DVec3::ZERO,
            side: f64::from(1u32 << 30),
        };
        let cells = [
            UVec3::ZERO,
            UVec3::new(far, 0, 0),
            UVec3::new(far, far, far),
            UVec3::new(1, 0, 0),
            UVec3::new(far / 2, far / 2 + 1, far / 2),
        ];
        let tree =
            Octree::from_cells(root, 30, cells.iter().map(|&c| (c, Voxel::default()))).unwrap();
        let big = (1u64 << 30) as f32;
        let rays = [
            GridRay {
                origin: Vec3::new(-1.0, 0.5, 0.5),
                dir: Vec3::new(1.0, 1e-30, -0.0),
            },
            GridRay {
                origin: Vec3::new(-1e6, 0.25, 0.75),
                dir: Vec3::new(1.0, 1e-12, 1e-12),
            },
            GridRay {
                origin: Vec3::new(-big, -big, -big),
                dir: Vec3::new(1.0, 1.0, 1.0),
            },
            GridRay {
                origin: Vec3::new(-2.0, big * 0.5, big * 0.5),
                dir: Vec3::new(1.0, 0.0, 0.0),
            },
        ];
        let stop = |_: &LeafEntry| false;
        let got = packed(
            &tree,
            &rays,
            [0.0; LANES],
            [f32::INFINITY; LANES],
            0b1111,
            MAX_STEPS,
            &stop,
        );
        for l in 0..LANES {
            let want = alone(&tree, &rays[l], 0.0, f32::INFINITY, MAX_STEPS, &stop);
            assert_eq!(got[l], want, "lane {l}");
        }
        assert!(
            !got[0].0.is_empty(),
            "the first lane sees the cells along x: {:?}",
            got
        );
    }
}
