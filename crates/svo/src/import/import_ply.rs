//! PLY import (ASCII and binary) through `ply-rs-bw`: the `vertex` element's `x`, `y`, `z`
//! and the `face` element's `vertex_indices` (or `vertex_index`) lists, fan-triangulated.

use super::{io_error, parse_error};
use crate::mesh::{Mesh, MeshError};
use glam::DVec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
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

/// Loads a PLY file.
pub fn load_ply(path: &Path) -> Result<Mesh, MeshError> {
    let file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    read_ply(&mut std::io::BufReader::new(file), path)
}

/// Reads a PLY (ASCII or binary) from memory; `name` appears in error messages.
pub fn ply_from_bytes(bytes: &[u8], name: &Path) -> Result<Mesh, MeshError> {
    read_ply(&mut std::io::Cursor::new(bytes), name)
}

fn read_ply(r: &mut impl std::io::BufRead, path: &Path) -> Result<Mesh, MeshError> {
    let ply = Parser::<DefaultElement>::new()
        .read_ply(r)
        .map_err(|e| parse_error(path, e))?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| parse_error(path, "no vertex element"))?;
    let mut mesh = Mesh::default();
    mesh.positions.reserve(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let c = |k: &str| v.get(k).and_then(scalar);
        match (c("x"), c("y"), c("z")) {
            (Some(x), Some(y), Some(z)) => mesh.positions.push(DVec3::new(x, y, z)),
            _ => {
                return Err(parse_error(
                    path,
                    format!("vertex {i} lacks a numeric x, y or z"),
                ));
            }
        }
    }
    let nv = mesh.positions.len();
    if let Some(faces) = ply.payload.get("face") {
        for (f, face) in faces.iter().enumerate() {
            let list = face
                .get("vertex_indices")
                .or_else(|| face.get("vertex_index"))
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
    }
    Ok(mesh)
}
