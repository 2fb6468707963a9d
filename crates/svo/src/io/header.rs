//! The `.svo` file header (format version 2; version 1 is still read); `docs/format.md`
//! gives every byte.
//!
//! ```text
//! offset  size  field
//! 0       8     magic 89 53 56 4F 0D 0A 1A 0A ("\x89SVO\r\n\x1a\n")
//! 8       4     format version, u32 LE (2)
//! 12      4     header length H, u32 LE (at most 65536)
//! 16      H     header: bincode 2, standard config with fixed-width little-endian integers
//! ...           zero padding to a multiple of 8
//! ...           arrays, each at the 8-aligned offset the header names, zero-padded to 8
//! end-8   8     xxh3-64 of every byte before it, u64 LE
//! ```

use crate::mesh::scene_info::SceneInfo;
use serde::{Deserialize, Serialize};

/// The file's first 8 bytes.
pub const MAGIC: [u8; 8] = *b"\x89SVO\r\n\x1a\n";
/// The format version this library writes (and the newest it reads; it reads version 1 too).
pub const VERSION: u32 = crate::octree::format_check::CURRENT_VERSION;
/// The largest header accepted.
pub const MAX_HEADER_LEN: usize = 1 << 16;
/// Bytes before the header: magic, version, header length.
pub const PREAMBLE_LEN: usize = 16;

/// Where an array sits in the file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ArrayRef {
    /// Byte offset from the start of the file (a multiple of 8).
    pub offset: u64,
    /// Length in bytes (elements times element size, without padding).
    pub len: u64,
}

/// How a channel is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Storage {
    /// One value for all leaves, stored here (the value's bits, zero-extended to `u32`).
    Constant(u32),
    /// One value per leaf, in an array.
    PerLeaf(ArrayRef),
}

/// One stored channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChannelEntry {
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
pub struct BuildInfoV1 {
    /// See [`BuildInfo::generator`].
    pub generator: String,
    /// See [`BuildInfo::strategy`].
    pub strategy: String,
    /// See [`BuildInfo::source_triangles`].
    pub source_triangles: u64,
}

/// [`Header`] as version 1 stored it: the same fields, without the scene.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct HeaderV1 {
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
        }
    }
}

/// The header, version 2.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
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
}

/// The bincode configuration of the header.
pub fn bincode_config() -> impl bincode::config::Config {
    bincode::config::standard()
        .with_fixed_int_encoding()
        .with_little_endian()
        .with_limit::<MAX_HEADER_LEN>()
}
