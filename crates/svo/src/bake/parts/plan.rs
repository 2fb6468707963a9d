//! A bake split into parts: which subtrees each part bakes, and the plan file that every
//! part and the merge read.
//!
//! The tree is cut at a level `T` of the octree (the parts' level): its `8^T` nodes, in Morton
//! order (the order of their leaves in the file), are dealt into contiguous ranges, one a part,
//! of about equal estimated leaves. A part bakes the subtrees of its range exactly as the whole
//! bake would ([`crate::voxelize::build::voxelize_subtrees`]); the merge
//! ([`crate::bake::parts::merge`]) joins them under the top levels. `T` is at most `depth - 5`: above
//! it every node of the whole bake is split the same way whatever part it falls in, which is
//! what makes the merged file byte for byte the whole bake's.
//!
//! The plan file (`.svoplan`) holds what makes the parts agree: the mesh's path and the hash
//! of its bytes, the bake options, the root cube, the level and the ranges, and what the
//! merged file's header says of its source. Its own hash names it in every part file, so a
//! part of another plan is refused.

use crate::bake::bake_mesh::{BakeError, BakeOptions, prepare};
use crate::bake::estimate::triangle_cells_bound;
use crate::bake::parts::merge::{MergeFormat, dag_values};
use crate::dag::DagValues;
use crate::geometry::grid::RootCube;
use crate::io::atomic_write::write_atomic;
use crate::io::header::BuildInfo;
use crate::mesh::triangle_mesh::Mesh;
use crate::octree::tree::ChannelKind;
use crate::voxelize::build::deepest_part_level;
use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The first bytes of a plan file.
const PLAN_MAGIC: [u8; 8] = *b"\x89SVOPLN\n";
/// The plan file's version.
const PLAN_VERSION: u32 = 4;
/// The fewest parts for at most `max_leaves` leaves ([`crate::bake::Estimate::max_leaves`]):
/// a part holds at most 2^31 leaves.
pub(crate) fn least_parts(max_leaves: f64) -> f64 {
    (max_leaves / PART_LEAVES).ceil()
}

/// The most leaves a part holds.
pub(crate) const PART_LEAVES: f64 = (1u64 << 31) as f64;

/// The most parts a plan may have.
pub(crate) const MAX_PARTS: u32 = 1 << 16;

/// Errors of plans, parts and their merge.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PartsError {
    /// A file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// The bake itself failed (its checks, or the mesh).
    #[error(transparent)]
    Bake(#[from] BakeError),
    /// Loading the mesh failed.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// A plan or part file is damaged, truncated or not one.
    #[error("{path}: {detail}")]
    Corrupt {
        /// The file.
        path: String,
        /// What is wrong.
        detail: String,
    },
    /// A part file belongs to another plan, or to another part.
    #[error("{path}: {detail}")]
    Mismatch {
        /// The part file.
        path: String,
        /// What does not match.
        detail: String,
    },
    /// A part file is missing.
    #[error("part {index} of {count} is missing: {path} does not exist")]
    MissingPart {
        /// The part's index.
        index: u32,
        /// The number of parts.
        count: u32,
        /// Where it should be.
        path: String,
    },
    /// The mesh changed since the plan was made.
    #[error(
        "{path}: the mesh changed since the plan was made (hash {found:#018x}, the plan has {planned:#018x}); make the plan again"
    )]
    MeshChanged {
        /// The mesh.
        path: String,
        /// Its hash now.
        found: u64,
        /// The plan's.
        planned: u64,
    },
    /// The thread pool could not be made.
    #[error(transparent)]
    Threads(#[from] crate::thread_pool::ThreadsError),
    /// The memory budget leaves too little beside the mesh.
    #[error(
        "the mesh alone needs about {mesh_gib:.2} GiB, too much of the {budget_gib:.2} GiB budget"
    )]
    BudgetTooSmall {
        /// The mesh and its lists, GiB.
        mesh_gib: f64,
        /// The budget, GiB.
        budget_gib: f64,
    },
    /// The tree may need more parts than a plan may have.
    #[error(
        "depth {depth} could make up to {leaves:.3e} leaves, more than 65536 parts of 2^31 leaves hold"
    )]
    TooManyParts {
        /// The depth.
        depth: u8,
        /// The most leaves the bake can make.
        leaves: f64,
    },
    /// The part files and the output would not fit on the disk.
    #[error(
        "depth {depth} would make about {leaves:.3e} leaves: its part files and the file need about {need_gb:.1} GB on disk, more than the {free_gb:.1} GB free in {dir}"
    )]
    NoDiskSpace {
        /// The depth.
        depth: u8,
        /// Estimated leaves.
        leaves: f64,
        /// Bytes needed, GB.
        need_gb: f64,
        /// Bytes free, GB.
        free_gb: f64,
        /// The folder.
        dir: String,
    },
    /// A request the parts cannot serve.
    #[error("{0}")]
    Unsupported(String),
}

impl PartsError {
    pub(crate) fn io(path: &Path, cause: std::io::Error) -> Self {
        Self::Io {
            path: path.display().to_string(),
            cause,
        }
    }
}

/// One part of a plan: the Morton codes of the nodes at the parts' level that it bakes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct PlanPart {
    /// First code.
    pub(crate) start: u64,
    /// One past the last code.
    pub(crate) end: u64,
    /// The most leaves the part can make: the sum of its triangles' bounds
    /// ([`crate::bake::Estimate::max_leaves`]).
    pub(crate) max_leaves: f64,
}

/// A bake split into parts, as the plan file stores it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakePlan {
    /// The mesh, as given (a relative path is relative to where the commands run).
    pub mesh: String,
    /// XXH3-64 of the mesh file's bytes.
    pub mesh_hash: u64,
    /// Tree depth.
    pub depth: u8,
    /// The voxelization strategy's name.
    pub strategy: String,
    /// The channels selected, as `--channels` takes them.
    pub channels: String,
    /// Empty cells around the mesh.
    pub pad: u32,
    /// Whether the inner nodes get their attributes ([`BakeOptions::node_attributes`]): the
    /// merge then writes format version 4.
    pub node_attributes: bool,
    /// The root cube's minimum corner.
    pub root_origin: [f64; 3],
    /// The root cube's side.
    pub root_side: f64,
    /// The parts' level: each part bakes subtrees of nodes at this level.
    pub level: u8,
    /// Whether the parts write their leaves' per-leaf channels. Not for a DAG whose leaves
    /// take their values from a level above ([`crate::bake::parts::MergeFormat::DagWith`]):
    /// its merge reads none, and at depth 15 they would be most of the parts' bytes.
    pub leaf_arrays: bool,
    /// The parts, in Morton order; their ranges cover `0..8^level` in order.
    pub(crate) parts: Vec<PlanPart>,
    /// What the merged file's header says of its source.
    pub build: BuildInfo,
    /// Estimated leaves of the whole tree.
    pub estimated_leaves: f64,
    /// The most leaves the whole tree can make ([`crate::bake::Estimate::max_leaves`]).
    pub max_leaves: f64,
}

impl BakePlan {
    /// The bake options the plan was made with (no memory limit, no solid fill).
    pub fn options(&self) -> Result<BakeOptions, PartsError> {
        let bad = |what: &str, e: String| PartsError::Unsupported(format!("plan's {what}: {e}"));
        Ok(BakeOptions {
            depth: self.depth,
            strategy: self.strategy.parse().map_err(|e| bad("strategy", e))?,
            channels: self.channels.parse().map_err(|e| bad("channels", e))?,
            pad: self.pad,
            max_memory: None,
            solid: None,
            node_attributes: self.node_attributes,
        })
    }

    /// The root cube.
    pub fn root(&self) -> RootCube {
        RootCube {
            origin: glam::DVec3::from_array(self.root_origin),
            side: self.root_side,
        }
    }

    /// Number of parts.
    pub fn part_count(&self) -> u32 {
        self.parts.len() as u32
    }

    /// The most leaves the largest part can make ([`crate::bake::Estimate::max_leaves`]).
    pub fn largest_part_leaves(&self) -> f64 {
        self.parts.iter().map(|p| p.max_leaves).fold(0.0, f64::max)
    }
}

/// XXH3-64 of a file's bytes, read in 1 MiB pieces.
pub(crate) fn hash_file(path: &Path) -> Result<u64, PartsError> {
    let mut f = std::fs::File::open(path).map_err(|e| PartsError::io(path, e))?;
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).map_err(|e| PartsError::io(path, e))?;
        if n == 0 {
            return Ok(h.digest());
        }
        h.update(&buf[..n]);
    }
}

/// Whether a plan of `opts` gives the inner nodes attributes: where they are asked for and
/// the leaves have channels (without, the bake writes version 2).
pub(crate) fn makes_node_attributes(opts: &BakeOptions) -> bool {
    opts.node_attributes && channel_names(opts) != "none"
}

/// The channels of a selection, as `--channels` takes them.
pub(crate) fn channel_names(opts: &BakeOptions) -> String {
    let names: Vec<&str> = ChannelKind::ALL
        .iter()
        .filter(|&&k| opts.channels.has(k))
        .map(|k| k.name())
        .collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(",")
    }
}

/// The parts' level for `parts` parts at `depth`: fine enough that the ranges can be
/// balanced (about 64 nodes a part), never deeper than exactness allows.
fn parts_level(depth: u8, parts: u32) -> u8 {
    let mut level = 2u8;
    while 8u64.pow(u32::from(level)) < 64 * u64::from(parts) {
        level += 1;
    }
    level.min(deepest_part_level(depth))
}

/// Plans the bake of `mesh` (read from `mesh_path`, whose bytes hash to `mesh_hash`) in
/// `parts` parts: checks the options as the bake does, estimates each subtree's leaves, and
/// deals the subtrees into ranges of about equal estimates. Solid fills are refused (a part
/// cannot tell inside from outside alone), and so are the inner nodes' attributes for trees
/// estimated past version 4's 2^31 leaves (which those attributes need in the tree layout),
/// unless the parts are for a DAG (`dag`, with the values it keeps: the graph keeps those
/// attributes only as the values of a level, and has no such bound).
pub(crate) fn plan_bake(
    mesh: &Mesh,
    mesh_path: &Path,
    mesh_hash: u64,
    opts: &BakeOptions,
    (parts, dag): (u32, Option<DagValues>),
    build: BuildInfo,
) -> Result<BakePlan, PartsError> {
    if opts.solid.is_some() {
        return Err(PartsError::Unsupported(
            "a solid fill needs the whole tree at once: bake it without parts".into(),
        ));
    }
    if !(1..=MAX_PARTS).contains(&parts) {
        return Err(PartsError::Unsupported(format!(
            "{parts} parts: a plan has 1 to {MAX_PARTS}"
        )));
    }
    let (root, est) = prepare(
        mesh,
        &BakeOptions {
            max_memory: None,
            ..opts.clone()
        },
    )?;
    if opts.node_attributes
        && dag.is_none()
        && est.leaves > crate::octree::validate::MAX_LEAVES as f64
    {
        return Err(PartsError::Unsupported(format!(
            "depth {} makes about {:.3e} leaves, more than format version 4 holds (2^31), and \
             the inner nodes' attributes need version 4: bake without them",
            opts.depth, est.leaves
        )));
    }
    let least = least_parts(est.max_leaves);
    if f64::from(parts) < least {
        return Err(PartsError::Unsupported(format!(
            "depth {} could make up to {:.3e} leaves: plan at least {least} parts (a part holds \
             at most 2^31 leaves)",
            opts.depth, est.max_leaves
        )));
    }
    let level = parts_level(opts.depth, parts);
    let weights = subtree_estimates(mesh, &root, opts.depth, level);
    Ok(BakePlan {
        mesh: mesh_path.display().to_string(),
        mesh_hash,
        depth: opts.depth,
        strategy: opts.strategy.name().to_string(),
        channels: channel_names(opts),
        pad: opts.pad,
        node_attributes: makes_node_attributes(opts),
        leaf_arrays: dag.is_none_or(|v| v.level_for(opts.depth) >= opts.depth),
        root_origin: root.origin.to_array(),
        root_side: root.side,
        level,
        parts: deal(&weights, level, parts),
        build,
        estimated_leaves: est.leaves,
        max_leaves: est.max_leaves,
    })
}

/// Per node at `level` (Morton code, most leaves), in code order: each triangle's bound on
/// its cells ([`triangle_cells_bound`], as the bake's estimate sums them) counted in the node
/// holding its centroid.
fn subtree_estimates(mesh: &Mesh, root: &RootCube, depth: u8, level: u8) -> Vec<(u64, f64)> {
    let n = (1u64 << depth) as f64;
    let scale = n / root.side;
    let shift = depth - level;
    let mut map = std::collections::BTreeMap::<u64, f64>::new();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| {
            (mesh.positions.get(i as usize).copied().unwrap_or_default() - root.origin) * scale
        });
        let cells = triangle_cells_bound(a, b, c);
        let centroid = (a + b + c) / 3.0;
        let cell = centroid
            .clamp(glam::DVec3::ZERO, glam::DVec3::splat(n - 1.0))
            .to_array()
            .map(|v| (v as u64) >> shift);
        *map.entry(morton(cell, level)).or_default() += cells;
    }
    map.into_iter().collect()
}

/// The Morton code of the node at `level` with coordinates `c` (in nodes of that level):
/// the child index (x in bit 2, y in bit 1, z in bit 0) at each level, the root's first.
pub(crate) fn morton(c: [u64; 3], level: u8) -> u64 {
    let mut code = 0;
    for l in (0..level).rev() {
        code = code << 3 | (c[0] >> l & 1) << 2 | (c[1] >> l & 1) << 1 | (c[2] >> l & 1);
    }
    code
}

/// Deals the weighted nodes into `parts` contiguous ranges covering `0..8^level`, each
/// ending where the running sum passes its share.
fn deal(weights: &[(u64, f64)], level: u8, parts: u32) -> Vec<PlanPart> {
    let all = 8u64.pow(u32::from(level));
    let total: f64 = weights.iter().map(|w| w.1).sum();
    let mut out = Vec::with_capacity(parts as usize);
    let (mut start, mut sum, mut acc) = (0u64, 0.0, 0.0);
    for &(code, w) in weights {
        acc += w;
        sum += w;
        let k = out.len() as u32;
        if k + 1 < parts && acc >= total * f64::from(k + 1) / f64::from(parts) {
            out.push(PlanPart {
                start,
                end: code + 1,
                max_leaves: sum,
            });
            start = code + 1;
            sum = 0.0;
        }
    }
    out.push(PlanPart {
        start,
        end: all,
        max_leaves: sum,
    });
    while out.len() < parts as usize {
        out.push(PlanPart {
            start: all,
            end: all,
            max_leaves: 0.0,
        });
    }
    out
}

/// Plans the bake of the mesh file `mesh_path` in `parts` parts and writes the plan to
/// `output` (what `svo-bake plan` does). The plan names the mesh by its absolute path and
/// the hash of its bytes. With `bins`, each part's triangles are also written to a file of
/// their own beside the plan (`NAME.IIIII.svobin`), which the part then loads instead
/// of the mesh. `format` is the merge the parts are for: a DAG with its values on a level
/// ([`MergeFormat::DagWith`]) needs the inner nodes' attributes in `opts`, and its parts then
/// keep no leaf channels (any other merge of them is refused). Returns the plan, and what
/// writing the bins did.
pub fn plan_file(
    mesh_path: &Path,
    opts: &BakeOptions,
    parts: u32,
    format: MergeFormat,
    output: &Path,
    bins: bool,
) -> Result<(BakePlan, Option<crate::bake::parts::bins::BinsReport>), PartsError> {
    if crate::mesh::format::is_scene_file(mesh_path) {
        return Err(PartsError::Unsupported(format!(
            "{}: a plan takes a mesh file (a scene's meshes are not hashed); bake scenes in one process",
            mesh_path.display()
        )));
    }
    let dag = dag_values(format, opts.depth, makes_node_attributes(opts))?;
    let abs = std::path::absolute(mesh_path).map_err(|e| PartsError::io(mesh_path, e))?;
    let hash = hash_file(&abs)?;
    let mesh = crate::import::load_mesh(&abs)?;
    let build = BuildInfo {
        strategy: opts.strategy.name().to_string(),
        source_triangles: mesh.triangles.len() as u64,
        scene: mesh.scene.clone(),
        ..BuildInfo::new()
    };
    let plan = plan_bake(&mesh, &abs, hash, opts, (parts, dag), build)?;
    let plan_hash = write_plan(&plan, output)?;
    let bins = if bins {
        Some(crate::bake::parts::bins::write_bins(
            &mesh, &plan, output, plan_hash,
        )?)
    } else {
        // Bins of an earlier plan of the same name would be refused; none is left behind.
        for i in 0..plan.part_count() {
            let old = crate::bake::parts::bins::bin_path(output, i);
            if old.exists() {
                std::fs::remove_file(&old).map_err(|e| PartsError::io(&old, e))?;
            }
        }
        None
    };
    Ok((plan, bins))
}

/// Encodes a plan as its file's bytes.
pub(crate) fn plan_to_bytes(plan: &BakePlan) -> Vec<u8> {
    let body = bincode::serde::encode_to_vec(plan, config()).unwrap_or_default();
    let mut out = Vec::with_capacity(body.len() + 24);
    out.extend_from_slice(&PLAN_MAGIC);
    out.extend_from_slice(&PLAN_VERSION.to_le_bytes());
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&body);
    let sum = xxhash_rust::xxh3::xxh3_64(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// Writes a plan file atomically; returns its hash (what its parts record).
pub(crate) fn write_plan(plan: &BakePlan, path: &Path) -> Result<u64, PartsError> {
    let bytes = plan_to_bytes(plan);
    write_atomic(path, |w| w.write_all(&bytes)).map_err(|e| PartsError::io(path, e))?;
    Ok(xxhash_rust::xxh3::xxh3_64(&bytes))
}

/// Reads and checks a plan file; returns the plan and its hash.
pub(crate) fn read_plan(path: &Path) -> Result<(BakePlan, u64), PartsError> {
    let bytes = std::fs::read(path).map_err(|e| PartsError::io(path, e))?;
    let corrupt = |detail: &str| PartsError::Corrupt {
        path: path.display().to_string(),
        detail: detail.to_string(),
    };
    if bytes.len() < 24 || bytes[..8] != PLAN_MAGIC {
        return Err(corrupt("not an svo plan file (bad magic bytes)"));
    }
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    if word(8) != PLAN_VERSION {
        return Err(corrupt(&format!(
            "plan version {} (this svo reads version {PLAN_VERSION})",
            word(8)
        )));
    }
    let len = word(12) as usize;
    if bytes.len() != 16 + len + 8 {
        return Err(corrupt("truncated or overlong plan file"));
    }
    let (data, sum) = bytes.split_at(16 + len);
    let stored = u64::from_le_bytes(sum.try_into().unwrap_or_default());
    if stored != xxhash_rust::xxh3::xxh3_64(data) {
        return Err(corrupt("checksum mismatch: the plan file is corrupt"));
    }
    let (plan, used): (BakePlan, usize) = bincode::serde::decode_from_slice(&data[16..], config())
        .map_err(|e| corrupt(&format!("undecodable plan: {e}")))?;
    if used != len {
        return Err(corrupt("bytes left over after the plan"));
    }
    check_plan(&plan).map_err(|d| corrupt(&d))?;
    Ok((plan, xxhash_rust::xxh3::xxh3_64(&bytes)))
}

/// What the parts and the merge rely on: a depth, level and ranges that fit.
fn check_plan(plan: &BakePlan) -> Result<(), String> {
    if !(1..=crate::MAX_DEPTH).contains(&plan.depth) {
        return Err(format!(
            "depth {} is outside 1..={}",
            plan.depth,
            crate::MAX_DEPTH
        ));
    }
    if plan.level > deepest_part_level(plan.depth) {
        return Err(format!(
            "parts level {} is too deep for depth {}",
            plan.level, plan.depth
        ));
    }
    if plan.parts.is_empty() || plan.parts.len() > MAX_PARTS as usize {
        return Err(format!(
            "{} parts (a plan has 1 to {MAX_PARTS})",
            plan.parts.len()
        ));
    }
    let all = 8u64.pow(u32::from(plan.level));
    let mut at = 0;
    for (i, p) in plan.parts.iter().enumerate() {
        if p.start != at || p.end < p.start || p.end > all {
            return Err(format!(
                "part {i}'s range {}..{} does not follow the previous",
                p.start, p.end
            ));
        }
        at = p.end;
    }
    if at != all {
        return Err("the parts' ranges do not cover the level".into());
    }
    if !(plan.root_side.is_finite()
        && plan.root_side > 0.0
        && plan.root_origin.iter().all(|v| v.is_finite()))
    {
        return Err("the root cube is not finite".into());
    }
    Ok(())
}

/// The path of part `index`'s file: beside the plan, `NAME.IIIII.svopart` for a plan
/// `NAME.svoplan`.
pub fn part_path(plan_path: &Path, index: u32) -> PathBuf {
    indexed_sibling(plan_path, index, "svopart")
}

/// `NAME.IIIII.EXT` beside the plan `NAME.svoplan`.
pub(crate) fn indexed_sibling(plan_path: &Path, index: u32, ext: &str) -> PathBuf {
    let stem = plan_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    plan_path.with_file_name(format!("{stem}.{index:05}.{ext}"))
}

pub(crate) fn config() -> impl bincode::config::Config {
    bincode::config::standard()
        .with_fixed_int_encoding()
        .with_little_endian()
        .with_limit::<{ 1 << 26 }>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_codes_follow_the_child_order() {
        assert_eq!(morton([1, 0, 0], 1), 4);
        assert_eq!(morton([0, 1, 1], 1), 3);
        // Level 2: the root's child first.
        assert_eq!(morton([2, 0, 0], 2), 4 << 3);
        assert_eq!(morton([3, 3, 3], 2), 63);
    }

    #[test]
    fn dealt_ranges_cover_the_level_in_order() {
        let w = [(3, 10.0), (9, 10.0), (10, 10.0), (40, 10.0)];
        let parts = deal(&w, 2, 3);
        assert_eq!(parts.len(), 3);
        assert_eq!(parts[0].start, 0);
        assert_eq!(parts.last().unwrap().end, 64);
        for p in parts.windows(2) {
            assert_eq!(p[0].end, p[1].start);
        }
        // More parts than nodes: the first takes the node, the others nothing.
        let parts = deal(&w[..1], 2, 4);
        assert_eq!(parts.len(), 4);
        assert_eq!((parts[0].start, parts[0].end), (0, 4));
        assert!(parts[1..].iter().all(|p| p.max_leaves == 0.0));
        assert_eq!(parts.last().unwrap().end, 64);
    }
}
