//! Writing `.svo` files (see [`crate::io::header`] and `docs/format.md`).

use crate::dag::levels::DagLevels;
use crate::dag::{Dag, DagValues};
use crate::io::atomic_write::write_atomic;
use crate::io::header::{
    ArrayRef, BuildInfo, ChannelEntry, ChunkRecord, Chunking, Header, HeaderV3, HeaderV4,
    LevelEntry, Levels, MAGIC, NodeChannelEntry, NodeStorage, PREAMBLE_LEN, Storage,
    bincode_config,
};
use crate::io::packed;
use crate::octree::format_check::{
    CHUNKED_VERSION, Check, DAG_LAYOUT, LEVELS_VERSION, MAX_CHUNK_LEVEL, PLAIN_VERSION,
};
use crate::octree::level_order::{depth_first, keeps_level_order, level_order};
use crate::octree::stitch;
use crate::octree::tree::{ChannelKind, Node, Octree, StoredChannel};
use crate::octree::validate::{InfoBits, check_tree};
use std::borrow::Cow;
use std::io::Write;
use std::path::Path;
use thiserror::Error;

/// Errors of reading and writing `.svo` files. Every error about a file's contents names
/// the numbered check of `docs/format.md` that failed ([`FormatError::check`]).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FormatError {
    /// The file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// The file does not start with the `.svo` magic bytes (check 1).
    #[error("{}: not an .svo file (bad magic bytes)", Check::Magic)]
    NotSvo,
    /// The file is from a newer format version (check 3).
    #[error(
        "{}: file format version {found} is newer than this reader supports (version {supported}); upgrade svo",
        Check::Version
    )]
    NewerVersion {
        /// The file's version.
        found: u32,
        /// What this library reads.
        supported: u32,
    },
    /// The file ends before its declared contents.
    #[error("{check}: truncated file: {detail}")]
    Truncated {
        /// The check that found it.
        check: Check,
        /// What is missing.
        detail: String,
    },
    /// The checksum does not match the contents (check 5).
    #[error(
        "{}: checksum mismatch: the file is corrupt (stored {stored:#018x}, computed {computed:#018x})",
        Check::Checksum
    )]
    Checksum {
        /// Stored value.
        stored: u64,
        /// Computed value.
        computed: u64,
    },
    /// The contents fail a check.
    #[error("{check}: corrupt file: {detail}")]
    Corrupt {
        /// The check that failed.
        check: Check,
        /// What is wrong, and where.
        detail: String,
    },
    /// A version-3 file whose tree is larger than one tree in memory holds (2^31 leaves and
    /// 2^31 nodes); refused before its node array is read.
    #[error(
        "the file's tree has {leaves} leaves and up to {nodes} nodes in {chunks} chunks: more than one tree in memory holds (2^31 leaves, 2^31 nodes); svo::io::ChunkedFile reads it a chunk at a time, and svo::render::ChunkedSurfaces traces its chunks as one tree"
    )]
    TooLarge {
        /// The tree's leaves.
        leaves: u64,
        /// Its nodes, the levels above the chunks counted at most.
        nodes: u64,
        /// Its chunks.
        chunks: u64,
    },
    /// A file of the DAG layout whose tree is larger than one tree in memory holds (2^31
    /// leaves and 2^31 nodes); refused after its levels are checked, before the tree is made.
    #[error(
        "the file's graph stands for a tree of {leaves} leaves and {nodes} nodes: more than one tree in memory holds (2^31 leaves, 2^31 nodes)"
    )]
    DagTooLarge {
        /// The tree's leaves.
        leaves: u64,
        /// Its nodes.
        nodes: u64,
    },
    /// The file's tree cannot be made a walkable graph ([`crate::dag::DagTree`]).
    #[cfg(feature = "trace")]
    #[error("the file's tree as a DAG: {0}")]
    Dag(#[from] crate::dag::DagError),
}

impl FormatError {
    /// The numbered check of `docs/format.md` that the file failed (`None` for an I/O error).
    pub fn check(&self) -> Option<Check> {
        match self {
            Self::Io { .. } | Self::TooLarge { .. } | Self::DagTooLarge { .. } => None,
            #[cfg(feature = "trace")]
            Self::Dag(_) => None,
            Self::NotSvo => Some(Check::Magic),
            Self::NewerVersion { .. } => Some(Check::Version),
            Self::Checksum { .. } => Some(Check::Checksum),
            Self::Truncated { check, .. } | Self::Corrupt { check, .. } => Some(*check),
        }
    }
}

/// A writer that hashes what passes through it and counts the bytes.
struct Hashing<'a> {
    inner: &'a mut dyn Write,
    hash: xxhash_rust::xxh3::Xxh3,
    len: u64,
}

impl Write for Hashing<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.update(&buf[..n]);
        self.len += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Streams an octree in the `.svo` format to `w` (arrays are written straight from memory,
/// not copied into a buffer first, but for a tree with inner-node attributes, whose levels'
/// blocks, nodes and values side by side, are put together first) and returns the number of bytes written: version 4 for a tree
/// with [`Octree::node_attributes`], version 2 for another.
pub fn write_to(tree: &Octree, build: &BuildInfo, w: &mut dyn Write) -> std::io::Result<u64> {
    // A tree a reader would refuse is not written (trees that svo builds pass). Bits 8-31
    // of the nodes are written as zeros whatever they hold.
    let (channels, arrays) = checked_channels(tree)?;
    let mut layout = Layout {
        root_origin: tree.root.origin.to_array(),
        root_side: tree.root.side,
        depth: tree.depth,
        node_count: tree.nodes.len() as u64,
        leaf_count: u64::from(tree.leaf_count),
        channels,
        build,
        chunks: None,
        levels: None,
    };
    if tree.node_attributes.stored().is_empty() {
        return write_layout(&layout, w, &mut |i, out| {
            if i == 0 {
                write_nodes(&tree.nodes, out)
            } else {
                out.write_all(arrays[i - 1])
            }
        });
    }
    let (plan, blocks) = level_blocks(tree);
    layout.levels = Some(plan);
    let all: Vec<&[u8]> = blocks
        .iter()
        .flatten()
        .map(Vec::as_slice)
        .chain(arrays)
        .collect();
    write_layout(&layout, w, &mut |i, out| out.write_all(all[i]))
}

/// Streams an octree to `w` as a version-4 file of the DAG layout (`docs/format.md`, section
/// 12): its geometry as a graph of distinct subtrees ([`Dag`]), the two lowest levels as
/// 64-bit bricks, its leaves' channels as [`write_to`] stores them. Refused for a tree of
/// depth 1 (a DAG's lowest node is a brick, two levels) and for a tree with inner-node
/// attributes (shared subtrees cannot keep values of their own). Returns the bytes written.
///
/// ```
/// use glam::{DVec3, UVec3};
/// use svo::io::{BuildInfo, from_bytes, to_bytes, write_dag_to};
/// use svo::{Octree, RootCube, Voxel};
/// let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
/// // A lattice: every subtree of a level the same.
/// let cells = (0..512u32)
///     .map(|i| UVec3::new(i % 8, i / 8 % 8, i / 64))
///     .filter(|c| c.x % 2 == 0 && c.y % 2 == 0 && c.z % 2 == 0)
///     .map(|c| (c, Voxel::glass()));
/// let tree = Octree::from_cells(root, 3, cells)?;
/// let mut dag = Vec::new();
/// write_dag_to(&tree, &BuildInfo::new(), &mut dag)?;
/// assert!(dag.len() < to_bytes(&tree, &BuildInfo::new()).len());
/// assert_eq!(from_bytes(&dag)?.0, tree); // the same tree
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_dag_to(tree: &Octree, build: &BuildInfo, w: &mut dyn Write) -> std::io::Result<u64> {
    if !tree.node_attributes.stored().is_empty() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "the DAG layout keeps no inner-node attributes: write the tree layout, keep the \
             leaves' values on a level above them (write_dag_to_with), or write a tree \
             without them",
        ));
    }
    write_dag_to_with(tree, build, &DagValues::default(), w)
}

/// [`write_dag_to`] with the leaves' values kept as `values` says (`docs/format.md`, section
/// 12, "Values on a level"): each leaf's own, or one for each node of a level above, taken
/// from the tree's inner-node attributes (which the file keeps only as those values), and
/// normals in fewer bits. With the defaults, the bytes of [`write_dag_to`] (a tree's
/// inner-node attributes are then left out).
///
/// ```
/// use svo::dag::DagValues;
/// use svo::io::{BuildInfo, read_dag_file, write_dag_file_with};
/// use svo::{BakeOptions, ChannelSelection, Mesh, bake_mesh, octree::ChannelKind};
/// let sphere = Mesh::sphere(glam::DVec3::splat(0.5), 0.4, 24);
/// let normals = ChannelSelection::NONE.with(ChannelKind::Normal);
/// let opts = BakeOptions { depth: 7, node_attributes: true, channels: normals, ..Default::default() };
/// let tree = bake_mesh(&sphere, &opts)?.0;
/// let path = std::env::temp_dir().join("svo-doc-values.svo");
/// let coarse = DagValues { level: Some(5), normal_bits: 16, colour_bits: 16 };
/// let bytes = write_dag_file_with(&tree, &BuildInfo::new(), &coarse, &path)?;
/// // Less than a byte a leaf, normals included (each leaf's own would take 4).
/// assert!(bytes < u64::from(tree.leaf_count));
/// let (dag, _) = read_dag_file(&path)?;
/// assert_eq!(dag.values_level(), 5);
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_dag_to_with(
    tree: &Octree,
    build: &BuildInfo,
    values: &DagValues,
    w: &mut dyn Write,
) -> std::io::Result<u64> {
    let refuse = |m: &str| {
        Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            m.to_string(),
        ))
    };
    if tree.depth < 2 {
        return refuse(
            "the DAG layout needs a tree of depth 2 or more (its lowest nodes are 4x4x4 bricks)",
        );
    }
    let level = values.level_for(tree.depth);
    let invalid = |e: crate::dag::ValuesError| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, e.to_string())
    };
    values.check(tree.depth).map_err(invalid)?;
    // The tree's own checks, on its geometry and leaf channels; with each leaf's own values
    // at their own width, its arrays are written as they are.
    let (mut channels, borrowed) = checked_channels(tree)?;
    let mut arrays: Vec<Cow<'_, [u8]>> = borrowed.into_iter().map(Cow::Borrowed).collect();
    if level < tree.depth || values.normal_bits < 32 || values.colour_bits < 32 {
        // The values before the colours' round trip: the packer encodes them as a merge of
        // parts does, from the values themselves.
        let attributes = values.packed_values(tree).map_err(invalid)?;
        (channels, arrays) = (Vec::new(), Vec::new());
        for (kind, c) in attributes.stored() {
            match c {
                StoredChannel::Constant(v) => channels.push((kind, Stored::Constant(v))),
                StoredChannel::PerLeaf { bytes, size } => {
                    let kind_bits =
                        packed::stored_bits(kind, values.normal_bits, values.colour_bits);
                    if level == tree.depth && u32::from(kind_bits) == packed::element_bits(kind) {
                        channels.push((kind, Stored::PerLeaf(bytes.len() as u64)));
                        arrays.push(Cow::Owned(bytes.to_vec()));
                        continue;
                    }
                    let words = bytes.chunks_exact(size).map(packed::word);
                    let packed = packed::pack(kind, kind_bits, words);
                    channels.push((
                        kind,
                        Stored::Packed {
                            level,
                            bits: kind_bits,
                            len: packed.len() as u64,
                        },
                    ));
                    arrays.push(Cow::Owned(packed));
                }
            }
        }
    }
    let (plan, blocks) = dag_blocks(&Dag::from_tree(tree));
    let layout = Layout {
        root_origin: tree.root.origin.to_array(),
        root_side: tree.root.side,
        depth: tree.depth,
        node_count: plan.counts.iter().sum(),
        leaf_count: u64::from(tree.leaf_count),
        channels,
        build,
        chunks: None,
        levels: Some(plan),
    };
    let all: Vec<&[u8]> = blocks
        .iter()
        .map(Vec::as_slice)
        .chain(arrays.iter().map(|a| &**a))
        .collect();
    write_layout(&layout, w, &mut |i, out| out.write_all(all[i]))
}

/// The DAG layout's level blocks of `dag` (of depth 2 or more), and the plan [`write_layout`]
/// places them by.
pub(crate) fn dag_blocks(dag: &Dag) -> (LevelPlan, Vec<Vec<u8>>) {
    let levels = DagLevels::of(dag);
    let blocks = levels.blocks();
    let plan = LevelPlan {
        layout: DAG_LAYOUT,
        counts: levels.counts(),
        block_lens: blocks.iter().map(|b| b.len() as u64).collect(),
        hashes: blocks
            .iter()
            .map(|b| block_hash(std::slice::from_ref(b)))
            .collect(),
        node_channels: Vec::new(),
    };
    (plan, blocks)
}

/// [`write_dag_to`] into the file at `path`, atomically (as [`write_file`]).
pub fn write_dag_file(
    tree: &Octree,
    build: &BuildInfo,
    path: impl AsRef<Path>,
) -> Result<u64, FormatError> {
    written_atomically(path.as_ref(), &mut |w| write_dag_to(tree, build, w))
}

/// [`write_dag_to_with`] into the file at `path`, atomically (as [`write_file`]).
pub fn write_dag_file_with(
    tree: &Octree,
    build: &BuildInfo,
    values: &DagValues,
    path: impl AsRef<Path>,
) -> Result<u64, FormatError> {
    written_atomically(path.as_ref(), &mut |w| {
        write_dag_to_with(tree, build, values, w)
    })
}

/// What `write` streams, written to `path` atomically: the bytes written.
fn written_atomically(
    path: &Path,
    write: &mut dyn FnMut(&mut dyn Write) -> std::io::Result<u64>,
) -> Result<u64, FormatError> {
    let mut written = 0;
    write_atomic(path, |w| {
        written = write(w)?;
        Ok(())
    })
    .map_err(|cause| FormatError::Io {
        path: path.display().to_string(),
        cause,
    })?;
    Ok(written)
}

/// A tree's nodes level by level, as version 4 stores them: for each level its block's arrays
/// (the nodes' records, then on levels above the leaf parents each per-node channel's values),
/// and the plan [`write_layout`] places them by.
pub(crate) fn level_blocks(tree: &Octree) -> (LevelPlan, Vec<Vec<Vec<u8>>>) {
    let order = level_order(&tree.nodes, tree.depth);
    let stored = tree.node_attributes.stored();
    let mut blocks = Vec::with_capacity(order.counts.len());
    let mut start = 0usize;
    for (l, &count) in order.counts.iter().enumerate() {
        let range = start..start + count as usize;
        let mut block =
            vec![bytemuck::cast_slice::<Node, u8>(&order.nodes[range.clone()]).to_vec()];
        if l + 2 <= usize::from(tree.depth) {
            for (_, c) in &stored {
                if let StoredChannel::PerLeaf { bytes, size } = c {
                    let mut v = Vec::with_capacity(count as usize * size);
                    for &f in &order.from[range.clone()] {
                        let at = f as usize * size;
                        v.extend_from_slice(&bytes[at..at + size]);
                    }
                    block.push(v);
                }
            }
        }
        blocks.push(block);
        start = range.end;
    }
    let plan = LevelPlan {
        layout: 0,
        block_lens: Vec::new(),
        counts: order.counts,
        hashes: blocks.iter().map(|b| block_hash(b)).collect(),
        node_channels: stored
            .iter()
            .map(|(kind, c)| NodeChannelEntry {
                kind: *kind,
                storage: match c {
                    StoredChannel::Constant(v) => NodeStorage::Constant(*v),
                    StoredChannel::PerLeaf { .. } => NodeStorage::PerNode,
                },
            })
            .collect(),
    };
    (plan, blocks)
}

/// XXH3-64 of a level's block: its arrays with the zero padding between them (not after the
/// last).
pub(crate) fn block_hash(arrays: &[Vec<u8>]) -> u64 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    for (i, a) in arrays.iter().enumerate() {
        if i > 0 {
            h.update(&[0u8; 8][..(8 - arrays[i - 1].len() % 8) % 8]);
        }
        h.update(a);
    }
    h.digest()
}

/// What a version-4 file's levels hold, before their offsets are known.
pub(crate) struct LevelPlan {
    /// The nodes' layout: 0 the tree, 1 the DAG (`docs/format.md`, section 12).
    pub layout: u8,
    /// Nodes on each level, the root's first.
    pub counts: Vec<u64>,
    /// The DAG layout: each level's block length (its words or bricks); the tree layout's
    /// follow from the counts and channels.
    pub block_lens: Vec<u64>,
    /// Each level's block hash.
    pub hashes: Vec<u64>,
    /// The inner nodes' channels, in increasing kind.
    pub node_channels: Vec<NodeChannelEntry>,
}

/// Streams an octree to `w` as a version-3 file, its subtrees under the nodes at `level`
/// (`0..depth`, at most [`MAX_CHUNK_LEVEL`]) stored as chunks (`docs/format.md`, section 10), and returns the number of
/// bytes written. Version 3 is what holds trees past 2^31 leaves or nodes; any tree can be
/// written so, and reads back the same.
///
/// ```
/// use glam::{DVec3, UVec3};
/// use svo::io::{BuildInfo, from_bytes, write_chunked_to};
/// use svo::{Octree, RootCube, Voxel};
/// let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
/// let cells = [UVec3::ZERO, UVec3::new(7, 2, 5)].map(|c| (c, Voxel::glass()));
/// let tree = Octree::from_cells(root, 3, cells)?;
/// let mut bytes = Vec::new();
/// write_chunked_to(&tree, &BuildInfo::new(), 1, &mut bytes)?; // two chunks at level 1
/// assert_eq!(u32::from_le_bytes(bytes[8..12].try_into()?), 3);
/// assert_eq!(from_bytes(&bytes)?.0, tree);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_chunked_to(
    tree: &Octree,
    build: &BuildInfo,
    level: u8,
    w: &mut dyn Write,
) -> std::io::Result<u64> {
    if level >= tree.depth || level > MAX_CHUNK_LEVEL {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "chunk level {level} is not above depth {} or past {MAX_CHUNK_LEVEL}",
                tree.depth
            ),
        ));
    }
    let (channels, arrays) = checked_channels(tree)?;
    // Chunks are depth-first subtrees (version 3 keeps no inner-node channels).
    let depth_first_nodes;
    let nodes = if keeps_level_order(tree) {
        depth_first_nodes = depth_first(&tree.nodes).0;
        &depth_first_nodes
    } else {
        &tree.nodes
    };
    let cuts = stitch::cut(nodes, level);
    let table: Vec<ChunkRecord> = cuts
        .iter()
        .map(|c| ChunkRecord {
            code: c.code,
            nodes: 1 + c.below.len() as u64,
            leaves: c.leaves,
        })
        .collect();
    let layout = Layout {
        root_origin: tree.root.origin.to_array(),
        root_side: tree.root.side,
        depth: tree.depth,
        node_count: table.iter().map(|r| r.nodes).sum(),
        leaf_count: u64::from(tree.leaf_count),
        channels,
        build,
        chunks: Some((level, table.len() as u64)),
        levels: None,
    };
    write_layout(&layout, w, &mut |i, out| match i {
        0 => out.write_all(bytemuck::cast_slice(&table)),
        1 => {
            let mut buf = Vec::with_capacity(4096);
            for (c, r) in cuts.iter().zip(&table) {
                for j in 0..r.nodes as usize {
                    // A subtree of a checked tree numbers within 2^31.
                    buf.push(c.local(nodes, j).unwrap_or_default());
                    if buf.len() == 4096 {
                        out.write_all(bytemuck::cast_slice(&buf))?;
                        buf.clear();
                    }
                }
            }
            out.write_all(bytemuck::cast_slice(&buf))
        }
        _ => out.write_all(arrays[i - 2]),
    })
}

/// Checks a tree before it is written (a tree a reader would refuse is not written; trees
/// that svo builds pass; bits 8-31 of the nodes are written as zeros whatever they hold) and
/// returns its channels' storage and per-leaf arrays.
#[allow(clippy::type_complexity)]
fn checked_channels(tree: &Octree) -> std::io::Result<(Vec<(u8, Stored)>, Vec<&[u8]>)> {
    check_tree(tree, PLAIN_VERSION, InfoBits::Cleared).map_err(|(check, detail)| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{check}: {detail}"),
        )
    })?;
    // Arrays are stored little-endian: on little-endian machines a plain copy.
    #[cfg(target_endian = "big")]
    compile_error!("svo's file writer assumes a little-endian target");
    let mut arrays: Vec<&[u8]> = Vec::new();
    let mut channels: Vec<(u8, Stored)> = Vec::new();
    for (kind, c) in tree.attributes.stored() {
        match c {
            StoredChannel::Constant(v) => channels.push((kind, Stored::Constant(v))),
            StoredChannel::PerLeaf { bytes, .. } => {
                channels.push((kind, Stored::PerLeaf(bytes.len() as u64)));
                arrays.push(bytes);
            }
        }
    }
    Ok((channels, arrays))
}

/// How a channel is stored, before the arrays' offsets are known.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stored {
    /// One value for all leaves.
    Constant(u32),
    /// An array of this many bytes.
    PerLeaf(u64),
    /// The DAG layout: a bit stream of this many bytes, values of `bits` bits for the nodes of
    /// `level`.
    Packed { level: u8, bits: u8, len: u64 },
}

/// Everything a file's header says but where its arrays sit: what [`write_layout`] needs to
/// place them.
pub(crate) struct Layout<'a> {
    pub root_origin: [f64; 3],
    pub root_side: f64,
    pub depth: u8,
    pub node_count: u64,
    pub leaf_count: u64,
    /// The channels present, in increasing kind.
    pub channels: Vec<(u8, Stored)>,
    pub build: &'a BuildInfo,
    /// Version 3: the chunk level and the number of chunks (`node_count` is then the chunks'
    /// nodes); `None` writes version 2 or 4.
    pub chunks: Option<(u8, u64)>,
    /// Version 4: the levels (`None` writes version 2 or 3).
    pub levels: Option<LevelPlan>,
}

/// Writes a file of `layout` to `w` and returns the bytes written: the preamble and header,
/// then each array from `fill(i, out)` (`i` counts them in file order: the chunk table in
/// version 3, the node array, then the per-leaf channels in increasing kind), each padded to
/// 8 bytes, then the checksum. `fill` must write exactly
/// the array's length; anything else is an error, and so is a scene that fails
/// [`SceneInfo::validate`](crate::mesh::SceneInfo::validate), refused before the first byte.
pub(crate) fn write_layout(
    layout: &Layout<'_>,
    w: &mut dyn Write,
    fill: &mut dyn FnMut(usize, &mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<u64> {
    layout.build.scene.validate().map_err(|e| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("scene: {e}"))
    })?;
    let mut lens = Vec::new();
    if let Some((_, count)) = layout.chunks {
        lens.push(count.saturating_mul(size_of::<ChunkRecord>() as u64));
    }
    // Version 4: each level's arrays (how many a level has, to find its block's ends).
    let mut level_arrays = Vec::new();
    match &layout.levels {
        None => lens.push(layout.node_count.saturating_mul(8)),
        Some(plan) => {
            let per_node: Vec<u64> = plan
                .node_channels
                .iter()
                .filter(|e| e.storage == NodeStorage::PerNode)
                .map(|e| ChannelKind::ALL[usize::from(e.kind)].element_size() as u64)
                .collect();
            for (l, &count) in plan.counts.iter().enumerate() {
                if plan.layout == DAG_LAYOUT {
                    lens.push(plan.block_lens[l]);
                    level_arrays.push(1);
                    continue;
                }
                lens.push(count.saturating_mul(8));
                let mut k = 1;
                if l + 2 <= usize::from(layout.depth) {
                    lens.extend(per_node.iter().map(|&size| count.saturating_mul(size)));
                    k += per_node.len();
                }
                level_arrays.push(k);
            }
        }
    }
    let mut header = Header {
        root_origin: layout.root_origin,
        root_side: layout.root_side,
        depth: layout.depth,
        node_count: layout.node_count,
        leaf_count: layout.leaf_count,
        nodes: ArrayRef::default(),
        channels: layout
            .channels
            .iter()
            .map(|&(kind, s)| ChannelEntry {
                kind,
                storage: match s {
                    Stored::Constant(v) => Storage::Constant(v),
                    Stored::PerLeaf(len) => {
                        lens.push(len);
                        Storage::PerLeaf(ArrayRef::default())
                    }
                    Stored::Packed { level, bits, len } => {
                        lens.push(len);
                        Storage::Packed {
                            level,
                            bits,
                            array: ArrayRef::default(),
                        }
                    }
                },
            })
            .collect(),
        build: layout.build.clone(),
        chunks: layout.chunks.map(|(level, count)| Chunking {
            level,
            count,
            table: ArrayRef::default(),
        }),
        levels: layout.levels.as_ref().map(|plan| Levels {
            layout: plan.layout,
            table: plan
                .counts
                .iter()
                .zip(&plan.hashes)
                .map(|(&nodes, &hash)| LevelEntry {
                    nodes,
                    block: ArrayRef::default(),
                    hash,
                })
                .collect(),
            node_channels: plan.node_channels.clone(),
        }),
    };
    let encode = |h: &Header| {
        match (h.chunks, &h.levels) {
            (Some(c), _) => bincode::serde::encode_to_vec(HeaderV3::of(h, c), bincode_config()),
            (None, Some(l)) => bincode::serde::encode_to_vec(HeaderV4::of(h, l), bincode_config()),
            (None, None) => bincode::serde::encode_to_vec(h, bincode_config()),
        }
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
    };
    // Fixed-width integers: the header's size does not depend on the offsets in it.
    let hlen = encode(&header)?.len();
    // Version 4: the header's checksum follows it.
    let header_end = (PREAMBLE_LEN + hlen + if layout.levels.is_some() { 8 } else { 0 }) as u64;
    let pad8 = |x: u64| x.div_ceil(8) * 8;
    let mut offset = pad8(header_end);
    let mut refs = lens.iter().map(|&len| {
        let r = ArrayRef { offset, len };
        offset = pad8(offset + len);
        r
    });
    if let Some(c) = &mut header.chunks {
        c.table = refs.next().unwrap_or_default();
    }
    match &mut header.levels {
        None => header.nodes = refs.next().unwrap_or_default(),
        Some(levels) => {
            for (entry, &k) in levels.table.iter_mut().zip(&level_arrays) {
                let parts: Vec<ArrayRef> = refs.by_ref().take(k).collect();
                let (first, last) = (parts[0], parts[k - 1]);
                entry.block = ArrayRef {
                    offset: first.offset,
                    len: last.offset + last.len - first.offset,
                };
            }
        }
    }
    for e in &mut header.channels {
        match &mut e.storage {
            Storage::PerLeaf(r) | Storage::Packed { array: r, .. } => {
                *r = refs.next().unwrap_or_default();
            }
            Storage::Constant(_) => {}
        }
    }
    let hbytes = encode(&header)?;
    debug_assert_eq!(hbytes.len(), hlen);
    let mut out = Hashing {
        inner: w,
        hash: xxhash_rust::xxh3::Xxh3::new(),
        len: 0,
    };
    out.write_all(&MAGIC)?;
    let version = match (&header.chunks, &header.levels) {
        (Some(_), _) => CHUNKED_VERSION,
        (None, Some(_)) => LEVELS_VERSION,
        (None, None) => PLAIN_VERSION,
    };
    out.write_all(&version.to_le_bytes())?;
    out.write_all(&(hbytes.len() as u32).to_le_bytes())?;
    out.write_all(&hbytes)?;
    if header.levels.is_some() {
        let mut start = Vec::with_capacity(PREAMBLE_LEN + hlen);
        start.extend_from_slice(&MAGIC);
        start.extend_from_slice(&version.to_le_bytes());
        start.extend_from_slice(&(hbytes.len() as u32).to_le_bytes());
        start.extend_from_slice(&hbytes);
        out.write_all(&xxhash_rust::xxh3::xxh3_64(&start).to_le_bytes())?;
    }
    let zeros = [0u8; 8];
    let pad = |out: &mut Hashing<'_>| -> std::io::Result<()> {
        let n = pad8(out.len) - out.len;
        out.write_all(&zeros[..n as usize])
    };
    pad(&mut out)?;
    for (i, &len) in lens.iter().enumerate() {
        let start = out.len;
        fill(i, &mut out)?;
        if out.len - start != len {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "array {i} of the file: {} bytes written where the header says {len}",
                    out.len - start
                ),
            ));
        }
        pad(&mut out)?;
    }
    let sum = out.hash.digest();
    let len = out.len;
    out.inner.write_all(&sum.to_le_bytes())?;
    Ok(len + 8)
}

/// Writes the node array as files store it: bits 8-31 of `info` (the derived bounds) zero.
fn write_nodes(nodes: &[Node], out: &mut dyn Write) -> std::io::Result<()> {
    let mut buf = [Node::default(); 4096];
    for chunk in nodes.chunks(buf.len()) {
        for (b, n) in buf.iter_mut().zip(chunk) {
            *b = Node {
                info: n.info & 0xFF,
                first: n.first,
            };
        }
        out.write_all(bytemuck::cast_slice(&buf[..chunk.len()]))?;
    }
    Ok(())
}

/// Serializes an octree into the bytes of a `.svo` file (empty when `build.scene` fails
/// [`SceneInfo::validate`](crate::mesh::SceneInfo::validate)).
pub fn to_bytes(tree: &Octree, build: &BuildInfo) -> Vec<u8> {
    let mut v = Vec::new();
    // Writing to a Vec cannot fail, and the header always encodes; an invalid scene is
    // refused before the first byte, which leaves the vector empty (not a readable file).
    let _ = write_to(tree, build, &mut v);
    v
}

/// Writes an octree with its [`BuildInfo`] to `path` atomically (a temporary file in the
/// same folder, flushed to disk, then renamed over `path`), returning the bytes written.
pub fn write_file(
    tree: &Octree,
    build: &BuildInfo,
    path: impl AsRef<Path>,
) -> Result<u64, FormatError> {
    written_atomically(path.as_ref(), &mut |w| write_to(tree, build, w))
}

impl Octree {
    /// Writes the tree to a `.svo` file atomically, with [`BuildInfo::new`] (no lights or
    /// views; [`write_file`] stores a [`BuildInfo`] of the caller's), returning the bytes
    /// written.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<u64, FormatError> {
        write_file(self, &BuildInfo::new(), path)
    }
}
