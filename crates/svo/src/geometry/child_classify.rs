//! Thesis Algorithm 1: assign a triangle to the children of a node whose cells its bounding
//! box overlaps, by comparing the box against the parent's centre (at most 14 comparisons).
//!
//! Cells are closed: a box that touches the centre plane belongs to both sides. The
//! comparisons involve no arithmetic (the centre is an exact dyadic grid coordinate), so this
//! test is exact and, applied at every level from the root, it is the separating axis test
//! on the three box normals.
//!
//! Child index convention everywhere in `svo`: bit 2 = x, bit 1 = y, bit 0 = z; a set bit is
//! the upper half. Child 0 is the most negative octant, child 7 the most positive.

use glam::DVec3;

/// The children (bit `i` = child `i`) whose closed cells the box `[lo, hi]` overlaps,
/// given that it overlaps the parent cell whose centre is `c`.
#[inline]
pub(crate) fn classify_children(lo: DVec3, hi: DVec3, c: DVec3) -> u8 {
    // Per axis: which halves (bit 0 = lower, bit 1 = upper) the box reaches.
    let halves = |lo: f64, hi: f64, c: f64| -> u8 { u8::from(lo <= c) | (u8::from(hi >= c) << 1) };
    let hx = halves(lo.x, hi.x, c.x);
    let hy = halves(lo.y, hi.y, c.y);
    let hz = halves(lo.z, hi.z, c.z);
    // Expand each axis's halves into the 8-bit child masks: for axis bit b, the lower half
    // is the children with that bit clear.
    const X: [u8; 4] = [0x00, 0x0F, 0xF0, 0xFF];
    const Y: [u8; 4] = [0x00, 0x33, 0xCC, 0xFF];
    const Z: [u8; 4] = [0x00, 0x55, 0xAA, 0xFF];
    X[hx as usize] & Y[hy as usize] & Z[hz as usize]
}

/// The offset (0 or 1 per axis) of child `i` inside its parent, following the convention
/// above.
#[inline]
pub(crate) fn child_offset(i: u8) -> [u32; 3] {
    [
        u32::from((i >> 2) & 1),
        u32::from((i >> 1) & 1),
        u32::from(i & 1),
    ]
}

/// The min corner of child `i` of the node at `cell` whose children are `size` cells wide.
#[inline]
pub(crate) fn child_cell(cell: [u32; 3], i: u8, size: u32) -> [u32; 3] {
    let o = child_offset(i);
    [
        cell[0] + o[0] * size,
        cell[1] + o[1] * size,
        cell[2] + o[2] * size,
    ]
}
