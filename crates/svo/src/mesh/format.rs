//! The mesh file formats: which importer a file name asks for.

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

/// Whether `path` names a scene file (`.toml`, read with the `scene` feature) rather than a
/// mesh.
#[cfg(feature = "io")]
pub(crate) fn is_scene_file(path: &Path) -> bool {
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
