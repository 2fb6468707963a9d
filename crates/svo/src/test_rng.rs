//! A seeded xorshift generator for the unit tests: the same sequence on every machine, and
//! no dependency inside the library's own test modules.

/// The xorshift64 sequence from `seed` (non-zero).
pub(crate) fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    }
}

/// Uniform values in `[0, 1)` from [`xorshift`] (its top 53 bits).
pub(crate) fn unit_f64(seed: u64) -> impl FnMut() -> f64 {
    let mut next = xorshift(seed);
    move || (next() >> 11) as f64 / (1u64 << 53) as f64
}

/// `count` cells drawn from `next` in a grid of `2^depth` cells a side (x, y and z drawn in
/// that order).
pub(crate) fn random_cells(
    next: &mut impl FnMut() -> u64,
    depth: u8,
    count: usize,
) -> Vec<glam::UVec3> {
    let side = 1u64 << depth;
    (0..count)
        .map(|_| {
            let mut c = || (next() % side) as u32;
            glam::UVec3::new(c(), c(), c())
        })
        .collect()
}
