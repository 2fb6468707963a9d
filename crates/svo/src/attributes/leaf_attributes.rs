//! Per-leaf attributes and contours from the triangles that touch each leaf.
//!
//! The voxelizer hands every leaf its contacts: each touching triangle's part inside the
//! cell (sliced by [`crate::geometry::grid_slice`] at the bottom levels, clipped by [`crate::geometry::clip`]
//! elsewhere), whose area is the triangle's weight. The leaf's normal is the area-weighted mean of the triangles' unit normals; colour
//! (material colour times texture, sampled at the clipped polygon's centre, averaged in linear
//! space), reflectivity, refractivity and IOR are area-weighted means too (a blended
//! material's reflectivity and refractivity at the alpha sampled there,
//! [`crate::mesh::Material::optics_at`]). Where all contacts
//! have zero area (a triangle only touching the cell, or degenerate triangles) every triangle
//! weighs the same. The contour is then fitted to the clipped polygons against the *encoded*
//! normal ([`crate::octree::contour`]).
//!
//! The values are computed as the voxelizer emits each leaf, so they come in leaf order
//! whatever the thread count, and no list of triangles per leaf is ever stored. Contours are
//! fitted per block of leaves after their attributes, so the two are timed separately, which
//! is how the bake summary reports them.

use crate::attributes::ChannelSelection;
use crate::attributes::surface_sums::{NodeRule, NodeValue, SurfaceSums};
use crate::geometry::triangle_setup::GridTriangle;
use crate::mesh::triangle_mesh::{Material, Mesh};
use crate::octree::contour;
use crate::octree::encoding::{encode_colour, ior_encode, unorm8};
use crate::octree::normal_encoding;
use crate::octree::tree::{Channel, ChannelKind, LeafAttributes};
use glam::{DVec3, Vec2, Vec3};
use std::time::Duration;

/// Contour thickness statistics, in cells.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct ContourStats {
    /// Mean thickness.
    pub mean: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

/// Timings and contour statistics of the attribute work done while voxelizing.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct AttributeReport {
    /// Time spent on per-leaf attributes, apportioned to wall time.
    pub attributes: Duration,
    /// Time spent fitting contours, apportioned to wall time.
    pub contours: Duration,
    /// Contour thickness statistics, when contours were made.
    pub contour_stats: Option<ContourStats>,
}

/// A triangle's part in a leaf: the triangle (an index into the grid-space triangles), the
/// part's area (its weight) and its points, `pts[start..start + len]` of the caller's buffer,
/// relative to the cell's minimum corner (so `[0, 1]^3`) in `f32`: their rounding (under
/// `1e-7` cells) is far inside the contour's one-quantum margin.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Contact {
    /// The leaf's cell within its block (a local Morton index), for sorting.
    pub key: u16,
    /// Grid-space triangle index.
    pub tri: u32,
    /// Area of the triangle's part in the cell (zero for a touch).
    pub area: f64,
    /// First point.
    pub start: u32,
    /// Number of points.
    pub len: u32,
}

/// What the per-leaf computation reads: materials, the triangles' unit normals and which
/// channels are wanted and vary (the others are stored as constants or left out).
pub(crate) struct AttributeInputs<'a> {
    mesh: &'a Mesh,
    tris: &'a [GridTriangle],
    order: &'a [u32],
    select: ChannelSelection,
    normals: Vec<DVec3>,
    want_normal: bool,
    want_contour: bool,
    per_leaf_colour: bool,
    per_leaf_refl: bool,
    per_leaf_refr: bool,
    per_leaf_ior: bool,
}

impl<'a> AttributeInputs<'a> {
    /// Inputs for the grid-space triangles `tris`, where `order[k]` is the mesh triangle of
    /// `tris[k]`, computing the channels in `select`.
    pub(crate) fn new(
        mesh: &'a Mesh,
        tris: &'a [GridTriangle],
        order: &'a [u32],
        select: ChannelSelection,
    ) -> Self {
        let want_contour = select.has(ChannelKind::Contour);
        let want_normal = select.has(ChannelKind::Normal) || want_contour;
        let mats = materials(mesh);
        let textured = mats.iter().any(|m| m.texture.is_some()) && !mesh.triangle_uvs.is_empty();
        let varies = |f: &dyn Fn(&Material) -> u32| mats.iter().any(|m| f(m) != f(mats[0]));
        let per_leaf_colour =
            select.has(ChannelKind::Colour) && (textured || varies(&|m| encode_colour(m.colour)));
        // A blended material's optics follow its texture's alpha.
        let blend_textured = textured && mats.iter().any(|m| m.alpha_blend && m.texture.is_some());
        let per_leaf_refl = select.has(ChannelKind::Reflectivity)
            && (blend_textured || varies(&|m| u32::from(unorm8(plain_optics(m).0))));
        let per_leaf_refr = select.has(ChannelKind::Refractivity)
            && (blend_textured || varies(&|m| u32::from(unorm8(plain_optics(m).1))));
        let per_leaf_ior =
            select.has(ChannelKind::Ior) && varies(&|m| u32::from(ior_encode(m.ior)));
        let mut inputs = Self {
            mesh,
            tris,
            order,
            select,
            normals: Vec::new(),
            want_normal,
            want_contour,
            per_leaf_colour,
            per_leaf_refl,
            per_leaf_refr,
            per_leaf_ior,
        };
        // Unit normals of the grid-space triangles (zero for degenerate ones).
        if inputs.needs_geometry() {
            let unit = |t: &GridTriangle| {
                let len = t.n.length();
                if len > 0.0 && len.is_finite() {
                    t.n / len
                } else {
                    DVec3::ZERO
                }
            };
            #[cfg(feature = "parallel")]
            {
                use rayon::prelude::*;
                inputs.normals = tris.par_iter().with_min_len(4096).map(unit).collect();
            }
            #[cfg(not(feature = "parallel"))]
            {
                inputs.normals = tris.iter().map(unit).collect();
            }
        }
        inputs
    }

    /// Whether any per-leaf value needs the triangles' parts in the cells (areas, points);
    /// without it the voxelizer need not clip.
    pub(crate) fn needs_geometry(&self) -> bool {
        self.want_normal
            || self.per_leaf_colour
            || self.per_leaf_refl
            || self.per_leaf_refr
            || self.per_leaf_ior
    }

    /// The unit normal of grid-space triangle `ti` (zero for a degenerate one, or where
    /// its length is not finite), computed once per bake when geometry is needed.
    #[inline]
    pub(crate) fn unit_normal(&self, ti: u32) -> DVec3 {
        self.normals[ti as usize]
    }

    /// Whether contours are made.
    pub(crate) fn wants_contour(&self) -> bool {
        self.want_contour
    }

    /// The grid-space triangles.
    pub(crate) fn triangles(&self) -> &'a [GridTriangle] {
        self.tris
    }

    /// Computes the attributes of the leaf at grid cell `cell` (its minimum corner) from its
    /// `contacts` (points in `pts`, cell-local) and appends them to `out`. The contour is
    /// left pending ([`LeafValues::fit_contours`]). Returns the sums the values are the means
    /// of, for the leaf's parent ([`SurfaceSums`]).
    pub(crate) fn push_leaf(
        &self,
        out: &mut LeafValues,
        cell: DVec3,
        contacts: &[Contact],
        contact_start: u32,
        pts: &[Vec3],
    ) -> SurfaceSums {
        out.count += 1;
        out.pairs += contacts.len() as u64;
        let mut sums = SurfaceSums::default();
        if !self.needs_geometry() {
            return sums;
        }
        // The area and the area-weighted normal sum in one pass.
        for c in contacts {
            sums.area += c.area;
            if self.want_normal {
                sums.normal += self.normals[c.tri as usize] * c.area;
            }
        }
        let area = sums.area;
        let weight = |c: &Contact| if area > 0.0 { c.area } else { 1.0 };
        // The weights' sum: the area (added in the same order), or one per contact.
        sums.weight = if area > 0.0 {
            area
        } else {
            contacts.len() as f64
        };
        let material = |ti: u32| self.mesh.material_of(self.order[ti as usize] as usize);
        if self.want_normal {
            if !(area > 0.0) {
                sums.normal = DVec3::ZERO;
                for c in contacts {
                    sums.normal += self.normals[c.tri as usize];
                }
            }
            let enc = sums.encode_normal(|| {
                // The heaviest triangle's normal.
                contacts
                    .iter()
                    .map(|c| (self.normals[c.tri as usize], c.area))
                    .filter(|(n, _)| *n != DVec3::ZERO)
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .map_or(DVec3::Z, |(n, _)| n)
            });
            if self.select.has(ChannelKind::Normal) {
                out.normal.push(enc);
            }
            if self.want_contour {
                out.pending.push(PendingContour {
                    contacts: contact_start..contact_start + contacts.len() as u32,
                    normal: normal_encoding::decode(enc),
                });
            }
        }
        // The colour of contact `c`'s triangle at the centre of its part in the cell.
        let colour = |c: &Contact| {
            let p = out_points(pts, c);
            let centre = if p.is_empty() {
                DVec3::splat(0.5)
            } else {
                (p.iter().sum::<Vec3>() / p.len() as f32).as_dvec3()
            };
            let ti = c.tri as usize;
            triangle_colour(
                self.mesh,
                self.order[ti] as usize,
                &self.tris[ti],
                centre + cell,
            )
        };
        if self.per_leaf_colour {
            for c in contacts {
                let w = weight(c);
                let col = colour(c);
                for (a, v) in sums.colour.iter_mut().zip(col) {
                    *a += w * f64::from(v);
                }
            }
            out.colour.push(sums.encode_colour());
        }
        // Weighted sums of reflectivity, refractivity and IOR, each contact's optics taken
        // once (a blended material's at the alpha sampled at its part's centre).
        if self.per_leaf_refl || self.per_leaf_refr || self.per_leaf_ior {
            let optics = self.per_leaf_refl || self.per_leaf_refr;
            for c in contacts {
                let w = weight(c);
                let m = material(c.tri);
                let (kr, kt) = if optics && m.alpha_blend && m.texture.is_some() {
                    m.optics_at(colour(c)[3])
                } else {
                    plain_optics(m)
                };
                sums.reflectivity += w * f64::from(kr);
                sums.refractivity += w * f64::from(kt);
                sums.ior += w * f64::from(m.ior);
            }
            let (refl, refr, ior) = sums.encode_optics();
            if self.per_leaf_refl {
                out.reflectivity.push(refl);
            }
            if self.per_leaf_refr {
                out.refractivity.push(refr);
            }
            if self.per_leaf_ior {
                out.ior.push(ior);
            }
        }
        sums
    }

    /// The encoded attributes of an inner node from its `sums` (its children's, added):
    /// the channels that are per leaf, the others left zero.
    pub(crate) fn node_value(&self, sums: &mut SurfaceSums) -> NodeValue {
        self.node_rule().value(sums)
    }

    /// Which values a node's sums are encoded into.
    pub(crate) fn node_rule(&self) -> NodeRule {
        NodeRule {
            normal: self.want_normal,
            colour: self.per_leaf_colour,
            optics: self.per_leaf_refl || self.per_leaf_refr || self.per_leaf_ior,
        }
    }

    /// The leaf attributes from the voxelizer's values, with constants for the channels that
    /// do not vary, and the report.
    pub(crate) fn finish(
        &self,
        v: LeafValues,
        wall: Duration,
    ) -> (LeafAttributes, AttributeReport) {
        self.finish_with(v, wall, true)
    }

    #[cfg(feature = "io")]
    /// [`Self::finish`] without turning per-leaf channels whose values are all equal into
    /// constants: a part of a tree keeps its arrays, and the merge decides over all parts.
    pub(crate) fn finish_uncompacted(
        &self,
        v: LeafValues,
        wall: Duration,
    ) -> (LeafAttributes, AttributeReport) {
        self.finish_with(v, wall, false)
    }

    fn finish_with(
        &self,
        mut v: LeafValues,
        wall: Duration,
        compact: bool,
    ) -> (LeafAttributes, AttributeReport) {
        let select = self.select;
        let m0 = materials(self.mesh)[0];
        let mut attrs = LeafAttributes::default();
        if select.has(ChannelKind::Normal) {
            attrs.normal = Channel::PerLeaf(std::mem::take(&mut v.normal));
        }
        if self.want_contour {
            attrs.contour = Channel::PerLeaf(std::mem::take(&mut v.contour));
        }
        if select.has(ChannelKind::Colour) {
            attrs.colour = if self.per_leaf_colour {
                Channel::PerLeaf(std::mem::take(&mut v.colour))
            } else {
                Channel::Constant(encode_colour(m0.colour))
            };
        }
        if select.has(ChannelKind::Reflectivity) {
            attrs.reflectivity = if self.per_leaf_refl {
                Channel::PerLeaf(std::mem::take(&mut v.reflectivity))
            } else {
                Channel::Constant(unorm8(plain_optics(m0).0))
            };
        }
        if select.has(ChannelKind::Refractivity) {
            attrs.refractivity = if self.per_leaf_refr {
                Channel::PerLeaf(std::mem::take(&mut v.refractivity))
            } else {
                Channel::Constant(unorm8(plain_optics(m0).1))
            };
        }
        if select.has(ChannelKind::Ior) {
            attrs.ior = if self.per_leaf_ior {
                Channel::PerLeaf(std::mem::take(&mut v.ior))
            } else {
                Channel::Constant(ior_encode(m0.ior))
            };
        }
        if compact && v.count > 0 {
            attrs.compact();
        }
        // Apportion the wall time by the measured thread time of each step.
        let busy = (v.t_voxelize + v.t_attributes + v.t_contours).as_secs_f64();
        let share = |d: Duration| {
            if busy > 0.0 {
                wall.mul_f64(d.as_secs_f64() / busy)
            } else {
                Duration::ZERO
            }
        };
        let contour_stats = self.want_contour.then(|| thickness_stats(&v.thickness));
        (
            attrs,
            AttributeReport {
                attributes: share(v.t_attributes),
                contours: share(v.t_contours),
                contour_stats,
            },
        )
    }
}

/// The mesh's materials (the default one when it has none).
fn materials(mesh: &Mesh) -> Vec<&Material> {
    if mesh.materials.is_empty() {
        vec![mesh.material_of(0)]
    } else {
        mesh.materials.iter().collect()
    }
}

/// A material's reflectivity and refractivity where its texture is not sampled: a blended
/// one's at its colour's alpha.
fn plain_optics(m: &Material) -> (f32, f32) {
    m.optics_at(m.colour[3])
}

/// The points of contact `c` in `pts`.
fn out_points<'p>(pts: &'p [Vec3], c: &Contact) -> &'p [Vec3] {
    &pts[c.start as usize..(c.start + c.len) as usize]
}

/// A leaf whose contour waits for its block's points.
#[derive(Clone, Debug)]
pub(crate) struct PendingContour {
    contacts: std::ops::Range<u32>,
    normal: Vec3,
}

/// Per-leaf values as the voxelizer emits them, leaf after leaf, for the selected channels
/// that vary; with counts and the thread time of each step.
#[derive(Debug, Default)]
pub(crate) struct LeafValues {
    count: usize,
    /// Encoded normals.
    pub normal: Vec<u32>,
    /// Encoded contours.
    pub contour: Vec<u32>,
    /// RGBA8 colours.
    pub colour: Vec<u32>,
    /// Reflectivities.
    pub reflectivity: Vec<u8>,
    /// Refractivities.
    pub refractivity: Vec<u8>,
    /// Encoded IORs.
    pub ior: Vec<u16>,
    /// Contour thickness per leaf, in cells (for the statistics).
    pub thickness: Vec<f32>,
    /// Leaf/triangle contacts.
    pub pairs: u64,
    /// Leaves that no triangle touches (inexact strategies only).
    pub false_positives: u64,
    /// Thread time of voxelizing (tests, slicing, tree).
    pub t_voxelize: Duration,
    /// Thread time of the per-leaf attributes.
    pub t_attributes: Duration,
    /// Thread time of the contours.
    pub t_contours: Duration,
    pending: Vec<PendingContour>,
}

impl LeafValues {
    /// Number of leaves.
    pub(crate) fn len(&self) -> usize {
        self.count
    }

    /// Fits the pending contours from the contacts and their points, given in the same
    /// calls to [`AttributeInputs::push_leaf`].
    pub(crate) fn fit_contours(&mut self, contacts: &[Contact], pts: &[Vec3]) {
        for p in self.pending.drain(..) {
            // The minimum of the offsets and of their negations (the maximum, negated): two
            // minima, which the compiler keeps as one packed minimum per point.
            let (mut lo, mut neg_hi) = (f32::INFINITY, f32::INFINITY);
            let n = p.normal;
            for c in &contacts[p.contacts.start as usize..p.contacts.end as usize] {
                for &q in out_points(pts, c) {
                    // `n . (q - 0.5)`, summed as `Vec3::dot` does.
                    let d = (q.x - 0.5) * n.x + (q.y - 0.5) * n.y + (q.z - 0.5) * n.z;
                    // `f32::min` without its NaN handling (the points are finite).
                    lo = if lo < d { lo } else { d };
                    neg_hi = if neg_hi < -d { neg_hi } else { -d };
                }
            }
            let (lo, hi) = (f64::from(lo), -f64::from(neg_hi));
            let (c, thickness) = if lo <= hi {
                contour::pack_with_thickness(lo, hi, p.normal)
            } else {
                let c = contour::fit(&[], p.normal);
                (c, contour::thickness(c, p.normal))
            };
            self.thickness.push(thickness);
            self.contour.push(c);
        }
    }

    /// The leaves of `parts`, one after the other. Each channel is reserved once at its full
    /// length and the parts' arrays of that channel are freed as they are copied, so that at
    /// most one channel is held twice.
    pub(crate) fn concat(mut parts: Vec<Self>) -> Self {
        fn join<T: Copy>(
            parts: &mut [LeafValues],
            f: fn(&mut LeafValues) -> &mut Vec<T>,
        ) -> Vec<T> {
            let mut out = Vec::with_capacity(parts.iter_mut().map(|p| f(p).len()).sum());
            for p in parts.iter_mut() {
                out.extend_from_slice(&std::mem::take(f(p)));
            }
            out
        }
        let mut out = Self {
            normal: join(&mut parts, |p| &mut p.normal),
            contour: join(&mut parts, |p| &mut p.contour),
            colour: join(&mut parts, |p| &mut p.colour),
            reflectivity: join(&mut parts, |p| &mut p.reflectivity),
            refractivity: join(&mut parts, |p| &mut p.refractivity),
            ior: join(&mut parts, |p| &mut p.ior),
            thickness: join(&mut parts, |p| &mut p.thickness),
            ..Self::default()
        };
        for p in &parts {
            out.count += p.count;
            out.pairs += p.pairs;
            out.false_positives += p.false_positives;
            out.t_voxelize += p.t_voxelize;
            out.t_attributes += p.t_attributes;
            out.t_contours += p.t_contours;
        }
        out
    }
}

fn thickness_stats(v: &[f32]) -> ContourStats {
    if v.is_empty() {
        return ContourStats::default();
    }
    // Thicknesses are not negative (nor NaN), so their bit patterns sort as they do (`+ 0.0`
    // turns a -0.0 into 0.0): the ranks are selected on integers, by a radix select (a count
    // per top 16 bits, then the values of the buckets that hold the ranks). One pass counts,
    // sums (four running sums, so the additions do not wait on each other) and finds the
    // maximum; a scan of the counts names both ranks' buckets; one more pass collects their
    // values.
    let key = |x: f32| (x + 0.0).to_bits();
    let mut counts = vec![0u32; 1 << 16];
    let (mut sums, mut max) = ([0.0f64; 4], 0u32);
    let mut quads = v.chunks_exact(4);
    for q in &mut quads {
        for (s, &x) in sums.iter_mut().zip(q) {
            let b = key(x);
            counts[(b >> 16) as usize] += 1;
            *s += f64::from(x);
            max = max.max(b);
        }
    }
    for &x in quads.remainder() {
        let b = key(x);
        counts[(b >> 16) as usize] += 1;
        sums[0] += f64::from(x);
        max = max.max(b);
    }
    let mean = (sums[0] + sums[1] + (sums[2] + sums[3])) / v.len() as f64;
    let rank = |f: f64| ((v.len() - 1) as f64 * f).round() as usize;
    let ranks = [rank(0.5), rank(0.95)];
    // Per rank, its bucket and the count of values in the buckets below it.
    let mut found = [(0usize, 0usize); 2];
    let (mut below, mut r) = (0usize, 0usize);
    for (b, &c) in counts.iter().enumerate() {
        while r < 2 && below + c as usize > ranks[r] {
            found[r] = (b, below);
            r += 1;
        }
        if r == 2 {
            break;
        }
        below += c as usize;
    }
    let mut inside = [Vec::new(), Vec::new()];
    for &x in v {
        let b = key(x);
        for (list, &(bucket, _)) in inside.iter_mut().zip(&found) {
            if (b >> 16) as usize == bucket {
                list.push(b);
            }
        }
    }
    let mut select = |i: usize| -> f32 {
        let (_, below) = found[i];
        f32::from_bits(*inside[i].select_nth_unstable(ranks[i] - below).1)
    };
    ContourStats {
        mean,
        p50: f64::from(select(0)),
        p95: f64::from(select(1)),
        max: f64::from(f32::from_bits(max)),
    }
}

/// The colour of mesh triangle `ti` at grid point `q` on it: material colour times texture.
fn triangle_colour(mesh: &Mesh, ti: usize, t: &GridTriangle, q: DVec3) -> [f32; 4] {
    let mat = mesh.material_of(ti);
    let (Some(tex), Some(uvi)) = (
        mat.texture.and_then(|i| mesh.textures.get(i)),
        mesh.triangle_uvs.get(ti),
    ) else {
        return mat.colour;
    };
    // Barycentric coordinates of the clipped polygon's centre `q` (grid space).
    let (a, b, c) = (t.v[0], t.v[1], t.v[2]);
    let (v0, v1, v2) = (b - a, c - a, q - a);
    let (d00, d01, d11, d20, d21) = (v0.dot(v0), v0.dot(v1), v1.dot(v1), v2.dot(v0), v2.dot(v1));
    let den = d00 * d11 - d01 * d01;
    let (wb, wc) = if den.abs() > 0.0 {
        (
            ((d11 * d20 - d01 * d21) / den).clamp(0.0, 1.0),
            ((d00 * d21 - d01 * d20) / den).clamp(0.0, 1.0),
        )
    } else {
        (1.0 / 3.0, 1.0 / 3.0)
    };
    let wa = (1.0 - wb - wc).max(0.0);
    let uv = |i: u32| mesh.uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO);
    let st = uv(uvi[0]) * wa as f32 + uv(uvi[1]) * wb as f32 + uv(uvi[2]) * wc as f32;
    let s = tex.sample_linear(st);
    [
        mat.colour[0] * s[0],
        mat.colour[1] * s[1],
        mat.colour[2] * s[2],
        mat.colour[3] * s[3],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// `n` random triangles of about `size` around points of the unit cube.
    fn random_mesh(seed: u64, n: usize, size: f64) -> Mesh {
        let mut r = svo_tests::seeds::unit_f64(seed);
        let mut around = |c: f64| c + size * (2.0 * r() - 1.0);
        let mut m = Mesh::default();
        for i in 0..n as u32 {
            let c = DVec3::new(around(0.5), around(0.5), around(0.5));
            for _ in 0..3 {
                m.positions
                    .push(DVec3::new(around(c.x), around(c.y), around(c.z)));
            }
            m.triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        m
    }

    #[test]
    fn contours_enclose_the_clipped_surface() {
        // Small triangles (most leaves single-triangle: the no-clipping path) and large ones
        // (many triangles per leaf: the clipping path).
        for (seed, n, size, depth) in [(1u64, 300, 0.02, 6u8), (2, 60, 0.3, 5), (3, 200, 0.05, 7)] {
            let mesh = random_mesh(seed, n, size);
            let opts = crate::BakeOptions {
                depth,
                ..Default::default()
            };
            let (tree, _) = crate::bake_mesh(&mesh, &opts).unwrap();
            let (_, leaves) =
                crate::bake::voxelize_mesh(&mesh, depth, crate::Strategy::Exact).unwrap();
            let mut checked = 0;
            for leaf in tree.leaves() {
                let v = tree.attributes.get(leaf.index as usize);
                let (nrm, (near, far)) = (v.normal.unwrap(), v.contour.unwrap());
                let i = leaf.index as usize;
                assert_eq!(leaves.cells[i], leaf.cell.to_array());
                let m = leaf.cell.as_dvec3();
                for &t in leaves.triangles(i) {
                    let tri = mesh.triangles[t as usize]
                        .map(|k| tree.root.to_grid(mesh.positions[k as usize], depth) - m);
                    let p = crate::geometry::clip::clip_to_unit_cube(tri);
                    for q in p.points() {
                        let d = nrm.as_dvec3().dot(*q - DVec3::splat(0.5));
                        assert!(
                            d >= f64::from(near) - 1e-5 && d <= f64::from(far) + 1e-5,
                            "leaf {i}: {d} outside [{near}, {far}]"
                        );
                        checked += 1;
                    }
                }
            }
            assert!(checked > 100, "{checked}");
        }
    }

    /// The radix select gives the ranks a full sort gives (and the mean the sum in order,
    /// within rounding), on values with many repeats,
    /// zeros of both signs and values that share their top bits.
    #[test]
    fn thickness_percentiles_equal_sorting() {
        let mut rnd = svo_tests::seeds::xorshift(0x9e37_79b9_7f4a_7c15);
        for len in [1usize, 2, 3, 19, 1000, 20_001] {
            let v: Vec<f32> = (0..len)
                .map(|_| match rnd() % 4 {
                    0 => 0.0,
                    1 => -0.0,
                    2 => (rnd() % 7) as f32 * 1.5e-5,
                    _ => (rnd() % 1_000_000) as f32 * 1.7e-6,
                })
                .collect();
            let got = thickness_stats(&v);
            let mut sorted: Vec<f32> = v.iter().map(|x| x + 0.0).collect();
            sorted.sort_by(f32::total_cmp);
            let rank = |f: f64| ((len - 1) as f64 * f).round() as usize;
            assert_eq!(got.p50, f64::from(sorted[rank(0.5)]), "len {len}");
            assert_eq!(got.p95, f64::from(sorted[rank(0.95)]), "len {len}");
            assert_eq!(got.max, f64::from(sorted[len - 1]), "len {len}");
            let mean = sorted.iter().map(|&x| f64::from(x)).sum::<f64>() / len as f64;
            assert!((got.mean - mean).abs() <= 1e-12 * mean, "len {len}");
        }
    }
}
