//! The `.svo` file header (format version 2, version 3 for a tree stored in chunks, version 4
//! for nodes stored level by level with the inner nodes' channels; version 1 is still read);
//! `docs/format.md` gives every byte.
//!
//! ```text
//! offset  size  field
//! 0       8     magic 89 53 56 4F 0D 0A 1A 0A ("\x89SVO\r\n\x1a\n")
//! 8       4     format version, u32 LE (2)
//! 12      4     header length H, u32 LE (at most 65536)
//! 16      H     header: bincode 2, standard config with fixed-width little-endian integers
//! 16+H    8     version 4: xxh3-64 of bytes 0..16+H (the header checksum)
//! ...           zero padding to a multiple of 8
//! ...           arrays, each at the 8-aligned offset the header names, zero-padded to 8
//! end-8   8     xxh3-64 of every byte before it, u64 LE
//! ```

use crate::mesh::scene_info::SceneInfo;
use serde::{Deserialize, Serialize};

/// The file's first 8 bytes.
pub(crate) const MAGIC: [u8; 8] = *b"\x89SVO\r\n\x1a\n";
/// The newest format version this library reads and writes. It also reads versions 1 to 3,
/// and writes version 4 for a tree with inner-node attributes, version 2 for another tree that
/// one node array holds, and version 3 (chunks) past that or when asked.
pub const VERSION: u32 = crate::octree::format_check::CURRENT_VERSION;
/// The largest header accepted.
pub(crate) const MAX_HEADER_LEN: usize = 1 << 16;
/// Bytes before the header: magic, version, header length.
pub(crate) const PREAMBLE_LEN: usize = 16;

/// Where an array sits in the file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct ArrayRef {
    /// Byte offset from the start of the file (a multiple of 8).
    pub offset: u64,
    /// Length in bytes (elements times element size, without padding).
    pub len: u64,
}

/// How a channel is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum Storage {
    /// One value for all leaves, stored here (the value's bits, zero-extended to `u32`).
    Constant(u32),
    /// One value per leaf, in an array.
    PerLeaf(ArrayRef),
    /// The DAG layout only: one value for each node of the tree on `level` (the depth: each
    /// leaf), in Morton order, `bits` bits each in a bit stream (`docs/format.md`, section
    /// 12); a leaf takes its ancestor's on that level.
    Packed {
        /// The level whose nodes hold the values.
        level: u8,
        /// The bits of a value.
        bits: u8,
        /// The bit stream.
        array: ArrayRef,
    },
}

/// One stored channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct ChannelEntry {
    /// Channel code: 0 normal, 1 contour, 2 colour, 3 reflectivity, 4 refractivity, 5 IOR.
    pub kind: u8,
    /// Constant or per-leaf array.
    pub storage: Storage,
}

/// What accompanies the tree in the file: what made it (informative; no timestamps, so
/// output is reproducible), and the scene's lights and camera views.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BuildInfo {
    /// Generator name and version, e.g. `svo 0.1.0`.
    pub generator: String,
    /// The voxelization strategy, or `builder` for programmatic trees.
    pub strategy: String,
    /// Triangles in the source mesh (0 for programmatic trees).
    pub source_triangles: u64,
    /// Lights and camera views (version 2; empty in version-1 files).
    pub scene: SceneInfo,
}

impl BuildInfo {
    /// This library as the generator (`svo 0.1.0`), no strategy, no triangles, no scene.
    pub fn new() -> Self {
        Self {
            generator: format!("svo {}", env!("CARGO_PKG_VERSION")),
            ..Self::default()
        }
    }
}

/// [`BuildInfo`] as version 1 stored it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct BuildInfoV1 {
    /// See [`BuildInfo::generator`].
    pub generator: String,
    /// See [`BuildInfo::strategy`].
    pub strategy: String,
    /// See [`BuildInfo::source_triangles`].
    pub source_triangles: u64,
}

/// [`Header`] as version 1 stored it: the same fields, without the scene.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct HeaderV1 {
    /// See [`Header::root_origin`].
    pub root_origin: [f64; 3],
    /// See [`Header::root_side`].
    pub root_side: f64,
    /// See [`Header::depth`].
    pub depth: u8,
    /// See [`Header::node_count`].
    pub node_count: u64,
    /// See [`Header::leaf_count`].
    pub leaf_count: u64,
    /// See [`Header::nodes`].
    pub nodes: ArrayRef,
    /// See [`Header::channels`].
    pub channels: Vec<ChannelEntry>,
    /// Provenance.
    pub build: BuildInfoV1,
}

impl From<HeaderV1> for Header {
    fn from(h: HeaderV1) -> Self {
        Self {
            root_origin: h.root_origin,
            root_side: h.root_side,
            depth: h.depth,
            node_count: h.node_count,
            leaf_count: h.leaf_count,
            nodes: h.nodes,
            channels: h.channels,
            build: BuildInfo {
                generator: h.build.generator,
                strategy: h.build.strategy,
                source_triangles: h.build.source_triangles,
                scene: SceneInfo::default(),
            },
            chunks: None,
            levels: None,
        }
    }
}

/// What a version-3 header adds: the level of the chunks' roots and the chunk table.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Chunking {
    /// The level of the chunks' roots (0 to `depth - 1`).
    pub level: u8,
    /// Chunks.
    pub count: u64,
    /// The chunk table: `count` records of [`ChunkRecord`].
    pub table: ArrayRef,
}

/// One record of a version-3 chunk table (24 bytes, three `u64` LE): a chunk is the subtree
/// under one node at the chunk level, stored as a tree of its own.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ChunkRecord {
    /// The Morton code of the chunk's root at the chunk level.
    pub code: u64,
    /// The chunk's nodes, its root included.
    pub nodes: u64,
    /// The chunk's leaves.
    pub leaves: u64,
}

/// The header, version 2 (version 3 adds [`Chunking`], encoded as [`HeaderV3`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Header {
    /// Root cube minimum corner, scene units.
    pub root_origin: [f64; 3],
    /// Root cube side, scene units.
    pub root_side: f64,
    /// Levels below the root.
    pub depth: u8,
    /// Nodes in the node array.
    pub node_count: u64,
    /// Leaves.
    pub leaf_count: u64,
    /// The node array (`node_count` times 8 bytes: `info`, `first`, each u32 LE).
    pub nodes: ArrayRef,
    /// Present channels, in increasing `kind` order, each at most once.
    pub channels: Vec<ChannelEntry>,
    /// Provenance.
    pub build: BuildInfo,
    /// Version 3: the chunk level and table (`None` in versions 1 and 2).
    #[serde(skip)]
    pub chunks: Option<Chunking>,
    /// Version 4: the level table and the inner nodes' channels (`None` before; `nodes` is
    /// then unused: the nodes lie in the levels' blocks).
    #[serde(skip)]
    pub levels: Option<Levels>,
}

/// What a version-4 header adds: the nodes' layout, one entry a level, and the inner nodes'
/// channels.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Levels {
    /// 0: the tree (an info byte and a child pointer a node); other values are reserved.
    pub layout: u8,
    /// Levels 0 to `depth - 1`, root first.
    pub table: Vec<LevelEntry>,
    /// The inner nodes' channels: none, or one for each kind of `channels`, in the same order.
    pub node_channels: Vec<NodeChannelEntry>,
}

/// One level of a version-4 file: its nodes and where their block lies (the nodes' records,
/// then, on levels above `depth - 1`, one array for each per-node channel, each padded to 8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct LevelEntry {
    /// Nodes on the level.
    pub nodes: u64,
    /// The block: from its nodes' records to the end of its last array (without the padding
    /// after it).
    pub block: ArrayRef,
    /// XXH3-64 (seed 0) of the block's bytes.
    pub hash: u64,
}

/// How an inner-node channel is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum NodeStorage {
    /// One value for every inner node above the leaf parents.
    Constant(u32),
    /// One value per node, in each level's block (levels 0 to `depth - 2`).
    PerNode,
}

/// One stored inner-node channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct NodeChannelEntry {
    /// Channel code, as [`ChannelEntry::kind`].
    pub kind: u8,
    /// Constant or per node.
    pub storage: NodeStorage,
}

/// [`Header`] as version 4 stores it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct HeaderV4 {
    /// See [`Header::root_origin`].
    pub root_origin: [f64; 3],
    /// See [`Header::root_side`].
    pub root_side: f64,
    /// See [`Header::depth`].
    pub depth: u8,
    /// See [`Levels::layout`].
    pub layout: u8,
    /// See [`Header::node_count`].
    pub node_count: u64,
    /// See [`Header::leaf_count`].
    pub leaf_count: u64,
    /// See [`Levels::table`].
    pub levels: Vec<LevelEntry>,
    /// See [`Levels::node_channels`].
    pub node_channels: Vec<NodeChannelEntry>,
    /// See [`Header::channels`].
    pub channels: Vec<ChannelEntry>,
    /// See [`Header::build`].
    pub build: BuildInfo,
}

impl From<HeaderV4> for Header {
    fn from(h: HeaderV4) -> Self {
        Self {
            root_origin: h.root_origin,
            root_side: h.root_side,
            depth: h.depth,
            node_count: h.node_count,
            leaf_count: h.leaf_count,
            nodes: ArrayRef::default(),
            channels: h.channels,
            build: h.build,
            chunks: None,
            levels: Some(Levels {
                layout: h.layout,
                table: h.levels,
                node_channels: h.node_channels,
            }),
        }
    }
}

impl HeaderV4 {
    /// The version-4 form of a header with levels (`l`).
    pub(crate) fn of(h: &Header, l: &Levels) -> Self {
        Self {
            root_origin: h.root_origin,
            root_side: h.root_side,
            depth: h.depth,
            layout: l.layout,
            node_count: h.node_count,
            leaf_count: h.leaf_count,
            levels: l.table.clone(),
            node_channels: l.node_channels.clone(),
            channels: h.channels.clone(),
            build: h.build.clone(),
        }
    }
}

/// [`Header`] as version 3 stores it: the chunk level, count and table after the depth.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct HeaderV3 {
    /// See [`Header::root_origin`].
    pub root_origin: [f64; 3],
    /// See [`Header::root_side`].
    pub root_side: f64,
    /// See [`Header::depth`].
    pub depth: u8,
    /// See [`Chunking::level`].
    pub chunk_level: u8,
    /// See [`Chunking::count`].
    pub chunk_count: u64,
    /// Nodes of all chunks.
    pub node_count: u64,
    /// Leaves of all chunks.
    pub leaf_count: u64,
    /// See [`Chunking::table`].
    pub chunks: ArrayRef,
    /// The chunks' node arrays, one after another.
    pub nodes: ArrayRef,
    /// See [`Header::channels`].
    pub channels: Vec<ChannelEntry>,
    /// See [`Header::build`].
    pub build: BuildInfo,
}

impl From<HeaderV3> for Header {
    fn from(h: HeaderV3) -> Self {
        Self {
            root_origin: h.root_origin,
            root_side: h.root_side,
            depth: h.depth,
            node_count: h.node_count,
            leaf_count: h.leaf_count,
            nodes: h.nodes,
            channels: h.channels,
            build: h.build,
            chunks: Some(Chunking {
                level: h.chunk_level,
                count: h.chunk_count,
                table: h.chunks,
            }),
            levels: None,
        }
    }
}

impl HeaderV3 {
    /// The version-3 form of a header with chunks (`c`).
    pub(crate) fn of(h: &Header, c: Chunking) -> Self {
        Self {
            root_origin: h.root_origin,
            root_side: h.root_side,
            depth: h.depth,
            chunk_level: c.level,
            chunk_count: c.count,
            node_count: h.node_count,
            leaf_count: h.leaf_count,
            chunks: c.table,
            nodes: h.nodes,
            channels: h.channels.clone(),
            build: h.build.clone(),
        }
    }
}

/// The bincode configuration of the header.
pub(crate) fn bincode_config() -> impl bincode::config::Config {
    bincode::config::standard()
        .with_fixed_int_encoding()
        .with_little_endian()
        .with_limit::<MAX_HEADER_LEN>()
}
