//! A tree larger than the adapter's bindings: instead of refusing it, the GPU paths show the
//! deepest prefix of its levels whose arrays fit (the nodes of the last level drawn as leaves
//! with their inner-node attributes, [`svo::Octree::top_levels`]), and say so on one line. A
//! version-4 file too large is read only as deep as its header says may fit
//! ([`prefix_depth`]): the levels below are never read.

use crate::gpu_context::{GpuContext, GpuError};
use crate::gpu_render::{GpuLayout, adapter_capacity, arena_bytes};
use crate::gpu_types::ShaderVariant;
use crate::job::{JobError, RenderJob, prepare};
use std::fmt;
use svo::Octree;
use svo::io::LevelSizes;
use svo::render::{OctreeSurfaces, RenderScene, SetupError, Surfaces, TraceOptions};

/// What of a tree the GPU shows when the whole does not fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Prefix {
    /// The levels shown.
    pub depth: u8,
    /// The tree's levels.
    pub of: u8,
    /// The bytes the whole tree needs on the GPU.
    pub needed: u64,
    /// The most the adapter's bindings hold.
    pub limit: u64,
}

impl fmt::Display for Prefix {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "showing the top {} of {} levels: the whole tree needs {} bytes on the GPU, more than the adapter's {}",
            self.depth, self.of, self.needed, self.limit
        )
    }
}

/// Makes `scene`'s tree fit the adapter of `ctx` under `layout`: unchanged where it fits
/// (`None`), else the deepest prefix of its levels that does, with what was cut. The 64-ary
/// view's size is known only once built, so with `layout.wide_view` the tree is left as it
/// is (the upload refuses it if it does not fit).
pub fn fit_scene(
    ctx: &GpuContext,
    scene: &mut RenderScene,
    trace: &TraceOptions,
    layout: &GpuLayout,
) -> Result<Option<Prefix>, GpuError> {
    let lights = scene.lights.len();
    fit_tree(ctx, &mut scene.tree, lights, trace, layout)
}

/// [`fit_scene`] of a tree rendered with `lights` lights.
pub fn fit_tree(
    ctx: &GpuContext,
    tree: &mut Octree,
    lights: usize,
    trace: &TraceOptions,
    layout: &GpuLayout,
) -> Result<Option<Prefix>, GpuError> {
    let limit = adapter_capacity(ctx, layout);
    let needs = |t: &Octree| arena_bytes(t, &ShaderVariant::for_scene(t, trace, lights));
    let needed = needs(tree);
    let of = tree.depth;
    if needed <= limit || layout.wide_view || of <= 1 {
        return Ok(None);
    }
    // From the deepest prefix the level counts allow down, until one fits. The leaf parents
    // keep no values, so where the inner nodes carry attributes a prefix that ends on their
    // level would draw bare cubes: the level above is shown instead.
    let levels = OctreeSurfaces::new(tree, trace.mode).level_of_detail();
    let usable = |k: usize| !(levels && k + 1 == usize::from(of) && k > 1);
    let counts = level_counts(tree);
    let per_leaf =
        needed.saturating_sub(8 * tree.nodes.len() as u64) / u64::from(tree.leaf_count.max(1));
    let estimate = |k: usize| 8 * counts[..k].iter().sum::<u64>() + per_leaf * counts[k];
    let mut k = (1..usize::from(of))
        .rev()
        .find(|&k| usable(k) && estimate(k) <= limit)
        .unwrap_or(1);
    loop {
        if !usable(k) {
            k -= 1;
            continue;
        }
        let top = tree
            .top_levels(k as u8)
            .map_err(|e| GpuError::Unsupported(format!("cutting the tree to fit: {e}")))?;
        if needs(&top) <= limit || k == 1 {
            *tree = top;
            return Ok(Some(Prefix {
                depth: k as u8,
                of,
                needed,
                limit,
            }));
        }
        k -= 1;
    }
}

/// The deepest `k` whose top-`k`-levels tree of a version-4 file with these level sizes
/// should fit in `limit` bytes of arena, by the header alone (8 bytes a node, and its
/// per-node channels where a level of detail (`lod`) reads them; the level-`k` nodes as
/// leaves with their values),
/// with the estimate of the whole tree; `None` where the whole tree fits. The leaf parents'
/// level, which keeps no values, is skipped where the inner nodes have values, as
/// [`fit_scene`] skips it. An estimate only: [`fit_scene`] then measures the tree read.
pub fn prefix_depth(sizes: &LevelSizes, limit: u64, lod: bool) -> Option<(u8, u64)> {
    let c = &sizes.counts;
    let depth = c.len().checked_sub(1)?;
    let estimate = |k: usize| {
        let inner: u64 = c[..k].iter().sum();
        let per_leaf = if k == depth {
            sizes.leaf_bytes
        } else if k + 1 < depth {
            sizes.node_bytes
        } else {
            0
        };
        let per_node = if lod { sizes.node_bytes } else { 0 };
        (8 + per_node) * inner + per_leaf * c[k]
    };
    let whole = estimate(depth);
    if whole <= limit || depth <= 1 {
        return None;
    }
    let usable = |k: usize| !(sizes.node_bytes > 0 && k + 1 == depth && k > 1);
    let k = (1..depth)
        .rev()
        .find(|&k| usable(k) && estimate(k) <= limit)
        .unwrap_or(1);
    Some((k as u8, whole))
}

/// The level table of `job`'s file where it has one and the job reads the whole file (no
/// `max_depth`, no 64-ary view, whose size only its build tells): read before any adapter
/// is opened, so a file that cannot be read fails first.
pub fn level_sizes(job: &RenderJob, layout: &GpuLayout) -> Result<Option<LevelSizes>, JobError> {
    if job.max_depth.is_some() || layout.wide_view {
        return Ok(None);
    }
    svo::io::read_level_sizes(&job.input).map_err(|e| JobError::from(SetupError::from(e)))
}

/// Sets `job`'s scene up, reading a version-4 file whose level table says `sizes` only down to
/// the levels an arena of `limit` bytes may hold ([`prefix_depth`]), and what of the file
/// that leaves out.
pub fn open_fitting(
    job: &RenderJob,
    sizes: Option<LevelSizes>,
    limit: u64,
) -> Result<(RenderScene, Option<Prefix>), JobError> {
    let cut = sizes
        .as_ref()
        .and_then(|s| prefix_depth(s, limit, job.trace.lod > 0.0));
    let (Some((k, needed)), Some(sizes)) = (cut, sizes) else {
        return Ok((prepare(job)?, None));
    };
    let job = RenderJob {
        max_depth: Some(k),
        ..job.clone()
    };
    let prefix = Prefix {
        depth: k,
        of: (sizes.counts.len() - 1) as u8,
        needed,
        limit,
    };
    Ok((prepare(&job)?, Some(prefix)))
}

/// What [`fit_scene`] cut (`shown`) of a tree read as the prefix `read` of a file, said of
/// the file's levels.
pub fn said_of_file(shown: Option<Prefix>, read: Option<Prefix>) -> Option<Prefix> {
    match (shown, read) {
        (Some(p), Some(r)) => Some(Prefix {
            of: r.of,
            needed: r.needed,
            ..p
        }),
        (None, r) => r,
        (p, None) => p,
    }
}

/// The nodes on each level of `tree`, from the root (level 0) to the leaves (level `depth`).
fn level_counts(tree: &Octree) -> Vec<u64> {
    let mut counts = vec![0u64; usize::from(tree.depth) + 1];
    let mut level = vec![0u32];
    for count in counts.iter_mut().take(usize::from(tree.depth)) {
        *count = level.len() as u64;
        let mut next = Vec::new();
        for &i in &level {
            let Some(n) = tree.nodes.get(i as usize) else {
                continue;
            };
            if n.is_leaf_parent() {
                continue;
            }
            next.extend(n.first..n.first + n.child_mask().count_ones());
        }
        level = next;
    }
    counts[usize::from(tree.depth)] = u64::from(tree.leaf_count);
    counts
}
