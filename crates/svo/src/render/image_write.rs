//! Writing rendered images: 8-bit RGB PNG, and 32-bit float depth as PFM or OpenEXR, all
//! atomically (a temporary file renamed into place; no partial output on failure).

use crate::io::atomic_write::write_atomic;
use std::io::Write;
use std::path::Path;
use thiserror::Error;

/// Errors writing images.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ImageWriteError {
    /// The file could not be written.
    #[error("cannot write {path}")]
    Io {
        /// The path.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The encoder failed.
    #[error("cannot encode {path}")]
    Encode {
        /// The path.
        path: String,
        /// The cause.
        #[source]
        source: image::ImageError,
    },
    /// The extension names no supported format.
    #[error("{0}: unknown image extension (expected .png, or .pfm / .exr for depth)")]
    Extension(String),
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ImageWriteError + '_ {
    move |source| ImageWriteError::Io {
        path: path.display().to_string(),
        source,
    }
}

fn encode(
    path: &Path,
    f: impl FnOnce(&mut Vec<u8>) -> image::ImageResult<()>,
) -> Result<(), ImageWriteError> {
    let mut buf = Vec::new();
    f(&mut buf).map_err(|source| ImageWriteError::Encode {
        path: path.display().to_string(),
        source,
    })?;
    write_atomic(path, |out: &mut dyn Write| out.write_all(&buf)).map_err(io_err(path))
}

/// Writes `rgb` (`width * height * 3` bytes, top row first) as a PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), ImageWriteError> {
    encode(path, |buf| {
        use image::ImageEncoder;
        image::codecs::png::PngEncoder::new(std::io::Cursor::new(buf)).write_image(
            rgb,
            width,
            height,
            image::ExtendedColorType::Rgb8,
        )
    })
}

/// Writes one `f32` per pixel (top row first) as a greyscale PFM (`Pf`, little-endian, rows
/// bottom to top as the format wants) or, for `.exr`, as an RGB float OpenEXR image with the
/// value in all three channels.
pub fn write_float(path: &Path, width: u32, height: u32, v: &[f32]) -> Result<(), ImageWriteError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("pfm") => {
            let mut buf = format!("Pf\n{width} {height}\n-1.0\n").into_bytes();
            for row in v.chunks(width as usize).rev() {
                for x in row {
                    buf.extend_from_slice(&x.to_le_bytes());
                }
            }
            write_atomic(path, |out: &mut dyn Write| out.write_all(&buf)).map_err(io_err(path))
        }
        Some("exr") => {
            let rgb: Vec<f32> = v.iter().flat_map(|&x| [x, x, x]).collect();
            encode(path, |buf| {
                use image::ImageEncoder;
                image::codecs::openexr::OpenExrEncoder::new(std::io::Cursor::new(buf)).write_image(
                    bytemuck::cast_slice(&rgb),
                    width,
                    height,
                    image::ExtendedColorType::Rgb32F,
                )
            })
        }
        _ => Err(ImageWriteError::Extension(path.display().to_string())),
    }
}

/// Reads a greyscale little-endian PFM written by [`write_float`] (for tests and tools):
/// `(width, height, values top row first)`.
pub fn read_pfm(bytes: &[u8]) -> Option<(u32, u32, Vec<f32>)> {
    let mut parts = Vec::new();
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'\n' {
            parts.push(std::str::from_utf8(&bytes[start..i]).ok()?);
            start = i + 1;
            if parts.len() == 3 {
                break;
            }
        }
    }
    if parts.len() != 3 || parts[0] != "Pf" || parts[2] != "-1.0" {
        return None;
    }
    let mut wh = parts[1].split_whitespace().map(str::parse::<u32>);
    let (w, h) = (wh.next()?.ok()?, wh.next()?.ok()?);
    let data = &bytes[start..];
    let n = (w as usize).checked_mul(h as usize)?;
    if data.len() != n.checked_mul(4)? {
        return None;
    }
    let vals: Vec<f32> = data
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let mut out = Vec::with_capacity(n);
    for row in vals.chunks(w.max(1) as usize).rev() {
        out.extend_from_slice(row);
    }
    Some((w, h, out))
}
