//! PLY import (ASCII and binary) through `ply-rs-bw`: the `vertex` element's `x`, `y`, `z`
//! and the `face` element's `vertex_indices` (or `vertex_index`) lists, fan-triangulated.
//!
//! The crate reads the header. A plain ASCII payload (a `vertex` and a `face` element) is
//! then read by our own scan ([`super::ply_ascii`]), which gives exactly the crate's mesh or
//! declines; every other payload, and every one it declines, goes to the crate, its
//! elements read into small types of our own (`PlyVertex`, `PlyFace`) rather than the
//! crate's `DefaultElement`, a map from property names to values built for every vertex and
//! face (the same parser, values and errors, 2.8 times faster). `ply_reader_tests.rs` holds
//! all of it equal to the straightforward reading through `DefaultElement`.

use super::{io_error, parse_error};
use crate::mesh::triangle_mesh::{Mesh, MeshError};
use glam::DVec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Header, Property, PropertyAccess, PropertyAccessResult};
use std::path::Path;

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => f64::from(v),
        Property::UChar(v) => f64::from(v),
        Property::Short(v) => f64::from(v),
        Property::UShort(v) => f64::from(v),
        Property::Int(v) => f64::from(v),
        Property::UInt(v) => f64::from(v),
        Property::Float(v) => f64::from(v),
        Property::Double(v) => v,
        _ => return None,
    })
}

fn index_list(p: &Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListUChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListUShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListUInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
        _ => return None,
    })
}

/// A vertex as the importer reads it: `x`, `y`, `z` of any scalar type, widened to `f64`
/// (`None` where one is missing or a list).
#[derive(Default)]
struct PlyVertex {
    xyz: [Option<f64>; 3],
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.xyz[axis] = scalar(&property);
        PropertyAccessResult::Set
    }
}

/// A face as the importer reads it: its `vertex_indices` and `vertex_index` properties, as
/// given.
#[derive(Default)]
struct PlyFace {
    indices: Option<Property>,
    index: Option<Property>,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        match name {
            "vertex_indices" => self.indices = Some(property),
            "vertex_index" => self.index = Some(property),
            _ => return PropertyAccessResult::Ignored,
        }
        PropertyAccessResult::Set
    }
}

/// Any other element: parsed (so that it is checked as before) and dropped.
struct PlySkip;

impl PropertyAccess for PlySkip {
    fn new() -> Self {
        PlySkip
    }
}

/// One element's payload, read into `T` (the type that keeps what the importer needs).
fn payload<T: PropertyAccess>(
    reader: &mut Reader<impl std::io::BufRead>,
    def: &ElementDef,
    header: &Header,
    path: &Path,
) -> Result<Vec<T>, MeshError> {
    Parser::<T>::new()
        .read_payload_for_element(reader, def, header)
        .map_err(|e| parse_error(path, e))
}

/// Loads a PLY file.
pub(crate) fn load_ply(path: &Path) -> Result<Mesh, MeshError> {
    let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
    ply_from_bytes(&bytes, path)
}

/// Reads a PLY (ASCII or binary) from memory; `name` appears in error messages.
pub(crate) fn ply_from_bytes(bytes: &[u8], name: &Path) -> Result<Mesh, MeshError> {
    read_bytes(bytes, name, true)
}

/// Reads a PLY from memory through the crate alone (what [`ply_from_bytes`] does for a file
/// the ASCII fast path declines): the reference that fast path is tested against.
#[cfg(any(test, fuzzing, feature = "differential"))]
pub(crate) fn ply_from_bytes_crate(bytes: &[u8], name: &Path) -> Result<Mesh, MeshError> {
    read_bytes(bytes, name, false)
}

/// The header through the crate, then the payload by our ASCII scan where `scan` is set and
/// it takes the file, else through the crate.
fn read_bytes(bytes: &[u8], name: &Path, scan: bool) -> Result<Mesh, MeshError> {
    let mut cursor = std::io::Cursor::new(bytes);
    let mut reader = Reader::new(&mut cursor);
    let header = Parser::<PlySkip>::new()
        .read_header(&mut reader)
        .map_err(|e| parse_error(name, e))?;
    if scan {
        // The plain ASCII case (exactly the crate's result, or it declines).
        let data = usize::try_from(reader.get_ref().position())
            .ok()
            .and_then(|at| bytes.get(at..));
        if let Some(mesh) = data.and_then(|d| super::ply_ascii::read_ascii_mesh(&header, d)) {
            return Ok(mesh);
        }
    }
    read_payload(&mut reader, &header, name)
}

/// The elements after the header through the crate.
fn read_payload(
    reader: &mut Reader<impl std::io::BufRead>,
    header: &Header,
    path: &Path,
) -> Result<Mesh, MeshError> {
    let (mut vertices, mut faces) = (None, Vec::new());
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" => vertices = Some(payload::<PlyVertex>(reader, def, header, path)?),
            "face" => faces = payload::<PlyFace>(reader, def, header, path)?,
            _ => drop(payload::<PlySkip>(reader, def, header, path)?),
        }
    }
    let vertices = vertices.ok_or_else(|| parse_error(path, "no vertex element"))?;
    let mut mesh = Mesh::default();
    mesh.positions.reserve(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        match v.xyz {
            [Some(x), Some(y), Some(z)] => mesh.positions.push(DVec3::new(x, y, z)),
            _ => {
                return Err(parse_error(
                    path,
                    format!("vertex {i} lacks a numeric x, y or z"),
                ));
            }
        }
    }
    let nv = mesh.positions.len();
    for (f, face) in faces.iter().enumerate() {
        let list = face
            .indices
            .as_ref()
            .or(face.index.as_ref())
            .and_then(index_list)
            .ok_or_else(|| parse_error(path, format!("face {f} has no vertex_indices list")))?;
        if let Some(&bad) = list.iter().find(|&&i| i < 0 || i as u64 >= nv as u64) {
            return Err(MeshError::IndexOutOfRange {
                triangle: mesh.triangles.len(),
                index: bad as u64,
                vertex_count: nv,
            });
        }
        for k in 1..list.len().saturating_sub(1) {
            mesh.triangles
                .push([list[0] as u32, list[k] as u32, list[k + 1] as u32]);
        }
    }
    Ok(mesh)
}
