//! Per-leaf attributes and contours from the triangles that touch each leaf.
//!
//! Every triangle in a leaf is clipped to the cell ([`crate::clip`]); its clipped area is its
//! weight. The leaf's normal is the area-weighted mean of the triangles' unit normals; colour
//! (material colour times texture, sampled at the clipped polygon's centre, averaged in linear
//! space), reflectivity, refractivity and IOR are area-weighted means too. Where all contacts
//! have zero area (a triangle only touching the cell, or degenerate triangles) every triangle
//! weighs the same. The contour is then fitted to the clipped polygons against the *encoded*
//! normal ([`crate::contour`]).
//!
//! Leaves are processed in parallel in fixed-size blocks and concatenated in order, so the
//! output does not depend on the thread count. Within a block the attribute and contour steps
//! are timed separately, which is how the bake summary reports them.

use crate::clip::clip_to_unit_cube;
use crate::contour;
use crate::mesh::{Material, Mesh, linear_to_srgb};
use crate::normal_encoding;
use crate::octree::{Channel, ChannelKind, LeafAttributes, ior_encode};
use crate::octree_build::LeafTriangles;
use crate::triangle_setup::GridTriangle;
use glam::{DVec3, Vec2, Vec3};
use std::time::{Duration, Instant};

/// Leaves per block of the parallel pass.
const BLOCK: usize = 2048;

/// A leaf touched by a single triangle at most this many cells across skips clipping: the
/// triangle's own vertices bound the contour. Its planes then sit at most the normal's
/// quantization error (under 6.5e-5 rad) times the triangle's extent, under 0.01 cells,
/// beyond the clipped fit.
const SINGLE_TRIANGLE_MAX_EXTENT: f64 = 64.0;

/// Which channels to compute.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelSelection {
    bits: u8,
}

impl ChannelSelection {
    /// Every channel.
    pub const ALL: Self = Self { bits: 0b11_1111 };
    /// No channel: the tree alone.
    pub const NONE: Self = Self { bits: 0 };

    fn bit(k: ChannelKind) -> u8 {
        1 << ChannelKind::ALL.iter().position(|&c| c == k).unwrap_or(0)
    }

    /// Whether `k` is selected.
    pub fn has(self, k: ChannelKind) -> bool {
        self.bits & Self::bit(k) != 0
    }

    /// With `k` added.
    pub fn with(self, k: ChannelKind) -> Self {
        Self {
            bits: self.bits | Self::bit(k),
        }
    }

    /// With `k` removed.
    pub fn without(self, k: ChannelKind) -> Self {
        Self {
            bits: self.bits & !Self::bit(k),
        }
    }

    /// Parses a comma-separated list of channel names (`all` and `none` too).
    pub fn parse(s: &str) -> Result<Self, String> {
        let mut sel = Self::NONE;
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            match name {
                "all" => sel = Self::ALL,
                "none" => {}
                _ => {
                    let k = ChannelKind::parse(name).ok_or_else(|| {
                        let names: Vec<_> = ChannelKind::ALL.iter().map(|k| k.name()).collect();
                        format!(
                            "unknown channel {name:?} (expected: {}, all, none)",
                            names.join(", ")
                        )
                    })?;
                    sel = sel.with(k);
                }
            }
        }
        Ok(sel)
    }
}

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

/// What the attribute pass returns besides the channels.
#[derive(Clone, Copy, Debug, Default)]
pub struct AttributeReport {
    /// Time spent computing attributes (including clipping), apportioned to wall time.
    pub attributes: Duration,
    /// Time spent fitting contours, apportioned to wall time.
    pub contours: Duration,
    /// Contour thickness statistics, when contours were made.
    pub contour_stats: Option<ContourStats>,
}

#[derive(Default)]
struct Block {
    normal: Vec<u32>,
    contour: Vec<u32>,
    colour: Vec<u32>,
    reflectivity: Vec<u8>,
    refractivity: Vec<u8>,
    ior: Vec<u16>,
    thickness: Vec<f32>,
    t_attr: Duration,
    t_contour: Duration,
}

/// Computes the selected channels for the voxelizer's leaves. `tris` are the grid-space
/// triangles the leaves' lists index, and `order[k]` the mesh triangle of `tris[k]`.
pub fn compute(
    mesh: &Mesh,
    tris: &[GridTriangle],
    order: &[u32],
    leaves: &LeafTriangles,
    select: ChannelSelection,
) -> (LeafAttributes, AttributeReport) {
    let wall = Instant::now();
    let n_leaves = leaves.cells.len();
    let want_contour = select.has(ChannelKind::Contour);
    let want_normal = select.has(ChannelKind::Normal) || want_contour;

    // Which material channels vary over the triangles (the others are constants).
    let mats: Vec<&Material> = if mesh.materials.is_empty() {
        vec![mesh.material_of(0)]
    } else {
        mesh.materials.iter().collect()
    };
    let textured = mats.iter().any(|m| m.texture.is_some()) && !mesh.triangle_uvs.is_empty();
    let varies = |f: &dyn Fn(&Material) -> u32| mats.iter().any(|m| f(m) != f(mats[0]));
    let colour_key = |m: &Material| encode_colour(m.colour);
    let per_leaf_colour = select.has(ChannelKind::Colour) && (textured || varies(&colour_key));
    let per_leaf_refl =
        select.has(ChannelKind::Reflectivity) && varies(&|m| u32::from(unorm8(m.reflectivity)));
    let per_leaf_refr =
        select.has(ChannelKind::Refractivity) && varies(&|m| u32::from(unorm8(m.refractivity)));
    let per_leaf_ior = select.has(ChannelKind::Ior) && varies(&|m| u32::from(ior_encode(m.ior)));
    let need_clip =
        want_normal || per_leaf_colour || per_leaf_refl || per_leaf_refr || per_leaf_ior;

    // Unit normals of the grid-space triangles (zero for degenerate ones); material values
    // are read through `material`, the mesh triangle's material.
    let normals: Vec<DVec3> = if need_clip {
        tris.iter()
            .map(|t| {
                let len = t.n.length();
                if len > 0.0 && len.is_finite() {
                    t.n / len
                } else {
                    DVec3::ZERO
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    let material = |ti: u32| mesh.material_of(order[ti as usize] as usize);

    let do_block = |b: usize| -> Block {
        let start = b * BLOCK;
        let end = (start + BLOCK).min(n_leaves);
        let mut out = Block::default();
        if !need_clip {
            return out;
        }
        let t0 = Instant::now();
        // Clipped polygons of the block: points flat, one area and point range per polygon.
        let mut pts: Vec<DVec3> = Vec::new();
        let mut poly_end: Vec<usize> = Vec::new();
        let mut areas: Vec<f64> = Vec::new();
        let mut leaf_poly_end: Vec<usize> = Vec::with_capacity(end - start);
        let mut normals_f: Vec<Vec3> = Vec::with_capacity(end - start);
        for leaf in start..end {
            let cell = leaves.cells[leaf];
            let m = DVec3::new(f64::from(cell[0]), f64::from(cell[1]), f64::from(cell[2]));
            let list = leaves.triangles(leaf);
            let first_poly = areas.len();
            let mut wsum = 0.0;
            let single = list.len() == 1 && !textured && {
                let t = &tris[list[0] as usize];
                (t.hi - t.lo).max_element() <= SINGLE_TRIANGLE_MAX_EXTENT
            };
            if single {
                // One small triangle: its normal and material are the leaf's whatever the
                // weight, and its vertices bound its clipped part, so no clipping is needed
                // (the contour is conservative; see SINGLE_TRIANGLE_MAX_EXTENT).
                let t = &tris[list[0] as usize];
                pts.extend(t.v.iter().map(|&v| v - m));
                poly_end.push(pts.len());
                areas.push(1.0);
                wsum = 1.0;
            }
            for &ti in list.iter().filter(|_| !single) {
                let t = &tris[ti as usize];
                let mut p = clip_to_unit_cube([t.v[0] - m, t.v[1] - m, t.v[2] - m]);
                if p.len == 0 {
                    // Touching only, and rounding lost the contact: keep the vertices pulled
                    // onto the cell so the contour still covers the contact.
                    p.len = 3;
                    for k in 0..3 {
                        p.v[k] = (t.v[k] - m).clamp(DVec3::ZERO, DVec3::ONE);
                    }
                }
                let area = p.area();
                wsum += area;
                pts.extend_from_slice(p.points());
                poly_end.push(pts.len());
                areas.push(area);
            }
            let leaf_areas = &areas[first_poly..];
            let weight = |k: usize| if wsum > 0.0 { leaf_areas[k] } else { 1.0 };
            if want_normal {
                let mut s = DVec3::ZERO;
                for (k, &ti) in list.iter().enumerate() {
                    s += normals[ti as usize] * weight(k);
                }
                if !(s.length() > 1e-12 * wsum.max(1e-300)) {
                    // Opposite sheets cancel: take the heaviest triangle's normal.
                    s = list
                        .iter()
                        .zip(leaf_areas)
                        .map(|(&ti, &a)| (normals[ti as usize], a))
                        .filter(|(n, _)| *n != DVec3::ZERO)
                        .max_by(|a, b| a.1.total_cmp(&b.1))
                        .map_or(DVec3::Z, |(n, _)| n);
                }
                let enc = normal_encoding::encode(s.as_vec3());
                out.normal.push(enc);
                normals_f.push(normal_encoding::decode(enc));
            }
            if per_leaf_colour {
                let mut c = [0.0f64; 4];
                let mut ws = 0.0;
                for (k, &ti) in list.iter().enumerate() {
                    let w = weight(k);
                    let pi = first_poly + k;
                    let p0 = if pi == 0 { 0 } else { poly_end[pi - 1] };
                    let centre =
                        pts[p0..poly_end[pi]].iter().sum::<DVec3>() / (poly_end[pi] - p0) as f64;
                    let col = triangle_colour(
                        mesh,
                        order[ti as usize] as usize,
                        &tris[ti as usize],
                        centre + m,
                    );
                    for (acc, v) in c.iter_mut().zip(col) {
                        *acc += w * f64::from(v);
                    }
                    ws += w;
                }
                let ws = if ws > 0.0 { ws } else { 1.0 };
                out.colour.push(encode_colour(c.map(|v| (v / ws) as f32)));
            }
            let avg = |f: &dyn Fn(&Material) -> f32| -> f32 {
                let mut a = 0.0f64;
                let mut ws = 0.0;
                for (k, &ti) in list.iter().enumerate() {
                    let w = weight(k);
                    a += w * f64::from(f(material(ti)));
                    ws += w;
                }
                if ws > 0.0 { (a / ws) as f32 } else { 0.0 }
            };
            if per_leaf_refl {
                out.reflectivity.push(unorm8(avg(&|i| i.reflectivity)));
            }
            if per_leaf_refr {
                out.refractivity.push(unorm8(avg(&|i| i.refractivity)));
            }
            if per_leaf_ior {
                out.ior.push(ior_encode(avg(&|i| i.ior)));
            }
            leaf_poly_end.push(pts.len());
        }
        let t1 = Instant::now();
        out.t_attr = t1 - t0;
        if want_contour {
            let mut begin = 0;
            for (k, &end_p) in leaf_poly_end.iter().enumerate() {
                let c = contour::fit(&pts[begin..end_p], normals_f[k]);
                begin = end_p;
                out.thickness.push(contour::thickness(c, normals_f[k]));
                out.contour.push(c);
            }
            out.t_contour = t1.elapsed();
        }
        out
    };

    let n_blocks = n_leaves.div_ceil(BLOCK);
    #[cfg(feature = "parallel")]
    let blocks: Vec<Block> = {
        use rayon::prelude::*;
        (0..n_blocks).into_par_iter().map(do_block).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let blocks: Vec<Block> = (0..n_blocks).map(do_block).collect();

    let mut attrs = LeafAttributes::default();
    let mut cat = Block::default();
    for b in blocks {
        cat.normal.extend(b.normal);
        cat.contour.extend(b.contour);
        cat.colour.extend(b.colour);
        cat.reflectivity.extend(b.reflectivity);
        cat.refractivity.extend(b.refractivity);
        cat.ior.extend(b.ior);
        cat.thickness.extend(b.thickness);
        cat.t_attr += b.t_attr;
        cat.t_contour += b.t_contour;
    }
    let m0 = mats[0];
    if select.has(ChannelKind::Normal) {
        attrs.normal = Channel::PerLeaf(cat.normal);
    }
    if want_contour {
        attrs.contour = Channel::PerLeaf(cat.contour);
    }
    if select.has(ChannelKind::Colour) {
        attrs.colour = if per_leaf_colour {
            Channel::PerLeaf(cat.colour)
        } else {
            Channel::Constant(encode_colour(m0.colour))
        };
    }
    if select.has(ChannelKind::Reflectivity) {
        attrs.reflectivity = if per_leaf_refl {
            Channel::PerLeaf(cat.reflectivity)
        } else {
            Channel::Constant(unorm8(m0.reflectivity))
        };
    }
    if select.has(ChannelKind::Refractivity) {
        attrs.refractivity = if per_leaf_refr {
            Channel::PerLeaf(cat.refractivity)
        } else {
            Channel::Constant(unorm8(m0.refractivity))
        };
    }
    if select.has(ChannelKind::Ior) {
        attrs.ior = if per_leaf_ior {
            Channel::PerLeaf(cat.ior)
        } else {
            Channel::Constant(ior_encode(m0.ior))
        };
    }
    if n_leaves > 0 {
        attrs.compact();
    }

    // Apportion the wall time of the pass by the measured thread time of each step.
    let wall = wall.elapsed();
    let busy = (cat.t_attr + cat.t_contour).as_secs_f64();
    let share = if busy > 0.0 {
        cat.t_contour.as_secs_f64() / busy
    } else {
        0.0
    };
    let contours = wall.mul_f64(share);
    let contour_stats = want_contour.then(|| thickness_stats(&mut cat.thickness));
    (
        attrs,
        AttributeReport {
            attributes: wall - contours,
            contours,
            contour_stats,
        },
    )
}

fn thickness_stats(v: &mut [f32]) -> ContourStats {
    if v.is_empty() {
        return ContourStats::default();
    }
    let mean = v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64;
    let max = v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let mut q = |f: f64| {
        let k = ((v.len() - 1) as f64 * f).round() as usize;
        f64::from(*v.select_nth_unstable_by(k, f32::total_cmp).1)
    };
    ContourStats {
        mean,
        p50: q(0.5),
        p95: q(0.95),
        max: f64::from(max),
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

/// Linear RGBA to the stored RGBA8 sRGB word.
pub fn encode_colour(c: [f32; 4]) -> u32 {
    u32::from_le_bytes([
        linear_to_srgb(c[0]),
        linear_to_srgb(c[1]),
        linear_to_srgb(c[2]),
        unorm8(c[3]),
    ])
}

/// `[0, 1]` to unorm8.
pub fn unorm8(v: f32) -> u8 {
    if v.is_finite() {
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    } else {
        0
    }
}
