//! Image error: RMSE and PSNR between two renders of the same camera (on their 8-bit sRGB
//! colours, as displayed), and the share of pixels where one hits and the other misses.

use crate::render::aov::colour_rgb8;
use crate::render::frame::{Frame, NO_LEAF};

/// How two frames differ.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "io", derive(serde::Serialize))]
pub struct ImageDiff {
    /// Root mean square error over all channels, in 8-bit sRGB units (0-255).
    pub rmse: f64,
    /// Peak signal-to-noise ratio, dB (`+inf` for identical images).
    pub psnr_db: f64,
    /// Share of pixels whose primary ray hits in one frame and misses in the other.
    pub hit_mismatch: f64,
    /// Largest channel difference (0-255).
    pub max_abs: u8,
}

/// Compares two frames of the same size; `None` if the sizes differ.
pub fn compare(a: &Frame, b: &Frame) -> Option<ImageDiff> {
    if a.width != b.width || a.height != b.height {
        return None;
    }
    let (ca, cb) = (colour_rgb8(a), colour_rgb8(b));
    let mut sum = 0.0f64;
    let mut max_abs = 0u8;
    for (x, y) in ca.iter().zip(&cb) {
        let d = x.abs_diff(*y);
        max_abs = max_abs.max(d);
        sum += f64::from(d) * f64::from(d);
    }
    let rmse = (sum / ca.len().max(1) as f64).sqrt();
    let psnr_db = if rmse > 0.0 {
        20.0 * (255.0 / rmse).log10()
    } else {
        f64::INFINITY
    };
    let mismatch = a
        .leaf
        .iter()
        .zip(&b.leaf)
        .filter(|(x, y)| (**x == NO_LEAF) != (**y == NO_LEAF))
        .count();
    Some(ImageDiff {
        rmse,
        psnr_db,
        hit_mismatch: mismatch as f64 / a.leaf.len().max(1) as f64,
        max_abs,
    })
}
