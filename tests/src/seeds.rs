//! Seeds for every seeded test: a seeded xorshift generator (the same sequence on every
//! machine) and the seeds the other generators start from.
//!
//! `SVO_TEST_SEED` (a number, decimal or `0x` hex) moves every seed of the seeded tests to
//! other values, so a soak can run the same checks over new random cases; unset, the seeds are
//! the ones written in the tests.

/// `seed` as written, or mixed with `SVO_TEST_SEED` when that is set (never zero).
pub fn seed(seed: u64) -> u64 {
    match soak_salt() {
        None => seed,
        Some(salt) => splitmix(seed ^ splitmix(salt)).max(1),
    }
}

/// The value of `SVO_TEST_SEED` (empty is unset); a value that is not a number fails the test
/// that reads it.
fn soak_salt() -> Option<u64> {
    let v = std::env::var("SVO_TEST_SEED").ok()?;
    let v = v.trim();
    if v.is_empty() {
        return None;
    }
    let parsed = match v.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16),
        None => v.parse(),
    };
    Some(parsed.unwrap_or_else(|_| panic!("SVO_TEST_SEED={v:?} is not a number")))
}

/// One step of SplitMix64: a bijection that spreads nearby seeds apart.
fn splitmix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The xorshift64 sequence from `seed` (non-zero; moved by `SVO_TEST_SEED`, see [`seed`]).
pub fn xorshift(seed: u64) -> impl FnMut() -> u64 {
    let mut seed = self::seed(seed);
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    }
}

/// Uniform values in `[0, 1)` from [`xorshift`] (its top 53 bits).
pub fn unit_f64(seed: u64) -> impl FnMut() -> f64 {
    let mut next = xorshift(seed);
    move || (next() >> 11) as f64 / (1u64 << 53) as f64
}

/// `count` cells drawn from `next` in a grid of `2^depth` cells a side (x, y and z drawn in
/// that order).
pub fn random_cells(next: &mut impl FnMut() -> u64, depth: u8, count: usize) -> Vec<glam::UVec3> {
    let side = 1u64 << depth;
    (0..count)
        .map(|_| {
            let mut c = || (next() % side) as u32;
            glam::UVec3::new(c(), c(), c())
        })
        .collect()
}
