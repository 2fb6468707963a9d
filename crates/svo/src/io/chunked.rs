//! A version-3 file read one chunk at a time ([`ChunkedFile`]): what holds a tree past 2^31
//! leaves or nodes, more than one [`Octree`] in memory holds. Opening the file checks all of it
//! but the values, one chunk at a time; each chunk then reads as an ordinary tree of its own
//! (its root cube the cell of the chunk's root), which every tool of the library takes.

use crate::geometry::grid::RootCube;
use crate::io::header::{BuildInfo, ChannelEntry, ChunkRecord};
use crate::io::read::{
    ChunkArrays, ChunksRead, check_chunks_file, chunk_channel, chunk_starts, in_chunk,
    read_channels, read_chunks_file,
};
use crate::io::write::FormatError;
use crate::octree::format_check::Check;
use crate::octree::tree::{Node, Octree};
use crate::octree::validate::{check_chunk, check_values};
use glam::{DVec3, UVec3};
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// A version-3 `.svo` file opened for reading chunk by chunk, holding its header and chunk
/// table only.
///
/// ```
/// use glam::{DVec3, UVec3};
/// use svo::io::{BuildInfo, ChunkedFile, write_chunked_to};
/// use svo::{Octree, RootCube, Voxel};
/// let root = RootCube { origin: DVec3::ZERO, side: 8.0 };
/// let cells = [UVec3::ZERO, UVec3::new(7, 2, 5)].map(|c| (c, Voxel::glass()));
/// let tree = Octree::from_cells(root, 3, cells)?;
/// let path = std::env::temp_dir().join("svo-chunked-doc.svo");
/// let mut bytes = Vec::new();
/// write_chunked_to(&tree, &BuildInfo::new(), 1, &mut bytes)?;
/// std::fs::write(&path, bytes)?;
/// let file = ChunkedFile::open(&path)?; // every check but the values', a chunk at a time
/// assert_eq!((file.len(), file.leaf_count()), (2, 2));
/// let far = file.read_chunk(1)?; // the subtree of the root's child 5 (x and z high)
/// assert_eq!(file.chunk_cell(1), UVec3::new(1, 0, 1));
/// assert_eq!((far.depth, far.root.origin, far.root.side), (2, DVec3::new(4.0, 0.0, 4.0), 4.0));
/// assert_eq!(far.leaf_at(UVec3::new(3, 2, 1)), Some(0)); // cell (7, 2, 5) of the whole tree
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct ChunkedFile {
    path: PathBuf,
    read: ChunksRead,
    /// Each chunk's first node and first leaf in the file's arrays.
    starts: Vec<(u64, u64)>,
}

impl ChunkedFile {
    /// Opens and checks a version-3 file: checks 1 to 17 and 19 and the checksum, reading each
    /// chunk's nodes in turn (one chunk in memory at a time); the values (check 18) are
    /// checked as each chunk is read. A file of another version is refused with a
    /// [`FormatError`] saying so.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, FormatError> {
        let path = path.as_ref();
        let read = check_chunks_file(path)?;
        let starts = chunk_starts(&read.table);
        Ok(Self {
            path: path.to_path_buf(),
            read,
            starts,
        })
    }

    /// Opens a version-3 file as [`ChunkedFile::open`] does and reads every chunk in the same
    /// pass (each byte of the file is read once), as [`ChunkedFile::read_chunk`] would read
    /// them: chunk `i` of the list is `read_chunk(i)`. The whole tree is then in memory, in
    /// as many trees as the file has chunks.
    pub fn load(path: impl AsRef<Path>) -> Result<(Self, Vec<Octree>), FormatError> {
        let path = path.as_ref();
        let (read, arrays) = read_chunks_file(path)?;
        let starts = chunk_starts(&read.table);
        let file = Self {
            path: path.to_path_buf(),
            read,
            starts,
        };
        // Each chunk's checks and bounds, on every thread; the first chunk that fails is named.
        let tree = |(i, a)| file.chunk_tree(i, a);
        #[cfg(feature = "parallel")]
        let trees: Vec<Result<Octree, FormatError>> = {
            use rayon::prelude::*;
            arrays.into_par_iter().enumerate().map(tree).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let trees: Vec<Result<Octree, FormatError>> =
            arrays.into_iter().enumerate().map(tree).collect();
        let trees = trees.into_iter().collect::<Result<_, _>>()?;
        Ok((file, trees))
    }

    /// Chunks.
    pub fn len(&self) -> usize {
        self.read.table.len()
    }

    /// Whether the tree is empty (no chunk).
    pub fn is_empty(&self) -> bool {
        self.read.table.is_empty()
    }

    /// The whole tree's root cube.
    pub fn root(&self) -> RootCube {
        let h = &self.read.preamble.header;
        RootCube {
            origin: DVec3::from_array(h.root_origin),
            side: h.root_side,
        }
    }

    /// The whole tree's depth.
    pub fn depth(&self) -> u8 {
        self.read.preamble.header.depth
    }

    /// The level of the chunks' roots.
    pub fn level(&self) -> u8 {
        self.chunking().level
    }

    /// The whole tree's leaves.
    pub fn leaf_count(&self) -> u64 {
        self.read.preamble.header.leaf_count
    }

    /// The chunks' nodes (the levels above them are not stored).
    pub fn node_count(&self) -> u64 {
        self.read.preamble.header.node_count
    }

    /// What made the file, and its lights and views.
    pub fn build(&self) -> &BuildInfo {
        &self.read.preamble.header.build
    }

    /// Chunk `i`'s leaves, and the whole tree's index of its first (leaves are numbered in
    /// the same order in both). Panics if `i >= self.len()`.
    pub fn chunk_leaves(&self, i: usize) -> (u64, u64) {
        (self.read.table[i].leaves, self.starts[i].1)
    }

    /// The cell of chunk `i`'s root, at the chunk level. Panics if `i >= self.len()`.
    pub fn chunk_cell(&self, i: usize) -> UVec3 {
        let code = self.read.table[i].code;
        let mut c = UVec3::ZERO;
        for l in 0..u32::from(self.level()) {
            let child = (code >> (3 * l) & 7) as u32;
            c |= UVec3::new(child >> 2 & 1, child >> 1 & 1, child & 1) << l;
        }
        c
    }

    /// Reads chunk `i` as a tree of its own: depth `depth - level`, its root cube the cell of
    /// its root, its leaves and their values those of the whole tree there (leaf `j` is the
    /// whole tree's leaf `chunk_leaves(i).1 + j`). Its nodes are checked again and its
    /// values checked (check 18). Panics if `i >= self.len()`.
    pub fn read_chunk(&self, i: usize) -> Result<Octree, FormatError> {
        let h = &self.read.preamble.header;
        let rec: ChunkRecord = self.read.table[i];
        let (node0, leaf0) = self.starts[i];
        let io = |cause| FormatError::Io {
            path: self.path.display().to_string(),
            cause,
        };
        let mut f = std::fs::File::open(&self.path).map_err(io)?;
        let mut read_at = |offset: u64, dst: &mut [u8]| -> Result<(), FormatError> {
            f.seek(SeekFrom::Start(offset)).map_err(io)?;
            f.read_exact(dst).map_err(io)
        };
        let mut nodes = vec![Node::default(); rec.nodes as usize];
        read_at(
            h.nodes.offset + 8 * node0,
            bytemuck::cast_slice_mut(&mut nodes),
        )?;
        // The chunk's stretch of each per-leaf array.
        let channels: Vec<ChannelEntry> = h
            .channels
            .iter()
            .map(|e| chunk_channel(e, leaf0, rec.leaves))
            .collect();
        let attributes = read_channels(&channels, &mut |r, dst| read_at(r.offset, dst))?;
        self.chunk_tree(i, ChunkArrays { nodes, attributes })
    }

    /// Chunk `i` as a tree of its own from its arrays: its nodes checked (checks 14 to 17),
    /// its values (check 18), and its nodes' bounds derived.
    fn chunk_tree(&self, i: usize, a: ChunkArrays) -> Result<Octree, FormatError> {
        let rec = self.read.table[i];
        let corrupt = |e: (Check, String)| {
            let (check, detail) = in_chunk(i, rec.code)(e);
            FormatError::Corrupt { check, detail }
        };
        check_chunk(&a.nodes, self.depth() - self.level(), rec.leaves).map_err(corrupt)?;
        let root = self.root();
        let side = root.side / f64::from(1u32 << self.level());
        let mut tree = Octree {
            root: RootCube {
                origin: root.origin + self.chunk_cell(i).as_dvec3() * side,
                side,
            },
            depth: self.depth() - self.level(),
            leaf_count: rec.leaves as u32,
            nodes: a.nodes,
            attributes: a.attributes,
            node_attributes: Default::default(),
        };
        check_values(&tree, self.read.preamble.version).map_err(corrupt)?;
        tree.refresh_checked_bounds();
        Ok(tree)
    }

    fn chunking(&self) -> crate::io::header::Chunking {
        self.read.preamble.header.chunks.unwrap_or_default()
    }
}
