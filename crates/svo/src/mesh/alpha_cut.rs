//! Alpha cut-outs (glTF `alphaMode: MASK`) turned into geometry: the parts of a material's
//! triangles whose texels fall under the cutoff are removed along texel edges, so the
//! voxelizer, the triangle reference and every later stage see the holes.
//!
//! A point of a triangle samples the texel its texture coordinate falls in (nearest, repeat
//! wrap, as [`Texture::sample_linear`]); its coverage is the material's colour alpha times
//! the texel's alpha, and it is kept where that reaches the cutoff. The kept surface is the
//! union of the closed pieces `triangle ∩ texel square` of positive area over kept texels:
//! a cell touching a kept piece, even only along the texel edge, is a leaf, and a triangle
//! part that meets a kept texel only along a line or at a point is dropped. A run of kept
//! texels along a row is cut as one piece, and so is the same run over a band of rows that
//! keep the same runs within the triangle's columns; each piece is a convex polygon, split
//! into a fan.
//!
//! A triangle whose texels are all kept stays as it is (same vertices and index), one whose
//! texels are all cut goes; only triangles over both are split, into new vertices whose
//! positions and texture coordinates are interpolated in `f64` from the triangle's.

use super::triangle_mesh::{Mesh, MeshError, Texture};
use glam::{DVec2, DVec3, Vec2};

/// The most triangles a cut may leave in the mesh.
const MAX_TRIANGLES: usize = 1 << 24;
/// The most texels the cut triangles' texel rectangles may hold together: the cut visits
/// no more rows and runs than that (texture coordinates that repeat a texture millions of
/// times would otherwise take hours).
const MAX_TEXELS: f64 = (1u64 << 30) as f64;

/// One material's kept texels: per texture row, runs `[start, end]` of kept columns.
struct Coverage {
    width: i64,
    height: i64,
    rows: Vec<Vec<(u32, u32)>>,
}

impl Coverage {
    /// The kept texels of `tex` (or of a one-texel white texture) under `alpha * texel alpha
    /// >= cutoff`.
    fn new(tex: Option<&Texture>, alpha: f32, cutoff: f32) -> Self {
        let kept = |a: u8| alpha * (f32::from(a) / 255.0) >= cutoff;
        let usable = tex.filter(|t| {
            t.width > 0 && t.height > 0 && t.rgba.len() >= t.width as usize * t.height as usize
        });
        let Some(t) = usable else {
            let rows = vec![if kept(255) { vec![(0, 0)] } else { Vec::new() }];
            return Self {
                width: 1,
                height: 1,
                rows,
            };
        };
        let w = t.width as usize;
        let rows = t
            .rgba
            .chunks_exact(w)
            .take(t.height as usize)
            .map(|row| {
                let mut runs: Vec<(u32, u32)> = Vec::new();
                for (x, texel) in row.iter().enumerate() {
                    if !kept(texel[3]) {
                        continue;
                    }
                    match runs.last_mut() {
                        Some(r) if r.1 as usize + 1 == x => r.1 = x as u32,
                        _ => runs.push((x as u32, x as u32)),
                    }
                }
                runs
            })
            .collect();
        Self {
            width: i64::from(t.width),
            height: i64::from(t.height),
            rows,
        }
    }

    /// The runs of kept texels of row `j` (wrapped) over the columns `a..=b` (unwrapped),
    /// clamped to them, in the unwrapped frame, runs that meet across the texture's edge
    /// joined, into `out`.
    fn kept_runs(&self, j: i64, a: i64, b: i64, out: &mut Vec<(i64, i64)>) {
        out.clear();
        let row = &self.rows[j.rem_euclid(self.height) as usize];
        if row.is_empty() {
            return;
        }
        let w = self.width;
        let mut base = a.div_euclid(w) * w;
        while base <= b {
            let (lo, hi) = ((a - base).max(0), (b - base).min(w - 1));
            let first = row.partition_point(|r| i64::from(r.1) < lo);
            for &(s, e) in &row[first..] {
                if i64::from(s) > hi {
                    break;
                }
                let (s, e) = (base + i64::from(s).max(lo), base + i64::from(e).min(hi));
                match out.last_mut() {
                    Some(last) if last.1 + 1 == s => last.1 = e,
                    _ => out.push((s, e)),
                }
            }
            base += w;
        }
    }
}

/// A polygon vertex: barycentric coordinates `b` (of the triangle's second and third
/// vertex) and the texture coordinate in texels `uv`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Vertex {
    b: DVec2,
    uv: DVec2,
}

/// Clips the convex polygon `poly` to `uv[axis] >= c` (`above`) or `<= c` into `out`. A
/// crossing point takes exactly `c` on the axis, and its other values are clamped between
/// the edge's ends, so rounding never moves it outside the edge.
fn clip(poly: &[Vertex], axis: usize, c: f64, above: bool, out: &mut Vec<Vertex>) {
    out.clear();
    let side = |v: &Vertex| {
        let d = v.uv[axis] - c;
        if above { d } else { -d }
    };
    for (i, p) in poly.iter().enumerate() {
        let q = &poly[(i + 1) % poly.len()];
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            out.push(*p);
        }
        if (sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0) {
            let t = (c - p.uv[axis]) / (q.uv[axis] - p.uv[axis]);
            let lerp = |x: f64, y: f64| (x + t * (y - x)).clamp(x.min(y), x.max(y));
            let mut v = Vertex {
                b: DVec2::new(lerp(p.b.x, q.b.x), lerp(p.b.y, q.b.y)),
                uv: DVec2::new(lerp(p.uv.x, q.uv.x), lerp(p.uv.y, q.uv.y)),
            };
            v.uv[axis] = c;
            out.push(v);
        }
    }
}

/// The texel columns (or rows) whose open interior meets a polygon over values `lo..=hi`
/// of that axis (one texel, `floor(lo)`, where the value is constant over the triangle).
fn texel_range(lo: f64, hi: f64, constant: bool) -> (i64, i64) {
    let a = lo.floor() as i64;
    if constant {
        (a, a)
    } else {
        (a, (hi.ceil() as i64 - 1).max(a))
    }
}

/// The texels a triangle's texture coordinates (in texels) span.
struct Rect {
    /// Whether `u`, and `v`, is the same at the three corners.
    constant: [bool; 2],
    /// The columns, and rows, whose open interior the triangle meets (`floor` of a constant).
    cols: (i64, i64),
    rows: (i64, i64),
}

impl Rect {
    fn new(uv: [DVec2; 3]) -> Self {
        let lo = uv[0].min(uv[1]).min(uv[2]);
        let hi = uv[0].max(uv[1]).max(uv[2]);
        let constant = [lo.x == hi.x, lo.y == hi.y];
        Self {
            constant,
            cols: texel_range(lo.x, hi.x, constant[0]),
            rows: texel_range(lo.y, hi.y, constant[1]),
        }
    }

    /// How many texels the rectangle holds.
    fn texels(&self) -> f64 {
        let n = |(a, b): (i64, i64)| (b as f64 - a as f64) + 1.0;
        n(self.cols) * n(self.rows)
    }
}

/// What becomes of one triangle.
enum Fate {
    Keep,
    Drop,
    /// Pieces: convex polygons, each a run of the vertices in `Cutter::pieces`.
    Split,
}

/// The cut of triangles, reusing its buffers.
#[derive(Default)]
struct Cutter {
    strip: Vec<Vertex>,
    tmp: Vec<Vertex>,
    piece: Vec<Vertex>,
    runs: Vec<(i64, i64)>,
    next_runs: Vec<(i64, i64)>,
    /// The pieces' vertices, and where each piece ends.
    pieces: Vec<Vertex>,
    ends: Vec<usize>,
}

impl Cutter {
    /// Cuts the triangle with texture coordinates `uv` (in texels of `cover`, any range).
    fn cut(&mut self, cover: &Coverage, uv: [DVec2; 3]) -> Fate {
        self.pieces.clear();
        self.ends.clear();
        let Rect {
            constant,
            cols: (a, b),
            rows: (ja, jb),
        } = Rect::new(uv);
        // Every row of the triangle's texels wholly kept, or every one wholly cut: no split.
        let (mut all_kept, mut none_kept) = (true, true);
        for j in ja..=jb {
            cover.kept_runs(j, a, b, &mut self.runs);
            all_kept &= self.runs == [(a, b)];
            none_kept &= self.runs.is_empty();
            if !all_kept && !none_kept {
                break;
            }
        }
        if all_kept {
            return Fate::Keep;
        }
        if none_kept {
            return Fate::Drop;
        }
        let tri = [
            Vertex {
                b: DVec2::ZERO,
                uv: uv[0],
            },
            Vertex {
                b: DVec2::X,
                uv: uv[1],
            },
            Vertex {
                b: DVec2::Y,
                uv: uv[2],
            },
        ];
        // Bands of rows whose kept runs over the triangle's columns are the same: one
        // piece per run and band.
        let mut runs = std::mem::take(&mut self.runs);
        let mut next = std::mem::take(&mut self.next_runs);
        cover.kept_runs(ja, a, b, &mut runs);
        let mut j = ja;
        while j <= jb {
            let mut last = j;
            while last < jb {
                cover.kept_runs(last + 1, a, b, &mut next);
                if next != runs {
                    break;
                }
                last += 1;
            }
            if !runs.is_empty() {
                self.cut_band(&tri, (j, last), (ja, jb), &runs, constant[0]);
            }
            std::mem::swap(&mut runs, &mut next);
            j = last + 1;
        }
        (self.runs, self.next_runs) = (runs, next);
        if self.ends.is_empty() {
            Fate::Drop
        } else {
            Fate::Split
        }
    }

    /// Adds the pieces of triangle `tri` in the closed band of rows `rows.0 <= v <=
    /// rows.1 + 1` (of the triangle's rows `span`) over the kept column runs `runs`.
    fn cut_band(
        &mut self,
        tri: &[Vertex; 3],
        rows: (i64, i64),
        span: (i64, i64),
        runs: &[(i64, i64)],
        u_constant: bool,
    ) {
        self.strip.clear();
        self.strip.extend_from_slice(tri);
        if rows.0 > span.0 {
            clip(&self.strip, 1, rows.0 as f64, true, &mut self.tmp);
            std::mem::swap(&mut self.strip, &mut self.tmp);
        }
        if rows.1 < span.1 {
            clip(&self.strip, 1, (rows.1 + 1) as f64, false, &mut self.tmp);
            std::mem::swap(&mut self.strip, &mut self.tmp);
        }
        if self.strip.len() < 3 {
            return;
        }
        let (u_lo, u_hi) = self
            .strip
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v.uv.x), h.max(v.uv.x))
            });
        let (sa, sb) = texel_range(u_lo, u_hi, u_constant);
        for &(s, e) in runs {
            let (s, e) = (s.max(sa), e.min(sb));
            if s > e {
                continue;
            }
            self.piece.clear();
            self.piece.extend_from_slice(&self.strip);
            if !u_constant && s > sa {
                clip(&self.piece, 0, s as f64, true, &mut self.tmp);
                std::mem::swap(&mut self.piece, &mut self.tmp);
            }
            if !u_constant && e < sb {
                clip(&self.piece, 0, (e + 1) as f64, false, &mut self.tmp);
                std::mem::swap(&mut self.piece, &mut self.tmp);
            }
            self.piece.dedup();
            if self.piece.len() > 1 && self.piece.first() == self.piece.last() {
                self.piece.pop();
            }
            if self.piece.len() >= 3 {
                self.pieces.extend_from_slice(&self.piece);
                self.ends.push(self.pieces.len());
            }
        }
    }
}

impl Mesh {
    /// Cuts alpha-masked materials' triangles along their textures' texel edges, keeping
    /// the parts whose coverage (the material's colour alpha times the texel's alpha,
    /// sampled nearest with repeat wrap) reaches the cutoff: `masks` holds `(material,
    /// cutoff)` pairs (glTF's `alphaMode: MASK` and `alphaCutoff`, which the glTF importer
    /// applies). Triangles wholly kept stay as they are; those wholly cut are removed; the
    /// others are replaced by convex pieces (fans of new vertices), each the triangle's part
    /// over a run of kept texels in one texture row. A point on an edge between a kept and
    /// a cut texel belongs to the kept piece; a part meeting kept texels only along a line
    /// or at a point is dropped. The mesh must be valid ([`Mesh::validate`]).
    ///
    /// Errors, leaving the mesh as it was, when the masked triangles' texture coordinates
    /// span more than 2^30 texels together (a texture repeated millions of times) or the cut
    /// would leave more than 2^24 triangles.
    pub fn cut_alpha_masks(&mut self, masks: &[(u32, f32)]) -> Result<(), MeshError> {
        let nm = self.materials.len().max(1);
        let covers: Vec<Option<Coverage>> = (0..nm)
            .map(|m| {
                let cutoff = masks.iter().rev().find(|(i, _)| *i as usize == m)?.1;
                let mat = self.materials.get(m)?;
                let tex = mat.texture.and_then(|t| self.textures.get(t));
                let tex = tex.filter(|_| !self.triangle_uvs.is_empty());
                Some(Coverage::new(tex, mat.colour[3], cutoff))
            })
            .collect();
        if covers.iter().all(Option::is_none) {
            return Ok(());
        }
        // Each masked triangle's texture coordinates in texels, shifted by whole periods
        // (the texels repeat) so they are small, and the shift.
        let texels = |t: usize| -> Option<(&Coverage, [DVec2; 3], DVec2)> {
            let m = self.triangle_materials.get(t).copied().unwrap_or(0) as usize;
            let cover = covers.get(m)?.as_ref()?;
            let uvi = self.triangle_uvs.get(t).copied().unwrap_or([0; 3]);
            let uv = uvi.map(|i| {
                let p = self.uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO);
                if p.is_finite() {
                    p.as_dvec2()
                } else {
                    DVec2::ZERO
                }
            });
            let shift = uv[0].min(uv[1]).min(uv[2]).floor();
            let size = DVec2::new(cover.width as f64, cover.height as f64);
            Some((cover, uv.map(|p| (p - shift) * size), shift))
        };
        let spanned: f64 = (0..self.triangles.len())
            .filter_map(|t| texels(t).map(|(_, uv, _)| Rect::new(uv).texels()))
            .sum();
        if !(spanned <= MAX_TEXELS) {
            return Err(MeshError::AlphaCut(format!(
                "the masked triangles' texture coordinates span {spanned:.3e} texels, more \
                 than {MAX_TEXELS:.3e}"
            )));
        }
        let mut out = Out::default();
        let mut cutter = Cutter::default();
        for (t, tri) in self.triangles.iter().enumerate() {
            let Some((cover, uv, shift)) = texels(t) else {
                out.push(t, *tri, None)?;
                continue;
            };
            match cutter.cut(cover, uv) {
                Fate::Keep => out.push(t, *tri, None)?,
                Fate::Drop => {}
                Fate::Split => {
                    let p = tri.map(|i| self.positions[i as usize]);
                    let size = DVec2::new(cover.width as f64, cover.height as f64);
                    let mut start = 0;
                    for &end in &cutter.ends {
                        let poly = &cutter.pieces[start..end];
                        out.push_piece(self, t, poly, p, size, shift)?;
                        start = end;
                    }
                }
            }
        }
        out.commit(self);
        Ok(())
    }
}

/// The cut mesh's triangles as they are made: indices into the mesh's vertices and
/// texture coordinates followed by the new ones, and each one's source triangle.
#[derive(Default)]
struct Out {
    triangles: Vec<[u32; 3]>,
    uv_triangles: Vec<[u32; 3]>,
    sources: Vec<u32>,
    positions: Vec<DVec3>,
    uvs: Vec<Vec2>,
}

impl Out {
    /// Adds a triangle made from source triangle `t`, with new texture-coordinate indices
    /// or (`None`) the source's.
    fn push(&mut self, t: usize, tri: [u32; 3], uv: Option<[u32; 3]>) -> Result<(), MeshError> {
        if self.triangles.len() >= MAX_TRIANGLES {
            return Err(MeshError::AlphaCut(format!(
                "the cut would leave more than {MAX_TRIANGLES} triangles"
            )));
        }
        self.triangles.push(tri);
        self.uv_triangles.push(uv.unwrap_or([u32::MAX; 3]));
        self.sources.push(t as u32);
        Ok(())
    }

    /// Adds the convex polygon `poly` of source triangle `t` (corners `p`) as a fan of new
    /// vertices; `size` and `shift` turn its texel coordinates back into texture ones.
    fn push_piece(
        &mut self,
        mesh: &Mesh,
        t: usize,
        poly: &[Vertex],
        p: [DVec3; 3],
        size: DVec2,
        shift: DVec2,
    ) -> Result<(), MeshError> {
        let v0 = (mesh.positions.len() + self.positions.len()) as u32;
        let uv0 = (mesh.uvs.len() + self.uvs.len()) as u32;
        for v in poly {
            let a = 1.0 - v.b.x - v.b.y;
            self.positions.push(p[0] * a + p[1] * v.b.x + p[2] * v.b.y);
            self.uvs.push((v.uv / size + shift).as_vec2());
        }
        for k in 1..poly.len() as u32 - 1 {
            self.push(
                t,
                [v0, v0 + k, v0 + k + 1],
                Some([uv0, uv0 + k, uv0 + k + 1]),
            )?;
        }
        Ok(())
    }

    /// Replaces the mesh's triangles by the cut ones.
    fn commit(self, mesh: &mut Mesh) {
        let has_uvs = !mesh.triangle_uvs.is_empty();
        if has_uvs {
            mesh.triangle_uvs = self
                .uv_triangles
                .iter()
                .zip(&self.sources)
                .map(|(&uv, &t)| {
                    if uv[0] == u32::MAX {
                        mesh.triangle_uvs[t as usize]
                    } else {
                        uv
                    }
                })
                .collect();
            mesh.uvs.extend(self.uvs);
        }
        if !mesh.triangle_materials.is_empty() {
            mesh.triangle_materials = self
                .sources
                .iter()
                .map(|&t| mesh.triangle_materials[t as usize])
                .collect();
        }
        mesh.positions.extend(self.positions);
        mesh.triangles = self.triangles;
    }
}
