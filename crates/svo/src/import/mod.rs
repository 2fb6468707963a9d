//! Mesh import: `.obj` (with MTL), `.obj.gz`, `.ply`, `.gltf` and `.glb`, from a path, from
//! bytes or from a reader ([`Mesh::load`], [`Mesh::from_bytes`], [`Mesh::read`]). Each format
//! sits behind its cargo feature (`obj`, `ply`, `gltf`); every importer ends with
//! [`Mesh::validate`]. Our own readers for OBJ files without materials and for plain ASCII
//! PLY are held to give exactly the crates' meshes (tobj, ply-rs-bw), and hand every other
//! file to them.
//!
//! Depends on [`crate::mesh`] only.

// Public for the fuzz targets' and the repository's tests' re-export (`svo::fuzz_import`,
// under `cfg(fuzzing)` or the hidden `differential` feature only).
#[cfg(all(
    any(test, fuzzing, feature = "differential"),
    any(feature = "obj", feature = "ply")
))]
#[cfg_attr(not(any(fuzzing, feature = "differential")), allow(unreachable_pub))]
pub mod differential;
#[cfg(feature = "gltf")]
pub(crate) mod gltf;
#[cfg(feature = "obj")]
pub(crate) mod obj;
#[cfg(feature = "obj")]
pub(crate) mod obj_geometry;
#[cfg(all(test, feature = "obj"))]
mod obj_reader_tests;
#[cfg(feature = "ply")]
pub(crate) mod ply;
#[cfg(feature = "ply")]
pub(crate) mod ply_ascii;
#[cfg(all(test, feature = "ply"))]
mod ply_reader_tests;

use crate::mesh::{Mesh, MeshError, MeshFormat};
use std::path::Path;

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
    // One line, whatever the parser wrote (ply-rs-bw's messages span several).
    let message = message.to_string();
    MeshError::Parse {
        path: path.display().to_string(),
        message: message.split_whitespace().collect::<Vec<_>>().join(" "),
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
pub(crate) fn mesh_from_bytes(
    bytes: &[u8],
    format: MeshFormat,
    name: &Path,
) -> Result<Mesh, MeshError> {
    let mesh: Mesh = match format {
        #[cfg(feature = "obj")]
        MeshFormat::Obj => obj::obj_from_bytes(bytes, name)?,
        #[cfg(feature = "obj")]
        MeshFormat::ObjGz => {
            use std::io::Read;
            let mut text = Vec::new();
            flate2::read::GzDecoder::new(bytes)
                .read_to_end(&mut text)
                .map_err(|e| io_error(name, e))?;
            obj::obj_from_bytes(&text, name)?
        }
        #[cfg(feature = "ply")]
        MeshFormat::Ply => ply::ply_from_bytes(bytes, name)?,
        #[cfg(feature = "gltf")]
        MeshFormat::Gltf => gltf::gltf_from_bytes(bytes, name)?,
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
pub(crate) fn load_mesh(path: &Path) -> Result<Mesh, MeshError> {
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
        MeshFormat::Obj => obj::load_obj(path, false)?,
        #[cfg(feature = "obj")]
        MeshFormat::ObjGz => obj::load_obj(path, true)?,
        #[cfg(feature = "ply")]
        MeshFormat::Ply => ply::load_ply(path)?,
        #[cfg(feature = "gltf")]
        MeshFormat::Gltf => gltf::load_gltf(path)?,
        #[allow(unreachable_patterns)]
        _ => return Err(not_compiled_in(path, format)),
    };
    mesh.validate()?;
    Ok(mesh)
}

impl Mesh {
    /// Loads and validates a mesh, choosing the importer by the file's extension (`.obj`,
    /// `.obj.gz`, `.ply`, `.gltf`, `.glb`). OBJ materials (MTL) and textures, and glTF
    /// buffers, lights and cameras, are read from beside the file.
    ///
    /// ```no_run
    /// let mesh = svo::Mesh::load("bunny.obj")?;
    /// println!("{} triangles", mesh.triangles.len());
    /// # Ok::<(), svo::MeshError>(())
    /// ```
    pub fn load(path: impl AsRef<Path>) -> Result<Mesh, MeshError> {
        load_mesh(path.as_ref())
    }

    /// Reads and validates a mesh held in memory, in `format` (`ObjGz` is read as gzip).
    /// Files the mesh refers to (MTL libraries, textures, external glTF buffers) cannot be
    /// resolved from memory: OBJ materials fall back to the default, glTF references are an
    /// error.
    ///
    /// ```
    /// use svo::{Mesh, MeshFormat};
    /// let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    /// let mesh = Mesh::from_bytes(obj, MeshFormat::Obj)?;
    /// assert_eq!(mesh.triangles.len(), 1);
    /// # Ok::<(), svo::MeshError>(())
    /// ```
    pub fn from_bytes(bytes: &[u8], format: MeshFormat) -> Result<Mesh, MeshError> {
        mesh_from_bytes(bytes, format, Path::new("<memory>"))
    }

    /// Reads a whole mesh from `reader`, as [`Mesh::from_bytes`].
    pub fn read(mut reader: impl std::io::Read, format: MeshFormat) -> Result<Mesh, MeshError> {
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .map_err(|e| io_error(Path::new("<reader>"), e))?;
        Self::from_bytes(&bytes, format)
    }
}
