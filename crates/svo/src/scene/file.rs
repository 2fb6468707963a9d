//! Scene files: a small TOML format that `svo-bake scene.toml -o scene.svo` reads. A scene is
//! meshes (any supported format, found beside the scene file, in `$SVO_MODELS` or in the
//! scene's `models` folders) and primitives (boxes,
//! spheres, rectangles), each with a transform, a material and optionally a name; boolean
//! operations between named objects (`[[csg]]`, through `scene/csg.rs`); materials by preset or by a
//! table of the file; point lights and named camera views (stored in the `.svo`); and bake
//! defaults (depth, solid fill) that command-line flags override.
//!
//! ```toml
//! depth = 8
//! solid = "vote"                 # optional: closed or vote
//! models = ["../meshes"]         # optional: more folders for mesh files (after $SVO_MODELS)
//!
//! [material.tiles]
//! preset = "solid"               # void, glass, semi-solid, solid, water (default: solid)
//! colour = [0.55, 0.7, 0.8]      # linear RGB or RGBA; overrides the preset's
//! reflectivity = 0.1             # as can refractivity and ior
//!
//! [[mesh]]
//! file = "bunny.ply"
//! scale = 10.0                   # a number or [x, y, z]; then
//! rotate = [0.0, 90.0, 0.0]      # degrees about x, then y, then z; then
//! translate = [0.0, 1.0, 0.0]
//! material = "clay"              # optional: without it the file's own materials
//!
//! [[box]]
//! min = [-4.0, 0.0, -4.0]
//! max = [4.0, 0.5, 4.0]
//! material = "tiles"
//!
//! [[sphere]]
//! centre = [0.0, 2.0, 0.0]
//! radius = 1.0
//! detail = 16                    # the octahedron's faces split into detail^2 triangles
//! material = "glass"
//!
//! [[rectangle]]                  # two triangles, open: a water surface, a floor
//! centre = [0.0, 3.0, 0.0]
//! normal = [0.0, 1.0, 0.0]
//! size = [8.0, 8.0]
//! material = "water"
//!
//! [[csg]]                        # needs the `csg` feature (the Manifold kernel)
//! op = "difference"              # union, intersection, difference
//! a = "tub"                      # objects (or earlier results) by `name`; used up
//! b = "scoop"
//! material = "tiles"             # default: a's
//!
//! [[light]]
//! position = [2.0, 8.0, 5.0]
//! colour = [1.0, 0.95, 0.9]      # default white
//! intensity = 60.0
//!
//! [[camera]]
//! name = "water"
//! eye = [0.0, 6.0, 9.0]
//! target = [0.0, 2.0, 0.0]
//! up = [0.0, 1.0, 0.0]           # default +y
//! fov = 45.0                     # vertical, degrees; default 40
//! ```
//!
//! Objects made of `void` are left out. Unknown keys are errors (a misspelt key would
//! otherwise be silently ignored).

use crate::import::load_mesh;
use crate::mesh::presets::Preset;
use crate::mesh::scene_info::{SceneInfo, StoredCamera, StoredLight};
use crate::mesh::triangle_mesh::{Material, Mesh, MeshError};
use crate::solid::mode::SolidMode;
use glam::{DMat3, DVec3};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors of scene files.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The file could not be read.
    #[error("cannot read scene {path}: {cause}")]
    Io {
        /// The scene file.
        path: String,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// The file is not valid TOML, or not a scene.
    #[error("scene {path}: {message}")]
    Parse {
        /// The scene file.
        path: String,
        /// What is wrong, with the line.
        message: String,
    },
    /// A value is out of range or a name is unknown.
    #[error("scene {path}: {what}")]
    Invalid {
        /// The scene file.
        path: String,
        /// What is wrong and where.
        what: String,
    },
    /// A `[[mesh]]`'s relative `file` is in none of the folders searched (see
    /// [`load_scene`]).
    #[error(
        "scene {path}: mesh {index}: {file} is in none of {}{}",
        list(tried),
        MODELS_HINT
    )]
    MeshNotFound {
        /// The scene file.
        path: String,
        /// Which `[[mesh]]`, from 0.
        index: usize,
        /// The `file` as written.
        file: String,
        /// The folders searched, in order.
        tried: Vec<PathBuf>,
    },
    /// A mesh of the scene could not be loaded.
    #[error("scene {path}: mesh {index}")]
    Mesh {
        /// The scene file.
        path: String,
        /// Which `[[mesh]]`, from 0.
        index: usize,
        /// The loader's error.
        source: MeshError,
    },
    /// Nothing to bake: every object is void or the scene lists none.
    #[error("scene {path}: no objects (every object is void, or none is listed)")]
    Empty {
        /// The scene file.
        path: String,
    },
}

/// A loaded scene: its triangles in scene units, lights and views, and bake defaults.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Every object's triangles with their materials.
    pub mesh: Mesh,
    /// Lights and camera views, for the `.svo` file.
    pub info: SceneInfo,
    /// The file's depth, if it sets one.
    pub depth: Option<u8>,
    /// The file's solid fill, if it sets one.
    pub solid: Option<SolidMode>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Scale {
    Uniform(f64),
    Axes([f64; 3]),
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Colour {
    Rgb([f32; 3]),
    Rgba([f32; 4]),
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct MaterialEntry {
    preset: Option<String>,
    colour: Option<Colour>,
    reflectivity: Option<f32>,
    refractivity: Option<f32>,
    ior: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshEntry {
    name: Option<String>,
    file: PathBuf,
    material: Option<String>,
    scale: Option<Scale>,
    rotate: Option<[f64; 3]>,
    translate: Option<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoxEntry {
    name: Option<String>,
    min: [f64; 3],
    max: [f64; 3],
    material: Option<String>,
    scale: Option<Scale>,
    rotate: Option<[f64; 3]>,
    translate: Option<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereEntry {
    name: Option<String>,
    centre: [f64; 3],
    radius: f64,
    detail: Option<u32>,
    material: Option<String>,
    scale: Option<Scale>,
    rotate: Option<[f64; 3]>,
    translate: Option<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RectangleEntry {
    name: Option<String>,
    centre: [f64; 3],
    normal: [f64; 3],
    size: [f64; 2],
    material: Option<String>,
    scale: Option<Scale>,
    rotate: Option<[f64; 3]>,
    translate: Option<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CsgEntry {
    name: Option<String>,
    op: String,
    a: String,
    b: String,
    material: Option<String>,
    scale: Option<Scale>,
    rotate: Option<[f64; 3]>,
    translate: Option<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightEntry {
    position: [f64; 3],
    colour: Option<[f32; 3]>,
    intensity: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraEntry {
    name: String,
    eye: [f64; 3],
    target: [f64; 3],
    up: Option<[f64; 3]>,
    fov: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    models: Vec<PathBuf>,
    depth: Option<u8>,
    solid: Option<String>,
    #[serde(default)]
    material: BTreeMap<String, MaterialEntry>,
    #[serde(default)]
    mesh: Vec<MeshEntry>,
    #[serde(default, rename = "box")]
    boxes: Vec<BoxEntry>,
    #[serde(default)]
    sphere: Vec<SphereEntry>,
    #[serde(default)]
    rectangle: Vec<RectangleEntry>,
    #[serde(default)]
    csg: Vec<CsgEntry>,
    #[serde(default)]
    light: Vec<LightEntry>,
    #[serde(default)]
    camera: Vec<CameraEntry>,
}

/// The most triangles a sphere may ask for (`8 detail^2`).
const MAX_SPHERE_DETAIL: u32 = 1024;

/// An object's transform: scale, then rotation about x, y and z (degrees), then translation.
struct Transform {
    m: DMat3,
    t: DVec3,
}

impl Transform {
    fn new(
        scale: Option<&Scale>,
        rotate: Option<[f64; 3]>,
        translate: Option<[f64; 3]>,
    ) -> Result<Self, String> {
        let s = match scale {
            None => DVec3::ONE,
            Some(Scale::Uniform(k)) => DVec3::splat(*k),
            Some(Scale::Axes(a)) => DVec3::from_array(*a),
        };
        let r = DVec3::from_array(rotate.unwrap_or([0.0; 3]));
        let t = DVec3::from_array(translate.unwrap_or([0.0; 3]));
        if !(s.is_finite() && s.min_element().abs() > 0.0 && s.x * s.y * s.z != 0.0) {
            return Err("scale must be finite and non-zero".into());
        }
        if !(r.is_finite() && t.is_finite()) {
            return Err("rotate and translate must be finite".into());
        }
        let rot = DMat3::from_rotation_z(r.z.to_radians())
            * DMat3::from_rotation_y(r.y.to_radians())
            * DMat3::from_rotation_x(r.x.to_radians());
        Ok(Self {
            m: rot * DMat3::from_diagonal(s),
            t,
        })
    }

    /// Moves the mesh; a mirroring transform reverses the triangles so they still face out.
    fn apply(&self, mesh: &mut Mesh) {
        for p in &mut mesh.positions {
            *p = self.m * *p + self.t;
        }
        if self.m.determinant() < 0.0 {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
            for t in &mut mesh.triangle_uvs {
                t.swap(1, 2);
            }
        }
    }
}

fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Resolves `name` to a material: the file's `[material.NAME]`, else a preset. `Ok(None)`
/// for void.
fn material(
    name: &str,
    table: &BTreeMap<String, MaterialEntry>,
) -> Result<Option<Material>, String> {
    let Some(e) = table.get(name) else {
        return match Preset::parse(name) {
            Some(p) => Ok(p.material()),
            None => Err(format!(
                "unknown material {name:?} (not in [material.*]; presets: {})",
                Preset::ALL.map(Preset::name).join(", ")
            )),
        };
    };
    let preset = match &e.preset {
        None => Preset::Solid,
        Some(p) => Preset::parse(p).ok_or_else(|| {
            format!(
                "material {name:?}: unknown preset {p:?} ({})",
                Preset::ALL.map(Preset::name).join(", ")
            )
        })?,
    };
    let Some(mut m) = preset.material() else {
        return Ok(None);
    };
    m.name = name.to_string();
    if let Some(c) = &e.colour {
        m.colour = match *c {
            Colour::Rgb([r, g, b]) => [r, g, b, 1.0],
            Colour::Rgba(c) => c,
        };
    }
    m.reflectivity = e.reflectivity.unwrap_or(m.reflectivity);
    m.refractivity = e.refractivity.unwrap_or(m.refractivity);
    m.ior = e.ior.unwrap_or(m.ior);
    let unit = |v: f32| v.is_finite() && (0.0..=1.0).contains(&v);
    if !(m.colour.iter().all(|&c| unit(c)) && unit(m.reflectivity) && unit(m.refractivity)) {
        return Err(format!(
            "material {name:?}: colour, reflectivity and refractivity must lie in [0, 1]"
        ));
    }
    if m.reflectivity + m.refractivity > 1.0 + 1e-6 {
        return Err(format!(
            "material {name:?}: reflectivity + refractivity exceeds 1"
        ));
    }
    if !(m.ior.is_finite() && (1.0..5.0).contains(&m.ior)) {
        return Err(format!("material {name:?}: ior must lie in [1, 5)"));
    }
    Ok(Some(m))
}

/// Gives every triangle of `mesh` material `m`.
fn with_material(mut mesh: Mesh, m: Material) -> Mesh {
    mesh.triangle_materials = vec![0; mesh.triangles.len()];
    mesh.materials = vec![m];
    mesh
}

/// A name that occurs more than once, if any.
fn repeated<'a>(names: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    let mut names: Vec<&str> = names.collect();
    names.sort_unstable();
    names.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
}

/// An object of the scene before placing: CSG operands are used up, void ones left out.
struct Object {
    name: Option<String>,
    mesh: Mesh,
    void: bool,
    used: bool,
}

/// Evaluates a `[[csg]]` entry over the objects so far (its operands are marked used).
fn csg(
    objects: &mut [Object],
    e: &CsgEntry,
    table: &BTreeMap<String, MaterialEntry>,
) -> Result<Object, String> {
    let find = |objects: &[Object], n: &str| {
        objects
            .iter()
            .position(|o| o.name.as_deref() == Some(n))
            .ok_or_else(|| format!("no object named {n:?} before it"))
    };
    let (ia, ib) = (find(objects, &e.a)?, find(objects, &e.b)?);
    if ia == ib {
        return Err(format!("a and b are the same object {:?}", e.a));
    }
    let tr = Transform::new(e.scale.as_ref(), e.rotate, e.translate)?;
    let op = CsgOp::parse(&e.op)
        .ok_or_else(|| format!("unknown op {:?} (union, intersection, difference)", e.op))?;
    let mut mesh = boolean(&objects[ia].mesh, &objects[ib].mesh, op)?;
    objects[ia].used = true;
    objects[ib].used = true;
    // The result's material: the entry's, else operand a's (one material: the boolean
    // keeps no per-triangle materials).
    let (material, void) = match &e.material {
        Some(n) => match material(n, table)? {
            Some(m) => (m, false),
            None => (Material::default(), true),
        },
        None => (
            objects[ia]
                .mesh
                .materials
                .first()
                .cloned()
                .unwrap_or_default(),
            objects[ia].void,
        ),
    };
    mesh = with_material(mesh, material);
    tr.apply(&mut mesh);
    Ok(Object {
        name: e.name.clone(),
        mesh,
        void,
        used: false,
    })
}

/// A boolean operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CsgOp {
    /// Both.
    Union,
    /// What both hold.
    Intersection,
    /// The first without the second.
    Difference,
}

impl CsgOp {
    fn parse(s: &str) -> Option<Self> {
        match s {
            "union" => Some(Self::Union),
            "intersection" => Some(Self::Intersection),
            "difference" => Some(Self::Difference),
            _ => None,
        }
    }
}

#[cfg(feature = "csg")]
fn boolean(a: &Mesh, b: &Mesh, op: CsgOp) -> Result<Mesh, String> {
    crate::scene::csg::boolean(a, b, op)
}

#[cfg(not(feature = "csg"))]
fn boolean(_: &Mesh, _: &Mesh, _: CsgOp) -> Result<Mesh, String> {
    Err(
        "CSG needs svo's `csg` cargo feature (the Manifold kernel, C++, built with cmake and ninja)"
            .into(),
    )
}

/// What [`SceneError::MeshNotFound`] suggests.
const MODELS_HINT: &str = " (set SVO_MODELS to the folder that holds it)";

/// `a, b, c` from paths.
fn list(paths: &[PathBuf]) -> String {
    let v: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    v.join(", ")
}

/// The folders in which a scene file at `dir` with top-level `models = [...]` looks for a
/// mesh's relative `file`, in order (see [`load_scene`]).
pub(crate) fn mesh_search_path(dir: &Path, models: &[PathBuf]) -> Vec<PathBuf> {
    let mut v = vec![dir.to_path_buf()];
    if let Some(list) = std::env::var_os("SVO_MODELS") {
        v.extend(std::env::split_paths(&list).filter(|p| !p.as_os_str().is_empty()));
    }
    v.extend(models.iter().map(|m| dir.join(m)));
    v
}

/// Loads a scene file.
///
/// A `[[mesh]]`'s relative `file` is looked for in the scene file's folder, then in each
/// folder of the environment variable `SVO_MODELS` (a path list, separated as `PATH` is), then
/// in each folder of the scene's top-level `models = [...]` (relative to the scene file); the
/// first that holds it wins. An absolute `file` is used as it is.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|cause| SceneError::Io {
        path: path.display().to_string(),
        cause,
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse_scene(&text, dir, &path.display().to_string())
}

/// Parses a scene from its text; mesh paths are relative to `dir`; `name` is used in errors.
pub(crate) fn parse_scene(text: &str, dir: &Path, name: &str) -> Result<Scene, SceneError> {
    let f: SceneFile = toml::from_str(text).map_err(|e| SceneError::Parse {
        path: name.to_string(),
        message: e.to_string().trim_end().replace('\n', " "),
    })?;
    let mut b = Objects {
        name,
        materials: &f.material,
        objects: Vec::new(),
    };
    if let Some(d) = f.depth
        && !(1..=crate::MAX_DEPTH).contains(&d)
    {
        return Err(b.invalid(format!("depth {d} is outside 1..={}", crate::MAX_DEPTH)));
    }
    let solid = match &f.solid {
        None => None,
        Some(s) => Some(
            s.parse::<SolidMode>()
                .map_err(|_| b.invalid(format!("unknown solid mode {s:?} (closed, vote)")))?,
        ),
    };
    b.meshes(&f.mesh, &mesh_search_path(dir, &f.models))?;
    b.boxes(&f.boxes)?;
    b.spheres(&f.sphere)?;
    b.rectangles(&f.rectangle)?;
    if let Some(e) = b.duplicate() {
        return Err(b.invalid(e));
    }
    b.csgs(&f.csg)?;
    let mesh = b.placed()?;
    let info = stored_views(&f);
    info.validate().map_err(|e| b.invalid(e.to_string()))?;
    if let Some(n) = repeated(info.cameras.iter().map(|c| c.name.as_str())) {
        return Err(b.invalid(format!("two cameras are named {n:?}")));
    }
    Ok(Scene {
        mesh,
        info,
        depth: f.depth,
        solid,
    })
}

/// The scene's lights and camera views as stored with the tree.
fn stored_views(f: &SceneFile) -> SceneInfo {
    SceneInfo {
        lights: f
            .light
            .iter()
            .map(|l| StoredLight {
                position: l.position,
                colour: l.colour.unwrap_or([1.0; 3]),
                intensity: l.intensity,
            })
            .collect(),
        cameras: f
            .camera
            .iter()
            .map(|c| StoredCamera {
                name: c.name.clone(),
                eye: c.eye,
                target: c.target,
                up: c.up.unwrap_or([0.0, 1.0, 0.0]),
                fov_deg: c.fov.unwrap_or(40.0),
            })
            .collect(),
    }
}

/// The objects of a scene file as its entries are read, one kind of entry after another.
struct Objects<'a> {
    /// The scene file, for errors.
    name: &'a str,
    /// Its `[material.*]` table.
    materials: &'a BTreeMap<String, MaterialEntry>,
    objects: Vec<Object>,
}

impl Objects<'_> {
    /// The error for `what` in this scene.
    fn invalid(&self, what: String) -> SceneError {
        SceneError::Invalid {
            path: self.name.to_string(),
            what,
        }
    }

    /// Adds `mesh` (entry `what`, named `name`) in place with its material (or void).
    fn add(
        &mut self,
        what: &str,
        name: Option<&String>,
        mesh: Mesh,
        mat: Option<&String>,
        tr: Result<Transform, String>,
    ) -> Result<(), SceneError> {
        let tr = tr.map_err(|e| self.invalid(format!("{what}: {e}")))?;
        let (mut mesh, void) = match mat {
            None => (mesh, false),
            Some(n) => match material(n, self.materials)
                .map_err(|e| self.invalid(format!("{what}: {e}")))?
            {
                None => (mesh, true),
                Some(m) => (with_material(mesh, m), false),
            },
        };
        tr.apply(&mut mesh);
        // A scene file names its own lights and views; a glTF's are not taken along.
        mesh.scene = SceneInfo::default();
        self.objects.push(Object {
            name: name.cloned(),
            mesh,
            void,
            used: false,
        });
        Ok(())
    }

    /// The `[[mesh]]` entries: mesh files, relative ones found along `search`.
    fn meshes(&mut self, entries: &[MeshEntry], search: &[PathBuf]) -> Result<(), SceneError> {
        for (i, e) in entries.iter().enumerate() {
            let found = if e.file.is_absolute() {
                Some(e.file.clone())
            } else {
                search.iter().map(|d| d.join(&e.file)).find(|p| p.is_file())
            };
            let file = found.ok_or_else(|| SceneError::MeshNotFound {
                path: self.name.to_string(),
                index: i,
                file: e.file.display().to_string(),
                tried: search.to_vec(),
            })?;
            let mesh = load_mesh(&file).map_err(|source| SceneError::Mesh {
                path: self.name.to_string(),
                index: i,
                source,
            })?;
            let tr = Transform::new(e.scale.as_ref(), e.rotate, e.translate);
            self.add(
                &format!("mesh {i} ({})", e.file.display()),
                e.name.as_ref(),
                mesh,
                e.material.as_ref(),
                tr,
            )?;
        }
        Ok(())
    }

    /// The `[[box]]` entries.
    fn boxes(&mut self, entries: &[BoxEntry]) -> Result<(), SceneError> {
        for (i, e) in entries.iter().enumerate() {
            let what = format!("box {i}");
            let (lo, hi) = (DVec3::from_array(e.min), DVec3::from_array(e.max));
            if !(finite3(e.min) && finite3(e.max) && lo.cmplt(hi).all()) {
                return Err(self.invalid(format!(
                    "{what}: min must be finite and below max on every axis"
                )));
            }
            let tr = Transform::new(e.scale.as_ref(), e.rotate, e.translate);
            let mesh = Mesh::cuboid(lo, hi);
            self.add(&what, e.name.as_ref(), mesh, e.material.as_ref(), tr)?;
        }
        Ok(())
    }

    /// The `[[sphere]]` entries.
    fn spheres(&mut self, entries: &[SphereEntry]) -> Result<(), SceneError> {
        for (i, e) in entries.iter().enumerate() {
            let what = format!("sphere {i}");
            let detail = e.detail.unwrap_or(16);
            if !(finite3(e.centre) && e.radius.is_finite() && e.radius > 0.0) {
                return Err(
                    self.invalid(format!("{what}: centre must be finite and radius positive"))
                );
            }
            if !(1..=MAX_SPHERE_DETAIL).contains(&detail) {
                return Err(self.invalid(format!(
                    "{what}: detail {detail} is outside 1..={MAX_SPHERE_DETAIL}"
                )));
            }
            let tr = Transform::new(e.scale.as_ref(), e.rotate, e.translate);
            let mesh = Mesh::sphere(DVec3::from_array(e.centre), e.radius, detail);
            self.add(&what, e.name.as_ref(), mesh, e.material.as_ref(), tr)?;
        }
        Ok(())
    }

    /// The `[[rectangle]]` entries.
    fn rectangles(&mut self, entries: &[RectangleEntry]) -> Result<(), SceneError> {
        for (i, e) in entries.iter().enumerate() {
            let what = format!("rectangle {i}");
            let n = DVec3::from_array(e.normal);
            if !(finite3(e.centre)
                && n.is_finite()
                && n.length_squared() > 0.0
                && e.size.iter().all(|s| s.is_finite() && *s > 0.0))
            {
                return Err(self.invalid(format!(
                    "{what}: centre must be finite, normal non-zero and size positive"
                )));
            }
            let tr = Transform::new(e.scale.as_ref(), e.rotate, e.translate);
            let mesh = Mesh::rectangle(DVec3::from_array(e.centre), n, e.size);
            self.add(&what, e.name.as_ref(), mesh, e.material.as_ref(), tr)?;
        }
        Ok(())
    }

    /// The message for two objects of one name, if any.
    fn duplicate(&self) -> Option<String> {
        repeated(self.objects.iter().filter_map(|o| o.name.as_deref()))
            .map(|n| format!("two objects are named {n:?}"))
    }

    /// The `[[csg]]` entries, each over the objects before it.
    fn csgs(&mut self, entries: &[CsgEntry]) -> Result<(), SceneError> {
        for (i, e) in entries.iter().enumerate() {
            let what = format!("csg {i}");
            let obj = csg(&mut self.objects, e, self.materials)
                .map_err(|m| self.invalid(format!("{what}: {m}")))?;
            self.objects.push(obj);
            if let Some(e) = self.duplicate() {
                return Err(self.invalid(format!("{what}: {e}")));
            }
        }
        Ok(())
    }

    /// The placed objects as one mesh: CSG operands used up, void objects left out; an
    /// error when nothing is left.
    fn placed(&mut self) -> Result<Mesh, SceneError> {
        let mut out = Mesh::default();
        let mut placed = 0usize;
        for o in std::mem::take(&mut self.objects) {
            if !o.used && !o.void {
                out.append(o.mesh);
                placed += 1;
            }
        }
        if placed == 0 {
            return Err(SceneError::Empty {
                path: self.name.to_string(),
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Scene, SceneError> {
        parse_scene(text, Path::new("."), "test.toml")
    }

    #[test]
    fn primitives_materials_transforms_lights_and_views() {
        let s = parse(
            r#"
            depth = 6
            solid = "vote"
            [material.tiles]
            preset = "solid"
            colour = [0.5, 0.6, 0.7]
            reflectivity = 0.1
            [[box]]
            min = [0, 0, 0]
            max = [1, 2, 3]
            material = "tiles"
            scale = -1.0
            translate = [10, 0, 0]
            [[sphere]]
            centre = [0, 5, 0]
            radius = 1
            detail = 2
            material = "glass"
            [[rectangle]]
            centre = [0, 3, 0]
            normal = [0, 1, 0]
            size = [4, 4]
            material = "water"
            [[sphere]]
            centre = [9, 9, 9]
            radius = 1
            material = "void"
            [[light]]
            position = [1, 8, 1]
            intensity = 50
            [[camera]]
            name = "top"
            eye = [0, 10, 0.1]
            target = [0, 0, 0]
            "#,
        )
        .unwrap();
        assert_eq!((s.depth, s.solid), (Some(6), Some(SolidMode::Vote)));
        let m = &s.mesh;
        // The void sphere is left out: a box, a detail-2 sphere, a rectangle.
        assert_eq!(m.triangles.len(), 12 + 32 + 2);
        m.validate().unwrap();
        let names: Vec<&str> = m.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["tiles", "glass", "water"]);
        assert_eq!(m.materials[0].colour, [0.5, 0.6, 0.7, 1.0]);
        assert_eq!(m.materials[0].reflectivity, 0.1);
        // Mirrored by scale -1 and moved: the box spans x 9..10 and still faces out.
        let (lo, hi) = Mesh {
            triangles: m.triangles[..12].to_vec(),
            ..m.clone()
        }
        .bounds()
        .unwrap();
        assert_eq!(
            (lo, hi),
            (DVec3::new(9.0, -2.0, -3.0), DVec3::new(10.0, 0.0, 0.0))
        );
        let vol: f64 = m.triangles[..12]
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!((vol - 6.0).abs() < 1e-9, "{vol}");
        assert_eq!(s.info.lights[0].colour, [1.0; 3]);
        assert_eq!(s.info.cameras[0].up, [0.0, 1.0, 0.0]);
        assert_eq!(s.info.cameras[0].fov_deg, 40.0);
    }

    const CSG: &str = r#"
        [[box]]
        name = "tub"
        min = [-1, -1, -1]
        max = [1, 1, 1]
        material = "tiles"
        [[sphere]]
        name = "scoop"
        centre = [0, 0, 0]
        radius = 0.8
        detail = 24
        [[csg]]
        op = "difference"
        a = "tub"
        b = "scoop"
        [material.tiles]
        colour = [0.2, 0.4, 0.6]
    "#;

    #[cfg(feature = "csg")]
    #[test]
    fn csg_through_manifold() {
        let s = parse(CSG).unwrap();
        let m = &s.mesh;
        // Only the result is placed, closed, with operand a's material.
        assert_eq!(crate::mesh::closed::open_edges(m), 0);
        assert_eq!(m.materials.len(), 1);
        assert_eq!(m.materials[0].name, "tiles");
        let vol: f64 = m
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let want = 8.0 - 4.0 / 3.0 * std::f64::consts::PI * 0.512;
        assert!((vol - want).abs() < 0.01 * want, "{vol} vs {want}");
        // The hollow is empty in a solid bake: the centre cell is not a leaf.
        let opts = crate::BakeOptions {
            depth: 5,
            solid: Some(SolidMode::Closed),
            ..crate::BakeOptions::default()
        };
        let (tree, _) = crate::bake_mesh(m, &opts).unwrap();
        assert!(tree.leaf_at(glam::UVec3::splat(16)).is_none());
        assert!(tree.leaf_at(glam::UVec3::new(1, 16, 16)).is_some());
        // Manifold refuses open operands, named.
        let text = r#"
            [[box]]
            name = "a"
            min = [0, 0, 0]
            max = [1, 1, 1]
            [[rectangle]]
            name = "b"
            centre = [0.5, 0.5, 0.5]
            normal = [0, 1, 0]
            size = [2, 2]
            [[csg]]
            op = "union"
            a = "a"
            b = "b"
        "#;
        let e = parse(text).map(|_| ()).unwrap_err().to_string();
        assert!(
            e.contains("operand b is not a closed manifold (4 open edges"),
            "{e}"
        );
    }

    #[cfg(not(feature = "csg"))]
    #[test]
    fn csg_without_the_feature_says_so() {
        let e = parse(CSG).map(|_| ()).unwrap_err().to_string();
        assert!(
            e.contains("csg 0: CSG needs svo's `csg` cargo feature"),
            "{e}"
        );
    }

    #[test]
    fn csg_mistakes_are_named() {
        for (edit, needle) in [
            (
                ("op = \"difference\"", "op = \"minus\""),
                "unknown op \"minus\"",
            ),
            (
                ("b = \"scoop\"", "b = \"spoon\""),
                "no object named \"spoon\"",
            ),
            (("b = \"scoop\"", "b = \"tub\""), "the same object"),
            (("name = \"scoop\"", "name = \"tub\""), "named \"tub\""),
        ] {
            let text = CSG.replace(edit.0, edit.1);
            let e = parse(&text).map(|_| ()).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }

    #[test]
    fn mistakes_are_named() {
        let cases = [
            (
                "[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nmaterial = \"glas\"",
                "unknown material \"glas\"",
            ),
            (
                "[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\ncolour = 1",
                "unknown field `colour`",
            ),
            ("[[box]]\nmin = [0, 0, 0]\nmax = [1, 0, 1]", "below max"),
            (
                "[[sphere]]\ncentre = [0, 0, 0]\nradius = 1\ndetail = 5000",
                "detail 5000",
            ),
            (
                "[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nscale = 0",
                "non-zero",
            ),
            (
                "depth = 0\n[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]",
                "depth 0",
            ),
            (
                "solid = \"full\"\n[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]",
                "unknown solid mode",
            ),
            (
                "[[sphere]]\ncentre = [0, 0, 0]\nradius = 1\nmaterial = \"void\"",
                "no objects",
            ),
            ("", "no objects"),
            (
                "[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n[[camera]]\nname = \"a\"\neye = [0, 0, 0]\ntarget = [0, 0, 0]",
                "coincide",
            ),
            (
                "[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n[[light]]\nposition = [0, 0, 0]\nintensity = -1",
                "intensity",
            ),
            (
                "[material.x]\npreset = \"glass\"\nreflectivity = 0.5\n[[box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nmaterial = \"x\"",
                "exceeds 1",
            ),
            ("[[mesh]]\nfile = \"missing.obj\"", "mesh 0"),
            ("depth = [", "test.toml"),
        ];
        for (text, needle) in cases {
            let e = parse(text).map(|_| ()).unwrap_err().to_string();
            assert!(e.contains(needle), "{text:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
