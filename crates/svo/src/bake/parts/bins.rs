//! Each part's triangles in a file of its own, written when a bake is planned, so that a part
//! loads only the triangles that may touch its subtrees instead of the whole mesh.
//!
//! A bin file (`NAME.IIIII.svobin` beside the plan `NAME.svoplan`) is, in order: the magic
//! `\x89SVOBIN\n`, a `u32` version, the plan's hash (`u64`), the part's index (`u32`), the
//! body's length (`u64`), the body (bincode, as the plan: the vertices the part's triangles
//! use, its triangles in the mesh's order with their vertex indices moved, their texture
//! coordinates and materials, the mesh's materials and scene as they are, and its textures,
//! those that no triangle of the part samples left empty in their places), and the XXH3-64 of
//! everything before it. A part is baked from its bin with the plan's root cube
//! and hands over the bytes it would from the whole mesh: the triangles it keeps are those the
//! part would set up from the whole mesh (every triangle whose bounds reach a node of its
//! range), in the same relative order, and every value the bake derives from a triangle comes
//! from its own vertices, coordinates and material.

use crate::bake::parts::part::touched_lists;
use crate::bake::parts::plan::{BakePlan, PartsError, indexed_sibling};
use crate::io::atomic_write::write_atomic;
use crate::mesh::SceneInfo;
use crate::mesh::triangle_mesh::{Material, Mesh, Texture};
use glam::{DVec3, Vec2};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

const BIN_MAGIC: [u8; 8] = *b"\x89SVOBIN\n";
const BIN_VERSION: u32 = 2;
/// Magic, version, plan hash, index, body length.
const BIN_PREAMBLE: usize = 32;

/// The file holding part `index`'s triangles of the plan at `plan_path`.
pub(crate) fn bin_path(plan_path: &Path, index: u32) -> PathBuf {
    indexed_sibling(plan_path, index, "svobin")
}

#[derive(Serialize, Deserialize)]
struct BinMaterial {
    name: String,
    colour: [f32; 4],
    texture: Option<u64>,
    reflectivity: f32,
    refractivity: f32,
    ior: f32,
    alpha_blend: bool,
}

#[derive(Serialize, Deserialize)]
struct BinTexture {
    width: u32,
    height: u32,
    rgba: Vec<[u8; 4]>,
}

#[derive(Serialize, Deserialize)]
struct BinMesh {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    uvs: Vec<[f32; 2]>,
    triangle_uvs: Vec<[u32; 3]>,
    triangle_materials: Vec<u32>,
    materials: Vec<BinMaterial>,
    textures: Vec<BinTexture>,
    scene: SceneInfo,
}

fn config() -> impl bincode::config::Config {
    bincode::config::standard()
        .with_fixed_int_encoding()
        .with_little_endian()
}

/// What writing the bins did.
#[derive(Clone, Debug, PartialEq)]
pub struct BinsReport {
    /// Bin files written, one per part.
    pub files: u32,
    /// Their bytes together.
    pub bytes: u64,
    /// Triangles in all the bins together (a triangle near a boundary is in several).
    pub triangles: u64,
    /// The first bin's path (part I's is `NAME.IIIII.svobin` beside the plan `NAME.svoplan`).
    pub first: String,
}

/// The part of `mesh` made of triangles `tris` (indices into `mesh.triangles`, in order):
/// the vertices and texture coordinates they use, renumbered in order of first use.
fn subset(mesh: &Mesh, tris: &[u32]) -> BinMesh {
    let mut vertex = vec![u32::MAX; mesh.positions.len()];
    let mut uv = vec![u32::MAX; mesh.uvs.len()];
    let mut out = BinMesh {
        positions: Vec::new(),
        triangles: Vec::with_capacity(tris.len()),
        uvs: Vec::new(),
        triangle_uvs: Vec::new(),
        triangle_materials: Vec::new(),
        materials: mesh
            .materials
            .iter()
            .map(|m| BinMaterial {
                name: m.name.clone(),
                colour: m.colour,
                texture: m.texture.map(|t| t as u64),
                reflectivity: m.reflectivity,
                refractivity: m.refractivity,
                ior: m.ior,
                alpha_blend: m.alpha_blend,
            })
            .collect(),
        textures: Vec::new(),
        scene: mesh.scene.clone(),
    };
    let remap = |table: &mut Vec<u32>, i: u32, push: &mut dyn FnMut(usize) -> u32| -> u32 {
        match table.get(i as usize) {
            Some(&u32::MAX) => {
                let n = push(i as usize);
                table[i as usize] = n;
                n
            }
            Some(&n) => n,
            // An index out of range stays out of range (the bake refuses the mesh as it would
            // have refused the whole one).
            None => u32::MAX,
        }
    };
    for &t in tris {
        let Some(tri) = mesh.triangles.get(t as usize) else {
            continue;
        };
        let positions = &mut out.positions;
        out.triangles.push(tri.map(|i| {
            remap(&mut vertex, i, &mut |i| {
                positions.push(mesh.positions[i].to_array());
                (positions.len() - 1) as u32
            })
        }));
        if let Some(tuv) = mesh.triangle_uvs.get(t as usize) {
            let uvs = &mut out.uvs;
            out.triangle_uvs.push(tuv.map(|i| {
                remap(&mut uv, i, &mut |i| {
                    uvs.push(mesh.uvs[i].to_array());
                    (uvs.len() - 1) as u32
                })
            }));
        }
        if let Some(&m) = mesh.triangle_materials.get(t as usize) {
            out.triangle_materials.push(m);
        }
    }
    // Textures that no triangle of the part samples keep their place but not their texels.
    let mut material_used = vec![false; mesh.materials.len().max(1)];
    if out.triangle_materials.is_empty() {
        material_used[0] = !out.triangles.is_empty();
    }
    for &m in &out.triangle_materials {
        if let Some(u) = material_used.get_mut(m as usize) {
            *u = true;
        }
    }
    let mut sampled = vec![false; mesh.textures.len()];
    for (material, used) in mesh.materials.iter().zip(&material_used) {
        if let Some(s) = material.texture.and_then(|t| sampled.get_mut(t)) {
            *s |= *used;
        }
    }
    out.textures = mesh
        .textures
        .iter()
        .zip(sampled)
        .map(|(t, used)| BinTexture {
            width: if used { t.width } else { 0 },
            height: if used { t.height } else { 0 },
            rgba: if used { t.rgba.clone() } else { Vec::new() },
        })
        .collect();
    if out.triangles.is_empty() && !mesh.triangle_uvs.is_empty() {
        // Whether the mesh has texture coordinates decides how a part stores its colours,
        // leaves or none: a part without triangles keeps the mark (a part's bin with no
        // triangles is not checked as a mesh).
        out.uvs.push([0.0; 2]);
        out.triangle_uvs.push([0; 3]);
    }
    out
}

fn to_mesh(b: BinMesh) -> Mesh {
    Mesh {
        positions: b.positions.into_iter().map(DVec3::from_array).collect(),
        triangles: b.triangles,
        uvs: b.uvs.into_iter().map(Vec2::from_array).collect(),
        triangle_uvs: b.triangle_uvs,
        triangle_materials: b.triangle_materials,
        materials: b
            .materials
            .into_iter()
            .map(|m| Material {
                name: m.name,
                colour: m.colour,
                texture: m.texture.map(|t| t as usize),
                reflectivity: m.reflectivity,
                refractivity: m.refractivity,
                ior: m.ior,
                alpha_blend: m.alpha_blend,
            })
            .collect(),
        textures: b
            .textures
            .into_iter()
            .map(|t| Texture {
                width: t.width,
                height: t.height,
                rgba: t.rgba,
            })
            .collect(),
        scene: b.scene,
    }
}

/// Writes each part's triangles of `plan` (made from `mesh`, whose file's hash is
/// `plan_hash`'s plan's) to its bin file beside `plan_path`, atomically, one part at a time.
pub(crate) fn write_bins(
    mesh: &Mesh,
    plan: &BakePlan,
    plan_path: &Path,
    plan_hash: u64,
) -> Result<BinsReport, PartsError> {
    let all: Vec<u32> = (0..plan.part_count()).collect();
    let lists = touched_lists(mesh, plan, 0..mesh.triangles.len() as u32, &all);
    let mut report = BinsReport {
        files: 0,
        bytes: 0,
        triangles: 0,
        first: bin_path(plan_path, 0).display().to_string(),
    };
    for (index, tris) in lists.iter().enumerate() {
        let body = bincode::serde::encode_to_vec(subset(mesh, tris), config()).map_err(|e| {
            PartsError::Unsupported(format!("encoding part {index}'s triangles: {e}"))
        })?;
        let mut head = Vec::with_capacity(BIN_PREAMBLE);
        head.extend_from_slice(&BIN_MAGIC);
        head.extend_from_slice(&BIN_VERSION.to_le_bytes());
        head.extend_from_slice(&plan_hash.to_le_bytes());
        head.extend_from_slice(&(index as u32).to_le_bytes());
        head.extend_from_slice(&(body.len() as u64).to_le_bytes());
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        h.update(&head);
        h.update(&body);
        let path = bin_path(plan_path, index as u32);
        write_atomic(&path, |w| {
            w.write_all(&head)?;
            w.write_all(&body)?;
            w.write_all(&h.digest().to_le_bytes())
        })
        .map_err(|e| PartsError::io(&path, e))?;
        report.files += 1;
        report.bytes += (head.len() + body.len() + 8) as u64;
        report.triangles += tris.len() as u64;
    }
    Ok(report)
}

/// Reads and checks part `index`'s bin file of the plan whose hash is `plan_hash`.
pub(crate) fn read_bin(path: &Path, plan_hash: u64, index: u32) -> Result<Mesh, PartsError> {
    let bytes = std::fs::read(path).map_err(|e| PartsError::io(path, e))?;
    let corrupt = |detail: String| PartsError::Corrupt {
        path: path.display().to_string(),
        detail,
    };
    if bytes.len() < BIN_PREAMBLE + 8 || bytes[..8] != BIN_MAGIC {
        return Err(corrupt("not an svo bin file (bad magic bytes)".into()));
    }
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap_or_default());
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap_or_default());
    if u32_at(8) != BIN_VERSION {
        return Err(corrupt(format!(
            "bin version {} (this svo reads version {BIN_VERSION})",
            u32_at(8)
        )));
    }
    let len = u64_at(24);
    if (bytes.len() as u64).checked_sub((BIN_PREAMBLE + 8) as u64) != Some(len) {
        return Err(corrupt("truncated or overlong bin file".into()));
    }
    let data = &bytes[..bytes.len() - 8];
    if u64_at(bytes.len() - 8) != xxhash_rust::xxh3::xxh3_64(data) {
        return Err(corrupt("checksum mismatch: the bin file is corrupt".into()));
    }
    if u64_at(12) != plan_hash {
        return Err(PartsError::Mismatch {
            path: path.display().to_string(),
            detail: "the bin belongs to another plan".into(),
        });
    }
    if u32_at(20) != index {
        return Err(PartsError::Mismatch {
            path: path.display().to_string(),
            detail: format!("the bin holds part {}, not part {index}", u32_at(20)),
        });
    }
    let (b, used): (BinMesh, usize) =
        bincode::serde::decode_from_slice(&data[BIN_PREAMBLE..], config())
            .map_err(|e| corrupt(format!("undecodable bin: {e}")))?;
    if used as u64 != len {
        return Err(corrupt("trailing bytes in the bin's body".into()));
    }
    Ok(to_mesh(b))
}
