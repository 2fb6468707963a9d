//! The numbered checks of a `.svo` file (`docs/format.md`, "What a reader checks"), applied
//! in the order of their numbers except check 19 (version 3's chunk table), which comes
//! between 13 and 14, and checks 20 to 22 (version 4's header checksum, level table and level
//! checksums), which come after 5, after 11 and after 13. Every [`crate::io::FormatError`] about a file's
//! contents names the check that failed; the tree checks (14 to 18) are also what
//! [`crate::Octree::validate`] runs on a tree in memory.

use std::fmt;

/// The newest format version this library reads and writes: version 4 (nodes level by level,
/// with the inner nodes' channels) for a tree with inner-node attributes, version 3 (a tree
/// stored in chunks) when a tree needs it or when asked, version 2 otherwise.
pub(crate) const CURRENT_VERSION: u32 = 4;

/// The version that stores a tree in chunks.
#[cfg_attr(not(feature = "io"), allow(dead_code))]
pub(crate) const CHUNKED_VERSION: u32 = 3;

/// The version that stores the nodes level by level, each level's inner-node channels beside
/// its nodes.
#[cfg_attr(not(feature = "io"), allow(dead_code))]
pub(crate) const LEVELS_VERSION: u32 = 4;

/// The version of a file that holds one tree in one node array: what the writer makes of a
/// tree unless chunks are asked for.
#[cfg_attr(not(feature = "io"), allow(dead_code))]
pub(crate) const PLAIN_VERSION: u32 = 2;

/// Version 4's `layout` byte of the DAG layout (`docs/format.md`, section 12); 0 is the
/// tree.
#[cfg_attr(not(feature = "io"), allow(dead_code))]
pub(crate) const DAG_LAYOUT: u8 = 1;

/// The deepest chunk level of a version-3 file: the chunks' Morton codes are 64-bit.
#[cfg_attr(not(feature = "io"), allow(dead_code, unreachable_pub))]
pub const MAX_CHUNK_LEVEL: u8 = 21;

/// One of the reader's checks of a `.svo` file, numbered as in `docs/format.md`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[non_exhaustive]
pub enum Check {
    /// 1: the file starts with the 8 magic bytes.
    Magic,
    /// 2: the file holds at least the preamble and the checksum (24 bytes).
    Size,
    /// 3: the version is 1 to 4 (a newer one is reported as such).
    Version,
    /// 4: the header length is at most 65,536 and the header ends before the checksum.
    HeaderLength,
    /// 5: the checksum (XXH3-64, seed 0) over every byte before it.
    Checksum,
    /// 6: the header decodes in exactly its length.
    Header,
    /// 7: the depth is 1 to 30 (version 3: and the chunk level at most `depth - 1` and 21).
    Depth,
    /// 8: the root cube's origin is finite and its side finite and positive.
    RootCube,
    /// 9: at least one node; at most 2^31 leaves and at most 8 per node (version 3: at most 8
    /// leaves per node, no more chunks than nodes or than cells at the chunk level).
    Counts,
    /// 10: channel kinds known, increasing; constants that fit their element; a contour
    /// only with a normal.
    Channels,
    /// 11: the stored lights and camera views.
    Scene,
    /// 12: the arrays where the canonical layout puts them, with the lengths the counts give,
    /// and the checksum right after the last.
    ArrayLayout,
    /// 13: every padding byte is zero.
    Padding,
    /// 14: the reserved bits of every node's `info` are zero.
    NodeWords,
    /// 15: only the root may have no children; exactly the nodes one level above the leaves
    /// refer to leaves.
    TreeShape,
    /// 16: every children block where the canonical node order puts it, and no other node.
    NodeOrder,
    /// 17: leaves numbered in depth-first child order, each referenced once.
    LeafOrder,
    /// 18: the stored values: normal words, contours, interior leaves.
    Values,
    /// 19 (version 3, applied after 13 and before 14): the chunk table's codes increase and
    /// lie on the grid of the chunk level; each chunk's node and leaf counts are possible and
    /// they add up to the header's.
    Chunks,
    /// 20 (version 4, applied after 5): the header checksum after the header.
    HeaderChecksum,
    /// 21 (version 4, applied after 11): the layout is the tree, and the level table has one
    /// entry a level, the root alone on level 0, at most 8 nodes a node of the level above,
    /// and the header's node count in all.
    Levels,
    /// 22 (version 4, applied after 13): each level's block has the checksum its entry holds.
    LevelChecksums,
}

impl Check {
    /// Every check, by number.
    pub const ALL: [Check; 22] = [
        Self::Magic,
        Self::Size,
        Self::Version,
        Self::HeaderLength,
        Self::Checksum,
        Self::Header,
        Self::Depth,
        Self::RootCube,
        Self::Counts,
        Self::Channels,
        Self::Scene,
        Self::ArrayLayout,
        Self::Padding,
        Self::NodeWords,
        Self::TreeShape,
        Self::NodeOrder,
        Self::LeafOrder,
        Self::Values,
        Self::Chunks,
        Self::HeaderChecksum,
        Self::Levels,
        Self::LevelChecksums,
    ];

    /// The check's number in `docs/format.md` (1 to 22).
    pub fn number(self) -> u8 {
        Self::ALL
            .iter()
            .position(|&c| c == self)
            .map_or(0, |i| i as u8 + 1)
    }

    /// The check's short name, as `docs/format.md` and the corpus manifest spell it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Magic => "magic",
            Self::Size => "size",
            Self::Version => "version",
            Self::HeaderLength => "header length",
            Self::Checksum => "checksum",
            Self::Header => "header",
            Self::Depth => "depth",
            Self::RootCube => "root cube",
            Self::Counts => "counts",
            Self::Channels => "channels",
            Self::Scene => "scene",
            Self::ArrayLayout => "array layout",
            Self::Padding => "padding",
            Self::NodeWords => "node words",
            Self::TreeShape => "tree shape",
            Self::NodeOrder => "node order",
            Self::LeafOrder => "leaf order",
            Self::Values => "values",
            Self::Chunks => "chunks",
            Self::HeaderChecksum => "header checksum",
            Self::Levels => "levels",
            Self::LevelChecksums => "level checksums",
        }
    }

    /// The check with number `n`.
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    pub fn from_number(n: u8) -> Option<Check> {
        Self::ALL.get(usize::from(n).checked_sub(1)?).copied()
    }
}

impl fmt::Display for Check {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "check {} ({})", self.number(), self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_names_round_trip() {
        for (i, c) in Check::ALL.iter().enumerate() {
            assert_eq!(usize::from(c.number()), i + 1);
            assert_eq!(Check::from_number(c.number()), Some(*c));
        }
        assert_eq!(Check::from_number(0), None);
        assert_eq!(Check::from_number(23), None);
        assert_eq!(Check::Checksum.to_string(), "check 5 (checksum)");
        let names: std::collections::BTreeSet<_> = Check::ALL.iter().map(|c| c.name()).collect();
        assert_eq!(names.len(), Check::ALL.len());
    }
}
