//! The in-memory triangle mesh: positions in `f64`, triangles as index triples, optional
//! texture coordinates, and one material per triangle.
//!
//! Every importer produces a [`Mesh`]; [`Mesh::validate`] is the single place that rejects
//! bad input (non-finite coordinates, indices out of range, empty meshes) with a clear error.

use crate::mesh::scene_info::SceneInfo;
use glam::{DVec3, Vec2};
use thiserror::Error;

/// Errors of mesh import and validation.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file could not be opened or read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// The file's extension is not one of the supported mesh formats.
    #[error(
        "unsupported mesh format {extension:?} for {path} (expected .obj, .obj.gz, .ply, .gltf or .glb)"
    )]
    UnknownFormat {
        /// The file.
        path: String,
        /// What its name ends with.
        extension: String,
    },
    /// The file's syntax or structure is wrong.
    #[error("cannot parse {path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// What the parser said.
        message: String,
    },
    /// The mesh has no triangles.
    #[error("the mesh has no triangles")]
    Empty,
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate ({x}, {y}, {z})")]
    NonFinite {
        /// The vertex index.
        vertex: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
        /// Its z coordinate.
        z: f64,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "triangle {triangle} refers to vertex {index}, but the mesh has {vertex_count} vertices"
    )]
    IndexOutOfRange {
        /// The triangle.
        triangle: usize,
        /// The bad index.
        index: u64,
        /// How many vertices there are.
        vertex_count: usize,
    },
    /// A triangle refers to a material, texture or UV that does not exist.
    #[error("triangle {triangle}: {message}")]
    BadReference {
        /// The triangle.
        triangle: usize,
        /// What is wrong.
        message: String,
    },
    /// The mesh's extent is so large that grid coordinates overflow.
    #[error("the mesh's extent {extent:e} is not a finite positive number")]
    BadExtent {
        /// The largest extent.
        extent: f64,
    },
    /// A light or camera view stored with the mesh is unusable (not finite, a view without
    /// a direction, a name too long).
    #[error("{0}")]
    Scene(String),
    /// An alpha cut-out ([`Mesh::cut_alpha_masks`]) would make too many triangles or visit
    /// too many texels (texture coordinates repeating a texture millions of times).
    #[error("alpha cut-out: {0}")]
    AlphaCut(String),
}

/// An RGBA8 texture in sRGB, sampled with nearest filtering and repeat wrapping.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height` texels, row by row from the top, RGBA8 sRGB.
    pub rgba: Vec<[u8; 4]>,
}

impl Texture {
    /// The linear RGBA colour at texture coordinate `uv` (repeat wrap, nearest texel;
    /// `v = 0` is the top row, as in glTF; OBJ importers flip `v` on load).
    pub fn sample_linear(&self, uv: Vec2) -> [f32; 4] {
        if self.width == 0 || self.height == 0 || self.rgba.is_empty() {
            return [1.0; 4];
        }
        let wrap = |t: f32, n: u32| -> usize {
            let t = if t.is_finite() { t - t.floor() } else { 0.0 };
            ((t * n as f32) as usize).min(n as usize - 1)
        };
        let x = wrap(uv.x, self.width);
        let y = wrap(uv.y, self.height);
        let [r, g, b, a] = self.rgba[y * self.width as usize + x];
        [
            srgb_to_linear(r),
            srgb_to_linear(g),
            srgb_to_linear(b),
            f32::from(a) / 255.0,
        ]
    }
}

/// sRGB-encoded byte to linear `[0, 1]`.
pub fn srgb_to_linear(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear `[0, 1]` to an sRGB-encoded byte.
pub(crate) fn linear_to_srgb(c: f32) -> u8 {
    let c = if c.is_finite() {
        c.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// A surface material, already mapped to what the octree stores (see `docs/algorithms.md`
/// for the mapping from MTL and glTF).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// A name for messages.
    pub name: String,
    /// Linear RGBA base colour.
    pub colour: [f32; 4],
    /// Index into [`Mesh::textures`] of a colour texture multiplied with `colour`.
    pub texture: Option<usize>,
    /// Mirror reflectivity in `[0, 1]`.
    pub reflectivity: f32,
    /// Transparency (share of light refracted through) in `[0, 1]`.
    pub refractivity: f32,
    /// Index of refraction.
    pub ior: f32,
    /// Whether the colour's alpha (times the texture's) is coverage, as glTF's
    /// `alphaMode: BLEND`: a share `1 - alpha` of the light passes through the surface
    /// unchanged, and the rest meets the material ([`Material::optics_at`]).
    pub alpha_blend: bool,
}

impl Material {
    /// The reflectivity and refractivity at a point whose colour alpha (material colour
    /// times texture) is `alpha`: the material's own for an opaque one; for an
    /// [`alpha_blend`](Self::alpha_blend) one, the share `1 - alpha` passes through and the
    /// rest reflects and refracts as the material does: `(alpha * reflectivity,
    /// 1 - alpha * (1 - refractivity))`.
    pub fn optics_at(&self, alpha: f32) -> (f32, f32) {
        if !self.alpha_blend {
            return (self.reflectivity, self.refractivity);
        }
        let a = if alpha.is_finite() {
            alpha.clamp(0.0, 1.0)
        } else {
            1.0
        };
        (a * self.reflectivity, 1.0 - a * (1.0 - self.refractivity))
    }
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            colour: [0.8, 0.8, 0.8, 1.0],
            texture: None,
            reflectivity: 0.0,
            refractivity: 0.0,
            ior: 1.5,
            alpha_blend: false,
        }
    }
}

/// A triangle mesh in scene units.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Texture coordinates, referenced by `triangle_uvs`.
    pub uvs: Vec<Vec2>,
    /// Per triangle, indices into `uvs`; empty when the mesh has no texture coordinates.
    pub triangle_uvs: Vec<[u32; 3]>,
    /// Per triangle, an index into `materials`; empty means material 0 everywhere.
    pub triangle_materials: Vec<u32>,
    /// The materials; empty means one default material.
    pub materials: Vec<Material>,
    /// Textures referenced by materials.
    pub textures: Vec<Texture>,
    /// Lights and camera views the file brings (glTF's `KHR_lights_punctual` and cameras),
    /// in scene units; a bake stores them in the `.svo`.
    pub scene: SceneInfo,
}

impl Mesh {
    /// Appends `other`'s triangles with their materials, texture coordinates and textures
    /// (indices moved; a side without texture coordinates gets a dummy one, a side without
    /// materials the default material).
    pub fn append(&mut self, mut other: Mesh) {
        if self.triangles.is_empty() && self.positions.is_empty() {
            *self = other;
            return;
        }
        let fill_materials = |m: &mut Mesh| {
            if m.materials.is_empty() {
                m.materials.push(Material::default());
            }
            if m.triangle_materials.is_empty() {
                m.triangle_materials = vec![0; m.triangles.len()];
            }
        };
        let fill_uvs = |m: &mut Mesh| {
            if m.triangle_uvs.is_empty() {
                let i = m.uvs.len() as u32;
                m.uvs.push(Vec2::ZERO);
                m.triangle_uvs = vec![[i; 3]; m.triangles.len()];
            }
        };
        fill_materials(self);
        fill_materials(&mut other);
        if !(self.triangle_uvs.is_empty() && other.triangle_uvs.is_empty()) {
            fill_uvs(self);
            fill_uvs(&mut other);
        }
        let (p0, u0, m0, t0) = (
            self.positions.len() as u32,
            self.uvs.len() as u32,
            self.materials.len() as u32,
            self.textures.len(),
        );
        self.positions.append(&mut other.positions);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + p0)));
        self.uvs.append(&mut other.uvs);
        self.triangle_uvs
            .extend(other.triangle_uvs.iter().map(|t| t.map(|i| i + u0)));
        self.triangle_materials
            .extend(other.triangle_materials.iter().map(|&m| m + m0));
        self.materials
            .extend(other.materials.into_iter().map(|mut m| {
                m.texture = m.texture.map(|t| t + t0);
                m
            }));
        self.textures.append(&mut other.textures);
        self.scene.lights.append(&mut other.scene.lights);
        self.scene.cameras.append(&mut other.scene.cameras);
    }

    /// A mesh of plain triangles with the default material.
    pub fn from_triangles(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Self {
        Self {
            positions,
            triangles,
            ..Self::default()
        }
    }

    /// The material of triangle `t`.
    pub fn material_of(&self, t: usize) -> &Material {
        static DEFAULT: std::sync::OnceLock<Material> = std::sync::OnceLock::new();
        let m = self.triangle_materials.get(t).copied().unwrap_or(0) as usize;
        self.materials
            .get(m)
            .unwrap_or_else(|| DEFAULT.get_or_init(Material::default))
    }

    /// The axis-aligned bounds of the vertices that triangles use.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for &i in t {
                let p = *self.positions.get(i as usize)?;
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (!self.triangles.is_empty()).then_some((lo, hi))
    }

    /// Checks everything the voxelizer relies on: at least one triangle, every index in
    /// range, every used coordinate finite, material/UV/texture references valid.
    pub fn validate(&self) -> Result<(), MeshError> {
        self.validated_bounds().map(|_| ())
    }

    /// [`Self::validate`], returning the bounds of the used vertices ([`Self::bounds`]):
    /// one pass over the triangles and one over the vertices.
    pub fn validated_bounds(&self) -> Result<(DVec3, DVec3), MeshError> {
        if self.triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        let n = self.positions.len();
        let mut used = vec![false; n];
        for (t, tri) in self.triangles.iter().enumerate() {
            for &i in tri {
                let Some(u) = used.get_mut(i as usize) else {
                    return Err(MeshError::IndexOutOfRange {
                        triangle: t,
                        index: u64::from(i),
                        vertex_count: n,
                    });
                };
                *u = true;
            }
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut finite = true;
        for (p, _) in self.positions.iter().zip(&used).filter(|(_, u)| **u) {
            finite &= p.is_finite();
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if !finite {
            // Name the first used vertex that is not finite.
            if let Some((v, p)) = self
                .positions
                .iter()
                .enumerate()
                .find(|(v, p)| used[*v] && !p.is_finite())
            {
                return Err(MeshError::NonFinite {
                    vertex: v,
                    x: p.x,
                    y: p.y,
                    z: p.z,
                });
            }
        }
        if !self.triangle_materials.is_empty() {
            if self.triangle_materials.len() != self.triangles.len() {
                return Err(MeshError::BadReference {
                    triangle: 0,
                    message: format!(
                        "{} material indices for {} triangles",
                        self.triangle_materials.len(),
                        self.triangles.len()
                    ),
                });
            }
            let nm = self.materials.len().max(1);
            if let Some((t, m)) = self
                .triangle_materials
                .iter()
                .enumerate()
                .find(|(_, m)| **m as usize >= nm)
            {
                return Err(MeshError::BadReference {
                    triangle: t,
                    message: format!("material {m} does not exist ({nm} materials)"),
                });
            }
        }
        if !self.triangle_uvs.is_empty() {
            if self.triangle_uvs.len() != self.triangles.len() {
                return Err(MeshError::BadReference {
                    triangle: 0,
                    message: format!(
                        "{} UV triples for {} triangles",
                        self.triangle_uvs.len(),
                        self.triangles.len()
                    ),
                });
            }
            let nu = self.uvs.len();
            if let Some((t, _)) = self
                .triangle_uvs
                .iter()
                .enumerate()
                .find(|(_, uv)| uv.iter().any(|&i| i as usize >= nu))
            {
                return Err(MeshError::BadReference {
                    triangle: t,
                    message: "UV index out of range".into(),
                });
            }
        }
        for m in &self.materials {
            if let Some(tex) = m.texture
                && tex >= self.textures.len()
            {
                return Err(MeshError::BadReference {
                    triangle: 0,
                    message: format!("material {:?} refers to missing texture {tex}", m.name),
                });
            }
        }
        let extent = (hi - lo).max_element();
        if !extent.is_finite() {
            return Err(MeshError::BadExtent { extent });
        }
        Ok((lo, hi))
    }
}
