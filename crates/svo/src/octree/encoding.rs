//! The scalar channel encodings: unorm8, RGBA8 sRGB colour, and the index of refraction as
//! `1 + v / 16384` in a `u16`.

use crate::mesh::triangle_mesh::linear_to_srgb;

/// Linear RGBA to the stored RGBA8 sRGB word.
pub(crate) fn encode_colour(c: [f32; 4]) -> u32 {
    u32::from_le_bytes([
        linear_to_srgb(c[0]),
        linear_to_srgb(c[1]),
        linear_to_srgb(c[2]),
        unorm8(c[3]),
    ])
}

/// `[0, 1]` to unorm8.
pub(crate) fn unorm8(v: f32) -> u8 {
    if v.is_finite() {
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    } else {
        0
    }
}

/// Encodes an index of refraction (clamped to `[1, 5)`).
pub(crate) fn ior_encode(ior: f32) -> u16 {
    let v = ((ior - 1.0) * 16384.0).round();
    if v.is_finite() {
        v.clamp(0.0, 65535.0) as u16
    } else {
        8192
    }
}

/// Decodes an index of refraction.
pub(crate) fn ior_decode(v: u16) -> f32 {
    1.0 + f32::from(v) / 16384.0
}
