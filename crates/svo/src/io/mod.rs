//! Files: the versioned `.svo` format (read with every field validated before use: a
//! corrupt, truncated or hostile file is an error, never a panic, a hang or an allocation
//! larger than the file; written atomically, so a failed write leaves the previous file or
//! none; version 3 stores a tree past 2^31 leaves or nodes as chunks, which [`ChunkedFile`]
//! reads one at a time), the `.binvox` export and reader, the MagicaVoxel `.vox` export
//! (feature `vox`), and [`describe_file`], the summary `svo-view --info` prints. `docs/format.md` gives every byte.
//!
//! ```
//! use glam::{DVec3, UVec3};
//! use svo::io::{BuildInfo, from_bytes, to_bytes};
//! use svo::{Octree, RootCube, Voxel};
//! let root = RootCube { origin: DVec3::ZERO, side: 1.0 };
//! let tree = Octree::from_cells(root, 3, [(UVec3::ONE, Voxel::glass())])?;
//! let bytes = to_bytes(&tree, &BuildInfo::new());
//! let (back, info) = from_bytes(&bytes)?; // every field checked before use
//! assert_eq!(back, tree);
//! assert!(from_bytes(&bytes[..bytes.len() - 1]).is_err()); // truncated: an error, no panic
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Depends on [`crate::octree`] and [`crate::mesh`] (the lights and views a file stores).

pub(crate) mod atomic_write;
pub(crate) mod binvox;
pub(crate) mod chunked;
pub(crate) mod describe;
pub(crate) mod header;
#[cfg(test)]
mod hostile_tests;
pub(crate) mod packed;
pub(crate) mod read;
#[cfg(feature = "vox")]
pub(crate) mod vox;
pub(crate) mod write;

pub use crate::octree::format_check::MAX_CHUNK_LEVEL;
pub use binvox::{BinvoxGrid, ExportError, read_binvox, write_binvox};
pub use chunked::ChunkedFile;
pub use describe::describe_file;
pub use header::{BuildInfo, VERSION};
#[cfg(feature = "trace")]
pub use read::read_dag_file;
pub use read::{
    LevelSizes, from_bytes, is_dag_file, read_file, read_file_to_depth, read_from, read_level_sizes,
};
#[cfg(feature = "vox")]
pub use vox::write_vox;
pub use write::{
    FormatError, to_bytes, write_chunked_to, write_dag_file, write_dag_file_with, write_dag_to,
    write_dag_to_with, write_file, write_to,
};
