//! glTF 2.0 / GLB import: every mesh instance of the default scene (or the first scene, or
//! every mesh when there is none), with node transforms applied in `f64`.
//!
//! Material mapping: colour = `baseColorFactor` times `baseColorTexture`; reflectivity =
//! `metallic * (1 - roughness)` (factors); refractivity = `KHR_materials_transmission`'s
//! factor; IOR = `KHR_materials_ior` (1.5 when absent). Primitive modes other than
//! triangles, strips and fans are skipped.

use super::parse_error;
use crate::mesh::{Material, Mesh, MeshError, Texture};
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
        self.mesh.materials.push(Material {
            name: m.name().unwrap_or("unnamed").to_string(),
            colour: pbr.base_color_factor(),
            texture,
            reflectivity: (pbr.metallic_factor() * (1.0 - pbr.roughness_factor())).clamp(0.0, 1.0),
            refractivity: refractivity.clamp(0.0, 1.0),
            ior: m.ior().unwrap_or(1.5),
        });
        let r = ((self.mesh.materials.len() - 1) as u32, set);
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

/// Loads a `.gltf` or `.glb` file with its buffers and images.
pub fn load_gltf(path: &Path) -> Result<Mesh, MeshError> {
    let (doc, buffers, images) = gltf::import(path).map_err(|e| parse_error(path, e))?;
    let mut l = Loader {
        buffers: &buffers,
        images: &images,
        tex_of_image: HashMap::new(),
        mat_index: HashMap::new(),
        mesh: Mesh::default(),
    };
    match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => {
            let mut stack: Vec<(gltf::Node<'_>, DMat4)> =
                scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
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
                stack.extend(node.children().map(|c| (c, xf)));
            }
        }
        None => {
            for m in doc.meshes() {
                l.add_mesh(path, &m, DMat4::IDENTITY)?;
            }
        }
    }
    let mut mesh = l.mesh;
    if mesh.textures.is_empty() {
        mesh.uvs.clear();
        mesh.triangle_uvs.clear();
    }
    Ok(mesh)
}
