//! Node bounds: the box that holds a node's leaves, derived from the tree and kept in the
//! spare bits 8-31 of the node's `info` word, where a traversal reads it with the node. A ray
//! that passes beside a child's box is not walked into that child; without the box it would
//! descend and step through the child's empty parts before leaving it with nothing.
//!
//! For a node of side `s` cells the box is stored in units of `u = max(1, s / 16)` as six
//! 4-bit numbers: per axis `lo`, the box's low side over `u`, and `hi`, the distance from the
//! box's high side to the node's high side over `u`, both rounded down, so the box
//! `[lo * u, s - hi * u]` holds every leaf below the node. Bits 8-11, 12-15 and 16-19 hold `lo`
//! on x, y, z; bits 20-23, 24-27 and 28-31 hold `hi`. All zero is the whole node, which is
//! always correct: a tree whose bits are zero is traversed as before, only with more steps.
//!
//! Storing the distance from the high side makes mirroring free: on a mirrored axis the
//! box's low side is `hi * u` and its high side `s - lo * u`, so the traversal swaps the two
//! nibbles of the mirrored axes ([`swap_mask`], [`mirrored`]).
//!
//! Files store zeros (format check 14). Every tree `svo` makes or reads has its bounds:
//! the reader derives them after its checks, the builders when they finish, and the writer
//! writes the nodes with the bits cleared. A tree whose `nodes` were edited by hand gets them
//! with [`Octree::refresh_bounds`]; stale bounds could hide leaves from rays, so
//! [`Octree::validate`] refuses them.

use crate::octree::tree::{Node, Octree};
#[cfg(any(feature = "trace", test))]
use glam::UVec3;

/// Bits 8-31 of `info`.
const SHIFT: u32 = 8;

/// A level not (yet) known from the root.
const UNKNOWN: u8 = u8::MAX;

/// Derives the bounds of every node of a tree of `depth` into bits 8-31 of its `info`: zero
/// (the whole node, which never hides a leaf) for the root of an empty tree and for any node
/// that a well-formed tree would not have (unreachable, reached twice, out of range, or with
/// children at the wrong level). Linear in the nodes: levels from the root in one forward
/// pass, boxes from the leaves up in one backward pass (in the canonical order every inner
/// node's children come after it), no recursion.
pub(crate) fn derive(nodes: &mut [Node], depth: u8) {
    let n = nodes.len();
    if n == 0 || depth == 0 || depth > crate::MAX_DEPTH {
        for node in nodes.iter_mut() {
            node.info &= 0xFF;
        }
        return;
    }
    let mut level = vec![UNKNOWN; n];
    level[0] = 0;
    for i in 0..n {
        let (l, node) = (level[i], nodes[i]);
        if l >= depth || node.is_leaf_parent() {
            continue;
        }
        let k = node.child_mask().count_ones() as usize;
        let first = node.first as usize;
        if first <= i || first + k > n || l + 1 >= depth {
            continue;
        }
        for lc in &mut level[first..first + k] {
            // A node reached twice is not a tree's: its bounds stay the whole node.
            *lc = if *lc == UNKNOWN { l + 1 } else { UNKNOWN - 1 };
        }
    }
    for i in (0..n).rev() {
        // Every node's old bits go here, before its parent (earlier in the array) reads them.
        nodes[i].info &= 0xFF;
        let (l, node) = (level[i], nodes[i]);
        let mask = node.child_mask();
        if l >= depth || mask == 0 {
            continue;
        }
        let side_log = u32::from(depth - l);
        if node.is_leaf_parent() {
            if side_log == 1 {
                nodes[i].info |= LEAF_PARENT[usize::from(mask)] << SHIFT;
            }
            continue;
        }
        let first = node.first as usize;
        if side_log == 1 || first <= i || first + mask.count_ones() as usize > n {
            continue;
        }
        let whole = level[first..first + mask.count_ones() as usize]
            .iter()
            .any(|&lc| lc != l + 1);
        if !whole {
            nodes[i].info |= combine(nodes, first, mask, side_log) << SHIFT;
        }
    }
}

/// [`derive`] for a tree that passed checks 15 and 16 (every node reached once, the leaf
/// parents on the level above the leaves, children after their parents): one backward pass,
/// each node's side taken from its first child's, no levels from the root. The same bits as
/// [`derive`] there; on any other tree, bounds that may hide leaves (never a panic).
pub(crate) fn derive_checked(nodes: &mut [Node], depth: u8) {
    let n = nodes.len();
    if n == 0 || depth == 0 || depth > crate::MAX_DEPTH {
        derive(nodes, depth);
        return;
    }
    // log2 of each node's side, filled from the leaves up.
    let mut side_logs = vec![0u8; n];
    for i in (0..n).rev() {
        nodes[i].info &= 0xFF;
        let node = nodes[i];
        let mask = node.child_mask();
        if mask == 0 {
            continue;
        }
        if node.is_leaf_parent() {
            side_logs[i] = 1;
            nodes[i].info |= LEAF_PARENT[usize::from(mask)] << SHIFT;
            continue;
        }
        let first = node.first as usize;
        let Some(&below) = side_logs.get(first).filter(|_| first > i) else {
            continue;
        };
        if below == 0 || below >= depth || first + mask.count_ones() as usize > n {
            continue;
        }
        side_logs[i] = below + 1;
        nodes[i].info |= combine(nodes, first, mask, u32::from(below) + 1) << SHIFT;
    }
}

/// The code of a node of side `2^side_log` (at least 4) whose children, in `mask`, start at
/// `first`, from the children's codes. They are combined in the parent's units, six 5-bit
/// lanes at a time (see [`lanes`]): a child's box moves by its offset in the parent, and a
/// unit doubles from a side of 32 up (the parent's unit is then twice the child's), which
/// halves the child's numbers; below, both units are one cell.
#[inline]
fn combine(nodes: &[Node], first: usize, mask: u8, side_log: u32) -> u32 {
    combine_codes(
        mask,
        nodes[first..].iter().map(|n| n.info >> SHIFT),
        side_log,
    )
}

/// The code of a node of side `2^side_log` (at least 4) with child `mask` from its children's
/// codes, in child order (as [`combine`]; a graph's nodes, whose children are not packed, take
/// it so).
#[inline]
pub(crate) fn combine_codes(
    mask: u8,
    mut children: impl Iterator<Item = u32>,
    side_log: u32,
) -> u32 {
    let mut rest = mask;
    let mut acc = LANES_MAX;
    let half = 1u32 << (side_log - 1);
    while rest != 0 {
        let c = usize::from(rest.trailing_zeros() as u8);
        rest &= rest - 1;
        let v = lanes(children.next().unwrap_or(0));
        let v = if side_log >= 5 {
            ((v >> 1) & LANES_LOW4) + LANE_OFFSET[c] * 8
        } else {
            v + LANE_OFFSET[c] * half
        };
        acc = lanes_min(acc, v);
    }
    unlanes(acc)
}

/// The code of a leaf parent with child `mask`.
#[cfg(feature = "trace")]
#[inline]
pub(crate) fn leaf_parent_code(mask: u8) -> u32 {
    LEAF_PARENT[usize::from(mask)]
}

/// A 24-bit code's six 4-bit numbers in six 5-bit lanes (bits `5k..5k+4`), the top bit of
/// each lane clear: room for [`lanes_min`]'s comparison.
#[inline]
fn lanes(code: u32) -> u32 {
    (code & 0xF)
        | (code & 0xF0) << 1
        | (code & 0xF00) << 2
        | (code & 0xF000) << 3
        | (code & 0xF_0000) << 4
        | (code & 0xF0_0000) << 5
}

/// The inverse of [`lanes`] for lanes below 16.
#[inline]
fn unlanes(v: u32) -> u32 {
    (v & 0xF)
        | (v >> 1 & 0xF0)
        | (v >> 2 & 0xF00)
        | (v >> 3 & 0xF000)
        | (v >> 4 & 0xF_0000)
        | (v >> 5 & 0xF0_0000)
}

/// The top bit of each lane.
const LANES_TOP: u32 = 0b10000_10000_10000_10000_10000_10000;
/// The low four bits of each lane.
const LANES_LOW4: u32 = 0b01111_01111_01111_01111_01111_01111;
/// Fifteen in every lane.
const LANES_MAX: u32 = LANES_LOW4;

/// The lane-wise minimum of two values whose lanes are below 16.
#[inline]
fn lanes_min(a: u32, b: u32) -> u32 {
    // Per lane, (a + 16) - b is 1..=31 and keeps bit 4 exactly where a >= b.
    let ge = ((a | LANES_TOP) - b) & LANES_TOP;
    let m = (ge >> 4) * 0b11111;
    (b & m) | (a & !m)
}

/// Per child index (x = bit 2), one in the lanes its position in the parent adds a half to:
/// the low side on the axes where it is the high half, the distance from the high side on
/// the others.
const LANE_OFFSET: [u32; 8] = {
    let mut t = [0u32; 8];
    let mut c = 0;
    while c < 8 {
        let mut axis = 0;
        while axis < 3 {
            let high = c >> (2 - axis) & 1 != 0;
            let lane = if high { axis } else { 3 + axis };
            t[c] |= 1 << (5 * lane);
            axis += 1;
        }
        c += 1;
    }
    t
};

/// The 24-bit codes of leaf parents (side 2, unit 1) by child mask.
const LEAF_PARENT: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut mask = 1;
    while mask < 256 {
        // Per axis (bit 2 = x, 1 = y, 0 = z): a child on the low side and one on the high.
        let mut code = 0;
        let mut axis = 0;
        while axis < 3 {
            let bit = 4 >> axis;
            let (mut low, mut high) = (false, false);
            let mut c = 0;
            while c < 8 {
                if mask >> c & 1 != 0 {
                    if c & bit != 0 {
                        high = true;
                    } else {
                        low = true;
                    }
                }
                c += 1;
            }
            // The box's low side is 1 without a low child; its high side 1 short of the
            // node's without a high child.
            code |= (!low as u32) << (4 * axis) | (!high as u32) << (12 + 4 * axis);
            axis += 1;
        }
        t[mask] = code;
        mask += 1;
    }
    t
};

/// The low and high corners (in cells) of the box that the 24-bit `code` of a node of `side`
/// cells at `corner` holds. The traversal passes a [`mirrored`] code and the node's mirrored
/// corner, and gets the box's corners in the mirrored space.
#[cfg(any(feature = "trace", test))]
#[inline(always)]
pub(crate) fn cell_box(code: u32, corner: UVec3, side: u32) -> (UVec3, UVec3) {
    let sh = unit_shift(side);
    let (lo, from_hi) = nibbles(code);
    (
        corner + (lo << sh),
        (corner + UVec3::splat(side)).wrapping_sub(from_hi << sh),
    )
}

/// `log2` of the unit of a node of `side` cells: `max(1, side / 16)`.
#[cfg(any(feature = "trace", test))]
#[inline(always)]
fn unit_shift(side: u32) -> u32 {
    side.trailing_zeros().saturating_sub(4)
}

/// The code's low sides and distances from the high sides, in units.
#[cfg(any(feature = "trace", test))]
#[inline(always)]
fn nibbles(code: u32) -> (UVec3, UVec3) {
    (
        UVec3::new(code & 15, code >> 4 & 15, code >> 8 & 15),
        UVec3::new(code >> 12 & 15, code >> 16 & 15, code >> 20 & 15),
    )
}

/// The bits of a 24-bit code that [`mirrored`] swaps for a ray whose mirror mask (child
/// bits: x = 4, y = 2, z = 1) is `mask`.
#[cfg(feature = "trace")]
#[inline]
pub(crate) fn swap_mask(mask: u8) -> u32 {
    (u32::from(mask >> 2 & 1) * 0xF)
        | (u32::from(mask >> 1 & 1) * 0xF0)
        | (u32::from(mask & 1) * 0xF00)
}

/// The code of `info`'s box seen in the mirrored space of a ray with swap mask `swap`: the low
/// side and the distance from the high side trade places on each mirrored axis.
#[cfg(feature = "trace")]
#[inline]
pub(crate) fn mirrored(info: u32, swap: u32) -> u32 {
    let e = info >> SHIFT;
    let d = (e ^ (e >> 12)) & swap;
    e ^ d ^ (d << 12)
}

impl Octree {
    /// Derives every node's bounds into bits 8-31 of its `info` word (see
    /// [`Node::info`]). Trees that `svo` builds or reads have them; call this after editing
    /// `nodes` by hand (stale bounds could hide leaves from rays; [`Octree::validate`]
    /// refuses them). Linear in the nodes.
    pub fn refresh_bounds(&mut self) {
        derive(&mut self.nodes, self.depth);
    }

    /// [`Octree::refresh_bounds`] for a tree that passed checks 15 and 16 ([`derive_checked`]).
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    pub(crate) fn refresh_checked_bounds(&mut self) {
        derive_checked(&mut self.nodes, self.depth);
    }

    /// Clears bits 8-31 of every node: the tree as a file stores it, traversed with more
    /// steps to the same leaves.
    pub fn clear_bounds(&mut self) {
        for node in &mut self.nodes {
            node.info &= 0xFF;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::octree::{RootCube, Voxel};
    use glam::DVec3;

    /// The 24-bit code of the box `[lo, hi]` (cells, relative to the node) of a node of `side`.
    #[cfg(feature = "trace")]
    fn encode(lo: UVec3, hi: UVec3, side: u32) -> u32 {
        let sh = unit_shift(side);
        let a = lo >> sh;
        let b = (UVec3::splat(side) - hi) >> sh;
        a.x | a.y << 4 | a.z << 8 | b.x << 12 | b.y << 16 | b.z << 20
    }

    fn tree(depth: u8, cells: &[UVec3]) -> Octree {
        let root = RootCube {
            origin: DVec3::ZERO,
            side: 1.0,
        };
        Octree::from_cells(root, depth, cells.iter().map(|&c| (c, Voxel::default()))).unwrap()
    }

    /// The one-pass derive for checked trees gives [`derive`]'s bits on seeded random trees
    /// (depths 1 to 12, sparse and dense), and neither panics on broken ones.
    #[test]
    fn the_derive_for_checked_trees_equals_the_derive() {
        let mut next = svo_tests::seeds::xorshift(0x00DE_C4ED);
        let mut compared = 0usize;
        for depth in 1..=12u8 {
            for count in [1usize, 5, 60, 900] {
                let cells = svo_tests::seeds::random_cells(&mut next, depth, count);
                let t = tree(depth, &cells);
                let mut fast = t.nodes.clone();
                derive_checked(&mut fast, depth);
                assert_eq!(fast, t.nodes, "depth {depth}, {count} cells");
                compared += t.nodes.len();
                // Broken trees: children pointing back, a node's level lied about.
                let mut broken = t.nodes.clone();
                for node in broken.iter_mut().filter(|n| !n.is_leaf_parent()) {
                    node.first = node.first.wrapping_sub(1 + (next() % 3) as u32);
                }
                derive_checked(&mut broken, depth);
                derive_checked(&mut broken, 30);
                derive(&mut broken, depth);
            }
        }
        assert!(compared > 10_000, "{compared} nodes");
    }

    /// Every node's box, decoded, holds each of its leaves, and is the tightest box the
    /// node's units allow: the leaves' own box with each side rounded outward to a unit.
    #[test]
    fn boxes_hold_their_leaves_within_one_unit() {
        let mut next = svo_tests::seeds::xorshift(0xB0_0D5);
        for depth in 1..=9u8 {
            for count in [1usize, 2, 7, 40] {
                let n = 1u32 << depth;
                let cells = svo_tests::seeds::random_cells(&mut next, depth, count);
                let t = tree(depth, &cells);
                let mut checked = 0;
                for level in 0..depth {
                    let side = n >> level;
                    for (i, corner, s) in t.nodes_at_level(level, usize::MAX).unwrap() {
                        assert_eq!(s, side);
                        let (lo, hi) =
                            cell_box(t.nodes[i as usize].info >> SHIFT, UVec3::ZERO, side);
                        let inside: Vec<UVec3> = cells
                            .iter()
                            .filter(|c| {
                                c.cmpge(corner).all() && c.cmplt(corner + UVec3::splat(side)).all()
                            })
                            .map(|&c| c - corner)
                            .collect();
                        assert!(!inside.is_empty());
                        let tight_lo = inside.iter().fold(UVec3::splat(side), |a, &c| a.min(c));
                        let tight_hi = inside
                            .iter()
                            .fold(UVec3::ZERO, |a, &c| a.max(c + UVec3::ONE));
                        assert!(lo.cmple(tight_lo).all() && hi.cmpge(tight_hi).all());
                        let sh = unit_shift(side);
                        let u = 1u32 << sh;
                        let (want_lo, want_hi) = (
                            tight_lo >> sh << sh,
                            UVec3::splat(side) - ((UVec3::splat(side) - tight_hi) >> sh << sh),
                        );
                        assert_eq!((lo, hi), (want_lo, want_hi), "side {side} unit {u}");
                        checked += 1;
                    }
                }
                assert!(checked >= usize::from(depth));
            }
        }
    }

    /// Swapping the mirrored axes' nibbles gives the box of the mirrored node: on a mirrored
    /// axis the low side is the distance from the high side, and the high side is the node's
    /// side less the low side.
    #[cfg(feature = "trace")]
    #[test]
    fn mirroring_swaps_the_sides_of_mirrored_axes() {
        let side = 64;
        let lo = UVec3::new(4, 20, 36);
        let hi = UVec3::new(12, 64, 40);
        let info = encode(lo, hi, side) << SHIFT;
        for mask in 0..8u8 {
            let (mlo, mhi) = cell_box(mirrored(info, swap_mask(mask)), UVec3::ZERO, side);
            for axis in 0..3 {
                if mask & (4 >> axis) != 0 {
                    assert_eq!(mlo[axis], side - hi[axis], "mask {mask} axis {axis}");
                    assert_eq!(mhi[axis], side - lo[axis], "mask {mask} axis {axis}");
                } else {
                    assert_eq!((mlo[axis], mhi[axis]), (lo[axis], hi[axis]));
                }
            }
        }
    }

    /// Trees that are not trees get whole-node bounds (zero bits) where their shape is
    /// wrong, and deriving them never panics: children before their parent, out of range,
    /// shared, or at the wrong level, and trees of no depth.
    #[test]
    fn malformed_trees_get_whole_nodes() {
        let good = tree(3, &[UVec3::ONE, UVec3::splat(5)]);
        // Root, its two children, their two leaf parents: every box smaller than its node.
        assert_eq!(good.nodes.len(), 5);
        assert!(good.nodes.iter().all(|n| n.info >> SHIFT != 0));
        // The root's two children share one leaf parent: it is reached twice, so it and its
        // parents are whole.
        let mut t = good.clone();
        t.nodes[2].first = t.nodes[1].first;
        t.refresh_bounds();
        let whole = |t: &Octree, i: usize| t.nodes[i].info >> SHIFT == 0;
        assert!(whole(&t, 1) && whole(&t, 2) && whole(&t, 3));
        // The root's children out of range, or the root itself.
        for first in [u32::MAX - 1, 4, 0] {
            let mut t = good.clone();
            t.nodes[0].first = first;
            t.refresh_bounds();
            assert!(whole(&t, 0), "first {first}");
        }
        // Leaves where nodes should be (a depth that disagrees with the nodes), no depth, and
        // a depth beyond the deepest tree.
        for (depth, wrong) in [(2, [1, 2]), (4, [3, 4]), (0, [0, 4]), (31, [0, 4])] {
            let mut t = good.clone();
            t.depth = depth;
            t.refresh_bounds();
            assert!(wrong.iter().all(|&i| whole(&t, i)), "depth {depth}");
        }
        let mut t = good;
        t.clear_bounds();
        assert!((0..5).all(|i| whole(&t, i)));
    }

    /// A tree in memory is valid with its bounds or with zeros, not with other bits there.
    #[test]
    fn validation_takes_bounds_or_zeros_and_nothing_else() {
        let mut t = tree(4, &[UVec3::ONE, UVec3::new(9, 2, 3), UVec3::new(2, 2, 2)]);
        t.validate().unwrap();
        let good = t.clone();
        t.clear_bounds();
        t.validate().unwrap();
        let mut t = good.clone();
        t.nodes[1].info ^= 1 << 9;
        let e = t.validate().unwrap_err();
        assert!(
            matches!(
                e,
                crate::octree::OctreeError::Invalid {
                    check: crate::octree::Check::NodeWords,
                    ..
                }
            ) && e.to_string().contains("refresh_bounds"),
            "{e}"
        );
        t.refresh_bounds();
        assert_eq!(t, good);
    }

    /// The writer stores zeros in bits 8-31, and the reader derives the bounds again: the
    /// file is the one a tree without bounds makes, and reads back equal to the tree.
    #[cfg(feature = "io")]
    #[test]
    fn files_hold_zeros_and_read_back_with_bounds() {
        let t = tree(
            5,
            &[
                UVec3::new(3, 30, 7),
                UVec3::new(4, 30, 8),
                UVec3::new(17, 2, 2),
            ],
        );
        assert!(t.nodes.iter().any(|n| n.info >> SHIFT != 0));
        let mut bare = t.clone();
        bare.clear_bounds();
        let build = crate::io::BuildInfo::default();
        let bytes = crate::io::to_bytes(&t, &build);
        assert_eq!(bytes, crate::io::to_bytes(&bare, &build));
        let (back, _) = crate::io::from_bytes(&bytes).unwrap();
        assert_eq!(back, t);
    }
}
