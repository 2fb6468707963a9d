//! A tree held as chunks ([`ChunkedSurfaces`]): the subtrees under one level, each an
//! [`Octree`] of its own, as a version-3 file stores a tree past what one tree in memory holds
//! (`svo::io::ChunkedFile`). A ray walks the chunks' cells at that level front to back (the
//! traversal over a tree of one leaf a chunk) and each chunk it enters with the ray moved into
//! the chunk's grid, so the tracer renders the chunks as one tree.

use crate::geometry::grid::RootCube;
use crate::octree::builder::Voxel;
use crate::octree::tree::Octree;
use crate::render::surfaces::{OctreeSurfaces, Query, Skip, SurfaceHit, Surfaces, Traced, Walked};
use crate::render::surfaces_error::SurfacesError;
use crate::trace::cone::Cone;
use crate::trace::grid_ray::GridRay;
use crate::trace::leaf_hit::HitMode;
use crate::trace::traverse::traverse;
use glam::{UVec3, Vec3};

/// One chunk: the cell of its root at the chunk level, the whole tree's index of its first
/// leaf, and its subtree as a tree of its own (its root cube that cell).
#[derive(Clone, Debug)]
pub struct ChunkTree {
    /// The cell of the chunk's root, at the chunk level.
    pub cell: UVec3,
    /// The whole tree's index of the chunk's first leaf.
    pub first_leaf: u64,
    /// The chunk's subtree.
    pub tree: Octree,
}

struct Chunk<'a> {
    /// The chunk's minimum corner in the whole tree's grid (cells).
    shift: Vec3,
    /// The same corner as a cell.
    corner: UVec3,
    first_leaf: u32,
    leaves: u32,
    s: OctreeSurfaces<'a>,
}

/// The surfaces of a tree in chunks, hit in one of the [`HitMode`]s: hits are numbered by
/// the whole tree's leaf index.
pub struct ChunkedSurfaces<'a> {
    root: RootCube,
    depth: u8,
    /// Grid units of the chunk level's cells per cell of the whole grid (a power of two).
    to_top: f32,
    /// A tree of one leaf a chunk, at the chunk level (none for level 0: one chunk).
    top: Option<Octree>,
    chunks: Vec<Chunk<'a>>,
}

impl<'a> ChunkedSurfaces<'a> {
    /// The tree over `root` at `depth` whose subtrees under the nodes at `level` are `chunks`
    /// (in increasing Morton code of their cells, each of depth `depth - level`). Refuses
    /// chunks that do not fit those, and a tree of 2^32 leaves or more (hits are numbered by
    /// 32-bit leaf indices).
    pub fn new(
        root: RootCube,
        depth: u8,
        level: u8,
        chunks: &'a [ChunkTree],
        mode: HitMode,
    ) -> Result<Self, SurfacesError> {
        let leaves: u64 = chunks.iter().map(|c| u64::from(c.tree.leaf_count)).sum();
        if leaves > u64::from(u32::MAX) {
            return Err(SurfacesError::TooManyLeaves(leaves));
        }
        if level >= depth || (level == 0 && chunks.len() > 1) {
            return Err(SurfacesError::Level { level, depth });
        }
        let below = u32::from(depth - level);
        let side = f64::from(1u32 << below);
        let mut out = Vec::with_capacity(chunks.len());
        let mut next = 0u64;
        for c in chunks {
            let corner = c.cell.as_dvec3() * side;
            if c.tree.depth != depth - level
                || c.first_leaf != next
                || c.cell.max_element() >= 1 << level
            {
                return Err(SurfacesError::Misfit {
                    cell: c.cell,
                    depth,
                    level,
                });
            }
            next += u64::from(c.tree.leaf_count);
            out.push(Chunk {
                shift: corner.as_vec3(),
                corner: c.cell << below,
                first_leaf: c.first_leaf as u32,
                leaves: c.tree.leaf_count,
                s: OctreeSurfaces::new(&c.tree, mode),
            });
        }
        let top = (level > 0)
            .then(|| {
                Octree::from_cells(
                    root,
                    level,
                    chunks.iter().map(|c| (c.cell, Voxel::default())),
                )
            })
            .transpose()?;
        if top
            .as_ref()
            .is_some_and(|t| t.leaf_count as usize != chunks.len())
        {
            return Err(SurfacesError::SharedCell);
        }
        Ok(Self {
            root,
            depth,
            to_top: 1.0 / side as f32,
            top,
            chunks: out,
        })
    }

    /// Calls `f(chunk, ray in its grid)` for the chunks along `ray` within `[tmin, tmax]`,
    /// front to back, until it returns `Some`; returns that and the steps among the chunks.
    fn along<T>(
        &self,
        ray: &GridRay,
        tmin: f32,
        tmax: f32,
        max_steps: u32,
        mut f: impl FnMut(&Chunk<'a>, &GridRay) -> Option<T>,
    ) -> (Option<T>, u32, bool) {
        let moved = |c: &Chunk<'a>| GridRay {
            origin: ray.origin - c.shift,
            dir: ray.dir,
        };
        let Some(top) = &self.top else {
            return (self.chunks.first().and_then(|c| f(c, &moved(c))), 0, false);
        };
        // The same parameters in the chunk level's grid: both scaled by a power of two.
        let top_ray = GridRay {
            origin: ray.origin * self.to_top,
            dir: ray.dir * self.to_top,
        };
        let t = traverse(top, &top_ray, tmin, tmax, max_steps, |e| {
            let c = &self.chunks[e.leaf as usize];
            f(c, &moved(c))
        });
        (t.hit, t.steps, t.capped)
    }
}

/// A chunk's hit numbered as the whole tree's leaf, in the whole tree's cells.
fn whole(c: &Chunk<'_>, h: &SurfaceHit) -> SurfaceHit {
    SurfaceHit {
        id: h.id + c.first_leaf,
        cell: h.cell + c.corner,
        ..*h
    }
}

/// The whole tree's leaf `skip` as chunk `c`'s, if it is one of its leaves.
fn local(c: &Chunk<'_>, skip: Option<Skip>) -> Option<Skip> {
    let s = skip?;
    let id = s.id.checked_sub(c.first_leaf).filter(|&l| l < c.leaves)?;
    Some(Skip {
        id,
        cell: s.cell.checked_sub(c.corner)?,
    })
}

impl Surfaces for ChunkedSurfaces<'_> {
    fn grid(&self) -> (RootCube, u8) {
        (self.root, self.depth)
    }

    fn closest(&self, ray: &GridRay, q: &Query) -> Traced {
        let (mut steps, mut capped) = (0u32, false);
        let (hit, top_steps, top_capped) = self.along(ray, q.tmin, q.tmax, q.max_steps, |c, r| {
            let local_q = Query {
                skip: local(c, q.skip),
                max_steps: q.max_steps.saturating_sub(steps),
                ..*q
            };
            let t = c.s.closest(r, &local_q);
            steps += t.steps;
            capped |= t.capped;
            t.hit.map(|h| whole(c, &h))
        });
        Traced {
            hit,
            steps: steps + top_steps,
            capped: capped || top_capped,
        }
    }

    fn walk(
        &self,
        ray: &GridRay,
        tmax: f32,
        skip: Option<Skip>,
        cone: Cone,
        max_steps: u32,
        visit: &mut dyn FnMut(&SurfaceHit) -> bool,
    ) -> Walked {
        let (mut steps, mut capped) = (0u32, false);
        let (blocked, top_steps, top_capped) = self.along(ray, 0.0, tmax, max_steps, |c, r| {
            let w = c.s.walk(
                r,
                tmax,
                local(c, skip),
                cone,
                max_steps.saturating_sub(steps),
                &mut |h| visit(&whole(c, h)),
            );
            steps += w.steps;
            capped |= w.capped;
            w.blocked.then_some(())
        });
        Walked {
            blocked: blocked.is_some(),
            steps: steps + top_steps,
            capped: capped || top_capped,
        }
    }
}
