//! Mesh import by file extension: `.obj` (with MTL), `.obj.gz`, `.ply`, `.gltf`, `.glb`.
//! Each format sits behind its cargo feature; every importer ends with
//! [`Mesh::validate`](crate::mesh::Mesh::validate).

#[cfg(feature = "gltf")]
pub mod import_gltf;
#[cfg(feature = "obj")]
pub mod import_obj;
#[cfg(feature = "ply")]
pub mod import_ply;
#[cfg(feature = "obj")]
pub mod obj_geometry;
#[cfg(feature = "ply")]
pub mod ply_ascii;

use crate::mesh::{Mesh, MeshError};
use std::path::Path;

/// The mesh formats `svo` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum MeshFormat {
    /// Wavefront OBJ with MTL materials.
    Obj,
    /// Gzip-compressed OBJ.
    ObjGz,
    /// Stanford PLY (ASCII or binary).
    Ply,
    /// glTF 2.0, JSON or binary.
    Gltf,
}

/// Whether `path` names a scene file (`.toml`, read by [`crate::scene_file`] with the
/// `scene` feature) rather than a mesh.
pub fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

impl MeshFormat {
    /// The format a file name's extension names, if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        if name.ends_with(".obj.gz") {
            Some(Self::ObjGz)
        } else if name.ends_with(".obj") {
            Some(Self::Obj)
        } else if name.ends_with(".ply") {
            Some(Self::Ply)
        } else if name.ends_with(".gltf") || name.ends_with(".glb") {
            Some(Self::Gltf)
        } else {
            None
        }
    }
}

pub(crate) fn io_error(path: &Path, cause: std::io::Error) -> MeshError {
    MeshError::Io {
        path: path.display().to_string(),
        cause,
    }
}

#[cfg_attr(
    not(any(feature = "obj", feature = "ply", feature = "gltf")),
    allow(dead_code)
)]
pub(crate) fn parse_error(path: &Path, message: impl std::fmt::Display) -> MeshError {
    MeshError::Parse {
        path: path.display().to_string(),
        message: message.to_string(),
    }
}

/// The error for a format whose importer's cargo feature is off.
#[cfg_attr(
    all(feature = "obj", feature = "ply", feature = "gltf"),
    allow(dead_code)
)]
fn not_compiled_in(path: &Path, format: MeshFormat) -> MeshError {
    MeshError::UnknownFormat {
        path: path.display().to_string(),
        extension: format!("{format:?} (support not compiled in: enable the cargo feature)"),
    }
}

/// Reads and validates a mesh held in memory, in `format` (`ObjGz` is read as gzip). Files
/// the mesh refers to (MTL libraries, textures, external glTF buffers) cannot be resolved
/// from memory: OBJ materials fall back to the default, glTF references are an error.
/// `name` appears in error messages.
#[cfg_attr(
    not(any(feature = "obj", feature = "ply", feature = "gltf")),
    allow(unreachable_code, unused_variables)
)]
pub fn mesh_from_bytes(bytes: &[u8], format: MeshFormat, name: &Path) -> Result<Mesh, MeshError> {
    let mesh: Mesh = match format {
        #[cfg(feature = "obj")]
        MeshFormat::Obj => import_obj::obj_from_bytes(bytes, name)?,
        #[cfg(feature = "obj")]
        MeshFormat::ObjGz => {
            use std::io::Read;
            let mut text = Vec::new();
            flate2::read::GzDecoder::new(bytes)
                .read_to_end(&mut text)
                .map_err(|e| io_error(name, e))?;
            import_obj::obj_from_bytes(&text, name)?
        }
        #[cfg(feature = "ply")]
        MeshFormat::Ply => import_ply::ply_from_bytes(bytes, name)?,
        #[cfg(feature = "gltf")]
        MeshFormat::Gltf => import_gltf::gltf_from_bytes(bytes, name)?,
        #[allow(unreachable_patterns)]
        _ => return Err(not_compiled_in(name, format)),
    };
    mesh.validate()?;
    Ok(mesh)
}

/// Loads and validates a mesh, choosing the importer by extension.
// Without any importer feature every arm returns early.
#[cfg_attr(
    not(any(feature = "obj", feature = "ply", feature = "gltf")),
    allow(unreachable_code, unused_variables)
)]
pub fn load_mesh(path: &Path) -> Result<Mesh, MeshError> {
    let format = MeshFormat::from_path(path).ok_or_else(|| MeshError::UnknownFormat {
        path: path.display().to_string(),
        extension: path
            .extension()
            .map(|e| e.to_string_lossy().into_owned())
            .unwrap_or_default(),
    })?;
    // A clear error for a missing or unreadable file, whatever the importer would say.
    let meta = std::fs::metadata(path).map_err(|e| io_error(path, e))?;
    if meta.is_dir() {
        return Err(io_error(path, std::io::Error::other("is a directory")));
    }
    let mesh: Mesh = match format {
        #[cfg(feature = "obj")]
        MeshFormat::Obj => import_obj::load_obj(path, false)?,
        #[cfg(feature = "obj")]
        MeshFormat::ObjGz => import_obj::load_obj(path, true)?,
        #[cfg(feature = "ply")]
        MeshFormat::Ply => import_ply::load_ply(path)?,
        #[cfg(feature = "gltf")]
        MeshFormat::Gltf => import_gltf::load_gltf(path)?,
        #[allow(unreachable_patterns)]
        _ => return Err(not_compiled_in(path, format)),
    };
    mesh.validate()?;
    Ok(mesh)
}
