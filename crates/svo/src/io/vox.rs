//! MagicaVoxel `.vox` export through the `dot_vox` crate, for trees whose grid fits one
//! model (depth 8 and below: 256^3).
//!
//! MagicaVoxel is Z-up; our trees are Y-up, so a cell `(x, y, z)` becomes the voxel
//! `(x, dim - 1 - z, y)`. Colours go into a palette of at most 255 entries: exact when
//! the tree has that few colours, otherwise a 6 x 7 x 6 colour cube.

use crate::io::atomic_write::write_atomic;
use crate::io::binvox::ExportError;
use crate::octree::tree::Octree;
use dot_vox::{Color, DotVoxData, Model, Size, Voxel};
use std::collections::BTreeMap;
use std::path::Path;

/// The deepest tree exported as `.vox`.
pub(crate) const MAX_VOX_DEPTH: u8 = 8;

fn cube_index(c: [u8; 4]) -> u8 {
    let q = |v: u8, n: u32| ((u32::from(v) * (n - 1) + 127) / 255) as u8;
    q(c[0], 6) * 42 + q(c[1], 7) * 6 + q(c[2], 6)
}

/// Converts the tree to MagicaVoxel data.
pub(crate) fn to_vox(tree: &Octree) -> Result<DotVoxData, ExportError> {
    if tree.depth > MAX_VOX_DEPTH {
        return Err(ExportError::TooLarge {
            format: "vox",
            max: 1 << MAX_VOX_DEPTH,
            depth: tree.depth,
            need: 1 << tree.depth,
        });
    }
    let dim = 1u32 << tree.depth;
    let colour = |i: u32| {
        tree.attributes
            .colour
            .get(i as usize)
            .map_or([204, 204, 204, 255], u32::to_le_bytes)
    };
    let mut distinct: BTreeMap<[u8; 4], u8> = BTreeMap::new();
    for l in tree.leaves() {
        let c = colour(l.index);
        if distinct.len() <= 255 && !distinct.contains_key(&c) {
            distinct.insert(c, 0);
        }
    }
    let exact = distinct.len() <= 255;
    let mut palette: Vec<Color> = Vec::with_capacity(256);
    if exact {
        for (k, (c, slot)) in distinct.iter_mut().enumerate() {
            *slot = k as u8;
            palette.push(Color {
                r: c[0],
                g: c[1],
                b: c[2],
                a: c[3],
            });
        }
    } else {
        for r in 0..6u32 {
            for g in 0..7u32 {
                for b in 0..6u32 {
                    let s = |v: u32, n: u32| (v * 255 / (n - 1)) as u8;
                    palette.push(Color {
                        r: s(r, 6),
                        g: s(g, 7),
                        b: s(b, 6),
                        a: 255,
                    });
                }
            }
        }
    }
    palette.resize(
        256,
        Color {
            r: 0,
            g: 0,
            b: 0,
            a: 255,
        },
    );
    let voxels = tree
        .leaves()
        .map(|l| {
            let c = colour(l.index);
            let i = if exact { distinct[&c] } else { cube_index(c) };
            Voxel {
                x: l.cell.x as u8,
                y: (dim - 1 - l.cell.z) as u8,
                z: l.cell.y as u8,
                i,
            }
        })
        .collect();
    Ok(DotVoxData {
        version: 150,
        index_map: (0..=255u8).collect(),
        models: vec![Model {
            size: Size {
                x: dim,
                y: dim,
                z: dim,
            },
            voxels,
        }],
        palette,
        materials: Vec::new(),
        scenes: Vec::new(),
        layers: Vec::new(),
    })
}

/// Writes the tree as a `.vox` file.
pub fn write_vox(tree: &Octree, path: &Path) -> Result<u64, ExportError> {
    let data = to_vox(tree)?;
    let mut bytes = Vec::new();
    let io = |cause| ExportError::Io {
        path: path.display().to_string(),
        cause,
    };
    data.write_vox(&mut bytes).map_err(io)?;
    write_atomic(path, |w| w.write_all(&bytes)).map_err(io)?;
    Ok(bytes.len() as u64)
}
