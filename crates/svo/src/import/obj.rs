//! OBJ + MTL import through tobj (positions in `f64`), plain or gzipped. A geometry-only
//! file (no materials) is read by [`super::obj_geometry`] instead, which gives the same mesh
//! several times faster; anything it does not mirror exactly goes to tobj.
//!
//! Material mapping: colour = `Kd` (times `map_Kd`); reflectivity = the largest `Ks`
//! component for the mirror illumination models (`illum` 3, 4, 5, 6, 7), else 0;
//! refractivity = `1 - d`, where `d` comes from `d` or `1 - Tr` (tobj leaves `Tr` among the
//! unknown parameters); IOR = `Ni` (1.5 when absent).

use super::{io_error, parse_error};
use crate::mesh::triangle_mesh::{Material, Mesh, MeshError, Texture};
use glam::{DVec3, Vec2};
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

/// Loads an OBJ file (gzip-compressed when `gz`); MTL files and textures are looked up
/// beside it.
pub(crate) fn load_obj(path: &Path, gz: bool) -> Result<Mesh, MeshError> {
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mut file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    // Room for the whole file at once (for a gzipped one, the size its trailer states,
    // within reason: it is only a hint).
    let len = file.metadata().map_or(0, |m| m.len());
    let hint = if gz {
        gz_size_hint(&mut file, len)
    } else {
        len
    };
    let mut bytes = Vec::new();
    // Only a hint: without the memory, the buffer grows as it is read.
    let _ = bytes.try_reserve_exact(usize::try_from(hint).unwrap_or(0));
    if gz {
        flate2::read::GzDecoder::new(file).read_to_end(&mut bytes)
    } else {
        file.read_to_end(&mut bytes)
    }
    .map_err(|e| io_error(path, e))?;
    if let Some(mesh) = super::obj_geometry::parse(&bytes) {
        return Ok(mesh);
    }
    read_obj(&bytes, path, Some(&dir))
}

/// The uncompressed size a gzip file's trailer states (its last four bytes, modulo 2^32),
/// capped at 64 times the compressed size; 0 when it cannot be read. Leaves the file at its
/// start.
fn gz_size_hint(file: &mut std::fs::File, len: u64) -> u64 {
    use std::io::{Seek, SeekFrom};
    let mut tail = [0u8; 4];
    let ok = len >= 18
        && file.seek(SeekFrom::End(-4)).is_ok()
        && file.read_exact(&mut tail).is_ok()
        && file.seek(SeekFrom::Start(0)).is_ok();
    if ok {
        u64::from(u32::from_le_bytes(tail)).min(len.saturating_mul(64))
    } else {
        let _ = file.seek(SeekFrom::Start(0));
        0
    }
}

/// Reads an OBJ from memory (uncompressed). Material libraries and textures cannot be
/// resolved without a folder, so every triangle gets the default material; `name` appears
/// in error messages.
pub(crate) fn obj_from_bytes(bytes: &[u8], name: &Path) -> Result<Mesh, MeshError> {
    if let Some(mesh) = super::obj_geometry::parse(bytes) {
        return Ok(mesh);
    }
    read_obj(bytes, name, None)
}

/// Reads an OBJ from memory through tobj alone (what [`obj_from_bytes`] does for a file its
/// own geometry reader declines): the reference that reader is tested against.
#[cfg(any(test, fuzzing, feature = "differential"))]
pub(crate) fn obj_from_bytes_tobj(bytes: &[u8], name: &Path) -> Result<Mesh, MeshError> {
    read_obj(bytes, name, None)
}

/// Finds a face whose texture or normal index tobj would resolve to one so large that its
/// bounds check overflows (`vt * 2 + 1`, `vn * 3 + 2`: a panic where overflow is checked,
/// as in the fuzzer's builds, found by it): a relative index reaching before the first
/// element, a zero, or an absurd one. Returns the face's line number (1-based). Lines are
/// split as tobj splits them, up to the first that is not UTF-8, where tobj stops.
fn huge_texture_or_normal_index(bytes: &[u8]) -> Option<usize> {
    let lines = || {
        bytes
            .split(|&b| b == b'\n')
            .map_while(|l| std::str::from_utf8(l).ok())
    };
    // tobj checks these indices only when the file has such elements.
    let (mut has_vt, mut has_vn) = (false, false);
    for line in lines() {
        match line.split_whitespace().next() {
            Some("vt") => has_vt = true,
            Some("vn") => has_vn = true,
            _ => {}
        }
    }
    let (mut vt, mut vn) = (0usize, 0usize);
    for (n, line) in lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("vt") => vt += 1,
            Some("vn") => vn += 1,
            Some("f" | "l") => {
                let words: Vec<&str> = words.collect();
                if words.len() < 3 {
                    continue; // points and lines are skipped, their indices unused
                }
                for w in words {
                    for (part, text) in w.split('/').enumerate().skip(1).take(2) {
                        let Ok(x) = text.parse::<isize>() else {
                            continue;
                        };
                        let (count, limit, present) = if part == 1 {
                            (vt, (usize::MAX - 1) / 2, has_vt)
                        } else {
                            (vn, (usize::MAX - 2) / 3, has_vn)
                        };
                        // tobj's resolution, wrapping as its casts do.
                        let r = if x < 0 {
                            (count as isize).wrapping_add(x) as usize
                        } else {
                            (x as usize).wrapping_sub(1)
                        };
                        if present && r > limit {
                            return Some(n + 1);
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// The first line (1-based) at which tobj's parse of `bytes` fails, and tobj's error there:
/// the shortest prefix of whole lines that tobj rejects ends with that line (tobj reads line
/// by line; found by bisection, without material libraries). `None` when every prefix
/// parses.
fn failing_line(bytes: &[u8], opts: &tobj::LoadOptions) -> Option<(usize, tobj::LoadError)> {
    let ends: Vec<usize> = bytes
        .iter()
        .enumerate()
        .filter(|&(_, &b)| b == b'\n')
        .map(|(i, _)| i + 1)
        .chain((bytes.last() != Some(&b'\n')).then_some(bytes.len()))
        .collect();
    let parse = |lines: usize| {
        let prefix = &bytes[..ends[lines - 1]];
        tobj::load_obj_buf(&mut std::io::Cursor::new(prefix), opts, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .err()
    };
    if ends.is_empty() {
        return None;
    }
    let mut first = parse(ends.len())?;
    // Invariant: the first `lo` lines parse, the first `hi` do not (tobj's error: `first`).
    let (mut lo, mut hi) = (0, ends.len());
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        match parse(mid) {
            Some(e) => (hi, first) = (mid, e),
            None => lo = mid,
        }
    }
    Some((hi, first))
}

/// Reads an OBJ through tobj; `dir` is where its MTL files and textures are, if anywhere.
fn read_obj(bytes: &[u8], path: &Path, dir: Option<&Path>) -> Result<Mesh, MeshError> {
    if let Some(line) = huge_texture_or_normal_index(bytes) {
        return Err(parse_error(
            path,
            format!("line {line}: a texture or normal index out of range"),
        ));
    }
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mtl_dir = dir.map(Path::to_path_buf);
    let loader = move |p: &Path| match &mtl_dir {
        Some(d) => tobj::load_mtl(d.join(p)),
        None => Err(tobj::LoadError::OpenFileFailed),
    };
    let (models, materials) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, loader)
        .map_err(|e| match failing_line(bytes, &opts) {
        Some((line, first)) => parse_error(path, format!("line {line}: {first}")),
        None => parse_error(path, e),
    })?;
    // A missing or broken MTL file is not fatal: the default material is used.
    let materials = materials.unwrap_or_default();

    let mut mesh = Mesh::default();
    let mut textures: HashMap<String, Option<usize>> = HashMap::new();
    for m in &materials {
        let texture = m.diffuse_texture.as_ref().and_then(|name| {
            *textures.entry(name.clone()).or_insert_with(|| {
                dir.and_then(|d| load_texture(&d.join(name))).map(|t| {
                    mesh.textures.push(t);
                    mesh.textures.len() - 1
                })
            })
        });
        mesh.materials.push(map_material(m, texture));
    }
    if mesh.materials.is_empty() {
        mesh.materials.push(Material::default());
    }
    let n_mat = mesh.materials.len();
    for model in models {
        let tm = model.mesh;
        if tm.positions.len() % 3 != 0 {
            return Err(parse_error(path, "position count is not a multiple of 3"));
        }
        if tm.indices.len() % 3 != 0 {
            return Err(parse_error(path, "face index count is not a multiple of 3"));
        }
        let vbase = mesh.positions.len() as u32;
        let nv = (tm.positions.len() / 3) as u32;
        mesh.positions.extend(
            tm.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0], p[1], p[2])),
        );
        let first_tri = mesh.triangles.len();
        for (k, t) in tm.indices.chunks_exact(3).enumerate() {
            if let Some(&bad) = t.iter().find(|&&i| i >= nv) {
                return Err(MeshError::IndexOutOfRange {
                    triangle: first_tri + k,
                    index: u64::from(bad),
                    vertex_count: nv as usize,
                });
            }
            mesh.triangles
                .push([t[0] + vbase, t[1] + vbase, t[2] + vbase]);
        }
        let mat = tm.material_id.filter(|&m| m < n_mat).unwrap_or(0) as u32;
        mesh.triangle_materials
            .extend(std::iter::repeat_n(mat, tm.indices.len() / 3));
        let ntex = (tm.texcoords.len() / 2) as u32;
        if ntex > 0 && tm.texcoord_indices.len() == tm.indices.len() {
            let uvbase = mesh.uvs.len() as u32;
            // OBJ's v runs upwards; textures are stored top row first.
            mesh.uvs.extend(
                tm.texcoords
                    .chunks_exact(2)
                    .map(|t| Vec2::new(t[0] as f32, 1.0 - t[1] as f32)),
            );
            for t in tm.texcoord_indices.chunks_exact(3) {
                let ok = t.iter().all(|&i| i < ntex);
                mesh.triangle_uvs.push(if ok {
                    [t[0] + uvbase, t[1] + uvbase, t[2] + uvbase]
                } else {
                    [uvbase; 3]
                });
            }
        } else {
            pad_uvs(&mut mesh, tm.indices.len() / 3);
        }
    }
    if mesh.textures.is_empty() {
        mesh.uvs.clear();
        mesh.triangle_uvs.clear();
    }
    Ok(mesh)
}

/// Gives `n` more triangles a UV of (0, 0) so the UV array stays parallel to the triangles.
fn pad_uvs(mesh: &mut Mesh, n: usize) {
    let zero = mesh.uvs.len() as u32;
    mesh.uvs.push(Vec2::ZERO);
    mesh.triangle_uvs.extend(std::iter::repeat_n([zero; 3], n));
}

fn map_material(m: &tobj::Material, texture: Option<usize>) -> Material {
    let kd = m.diffuse.unwrap_or([0.8, 0.8, 0.8]);
    let d = m
        .dissolve
        .or_else(|| {
            m.unknown_param
                .get("Tr")
                .and_then(|s| s.trim().parse::<f64>().ok())
                .map(|tr| 1.0 - tr)
        })
        .unwrap_or(1.0);
    let mirror = matches!(m.illumination_model, Some(3..=7));
    let ks = m.specular.unwrap_or([0.0; 3]);
    let finite = |v: f64, dflt: f64| if v.is_finite() { v } else { dflt };
    Material {
        name: m.name.clone(),
        colour: [
            finite(kd[0], 0.8) as f32,
            finite(kd[1], 0.8) as f32,
            finite(kd[2], 0.8) as f32,
            1.0,
        ],
        texture,
        reflectivity: if mirror {
            finite(ks[0].max(ks[1]).max(ks[2]), 0.0).clamp(0.0, 1.0) as f32
        } else {
            0.0
        },
        refractivity: (1.0 - finite(d, 1.0).clamp(0.0, 1.0)) as f32,
        ior: m.optical_density.map_or(1.5, |n| finite(n, 1.5)) as f32,
        alpha_blend: false,
    }
}

/// Loads an image file as an RGBA8 texture; `None` (the material's plain colour is used)
/// when the file is missing or unreadable.
pub(crate) fn load_texture(path: &Path) -> Option<Texture> {
    let img = image::open(path).ok()?.to_rgba8();
    let (width, height) = img.dimensions();
    let rgba = img.pixels().map(|p| p.0).collect();
    Some(Texture {
        width,
        height,
        rgba,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parse_error_names_its_line() {
        let cases = [
            ("v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n", 3, "position"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0\nf 1//1 2//1 3//1\n",
                4,
                "normal",
            ),
            ("# c\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 q\n", 5, "face"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1 1", 5, "position"),
        ];
        for (text, line, what) in cases {
            let e = obj_from_bytes(text.as_bytes(), Path::new("t.obj"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(&format!("line {line}: {what}")), "{e}");
        }
        assert!(failing_line(b"v 0 0 0\n", &tobj::LoadOptions::default()).is_none());
        // Two faults: the first line that fails, with its own error.
        let e = obj_from_bytes(b"v 0 0 0\nv 1 0 0\nf 1 2 3\nv 1 1\n", Path::new("t.obj"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3: ") && !e.contains("position"), "{e}");
    }

    #[test]
    fn texture_and_normal_indices_that_would_overflow_in_tobj_are_found() {
        let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
        let line = |face: &str| huge_texture_or_normal_index(format!("{head}{face}\n").as_bytes());
        // Before the first element, zero, and absurd: found on the face's line (6).
        assert_eq!(line("f 1/-3 2/1 3/1"), Some(6));
        assert_eq!(line("f 1/0 2/1 3/1"), Some(6));
        assert_eq!(line("f 1//-2 2//1 3//1"), Some(6));
        assert_eq!(line("f 1//9223372036854775807 2//1 3//1"), Some(6));
        assert_eq!(line("l 1/-3 2/1 3/1"), Some(6));
        // In range, merely out of range (tobj reports those itself), or unused.
        assert_eq!(line("f 1/1/1 2/-1/-1 3/1/1"), None);
        assert_eq!(line("f 1/5 2/1 3/1"), None);
        assert_eq!(line("f 1/-3 2/1"), None);
        assert_eq!(line("f 1/x 2/1 3/1"), None);
        // Without any `vt` lines tobj ignores texture indices.
        let bare = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/-3 2/0 3\n";
        assert_eq!(huge_texture_or_normal_index(bare.as_bytes()), None);
        // And such a file gets one clear error instead of tobj's arithmetic.
        let e = obj_from_bytes(
            format!("{head}f 1/-3 2/1 3/1\n").as_bytes(),
            Path::new("t.obj"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 6") && e.contains("out of range"), "{e}");
    }
}
