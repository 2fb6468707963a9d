//! `.binvox` export: the dense, run-length-encoded format that binvox, cuda_voxelizer and
//! trimesh read. The grid is the root cube: `dim` = `2^depth`, `translate` = the root's
//! origin, `scale` = the root's side. Voxel order: x slowest, then z, then y fastest.

use crate::io::atomic_write::write_atomic;
use crate::octree::tree::Octree;
use std::io::Write;
use std::path::Path;
use thiserror::Error;

/// The deepest tree exported as binvox (a 1024^3 grid).
pub(crate) const MAX_BINVOX_DEPTH: u8 = 10;

/// Errors of the dense exports.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The grid is too large for the format.
    #[error(
        "{format} holds grids up to {max}^3; depth {depth} needs {need}^3 (bake at a smaller depth, or write .svo)"
    )]
    TooLarge {
        /// The format.
        format: &'static str,
        /// Its largest grid side.
        max: u64,
        /// The tree's depth.
        depth: u8,
        /// The tree's grid side.
        need: u64,
    },
    /// Writing failed.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's error.
        cause: std::io::Error,
    },
}

/// The binvox linear index of a cell.
pub(crate) fn binvox_index(x: u32, y: u32, z: u32, dim: u64) -> u64 {
    u64::from(x) * dim * dim + u64::from(z) * dim + u64::from(y)
}

/// Writes the octree's leaf cells as a binvox grid.
pub fn write_binvox(tree: &Octree, path: &Path) -> Result<u64, ExportError> {
    if tree.depth > MAX_BINVOX_DEPTH {
        return Err(ExportError::TooLarge {
            format: "binvox",
            max: 1 << MAX_BINVOX_DEPTH,
            depth: tree.depth,
            need: 1 << tree.depth,
        });
    }
    let dim = 1u64 << tree.depth;
    let mut idx: Vec<u64> = tree
        .leaves()
        .map(|l| binvox_index(l.cell.x, l.cell.y, l.cell.z, dim))
        .collect();
    idx.sort_unstable();
    let mut out: Vec<u8> = Vec::with_capacity(idx.len() / 4 + 256);
    let o = tree.root.origin;
    write!(
        out,
        "#binvox 1\ndim {dim} {dim} {dim}\ntranslate {} {} {}\nscale {}\ndata\n",
        o.x, o.y, o.z, tree.root.side
    )
    .map_err(|cause| ExportError::Io {
        path: path.display().to_string(),
        cause,
    })?;
    let total = dim * dim * dim;
    let run = |value: u8, mut n: u64, out: &mut Vec<u8>| {
        while n > 0 {
            let k = n.min(255);
            out.push(value);
            out.push(k as u8);
            n -= k;
        }
    };
    let mut pos = 0u64;
    let mut i = 0;
    while i < idx.len() {
        let start = idx[i];
        let mut end = start + 1;
        i += 1;
        while i < idx.len() && idx[i] == end {
            end += 1;
            i += 1;
        }
        run(0, start - pos, &mut out);
        run(1, end - start, &mut out);
        pos = end;
    }
    run(0, total - pos, &mut out);
    write_atomic(path, |w| w.write_all(&out)).map_err(|cause| ExportError::Io {
        path: path.display().to_string(),
        cause,
    })?;
    Ok(out.len() as u64)
}

/// A binvox grid as read back: `dim`, `translate`, `scale` and the occupied cells.
pub type BinvoxGrid = (u64, [f64; 3], f64, Vec<[u32; 3]>);

/// Reads a binvox file's header and occupied cells (for tests and round trips).
pub fn read_binvox(bytes: &[u8]) -> Option<BinvoxGrid> {
    let data_at = bytes.windows(5).position(|w| w == b"data\n")? + 5;
    let head = std::str::from_utf8(&bytes[..data_at]).ok()?;
    let mut dim = 0u64;
    let mut tr = [0.0; 3];
    let mut scale = 0.0;
    for line in head.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first() {
            Some(&"dim") if w.len() == 4 => dim = w[1].parse().ok()?,
            Some(&"translate") if w.len() == 4 => {
                for k in 0..3 {
                    tr[k] = w[k + 1].parse().ok()?;
                }
            }
            Some(&"scale") if w.len() == 2 => scale = w[1].parse().ok()?,
            _ => {}
        }
    }
    if dim == 0 || dim > 1024 {
        return None;
    }
    let mut cells = Vec::new();
    let mut pos = 0u64;
    for pair in bytes[data_at..].chunks_exact(2) {
        let (v, n) = (pair[0], u64::from(pair[1]));
        if v == 1 {
            for p in pos..pos + n {
                let x = p / (dim * dim);
                let z = (p / dim) % dim;
                let y = p % dim;
                cells.push([x as u32, y as u32, z as u32]);
            }
        }
        pos += n;
    }
    (pos == dim * dim * dim).then_some((dim, tr, scale, cells))
}
