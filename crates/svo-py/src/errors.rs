//! The exceptions: the library's errors as Python ones, each with the library's one-line
//! message. What the operating system refused (a missing file, a directory, no permission)
//! is the matching `OSError` subclass; what is wrong with a mesh, a bake's options, a file's
//! bytes or an export is a subclass of `ValueError` named for it (`MeshError`, `BakeError`,
//! `FormatError`, `ExportError`); a wrong array type is a `TypeError`.

use pyo3::PyErr;
use pyo3::create_exception;
use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyPermissionError, PyValueError,
};
use std::io::ErrorKind;

create_exception!(
    svo,
    MeshError,
    PyValueError,
    "A mesh that cannot be baked: no triangles, a non-finite coordinate, an index past the \
     vertices, or a file that does not parse."
);
create_exception!(
    svo,
    BakeError,
    PyValueError,
    "A bake refused before it starts: a depth outside 1..=30, a tree larger than the memory \
     available, an open mesh for a closed solid fill, contours without normals."
);
create_exception!(
    svo,
    FormatError,
    PyValueError,
    "An .svo file or byte string that is not a valid tree: bad magic bytes, truncated, \
     corrupt (the numbered check of docs/format.md that failed is named), or from a newer \
     format version."
);
create_exception!(
    svo,
    ExportError,
    PyValueError,
    "A tree that an export format cannot hold (binvox up to depth 10, MagicaVoxel up to 8)."
);

/// The `OSError` subclass for an operating system error of `kind`, with `message`.
fn os_error(kind: ErrorKind, message: String) -> PyErr {
    match kind {
        ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
        ErrorKind::IsADirectory => PyIsADirectoryError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}

/// A mesh error: its I/O failures as `OSError`s, the rest as `MeshError`.
pub(crate) fn mesh_error(e: svo::MeshError) -> PyErr {
    match &e {
        svo::MeshError::Io { cause, .. } => os_error(cause.kind(), e.to_string()),
        _ => MeshError::new_err(e.to_string()),
    }
}

/// A bake error: the mesh's as [`mesh_error`], the rest as `BakeError`.
pub(crate) fn bake_error(e: svo::BakeError) -> PyErr {
    match e {
        svo::BakeError::Mesh(m) => mesh_error(m),
        e => BakeError::new_err(e.to_string()),
    }
}

/// A file format error: its I/O failures as `OSError`s, the rest as `FormatError`.
pub(crate) fn format_error(e: svo::FormatError) -> PyErr {
    match &e {
        svo::FormatError::Io { cause, .. } => os_error(cause.kind(), e.to_string()),
        _ => FormatError::new_err(e.to_string()),
    }
}

/// An export error: its I/O failures as `OSError`s, the rest as `ExportError`.
pub(crate) fn export_error(e: svo::io::ExportError) -> PyErr {
    match &e {
        svo::io::ExportError::Io { cause, .. } => os_error(cause.kind(), e.to_string()),
        _ => ExportError::new_err(e.to_string()),
    }
}

/// A refused thread count, as a `ValueError`.
pub(crate) fn threads_error(e: svo::ThreadsError) -> PyErr {
    PyValueError::new_err(e.to_string())
}
