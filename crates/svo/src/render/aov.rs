//! Turning a [`Frame`]'s outputs into displayable 8-bit RGB: the colour (sRGB), the normal
//! map, a colour per leaf, and the cost heat map. Depth stays `f32` (see
//! [`crate::render::image_write`]).

use crate::mesh::triangle_mesh::linear_to_srgb;
use crate::render::frame::{Frame, NO_LEAF};
use glam::Vec3;

/// Which per-pixel output to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Aov {
    /// The shaded image.
    #[default]
    Colour,
    /// Primary hit distance (`f32`).
    Depth,
    /// Shading normal, `n * 0.5 + 0.5`.
    Normal,
    /// A colour per leaf index.
    Leaf,
    /// Traversal steps per pixel as a heat map.
    Cost,
}

impl std::str::FromStr for Aov {
    type Err = String;

    /// Parses a command-line name: `colour` (or `color`), `depth`, `normal`, `leaf`, `cost`.
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "colour" | "color" => Self::Colour,
            "depth" => Self::Depth,
            "normal" => Self::Normal,
            "leaf" => Self::Leaf,
            "cost" => Self::Cost,
            _ => {
                return Err(format!(
                    "unknown AOV {s:?} (expected colour, depth, normal, leaf or cost)"
                ));
            }
        })
    }
}

impl Aov {
    /// The AOV of `f` as 8-bit RGB, three bytes a pixel in row order (`cost_scale`: the
    /// steps at the hottest colour of the cost heat map); `None` for depth, which stays
    /// `f32` ([`crate::render::write_float`]).
    pub fn rgb8(self, f: &Frame, cost_scale: u32) -> Option<Vec<u8>> {
        match self {
            Self::Colour => Some(colour_rgb8(f)),
            Self::Normal => Some(normal_rgb8(f)),
            Self::Leaf => Some(leaf_rgb8(f)),
            Self::Cost => Some(cost_rgb8(f, cost_scale)),
            Self::Depth => None,
        }
    }
}

/// The colour image as sRGB bytes (clamped).
pub fn colour_rgb8(f: &Frame) -> Vec<u8> {
    f.colour
        .iter()
        .flat_map(|c| {
            [
                linear_to_srgb(c.x),
                linear_to_srgb(c.y),
                linear_to_srgb(c.z),
            ]
        })
        .collect()
}

/// The normal map (black where the ray missed).
#[cfg_attr(
    not(all(feature = "image-io", feature = "reference")),
    allow(dead_code)
)]
pub(crate) fn normal_rgb8(f: &Frame) -> Vec<u8> {
    f.normal
        .iter()
        .flat_map(|n| {
            if *n == Vec3::ZERO {
                [0, 0, 0]
            } else {
                let c = (*n * 0.5 + 0.5) * 255.0;
                [c.x.round() as u8, c.y.round() as u8, c.z.round() as u8]
            }
        })
        .collect()
}

/// A stable pseudo-random colour per leaf (black where the ray missed).
#[cfg_attr(
    not(all(feature = "image-io", feature = "reference")),
    allow(dead_code)
)]
pub(crate) fn leaf_rgb8(f: &Frame) -> Vec<u8> {
    f.leaf
        .iter()
        .flat_map(|&l| {
            if l == NO_LEAF {
                [0, 0, 0]
            } else {
                let h = l.wrapping_mul(0x9E37_79B9) ^ (l >> 7).wrapping_mul(0x85EB_CA6B);
                let b = h.to_le_bytes();
                [b[0] | 0x30, b[1] | 0x30, b[2] | 0x30]
            }
        })
        .collect()
}

/// The cost heat map: steps scaled so that `max_steps` is the hottest colour (black = 0,
/// then blue, cyan, green, yellow, red). Returns the bytes.
pub fn cost_rgb8(f: &Frame, max_steps: u32) -> Vec<u8> {
    let m = max_steps.max(1) as f32;
    f.cost
        .iter()
        .flat_map(|&s| heat((s as f32 / m).clamp(0.0, 1.0)))
        .collect()
}

/// The heat colour of `v` in `[0, 1]`.
pub(crate) fn heat(v: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
    ];
    let x = v * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let t = x - i as f32;
    let c = |k: usize| ((STOPS[i][k] * (1.0 - t) + STOPS[i + 1][k] * t) * 255.0).round() as u8;
    [c(0), c(1), c(2)]
}
