//! glTF 2.0 / GLB import: every mesh instance of the default scene (or the first scene, or
//! every mesh when there is none), with node transforms applied in `f64`.
//!
//! Material mapping: colour = `baseColorFactor` times `baseColorTexture`; reflectivity =
//! `metallic * (1 - roughness)` (factors); refractivity = `KHR_materials_transmission`'s
//! factor; IOR = `KHR_materials_ior` (1.5 when absent; 1 for a `BLEND` material without
//! transmission). `alphaMode: MASK` cuts the texels under `alphaCutoff` (0.5 when absent)
//! out of the mesh ([`Mesh::cut_alpha_masks`]); `BLEND` makes the colour's alpha a coverage
//! ([`Material::alpha_blend`]). Primitive modes other than triangles, strips and fans are
//! skipped.
//!
//! Lights (`KHR_lights_punctual`: point and spot lights, as point lights) and perspective
//! cameras on the scene's nodes go into [`Mesh::scene`], placed by their nodes' transforms.

use super::parse_error;
use crate::mesh::scene_info::{SceneInfo, StoredCamera, StoredLight};
use crate::mesh::triangle_mesh::{Material, Mesh, MeshError, Texture};
use glam::{DMat4, DVec3, Mat4, Vec2};
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::path::Path;

fn convert_image(img: &gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format;
    let n = (img.width as usize) * (img.height as usize);
    let px = &img.pixels;
    let rgba: Vec<[u8; 4]> = match img.format {
        Format::R8G8B8A8 if px.len() >= n * 4 => px
            .chunks_exact(4)
            .take(n)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect(),
        Format::R8G8B8 if px.len() >= n * 3 => px
            .chunks_exact(3)
            .take(n)
            .map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        Format::R8G8 if px.len() >= n * 2 => px
            .chunks_exact(2)
            .take(n)
            .map(|c| [c[0], c[0], c[0], c[1]])
            .collect(),
        Format::R8 if px.len() >= n => px.iter().take(n).map(|&c| [c, c, c, 255]).collect(),
        _ => return None,
    };
    Some(Texture {
        width: img.width,
        height: img.height,
        rgba,
    })
}

struct Loader<'a> {
    buffers: &'a [gltf::buffer::Data],
    images: &'a [gltf::image::Data],
    tex_of_image: HashMap<usize, Option<usize>>,
    mat_index: HashMap<Option<usize>, (u32, u32)>,
    /// Our alpha-masked materials and their cutoffs.
    masks: Vec<(u32, f32)>,
    mesh: Mesh,
}

impl Loader<'_> {
    /// Our material index for a glTF material, and the texture coordinate set it samples.
    fn material(&mut self, m: &gltf::Material<'_>) -> (u32, u32) {
        if let Some(&r) = self.mat_index.get(&m.index()) {
            return r;
        }
        let pbr = m.pbr_metallic_roughness();
        let (texture, set) = match pbr.base_color_texture() {
            Some(info) => {
                let img = info.texture().source().index();
                let texture = match self.tex_of_image.get(&img) {
                    Some(&t) => t,
                    None => {
                        let t = self.images.get(img).and_then(convert_image).map(|t| {
                            self.mesh.textures.push(t);
                            self.mesh.textures.len() - 1
                        });
                        self.tex_of_image.insert(img, t);
                        t
                    }
                };
                (texture, info.tex_coord())
            }
            None => (None, 0),
        };
        let refractivity = m.transmission().map_or(0.0, |t| t.transmission_factor());
        let alpha_mode = m.alpha_mode();
        let alpha_blend = alpha_mode == gltf::material::AlphaMode::Blend;
        // What passes through a blended surface without transmission goes straight on.
        let ior = match m.ior() {
            Some(ior) => ior,
            None if alpha_blend && refractivity == 0.0 => 1.0,
            None => 1.5,
        };
        self.mesh.materials.push(Material {
            name: m.name().unwrap_or("unnamed").to_string(),
            colour: pbr.base_color_factor(),
            texture,
            reflectivity: (pbr.metallic_factor() * (1.0 - pbr.roughness_factor())).clamp(0.0, 1.0),
            refractivity: refractivity.clamp(0.0, 1.0),
            ior,
            alpha_blend,
        });
        let index = (self.mesh.materials.len() - 1) as u32;
        if alpha_mode == gltf::material::AlphaMode::Mask {
            self.masks.push((index, m.alpha_cutoff().unwrap_or(0.5)));
        }
        let r = (index, set);
        self.mat_index.insert(m.index(), r);
        r
    }

    fn add_mesh(&mut self, path: &Path, gm: &gltf::Mesh<'_>, xf: DMat4) -> Result<(), MeshError> {
        for prim in gm.primitives() {
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue;
            }
            let buffers = self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let Some(pos) = reader.read_positions() else {
                continue;
            };
            let vbase = self.mesh.positions.len() as u32;
            let pos: Vec<DVec3> = pos
                .map(|p| xf.transform_point3(DVec3::new(p[0].into(), p[1].into(), p[2].into())))
                .collect();
            let nv = pos.len() as u32;
            self.mesh.positions.extend(pos);
            let idx: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..nv).collect(),
            };
            let tris: Vec<[u32; 3]> = match mode {
                Mode::Triangles => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
                Mode::TriangleStrip => (2..idx.len())
                    .map(|k| {
                        if k % 2 == 0 {
                            [idx[k - 2], idx[k - 1], idx[k]]
                        } else {
                            [idx[k - 1], idx[k - 2], idx[k]]
                        }
                    })
                    .collect(),
                _ => (2..idx.len())
                    .map(|k| [idx[0], idx[k - 1], idx[k]])
                    .collect(),
            };
            let first = self.mesh.triangles.len();
            for (k, t) in tris.iter().enumerate() {
                if let Some(&bad) = t.iter().find(|&&i| i >= nv) {
                    return Err(MeshError::IndexOutOfRange {
                        triangle: first + k,
                        index: u64::from(bad),
                        vertex_count: nv as usize,
                    });
                }
                self.mesh.triangles.push(t.map(|i| i + vbase));
            }
            let (mat, set) = self.material(&prim.material());
            self.mesh
                .triangle_materials
                .extend(std::iter::repeat_n(mat, tris.len()));
            let uvbase = self.mesh.uvs.len() as u32;
            let uv: Option<Vec<Vec2>> = reader
                .read_tex_coords(set)
                .map(|tc| tc.into_f32().map(Vec2::from).collect());
            match uv {
                Some(uv) if uv.len() as u32 == nv => {
                    self.mesh.uvs.extend(uv);
                    self.mesh
                        .triangle_uvs
                        .extend(tris.iter().map(|t| t.map(|i| i + uvbase)));
                }
                _ => {
                    self.mesh.uvs.push(Vec2::ZERO);
                    self.mesh
                        .triangle_uvs
                        .extend(std::iter::repeat_n([uvbase; 3], tris.len()));
                }
            }
        }
        let _ = path;
        Ok(())
    }
}

/// Loads a `.gltf` or `.glb` file with its buffers and images (resolved beside it).
pub(crate) fn load_gltf(path: &Path) -> Result<Mesh, MeshError> {
    let bytes = std::fs::read(path).map_err(|e| super::io_error(path, e))?;
    let base = path.parent().unwrap_or(Path::new("."));
    read_gltf(&bytes, path, Some(base))
}

/// Reads a glTF (JSON with embedded `data:` buffers and images) or GLB from memory; files
/// it refers to cannot be resolved and are an error. `name` appears in error messages.
pub(crate) fn gltf_from_bytes(bytes: &[u8], name: &Path) -> Result<Mesh, MeshError> {
    read_gltf(bytes, name, None)
}

/// Parses, validates and converts a glTF document; `base` resolves its file references.
fn read_gltf(bytes: &[u8], name: &Path, base: Option<&Path>) -> Result<Mesh, MeshError> {
    let err = |e: gltf::Error| parse_error(name, e);
    check_glb_header(bytes, name)?;
    // Parsed once, checked, then validated. The checks cover every panic we know of in the
    // gltf crates; a panic we do not know of still becomes an error for this file instead of
    // ending the program.
    let failed = |_| parse_error(name, "the glTF library failed on this file");
    let gltf::Gltf { document, blob } =
        std::panic::catch_unwind(|| gltf::Gltf::from_slice_without_validation(bytes))
            .map_err(failed)?
            .map_err(err)?;
    precheck(document.as_json(), name)?;
    let imported = std::panic::catch_unwind(move || {
        let document = gltf::Document::from_json(document.into_json()).map_err(err)?;
        check_accessors(&document, name)?;
        let buffers = gltf::import_buffers(&document, base, blob).map_err(err)?;
        let images = gltf::import_images(&document, base, &buffers).map_err(err)?;
        Ok::<_, MeshError>((document, buffers, images))
    })
    .map_err(failed)?;
    let (doc, buffers, images) = imported?;
    convert(name, &doc, &buffers, &images)
}

/// Refuses accessors that gltf 1.4's readers assert against (in builds with debug
/// assertions) or compute with unchecked arithmetic: a buffer-view stride smaller than the
/// element, an accessor of no elements or more than its buffer view holds, a sparse
/// accessor of zero entries or more than fit (the specification requires at least one),
/// and positions, texture coordinates or indices in a layout their meaning does not allow.
/// Found by the `mesh_import` fuzz target.
fn check_accessors(doc: &gltf::Document, name: &Path) -> Result<(), MeshError> {
    for a in doc.accessors() {
        if a.count() == 0 {
            return Err(parse_error(
                name,
                format!("accessor {}: count 0 (at least 1 is required)", a.index()),
            ));
        }
        if let Some(view) = a.view() {
            let stride = view.stride().unwrap_or(a.size());
            let end = (a.count() - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(a.size()))
                .and_then(|x| x.checked_add(a.offset()));
            if end.is_none_or(|e| e > view.length()) {
                return Err(parse_error(
                    name,
                    format!(
                        "accessor {}: {} elements do not fit its buffer view of {} bytes",
                        a.index(),
                        a.count(),
                        view.length()
                    ),
                ));
            }
        }
        if let Some(sp) = a.sparse()
            && (sp.count() > a.count()
                || sp
                    .count()
                    .checked_mul(a.size())
                    .is_none_or(|n| n > sp.values().view().length()))
        {
            return Err(parse_error(
                name,
                format!(
                    "accessor {}: {} sparse values do not fit",
                    a.index(),
                    sp.count()
                ),
            ));
        }
        if let Some(stride) = a.view().and_then(|v| v.stride())
            && stride < a.size()
        {
            return Err(parse_error(
                name,
                format!(
                    "accessor {}: buffer view stride {stride} is smaller than its {}-byte elements",
                    a.index(),
                    a.size()
                ),
            ));
        }
        if let Some(sp) = a.sparse()
            && sp.count() == 0
        {
            return Err(parse_error(
                name,
                format!("accessor {}: sparse with no entries", a.index()),
            ));
        }
    }
    // The readers take the accessor's layout from the attribute's meaning, so it must be one
    // the specification allows for that meaning.
    use gltf::accessor::{DataType as D, Dimensions as Dim};
    use gltf::mesh::Semantic;
    for m in doc.meshes() {
        for p in m.primitives() {
            let wrong = |what: &str, a: &gltf::Accessor<'_>| {
                parse_error(
                    name,
                    format!(
                        "mesh {}, primitive {}: {what} accessor {} is {:?} {:?}",
                        m.index(),
                        p.index(),
                        a.index(),
                        a.dimensions(),
                        a.data_type()
                    ),
                )
            };
            for (sem, a) in p.attributes() {
                let ok = match sem {
                    Semantic::Positions => a.dimensions() == Dim::Vec3 && a.data_type() == D::F32,
                    Semantic::TexCoords(_) => {
                        a.dimensions() == Dim::Vec2
                            && matches!(a.data_type(), D::U8 | D::U16 | D::F32)
                    }
                    _ => true,
                };
                if !ok {
                    return Err(wrong("an attribute's", &a));
                }
            }
            if let Some(a) = p.indices()
                && !(a.dimensions() == Dim::Scalar
                    && matches!(a.data_type(), D::U8 | D::U16 | D::U32))
            {
                return Err(wrong("the index", &a));
            }
        }
    }
    Ok(())
}

/// Refuses a binary glTF (GLB) whose header gives a total length shorter than the 12-byte
/// header itself, which gltf 1.4 subtracts unchecked (a panic where overflow checks are on).
/// Found by the `mesh_import` fuzz target.
fn check_glb_header(bytes: &[u8], name: &Path) -> Result<(), MeshError> {
    if let Some(length) = bytes
        .strip_prefix(b"glTF")
        .and_then(|rest| rest.get(4..8))
        .map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]))
        && length < 12
    {
        return Err(parse_error(
            name,
            format!("GLB header: total length {length} is shorter than the 12-byte header"),
        ));
    }
    Ok(())
}

/// Refuses what gltf 1.4 would panic on instead of reporting: a primitive attribute naming
/// an accessor that does not exist (its validation indexes the accessors unchecked), and a
/// relative URI whose percent-decoding is not UTF-8 (its import unwraps the decoding).
/// Found by the `mesh_import` fuzz target.
fn precheck(root: &gltf::json::Root, name: &Path) -> Result<(), MeshError> {
    for (mi, m) in root.meshes.iter().enumerate() {
        for (pi, p) in m.primitives.iter().enumerate() {
            for idx in p.attributes.values() {
                if idx.value() >= root.accessors.len() {
                    return Err(parse_error(
                        name,
                        format!(
                            "mesh {mi}, primitive {pi}: accessor {} does not exist ({} accessors)",
                            idx.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    let uris = root
        .buffers
        .iter()
        .filter_map(|b| b.uri.as_deref())
        .chain(root.images.iter().filter_map(|i| i.uri.as_deref()));
    for uri in uris {
        if !uri.contains(':') && !percent_decodes_to_utf8(uri) {
            return Err(parse_error(
                name,
                format!("URI {uri:?} does not percent-decode to UTF-8"),
            ));
        }
    }
    Ok(())
}

/// Whether `%XX`-decoding `s` gives valid UTF-8 (a `%` without two hex digits stays as is,
/// as the `urlencoding` crate leaves it).
fn percent_decodes_to_utf8(s: &str) -> bool {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && let (Some(h), Some(l)) = (
                b.get(i + 1).copied().and_then(hex),
                b.get(i + 2).copied().and_then(hex),
            )
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    std::str::from_utf8(&out).is_ok()
}

/// The light and camera of a glTF node, placed by its transform `xf`, added to `scene`.
/// Read from the JSON (the gltf crate's accessors unwrap fields that a hostile file may
/// lack). Point and spot lights become point lights (a spot's cone is not modelled; the
/// glTF intensity in candela is our intensity at distance 1); directional lights and
/// orthographic cameras are left out, as is anything not finite.
fn node_scene(doc: &gltf::Document, node: &gltf::Node<'_>, xf: DMat4, scene: &mut SceneInfo) {
    use gltf::json::validation::Checked;
    let root = doc.as_json();
    let Some(json) = root.nodes.get(node.index()) else {
        return;
    };
    let eye = xf.transform_point3(DVec3::ZERO);
    let light = json
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .and_then(|l| {
            root.extensions
                .as_ref()?
                .khr_lights_punctual
                .as_ref()?
                .lights
                .get(l.light.value())
        });
    if let Some(l) = light {
        use gltf::json::extensions::scene::khr_lights_punctual::Type;
        let positional = matches!(l.type_, Checked::Valid(Type::Point | Type::Spot));
        let stored = StoredLight {
            position: eye.to_array(),
            colour: l.color,
            intensity: l.intensity,
        };
        let alone = SceneInfo {
            lights: vec![stored.clone()],
            cameras: Vec::new(),
        };
        if positional && alone.validate().is_ok() {
            scene.lights.push(stored);
        }
    }
    let camera = json.camera.and_then(|c| root.cameras.get(c.value()));
    if let Some(c) = camera
        && let Some(p) = &c.perspective
    {
        let forward = xf.transform_vector3(DVec3::NEG_Z).normalize_or_zero();
        let stored = StoredCamera {
            name: c
                .name
                .clone()
                .unwrap_or_else(|| format!("camera {}", scene.cameras.len())),
            eye: eye.to_array(),
            target: (eye + forward).to_array(),
            up: xf.transform_vector3(DVec3::Y).to_array(),
            fov_deg: f64::from(p.yfov).to_degrees(),
        };
        let alone = SceneInfo {
            lights: Vec::new(),
            cameras: vec![stored.clone()],
        };
        if alone.validate().is_ok() {
            scene.cameras.push(stored);
        }
    }
}

fn convert(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    images: &[gltf::image::Data],
) -> Result<Mesh, MeshError> {
    let mut l = Loader {
        buffers,
        images,
        tex_of_image: HashMap::new(),
        mat_index: HashMap::new(),
        masks: Vec::new(),
        mesh: Mesh::default(),
    };
    match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => {
            // Depth first in document order (the stack pops the last pushed first), so the
            // first camera in the file is the first view.
            let mut stack: Vec<(gltf::Node<'_>, DMat4)> =
                scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
            stack.reverse();
            let mut visited = 0usize;
            while let Some((node, parent)) = stack.pop() {
                visited += 1;
                if visited > 1_000_000 {
                    return Err(parse_error(path, "node hierarchy too large or cyclic"));
                }
                let local = Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
                let xf = parent * local;
                if let Some(m) = node.mesh() {
                    l.add_mesh(path, &m, xf)?;
                }
                node_scene(doc, &node, xf, &mut l.mesh.scene);
                let first = stack.len();
                stack.extend(node.children().map(|c| (c, xf)));
                stack[first..].reverse();
            }
        }
        None => {
            for m in doc.meshes() {
                l.add_mesh(path, &m, DMat4::IDENTITY)?;
            }
        }
    }
    let mut mesh = l.mesh;
    if !l.masks.is_empty() {
        mesh.validate()?;
        mesh.cut_alpha_masks(&l.masks)?;
    }
    if mesh.textures.is_empty() {
        mesh.uvs.clear();
        mesh.triangle_uvs.clear();
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::percent_decodes_to_utf8;

    #[test]
    fn percent_decoding_checks_utf8() {
        assert!(percent_decodes_to_utf8("plain.bin"));
        assert!(percent_decodes_to_utf8("a%20b.bin"));
        assert!(percent_decodes_to_utf8("%C3%A9.bin"));
        assert!(percent_decodes_to_utf8("100%"));
        assert!(!percent_decodes_to_utf8("%FF.bin"));
        assert!(!percent_decodes_to_utf8("%C3"));
    }
}
