//! Octree ray traversal: Revelles et al.'s parametric algorithm with the octant mirror mask
//! (thesis 1.4.3-1.4.4), iterative with an explicit stack.
//!
//! The ray is mirrored into the positive octant ([`crate::trace::grid_ray`]). A node on the stack
//! holds the ray parameters of its three low planes `t0`, its three mid planes `tm` and its
//! three high planes `t1`; child `c` spans `[t0, tm]` or `[tm, t1]` on each axis by its bits.
//! The first child is the one containing the entry point (bit set where `tm <= t_enter`,
//! Revelles's `first_node`), and the next is found from the child's exit plane
//! (`new_node`): the axes whose exit parameter is the smallest are crossed together, so a
//! ray through an edge or a corner skips the neighbours it only touches, and when one of them
//! is already the high half the ray leaves the parent.
//!
//! Every plane parameter is computed directly from the plane's integer grid coordinate as
//! `(p - o) / d`, never as Revelles's midpoint `(t0 + t1) / 2` (which loses all precision for
//! nearly parallel rays). Neighbouring cells therefore share their boundary parameters bit
//! for bit, and the cells visited tile the ray with no gap: no leaf the ray enters is missed.
//!
//! The traversal visits leaves front to back and hands each existing one to a callback, which
//! decides whether the ray stops there (a cube, a contour or triangles: [`crate::trace::leaf_hit`];
//! shadow rays accumulate transmittance and go on). Each child examined is one step; a ray
//! that needs more than the cap is reported as capped, never as a silent miss.
//!
//! An inner child is entered only where the ray meets the box of its leaves that the node
//! keeps in its spare bits ([`crate::octree::Octree::refresh_bounds`]), tested on the same
//! integer planes: a leaf the ray enters lies in that box, so its parameters, which are those
//! of its own planes, fall within the box's, and no leaf is skipped. The leaves handed over
//! are the same with or without the boxes; only the steps differ.

use crate::octree::bounds;
use crate::octree::tree::{Node, Octree, slot_of};
use crate::trace::cone::{Cone, node_distance};
use crate::trace::grid_ray::{GridRay, MirroredRay};
use glam::{UVec3, Vec3, Vec3A};

/// The entry of an inner node drawn in place of its subtree (`stop`: its index, minimum
/// cell and side), for a ray whose parameters at the box of its leaves are `(b0, b1)`: that
/// box clipped to `[tmin, tmax]`, `None` where the ray misses it there; the faces' normals
/// with `normals` (else zero). The single and the packet walk stop at a node through it.
#[inline]
pub(crate) fn node_entry(
    r: &MirroredRay,
    (leaf, cell, side): (u32, UVec3, u32),
    (b0, b1): (Vec3A, Vec3A),
    (tmin, tmax): (f32, f32),
    normals: bool,
) -> Option<LeafEntry> {
    let (e0, e1) = (b0.max_element(), b1.min_element());
    let t_enter = if e0 > tmin { e0 } else { tmin };
    let t_exit = if e1 < tmax { e1 } else { tmax };
    if t_exit < t_enter {
        return None;
    }
    let (entry_normal, exit_normal) = if normals {
        (r.entry_normal_of(b0, tmin), r.exit_normal_of(b1))
    } else {
        (Vec3::ZERO, Vec3::ZERO)
    };
    Some(LeafEntry {
        leaf,
        cell,
        side,
        t_enter,
        t_exit,
        entry_normal,
        exit_normal,
    })
}

/// The default cap on traversal steps (children examined) per ray. A ray through a depth-10
/// tree examines at most about `3 * 1024 * 8` children, so only a pathological callback
/// (one that declines every leaf of a huge tree) reaches it.
pub const MAX_STEPS: u32 = 1 << 16;

/// A leaf the ray passes through, as handed to the callback; or, in a walk with a footprint
/// ([`traverse_cone`]), an inner node drawn in place of its subtree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafEntry {
    /// Index into the leaf arrays; for an inner node (`side > 1`), into the node array (and
    /// the tree's [`Octree::node_attributes`]).
    pub leaf: u32,
    /// Integer cell coordinates (an inner node's minimum cell).
    pub cell: UVec3,
    /// The side in cells: 1 for a leaf, a power of two of at least 4 for an inner node.
    pub side: u32,
    /// Where the ray enters the cell (at least the ray's `tmin`).
    pub t_enter: f32,
    /// Where it leaves (at most the ray's `tmax`).
    pub t_exit: f32,
    /// The unit normal of the face the ray enters through, facing the ray; zero when the ray
    /// starts inside the cell.
    pub entry_normal: Vec3,
    /// The outward unit normal of the face the ray leaves through.
    pub exit_normal: Vec3,
}

/// The outcome of a traversal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traversal<T> {
    /// What the callback returned for the leaf where the ray stopped.
    pub hit: Option<T>,
    /// Children examined.
    pub steps: u32,
    /// Whether the ray was stopped by the step cap (then `hit` is `None` but the ray was not
    /// proven to miss).
    pub capped: bool,
}

impl<T> Traversal<T> {
    /// No hit, no step.
    pub(crate) fn missed() -> Self {
        Self {
            hit: None,
            steps: 0,
            capped: false,
        }
    }
}

const DONE: u8 = 8;

/// What the walk reads of a node array: a tree's ([`Octree`]) or a graph's
/// ([`crate::dag::DagTree`]).
pub(crate) trait WalkNodes {
    /// A node as the walk holds it, in registers and on its stack.
    type N: Copy;
    /// The root, where there is one.
    fn root(&self) -> Option<Self::N>;
    /// The node's child mask.
    fn mask(n: Self::N) -> u8;
    /// Where a leaf parent's first leaf lies in the leaf arrays (`None` for another node).
    fn leaf_base(n: Self::N) -> Option<u32>;
    /// The index in the leaf arrays of leaf `rank` of a leaf parent whose [`Self::leaf_base`]
    /// is `base`: its own (`base + rank`), or where leaves take an ancestor's values, the
    /// ancestor's.
    #[inline]
    fn leaf_of(_n: Self::N, base: u32, rank: u32) -> u32 {
        base + rank
    }
    /// Child `real` of `n` (not a leaf parent), the `rank`-th of its existing children.
    fn child(&self, n: Self::N, real: u8, rank: u32) -> Option<Self::N>;
    /// Whether `n` is a leaf parent.
    fn is_leaf_parent(n: Self::N) -> bool;
    /// The box of `n`'s leaves that `n` keeps (bits 8-31 of a tree node's `info`; 0: none).
    fn leaf_box(n: Self::N) -> u32;
    /// The index by which the node attributes of child `rank` of `n` are found (a walk with a
    /// footprint stops there).
    fn child_index(n: Self::N, rank: u32) -> u32;
    /// An ancestor on the walk's stack: the node, the child to visit next and where the ray
    /// enters that child (its corner, side and planes follow from the current cell's).
    type Saved: Copy;
    /// An all-zero stack entry: the stack is initialized with it, which compiles to one
    /// `memset`.
    const EMPTY: Self::Saved;
    /// The stack entry of `n`.
    fn save(n: Self::N, next: u8, enter: f32) -> Self::Saved;
    /// The node, next child and entry of a stack entry.
    fn restore(s: Self::Saved) -> (Self::N, u8, f32);
}

impl WalkNodes for Octree {
    type N = Node;

    #[inline]
    fn root(&self) -> Option<Node> {
        self.nodes.first().copied()
    }

    #[inline]
    fn mask(n: Node) -> u8 {
        n.child_mask()
    }

    #[inline]
    fn leaf_base(n: Node) -> Option<u32> {
        n.leaf_base()
    }

    #[inline]
    fn child(&self, n: Node, _real: u8, rank: u32) -> Option<Node> {
        self.nodes.get((n.first + rank) as usize).copied()
    }

    #[inline]
    fn is_leaf_parent(n: Node) -> bool {
        n.is_leaf_parent()
    }

    #[inline]
    fn leaf_box(n: Node) -> u32 {
        n.info >> 8
    }

    #[inline]
    fn child_index(n: Node, rank: u32) -> u32 {
        n.first + rank
    }

    type Saved = Saved;
    const EMPTY: Saved = Saved {
        first: 0,
        info: 0,
        next: 0,
        enter: 0.0,
    };

    #[inline]
    fn save(n: Node, next: u8, enter: f32) -> Saved {
        Saved {
            first: n.first,
            info: n.child_mask(),
            next,
            enter,
        }
    }

    #[inline]
    fn restore(s: Saved) -> (Node, u8, f32) {
        let node = Node {
            info: u32::from(s.info),
            first: s.first,
        };
        (node, s.next, s.enter)
    }
}

/// A tree's ancestor on the stack: what the walk cannot recompute when it returns to it. Its
/// corner is the current cell's corner with the bits below its side cleared, its side
/// follows from its level, and its planes from both, so only the node, the child to visit
/// next and where the ray enters that child are kept (12 bytes).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Saved {
    first: u32,
    info: u8,
    next: u8,
    enter: f32,
}

/// SIMD comparison masks have x in bit 0; child indices have x in bit 2.
const REVERSE3: [u8; 8] = [0, 4, 2, 6, 1, 5, 3, 7];

/// Per child index, which axes are its high half.
const HIGH: [glam::BVec3A; 8] = [
    glam::BVec3A::new(false, false, false),
    glam::BVec3A::new(false, false, true),
    glam::BVec3A::new(false, true, false),
    glam::BVec3A::new(false, true, true),
    glam::BVec3A::new(true, false, false),
    glam::BVec3A::new(true, false, true),
    glam::BVec3A::new(true, true, false),
    glam::BVec3A::new(true, true, true),
];

#[inline]
fn first_child(tm: Vec3A, t: f32) -> u8 {
    REVERSE3[tm.cmple(Vec3A::splat(t)).bitmask() as usize]
}

/// The child after `c`, whose exit parameters are `exit` with smallest `m`: the axes at `m`
/// are crossed together; if one of them is already the high half the ray leaves the node.
#[inline]
fn next_child(c: u8, exit: Vec3A, m: f32) -> u8 {
    // The parameters are never NaN (finite planes times a finite inverse), so the SIMD
    // equality is the scalar one, `-0.0 == 0.0` included.
    let tied = REVERSE3[exit.cmpeq(Vec3A::splat(m)).bitmask() as usize];
    if c & tied != 0 { DONE } else { c | tied }
}

#[inline]
pub(crate) fn child_bits(c: u8) -> UVec3 {
    UVec3::new(
        u32::from(c >> 2 & 1),
        u32::from(c >> 1 & 1),
        u32::from(c & 1),
    )
}

/// Traverses `tree` along `ray` for parameters in `[tmin, tmax]`, calling `on_leaf` for each
/// existing leaf the ray passes through, front to back, until it returns `Some`.
/// At most `max_steps` children are examined (see [`MAX_STEPS`]).
pub fn traverse<T>(
    tree: &Octree,
    ray: &GridRay,
    tmin: f32,
    tmax: f32,
    max_steps: u32,
    on_leaf: impl FnMut(&LeafEntry) -> Option<T>,
) -> Traversal<T> {
    traverse_cone(tree, ray, Cone::EXACT, tmin, tmax, max_steps, on_leaf)
}

/// [`traverse`] with a footprint: an inner node the ray enters that is no wider than `cone`
/// at the node's distance from the ray's origin (and has values of its own: not a leaf
/// parent; not one that holds or touches the origin) is handed to the callback as an entry
/// of its side in place of its leaves; if the callback declines it, the walk goes on past
/// the node. [`Cone::EXACT`] is [`traverse`] (see [`crate::trace::Cone`]).
pub fn traverse_cone<T>(
    tree: &Octree,
    ray: &GridRay,
    cone: Cone,
    tmin: f32,
    tmax: f32,
    max_steps: u32,
    on_leaf: impl FnMut(&LeafEntry) -> Option<T>,
) -> Traversal<T> {
    // Only a walk from a node can be refused.
    let depth = tree.depth;
    traverse_from(tree, depth, ray, None, cone, tmin, tmax, max_steps, on_leaf)
        .unwrap_or_else(Traversal::missed)
}

/// An inner node to start a traversal at: its index in the node array, its minimum cell
/// and its side in cells (a power of two, at least 2).
#[cfg(test)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct StartNode {
    /// Index into the node array.
    pub index: u32,
    /// Minimum cell (real, not mirrored).
    pub origin: UVec3,
    /// Side in cells.
    pub side: u32,
}

/// [`StartNode`] with the node itself, as the walk holds it ([`WalkNodes::N`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct StartAt<N> {
    /// The node.
    pub node: N,
    /// Minimum cell (real, not mirrored).
    pub origin: UVec3,
    /// Side in cells.
    pub side: u32,
}

/// [`traverse`] within one inner node's cube: the leaves of `start`'s subtree that the ray
/// passes through, front to back, with the same entries (parameters, cells, normals) as a
/// traversal from the root would give them for the same `tmin`. A node that does not fit
/// the tree is not traversed (no leaves). `None` when the ray only touches the node's cube
/// at a point (an edge or a corner): a walk from the root crosses such points into the
/// diagonal neighbour without handing over the cells it touches, except where it starts
/// (at `tmin`, or where it only touches the root), so only that walk knows.
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn traverse_node<T>(
    tree: &Octree,
    ray: &GridRay,
    start: StartNode,
    cone: Cone,
    tmin: f32,
    tmax: f32,
    max_steps: u32,
    on_leaf: impl FnMut(&LeafEntry) -> Option<T>,
) -> Option<Traversal<T>> {
    let Some(&node) = tree.nodes.get(start.index as usize) else {
        return Some(Traversal::missed());
    };
    let StartNode { origin, side, .. } = start;
    traverse_from(
        tree,
        tree.depth,
        ray,
        Some(StartAt { node, origin, side }),
        cone,
        tmin,
        tmax,
        max_steps,
        on_leaf,
    )
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn traverse_from<W: WalkNodes, T>(
    tree: &W,
    depth: u8,
    ray: &GridRay,
    start: Option<StartAt<W::N>>,
    cone: Cone,
    tmin: f32,
    tmax: f32,
    max_steps: u32,
    on_leaf: impl FnMut(&LeafEntry) -> Option<T>,
) -> Option<Traversal<T>> {
    // The stack holds one frame per level above the leaves; a stack sized for the tree
    // keeps its initialization (a `memset` per ray) small.
    let levels = start.map_or(depth, |s| s.side.max(1).ilog2().min(32) as u8);
    let walk = (tree, depth);
    if levels <= 2 {
        traverse_with::<2, W, T>(walk, ray, start, cone, tmin, tmax, max_steps, on_leaf)
    } else if levels <= 4 {
        traverse_with::<4, W, T>(walk, ray, start, cone, tmin, tmax, max_steps, on_leaf)
    } else if levels <= 12 {
        traverse_with::<12, W, T>(walk, ray, start, cone, tmin, tmax, max_steps, on_leaf)
    } else {
        traverse_with::<32, W, T>(walk, ray, start, cone, tmin, tmax, max_steps, on_leaf)
    }
}

#[allow(clippy::too_many_arguments)]
fn traverse_with<const STACK: usize, W: WalkNodes, T>(
    (tree, depth): (&W, u8),
    ray: &GridRay,
    start: Option<StartAt<W::N>>,
    cone: Cone,
    tmin: f32,
    tmax: f32,
    max_steps: u32,
    mut on_leaf: impl FnMut(&LeafEntry) -> Option<T>,
) -> Option<Traversal<T>> {
    let coarse = !cone.is_exact();
    // At least the distance from the origin to a point at parameter `t` per unit of `t`: a
    // node entered at `t` is no further than `t * reach`, so one wider than the cone there
    // is not a stop, without working out its distance.
    let reach = if coarse {
        ray.dir.length() * (1.0 + 1e-5)
    } else {
        0.0
    };
    let mut out = Traversal::missed();
    let depth = usize::from(depth);
    if depth == 0 || depth > usize::from(crate::MAX_DEPTH) {
        return Some(out);
    }
    let n = 1u32 << depth;
    let (node, origin, side) = match start {
        None => match tree.root() {
            Some(root) => (root, UVec3::ZERO, n),
            None => return Some(out),
        },
        Some(s) => {
            let fits = s.side >= 2
                && s.side.is_power_of_two()
                && s.side <= n
                && (s.origin % s.side) == UVec3::ZERO
                && s.origin.max_element() < n;
            if !fits || W::is_leaf_parent(s.node) != (s.side == 2) {
                return Some(out);
            }
            (s.node, s.origin, s.side)
        }
    };
    if W::mask(node) == 0 {
        return Some(out);
    }
    let Some(r) = MirroredRay::new(ray, n) else {
        return Some(out);
    };
    // The node's minimum corner in mirrored cells.
    let origin = r.flip(origin, side);
    let Some((_, t1, enter)) = r.node_entry(origin, side, tmin, tmax) else {
        return Some(out);
    };
    if start.is_some() && enter >= t1.min_element() {
        // The ray only touches the node's cube.
        return None;
    }
    // The current node lives in locals (registers); the stack holds its ancestors.
    let mut node = node;
    let mut corner = origin;
    let mut half = side / 2;
    let mut t1 = t1;
    let mut tm = r.t_planes(origin + UVec3::splat(half));
    let mut next = first_child(tm, enter);
    let mut enter = enter;
    let mut stack = [W::EMPTY; STACK];
    let mut len = 0usize;
    let mask = r.mask;
    let swap = bounds::swap_mask(mask);
    loop {
        if next == DONE {
            // Pop to the nearest ancestor with a child left (one whose next child is DONE
            // would only be popped in turn), and visit that child in this same pass.
            loop {
                if len == 0 {
                    return Some(out);
                }
                len -= 1;
                let (n, s_next, s_enter) = W::restore(stack[len]);
                if s_next != DONE {
                    node = n;
                    next = s_next;
                    enter = s_enter;
                    break;
                }
            }
            half = side >> (len + 1);
            corner &= UVec3::splat(!(2 * half - 1));
            tm = r.t_planes(corner + UVec3::splat(half));
            t1 = r.t_planes(corner + UVec3::splat(2 * half));
        }
        // Step over the node's children in the ray's order until one exists or none is
        // left: most children of a sparse tree are absent, and this is the cheap part of a
        // step.
        let child_mask = W::mask(node);
        let (c, t_enter, c1, m, real) = loop {
            let c = next;
            let t_enter = enter;
            let c1 = Vec3A::select(HIGH[usize::from(c)], t1, tm);
            let (x, y, z) = (c1.x, c1.y, c1.z);
            let m = if x < y { x } else { y };
            let m = if m < z { m } else { z };
            next = next_child(c, c1, m);
            enter = if m > tmin { m } else { tmin };
            out.steps += 1;
            if out.steps > max_steps {
                out.capped = true;
                return Some(out);
            }
            let real = c ^ mask;
            if child_mask >> real & 1 != 0 || next == DONE {
                break (c, t_enter, c1, m, real);
            }
        };
        if child_mask >> real & 1 == 0 {
            continue;
        }
        if t_enter > tmax {
            // Front to back: everything after this child is further still.
            return Some(out);
        }
        let t_exit = if m < tmax { m } else { tmax };
        if t_exit < t_enter {
            continue;
        }
        let rank = slot_of(child_mask, real);
        let origin = corner + child_bits(c) * half;
        if let Some(base) = W::leaf_base(node) {
            // The cell's entry planes are its integer low planes: the values a walk that
            // carried them down would have, bit for bit.
            let entry = LeafEntry {
                leaf: W::leaf_of(node, base, rank),
                cell: r.unmirror_cell(origin),
                side: 1,
                t_enter,
                t_exit,
                entry_normal: r.entry_normal_of(r.t_planes(origin), tmin),
                exit_normal: r.exit_normal_of(c1),
            };
            if let Some(h) = on_leaf(&entry) {
                out.hit = Some(h);
                return Some(out);
            }
        } else {
            // A malformed tree deeper than its depth cannot overflow the stack.
            if len == STACK || half < 2 {
                continue;
            }
            let Some(child) = tree.child(node, real, rank) else {
                continue;
            };
            // The planes of the box of the child's leaves, where it keeps one: a ray that
            // passes beside it finds none there.
            let boxed = W::leaf_box(child);
            let leaf_box = (boxed != 0).then(|| {
                let (lo, hi) = bounds::cell_box(bounds::mirrored(boxed << 8, swap), origin, half);
                (r.t_planes(lo), r.t_planes(hi))
            });
            if let Some((b0, b1)) = leaf_box
                && b1.min_element().min(t_exit) < b0.max_element().max(t_enter)
            {
                continue;
            }
            if coarse && !W::is_leaf_parent(child) && half as f32 <= cone.width_at(t_enter * reach)
            {
                let cell = r.flip(origin, half);
                if cone.stops_at(half, node_distance(ray.origin, cell, half)) {
                    // Wide enough: the node stands for its subtree, within the box of its
                    // leaves (which holds its surface), as the primary prepass tests it.
                    let bounds = leaf_box.unwrap_or_else(|| (r.t_planes(origin), c1));
                    let stop = (W::child_index(node, rank), cell, half);
                    let Some(entry) = node_entry(&r, stop, bounds, (tmin, tmax), true) else {
                        continue;
                    };
                    if let Some(h) = on_leaf(&entry) {
                        out.hit = Some(h);
                        return Some(out);
                    }
                    continue;
                }
            }
            stack[len] = W::save(node, next, enter);
            len += 1;
            node = child;
            corner = origin;
            half /= 2;
            t1 = c1;
            tm = r.t_planes(origin + UVec3::splat(half));
            next = first_child(tm, t_enter);
            enter = t_enter;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::octree::{RootCube, Voxel};
    use glam::{DVec3, Vec3};

    fn tree_of_cells(depth: u8, cells: &[UVec3]) -> Octree {
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        Octree::from_cells(root, depth, cells.iter().map(|&c| (c, Voxel::default()))).unwrap()
    }

    fn handed_over(tree: &Octree, ray: &GridRay, start: Option<StartNode>) -> (Vec<UVec3>, u32) {
        let mut cells = Vec::new();
        let visit = |e: &LeafEntry| {
            cells.push(e.cell);
            None::<()>
        };
        let t = match start {
            None => traverse(tree, ray, 0.0, f32::INFINITY, MAX_STEPS, visit),
            Some(s) => traverse_node(
                tree,
                ray,
                s,
                Cone::EXACT,
                0.0,
                f32::INFINITY,
                MAX_STEPS,
                visit,
            )
            .expect("the ray enters the node's cube"),
        };
        (cells, t.steps)
    }

    /// The deepest tree the library builds (depth 30) is walked, to its far corner; a tree
    /// whose depth was set to 0 or beyond that by hand is not walked at all.
    #[test]
    fn trees_of_depth_1_to_30_are_walked_and_others_are_not() {
        let far = (1u32 << 30) - 1;
        let mut tree = tree_of_cells(30, &[UVec3::ZERO, UVec3::new(far, 0, 0)]);
        let ray = GridRay {
            origin: Vec3::new(-1.0, 0.5, 0.5),
            dir: Vec3::X,
        };
        let (cells, _) = handed_over(&tree, &ray, None);
        assert_eq!(cells, [UVec3::ZERO, UVec3::new(far, 0, 0)]);
        for depth in [0, 31, 40] {
            tree.depth = depth;
            assert_eq!(handed_over(&tree, &ray, None), (vec![], 0), "depth {depth}");
        }
    }

    /// In a depth-30 tree, rays along each axis next to the low faces see the same cells
    /// whatever the sign of their zero components: an axis with a negative (or `-0.0`)
    /// direction is mirrored, and its planes are mirrored in integers, so the planes of cells
    /// near the low faces stay exact there (mirrored in floats, `2^30 - p` lost its low bits
    /// and the cells next to the low faces collapsed to nothing).
    #[test]
    fn mirrored_axes_keep_the_low_cells_of_deep_trees() {
        let far = (1u32 << 30) - 1;
        let cells = [
            UVec3::ZERO,
            UVec3::new(1, 0, 0),
            UVec3::new(0, 1, 0),
            UVec3::new(0, 0, 1),
            UVec3::new(far, 0, 0),
            UVec3::new(0, far, 0),
            UVec3::new(0, 0, far),
        ];
        let tree = tree_of_cells(30, &cells);
        for axis in 0..3 {
            let mut want = None;
            for signs in 0..4u32 {
                let zero = |bit: u32| if signs >> bit & 1 == 0 { 0.0 } else { -0.0 };
                let (mut o, mut d) = (Vec3::splat(0.5), Vec3::ZERO);
                o[axis] = -1.0;
                d[axis] = 1.0;
                d[(axis + 1) % 3] = zero(0);
                d[(axis + 2) % 3] = zero(1);
                let (seen, _) = handed_over(&tree, &GridRay { origin: o, dir: d }, None);
                let mut along = vec![UVec3::ZERO, UVec3::ZERO, UVec3::ZERO];
                along[1][axis] = 1;
                along[2][axis] = far;
                assert_eq!(seen, along, "axis {axis}, direction {d:?}");
                assert_eq!(*want.get_or_insert(seen.clone()), seen);
            }
        }
    }

    /// A malformed tree whose nodes go deeper than its depth says (a depth-2 tree relabelled
    /// depth 1) is walked no deeper than its depth: the root's children are inner nodes where
    /// leaves should be, and nothing is handed over.
    #[test]
    fn a_tree_deeper_than_its_depth_is_not_walked_below_it() {
        let mut tree = tree_of_cells(2, &[UVec3::ONE, UVec3::splat(3)]);
        let ray = |y: f32| GridRay {
            origin: Vec3::new(-1.0, y, y),
            dir: Vec3::X,
        };
        assert_eq!(handed_over(&tree, &ray(1.5), None).0, [UVec3::ONE]);
        // Relabelled, the root's first child (the ray's cube at y = z = 0.5) holds the node
        // whose last child is the leaf (1, 1, 1): a walk below the depth would reach it.
        tree.depth = 1;
        let (cells, steps) = handed_over(&tree, &ray(0.5), None);
        assert!(cells.is_empty() && steps > 0, "{cells:?}");
    }

    /// A start node that does not fit the tree (side not a power of two, larger than the
    /// root or below 2; corner not a multiple of the side or outside the root; an index out
    /// of range or of a node at another level) is not walked: no leaves, no steps.
    #[test]
    fn start_nodes_that_do_not_fit_are_not_walked() {
        // Depth 3: the root (index 0), its child at the low corner (side 4, index 1), and
        // that child's child (side 2, a parent of leaves, index 2).
        let tree = tree_of_cells(3, &[UVec3::ZERO, UVec3::ONE]);
        let ray = GridRay {
            origin: Vec3::new(-1.0, 0.5, 0.5),
            dir: Vec3::X,
        };
        let fits = [
            StartNode {
                index: 1,
                origin: UVec3::ZERO,
                side: 4,
            },
            StartNode {
                index: 2,
                origin: UVec3::ZERO,
                side: 2,
            },
        ];
        for s in fits {
            let (cells, steps) = handed_over(&tree, &ray, Some(s));
            assert!(
                steps > 0 && cells.contains(&UVec3::ZERO),
                "{s:?}: {cells:?}"
            );
        }
        for s in [
            StartNode {
                index: 1,
                origin: UVec3::ZERO,
                side: 3,
            },
            StartNode {
                index: 1,
                origin: UVec3::ZERO,
                side: 16,
            },
            StartNode {
                index: 2,
                origin: UVec3::ZERO,
                side: 1,
            },
            StartNode {
                index: 1,
                origin: UVec3::new(2, 0, 0),
                side: 4,
            },
            StartNode {
                index: 1,
                origin: UVec3::new(8, 0, 0),
                side: 4,
            },
            StartNode {
                index: 9,
                origin: UVec3::ZERO,
                side: 4,
            },
            StartNode {
                index: 2,
                origin: UVec3::ZERO,
                side: 4,
            },
            StartNode {
                index: 1,
                origin: UVec3::ZERO,
                side: 2,
            },
        ] {
            let mut any = false;
            let t = traverse_node(
                &tree,
                &ray,
                s,
                Cone::EXACT,
                0.0,
                f32::INFINITY,
                MAX_STEPS,
                |_| {
                    any = true;
                    None::<()>
                },
            );
            assert!(!any && t.is_none_or(|t| t.steps == 0), "{s:?} was walked");
        }
    }

    /// A ray (with its `tmin`) in a root of `side` cells: from outside towards a point
    /// inside, from inside (sometimes starting later), axis-parallel with signed zeros, or
    /// from a lattice point along a small integer direction.
    fn random_ray(
        next: &mut dyn FnMut() -> u64,
        unit: &mut dyn FnMut() -> f64,
        side: u32,
    ) -> (GridRay, f32) {
        let n = side as f32;
        let mut f = || unit() as f32;
        let inside = Vec3::new(f() * n, f() * n, f() * n);
        let lattice = |k: u64| (k % (u64::from(side) + 5)) as f32 - 2.0;
        let signed_zero = |k: u64| if k & 1 == 0 { 0.0 } else { -0.0 };
        match next() % 4 {
            0 => {
                let o = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5).normalize_or_zero() * n * 1.5
                    + Vec3::splat(n * 0.5);
                (
                    GridRay {
                        origin: o,
                        dir: inside - o,
                    },
                    0.0,
                )
            }
            1 => {
                let d = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5);
                let tmin = if next().is_multiple_of(3) {
                    f() * n
                } else {
                    0.0
                };
                (
                    GridRay {
                        origin: inside,
                        dir: d,
                    },
                    tmin,
                )
            }
            2 => {
                let axis = (next() % 3) as usize;
                let mut d = Vec3::new(
                    signed_zero(next()),
                    signed_zero(next()),
                    signed_zero(next()),
                );
                d[axis] = if next() & 1 == 0 { 1.0 } else { -1.0 };
                let mut o = inside.floor();
                o[axis] = if d[axis] > 0.0 { -1.0 } else { n + 1.0 };
                (GridRay { origin: o, dir: d }, 0.0)
            }
            _ => {
                let o = Vec3::new(lattice(next()), lattice(next()), lattice(next()));
                let mut d = Vec3::new(
                    (next() % 5) as f32 - 2.0,
                    (next() % 5) as f32 - 2.0,
                    (next() % 5) as f32 - 2.0,
                );
                if d == Vec3::ZERO {
                    d.x = 1.0;
                }
                for k in 0..3 {
                    if d[k] == 0.0 {
                        d[k] = signed_zero(next());
                    }
                }
                (GridRay { origin: o, dir: d }, 0.0)
            }
        }
    }

    /// Walks `ray` from start node `s` and checks it against `all`, what the root walk
    /// handed over: `Some(true)` when they agree on some leaves, `Some(false)` when both saw
    /// none, `None` when the ray only touches the node (the walk declines it).
    fn walk_matches(
        tree: &Octree,
        ray: &GridRay,
        tmin: f32,
        s: StartNode,
        all: &[LeafEntry],
    ) -> Option<bool> {
        let within =
            |c: UVec3| c.cmpge(s.origin).all() && c.cmplt(s.origin + UVec3::splat(s.side)).all();
        let want: Vec<LeafEntry> = all.iter().copied().filter(|e| within(e.cell)).collect();
        let mut got: Vec<LeafEntry> = Vec::new();
        let walked = traverse_node(
            tree,
            ray,
            s,
            Cone::EXACT,
            tmin,
            f32::INFINITY,
            MAX_STEPS,
            |e| {
                got.push(*e);
                None::<()>
            },
        );
        if walked.is_none() {
            // Touched at one parameter: whatever the root walk handed over
            // there it entered and left at once.
            assert!(got.is_empty());
            assert!(
                want.iter().all(|e| e.t_enter == e.t_exit),
                "{ray:?} from {tmin}: node {s:?}: {want:?}"
            );
            None
        } else {
            assert_eq!(got, want, "{ray:?} from {tmin}: node {s:?}");
            Some(!want.is_empty())
        }
    }

    /// A walk started at an inner node (what the primary-ray prepass does) hands over exactly
    /// the leaves of that node that the walk from the root hands over, with the same entries,
    /// for every node of every level, unless the ray only touches the node's cube at a point,
    /// which the walk from the node reports as such (the walk from the root hands over touched
    /// leaves where it starts, and crosses them elsewhere). Rays: from outside towards a point
    /// inside, from inside (sometimes from a later `tmin`), axis-parallel with signed zeros on
    /// cell faces, and between lattice points (through corners and edges).
    #[test]
    fn a_walk_from_a_node_sees_what_the_root_walk_sees_there() {
        let mut next = svo_tests::seeds::xorshift(0x5_7A27);
        let mut unit = svo_tests::seeds::unit_f64(0x9E37);
        let (mut compared, mut touched) = (0usize, 0usize);
        for depth in 2..=5u8 {
            for density in [0.05, 0.3, 0.9] {
                let Some(tree) =
                    crate::trace::packet::tests::random_tree(depth, density, &mut unit)
                else {
                    continue;
                };
                let side = 1u32 << depth;
                let nodes: Vec<StartNode> = (1..depth)
                    .flat_map(|l| tree.nodes_at_level(l, usize::MAX).unwrap())
                    .map(|(index, origin, side)| StartNode {
                        index,
                        origin,
                        side,
                    })
                    .collect();
                for _ in 0..200 {
                    let (ray, tmin) = random_ray(&mut next, &mut unit, side);
                    let mut all: Vec<LeafEntry> = Vec::new();
                    traverse(&tree, &ray, tmin, f32::INFINITY, MAX_STEPS, |e| {
                        all.push(*e);
                        None::<()>
                    });
                    for s in &nodes {
                        match walk_matches(&tree, &ray, tmin, *s, &all) {
                            Some(true) => compared += 1,
                            Some(false) => {}
                            None => touched += 1,
                        }
                    }
                }
            }
        }
        assert!(compared > 10_000, "{compared} nodes with leaves compared");
        assert!(touched > 0, "no ray only touched a node");
    }
}
