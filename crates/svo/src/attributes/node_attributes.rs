//! Inner nodes' attributes: what a renderer draws in place of a node's subtree.
//!
//! A node's normal, colour, reflectivity, refractivity and IOR are the area-weighted means
//! over every triangle part below it, made as the build carries each node's sums up
//! ([`crate::attributes::surface_sums`]). A channel that is the same for every leaf (a
//! constant, or absent) is the same for the nodes, but for the normal: the nodes' contours are
//! fitted along their own normals, so the leaves' constant normal is the nodes' only where
//! every node that keeps values has it (else the nodes store theirs).
//!
//! A node's contour is made from its children's, once the tree is finished: the two planes
//! along the node's (decoded) normal that enclose, for every child, the part of the child's
//! cell between the child's own contour planes (the child's whole cell where it has no
//! contour: an interior leaf). That region holds the child's surface, so the node's contour
//! holds the node's surface; it is made from the stored contours alone, so the nodes above a
//! cut of the tree into parts come out the same from the parts' roots
//! ([`crate::bake::parts`]). It is tight where each
//! child's surface crosses its cell, and looser where a child holds only a corner of a sheet.
//!
//! The leaf parents keep no values (they are 0): a leaf parent is two leaves wide, so drawing
//! it instead of its leaves saves little, and its values would cost as much as the tree's
//! node records.

use crate::attributes::surface_sums::NodeValue;
use crate::geometry::child_classify::child_offset;
use crate::octree::contour;
use crate::octree::normal_encoding;
use crate::octree::tree::{Channel, LeafAttributes, NO_NORMAL, Node};
use glam::{DVec3, UVec3, Vec3};

/// The inner nodes' channels of a finished tree (`nodes`, with the leaves' channels
/// `leaves`) from the build's per-node `values`: see the module docs. A tree without leaves
/// has none.
pub(crate) fn node_attributes(
    nodes: &[Node],
    values: &[NodeValue],
    leaves: &LeafAttributes,
) -> LeafAttributes {
    let mut out = LeafAttributes::default();
    if nodes.first().is_none_or(|n| n.child_mask() == 0) || values.len() != nodes.len() {
        return out;
    }
    let kept = |i: usize| !nodes[i].is_leaf_parent();
    fn like<T: Copy + Default>(
        leaf: &Channel<T>,
        values: &[NodeValue],
        f: fn(&NodeValue) -> T,
        kept: &dyn Fn(usize) -> bool,
    ) -> Channel<T> {
        match leaf {
            Channel::Absent => Channel::Absent,
            Channel::Constant(v) => Channel::Constant(*v),
            Channel::PerLeaf(_) => Channel::PerLeaf(
                values
                    .iter()
                    .enumerate()
                    .map(|(i, v)| if kept(i) { f(v) } else { T::default() })
                    .collect(),
            ),
        }
    }
    let uniform = Uniform::of(
        values
            .iter()
            .enumerate()
            .filter(|&(i, _)| kept(i))
            .map(|(_, v)| v.normal),
    );
    out.normal = match normal_storage(&leaves.normal, uniform) {
        Some(c) => c,
        None => like(&Channel::PerLeaf(Vec::new()), values, |v| v.normal, &kept),
    };
    out.colour = like(&leaves.colour, values, |v| v.colour, &kept);
    out.reflectivity = like(&leaves.reflectivity, values, |v| v.reflectivity, &kept);
    out.refractivity = like(&leaves.refractivity, values, |v| v.refractivity, &kept);
    out.ior = like(&leaves.ior, values, |v| v.ior, &kept);
    if has_contours(leaves) {
        let mut c = node_contours(nodes, values, leaves, 0);
        for (i, x) in c.iter_mut().enumerate() {
            if !kept(i) {
                *x = 0;
            }
        }
        out.contour = Channel::PerLeaf(c);
    }
    out
}

/// Whether the nodes of a tree whose leaves have these channels get contours: where the
/// leaves have contours and normals.
pub(crate) fn has_contours(leaves: &LeafAttributes) -> bool {
    !matches!(leaves.contour, Channel::Absent) && !matches!(leaves.normal, Channel::Absent)
}

/// The values one channel takes over a set of nodes: none, all one, or several.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "io", derive(serde::Serialize, serde::Deserialize))]
pub(crate) enum Uniform {
    /// No node.
    Empty,
    /// Every node holds this value.
    One(u32),
    /// Two values differ.
    Many,
}

impl Uniform {
    /// Over `values`.
    pub(crate) fn of(values: impl IntoIterator<Item = u32>) -> Self {
        values
            .into_iter()
            .fold(Self::Empty, |u, v| u.and(Self::One(v)))
    }

    /// Over both sets.
    pub(crate) fn and(self, other: Self) -> Self {
        match (self, other) {
            (Self::Empty, x) | (x, Self::Empty) => x,
            (Self::One(a), Self::One(b)) if a == b => self,
            _ => Self::Many,
        }
    }
}

/// How the nodes store their normals, for leaves whose normal channel is `leaf` and nodes
/// keeping values whose normals are `uniform`: absent with the leaves', the leaves' constant
/// where every such node's normal is that constant, else per node (`None`). The contours are
/// fitted against each node's own normal, so one stored once must be every node's.
pub(crate) fn normal_storage(leaf: &Channel<u32>, uniform: Uniform) -> Option<Channel<u32>> {
    match (leaf, uniform) {
        (Channel::Absent, _) => Some(Channel::Absent),
        (Channel::Constant(v), Uniform::Empty) => Some(Channel::Constant(*v)),
        (Channel::Constant(v), Uniform::One(w)) if *v == w => Some(Channel::Constant(*v)),
        _ => None,
    }
}

/// Each node's contour from its children's (see the module docs): level by level from the
/// deepest, the nodes of a level in parallel. The normals are the nodes' `values`; the
/// leaves' values are `leaves`' from `leaf_off` on (a subtree's leaf bases count from its
/// first leaf). A leaf parent's contour is made (its parent's needs it) but kept by no file.
pub(crate) fn node_contours(
    nodes: &[Node],
    values: &[NodeValue],
    leaves: &LeafAttributes,
    leaf_off: usize,
) -> Vec<u32> {
    let mut out = vec![contour::FULL; nodes.len()];
    for level in by_level(nodes).iter().rev() {
        let one = |&i: &u32| {
            let node = nodes[i as usize];
            let children = (0..8u8).filter_map(|c| {
                let rank = node.child_rank(c)?;
                let slab = match node.leaf_base() {
                    Some(base) => {
                        let leaf = leaf_off + (base + rank) as usize;
                        let word = leaves.normal.get(leaf).filter(|&w| w != NO_NORMAL);
                        word.zip(leaves.contour.get(leaf))
                            .map(|(w, c)| node_slab(w, c))
                    }
                    None => {
                        let k = (node.first + rank) as usize;
                        Some(node_slab(values[k].normal, out[k]))
                    }
                };
                Some((c, slab))
            });
            contour_of(values[i as usize].normal, children)
        };
        #[cfg(feature = "parallel")]
        let level_values: Vec<u32> = {
            use rayon::prelude::*;
            level.par_iter().with_min_len(4096).map(one).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let level_values: Vec<u32> = level.iter().map(one).collect();
        for (&i, v) in level.iter().zip(level_values) {
            out[i as usize] = v;
        }
    }
    out
}

/// The indices of the nodes with children, level by level from the root.
fn by_level(nodes: &[Node]) -> Vec<Vec<u32>> {
    let mut levels: Vec<Vec<u32>> = Vec::new();
    let mut level = vec![0u32];
    while !level.is_empty() {
        level.retain(|&i| nodes[i as usize].child_mask() != 0);
        let mut next = Vec::new();
        for &i in &level {
            let n = nodes[i as usize];
            if n.leaf_base().is_none() {
                next.extend(n.first..n.first + n.child_mask().count_ones());
            }
        }
        levels.push(level);
        level = next;
    }
    levels
}

/// The slab of a child with normal word `normal` and contour word `contour`: its normal and
/// the planes' offsets from its centre, in its cells.
pub(crate) fn node_slab(normal: u32, contour: u32) -> (Vec3, (f32, f32)) {
    let n = normal_encoding::decode(normal);
    (n, contour::offsets(contour, n))
}

/// The contour of a node with normal word `normal` from its `children`: each one's index and
/// slab ([`node_slab`]; `None` for a child without a contour, which spans its cell).
pub(crate) fn contour_of(
    normal: u32,
    children: impl Iterator<Item = (u8, Option<(Vec3, (f32, f32))>)>,
) -> u32 {
    let n = normal_encoding::decode(normal);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (c, slab) in children {
        let (a, b) = child_extent(c, slab, n);
        lo = lo.min(a);
        hi = hi.max(b);
    }
    contour::pack(lo, hi, n)
}

/// The extreme offsets along `n`, from the centre of a node of side 1, of the part of child
/// `c`'s cell between the child's contour planes (`slab`: its normal and their offsets from
/// its centre, in its cells), or of its whole cell without one.
fn child_extent(c: u8, slab: Option<(Vec3, (f32, f32))>, n: Vec3) -> (f64, f64) {
    let o = UVec3::from_array(child_offset(c)).as_dvec3();
    let n = n.as_dvec3();
    // From the node's centre to the child's, in node units.
    let centre = n.dot(o * 0.5 - DVec3::splat(0.25));
    let Some((nc, (a, b))) = slab else {
        let r = 0.25 * (n.x.abs() + n.y.abs() + n.z.abs());
        return (centre - r, centre + r);
    };
    // `n = k nc + m` with `m` across the child's normal: along `nc` the slab bounds the
    // child's surface, across it the child's cell does.
    let nc = nc.as_dvec3();
    let k = n.dot(nc) / nc.length_squared();
    let m = n - nc * k;
    let r = 0.25 * (m.x.abs() + m.y.abs() + m.z.abs());
    let (a, b) = (0.5 * f64::from(a), 0.5 * f64::from(b));
    let (lo, hi) = if k >= 0.0 {
        (k * a, k * b)
    } else {
        (k * b, k * a)
    };
    (centre + lo - r, centre + hi + r)
}

/// [`child_extent`] exactly: the extremes over the vertices of the region.
#[cfg(test)]
fn child_extent_exact(c: u8, slab: Option<(Vec3, (f32, f32))>, n: Vec3) -> (f64, f64) {
    let o = UVec3::from_array(child_offset(c)).as_dvec3();
    // Along the node's normal from its centre, the corners of the child's cell (corner `k`
    // at child-local `(k >> 2 & 1, k >> 1 & 1, k & 1)`), and so by interpolation any point
    // of its edges.
    let n = n.as_dvec3() * 0.5;
    let base = n.dot(o - DVec3::ONE);
    let f: [f64; 8] = std::array::from_fn(|k| {
        base + [n.x, 0.0][usize::from(k & 4 == 0)]
            + [n.y, 0.0][usize::from(k & 2 == 0)]
            + [n.z, 0.0][usize::from(k & 1 == 0)]
    });
    let mut span = (f64::INFINITY, f64::NEG_INFINITY);
    let take = |span: &mut (f64, f64), v: f64| *span = (span.0.min(v), span.1.max(v));
    if let Some((nc, (a, b))) = slab {
        // The corners along the child's normal from its centre.
        let nc = nc.as_dvec3();
        let cb = -0.5 * (nc.x + nc.y + nc.z);
        let d: [f64; 8] = std::array::from_fn(|k| {
            cb + [nc.x, 0.0][usize::from(k & 4 == 0)]
                + [nc.y, 0.0][usize::from(k & 2 == 0)]
                + [nc.z, 0.0][usize::from(k & 1 == 0)]
        });
        let (a, b) = (f64::from(a), f64::from(b));
        // The region's vertices: the cell's corners between the planes, and where each plane
        // crosses each edge of the cell.
        for k in 0..8 {
            if d[k] >= a && d[k] <= b {
                take(&mut span, f[k]);
            }
        }
        for bit in [4usize, 2, 1] {
            for k0 in (0..8).filter(|k| k & bit == 0) {
                let k1 = k0 | bit;
                let (d0, d1) = (d[k0], d[k1]);
                for t in [a, b] {
                    if d0 != d1 && (d0 - t) * (d1 - t) <= 0.0 {
                        let s = ((t - d0) / (d1 - d0)).clamp(0.0, 1.0);
                        take(&mut span, f[k0] + (f[k1] - f[k0]) * s);
                    }
                }
            }
        }
    }
    if span.0 > span.1 {
        // No contour, or no point between its planes (which cannot miss the cell they were
        // fitted in): the whole cell.
        f.iter().for_each(|&v| take(&mut span, v));
    }
    span
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_without_a_contour_spans_its_cell() {
        // Child 7 (the upper corner) along +x: from the node's centre to its face.
        assert_eq!(child_extent(7, None, Vec3::X), (0.0, 0.5));
        assert_eq!(child_extent_exact(7, None, Vec3::X), (0.0, 0.5));
        // A thin slab through the child's centre, across its cell, along the same normal.
        for f in [child_extent, child_extent_exact] {
            let (lo, hi) = f(7, Some((Vec3::X, (-0.01, 0.01))), Vec3::X);
            assert!(
                (lo - 0.245).abs() < 1e-6 && (hi - 0.255).abs() < 1e-6,
                "{lo} {hi}"
            );
            // Along another axis the slab spans the whole cell.
            let (lo, hi) = f(0, Some((Vec3::X, (-0.01, 0.01))), Vec3::Y);
            assert!((lo + 0.5).abs() < 1e-9 && hi.abs() < 1e-9, "{lo} {hi}");
        }
    }

    /// The bound encloses the region's exact extent, equals it where the normals agree, and
    /// is within a small excess where they differ by a few degrees.
    #[test]
    fn the_extent_bound_encloses_the_exact_one() {
        let mut r = svo_tests::seeds::unit_f64(7);
        let unit = |r: &mut dyn FnMut() -> f64| {
            Vec3::new(
                (2.0 * r() - 1.0) as f32,
                (2.0 * r() - 1.0) as f32,
                (2.0 * r() - 1.0) as f32,
            )
            .normalize()
        };
        let mut close_excess = 0.0f64;
        for i in 0..20_000 {
            let nc = unit(&mut r);
            let n = if i % 2 == 0 {
                nc
            } else {
                (nc + 0.05 * unit(&mut r)).normalize()
            };
            let e = 0.5 * (nc.x.abs() + nc.y.abs() + nc.z.abs());
            let (t0, t1) = (r() as f32, r() as f32);
            let (a, b) = ((2.0 * t0.min(t1) - 1.0) * e, (2.0 * t0.max(t1) - 1.0) * e);
            let c = (r() * 8.0) as u8 & 7;
            let (lo, hi) = child_extent(c, Some((nc, (a, b))), n);
            let (xlo, xhi) = child_extent_exact(c, Some((nc, (a, b))), n);
            assert!(
                lo <= xlo + 1e-9 && hi >= xhi - 1e-9,
                "{i}: [{lo}, {hi}] vs [{xlo}, {xhi}]"
            );
            if i % 2 == 0 {
                assert!((lo - xlo).abs() < 1e-6 && (hi - xhi).abs() < 1e-6, "{i}");
            } else {
                close_excess = close_excess.max((xlo - lo) + (hi - xhi));
            }
        }
        // Normals up to about 3 degrees apart: the bound is loose by at most 0.055 of the
        // node's side in all (measured), on both sides together.
        assert!(close_excess < 0.06, "{close_excess}");
    }
}
