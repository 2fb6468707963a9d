//! Colours in fewer bits (`docs/format.md`, section 12, "Values on a level"): a colour word
//! (RGBA8, RGB sRGB-encoded) in 16 bits as R5G6B5, or in blocks of 16 values in Morton order
//! at 4 bits a value: two R5G6B5 end colours and, for each value, a 2-bit choice among the two
//! ends and the two colours a third and two thirds of the way between them (the 4-colour
//! mode of S3TC/BC1, applied along the level's values instead of a 4x4 texel tile; Dolonius
//! et al. 2017 compress voxel colours with end points and weights in the same spirit). Alpha
//! is not kept (255).
//!
//! The decode is integer arithmetic, the same in every reader; the block encoder is a
//! deterministic function of the block's values (principal axis, then least-squares
//! refinement of the ends), so a file's bytes do not depend on the thread count or on how
//! the values were streamed.
#![cfg_attr(not(any(feature = "io", feature = "trace")), allow(dead_code))]

/// Values in a block of the 4-bit form.
pub(crate) const BLOCK: usize = 16;

/// The bits of `count` colours in `bits` bits (4: blocks; 16 or 32: each value its bits).
#[cfg_attr(not(feature = "io"), allow(dead_code))]
pub(crate) fn stream_bits(count: u64, bits: u8) -> Option<u64> {
    if bits == 4 {
        let (full, rest) = (count / BLOCK as u64, count % BLOCK as u64);
        let tail = if rest > 0 { 32 + 2 * rest } else { 0 };
        full.checked_mul(64)?.checked_add(tail)
    } else {
        count.checked_mul(u64::from(bits))
    }
}

/// RGB bytes of a colour word.
#[inline]
fn rgb(w: u32) -> [u32; 3] {
    [w & 0xFF, (w >> 8) & 0xFF, (w >> 16) & 0xFF]
}

/// A colour word's R5G6B5 form (each channel rounded to the nearest level).
#[inline]
pub(crate) fn to_565(w: u32) -> u16 {
    let [r, g, b] = rgb(w);
    let q = |v: u32, levels: u32| (v * levels + 127) / 255;
    (q(r, 31) | q(g, 63) << 5 | q(b, 31) << 11) as u16
}

/// The RGB bytes an R5G6B5 value stands for (the high bits repeated into the low ones).
#[inline]
fn expand(c: u16) -> [u32; 3] {
    let c = u32::from(c);
    let (r, g, b) = (c & 31, (c >> 5) & 63, (c >> 11) & 31);
    [
        (r << 3) | (r >> 2),
        (g << 2) | (g >> 4),
        (b << 3) | (b >> 2),
    ]
}

/// The colour word of RGB bytes, alpha 255.
#[inline]
fn word([r, g, b]: [u32; 3]) -> u32 {
    r | g << 8 | b << 16 | 0xFF00_0000
}

/// The colour word an R5G6B5 value stands for.
#[inline]
pub(crate) fn from_565(c: u16) -> u32 {
    word(expand(c))
}

/// The four colours of a block with end values `ends` (`c0` in bits 0-15, `c1` in 16-31):
/// `c0`, `c1`, `(2 c0 + c1 + 1) / 3` and `(c0 + 2 c1 + 1) / 3`, per channel on the bytes.
fn palette(ends: u32) -> [u32; 4] {
    let (a, b) = (expand(ends as u16), expand((ends >> 16) as u16));
    let mix = |wa: u32, wb: u32| std::array::from_fn(|k| (wa * a[k] + wb * b[k] + 1) / 3);
    [word(a), word(b), word(mix(2, 1)), word(mix(1, 2))]
}

/// The squared distance of two RGB byte triples.
#[inline]
fn distance(a: [u32; 3], b: [u32; 3]) -> u32 {
    (0..3).map(|k| a[k].abs_diff(b[k]).pow(2)).sum()
}

/// The choices (2 bits each, value `k` in bits `2k..`) of `values` among `pal`, each the
/// nearest (the lowest index on a tie), and the summed squared error.
fn choose(values: &[u32], pal: &[u32; 4]) -> (u32, u64) {
    let pal = pal.map(rgb);
    let (mut idx, mut err) = (0u32, 0u64);
    for (k, &v) in values.iter().enumerate() {
        let c = rgb(v);
        let (best, d) = (0..4u32)
            .map(|i| (i, distance(c, pal[i as usize])))
            .min_by_key(|&(i, d)| (d, i))
            .unwrap_or((0, 0));
        idx |= best << (2 * k);
        err += u64::from(d);
    }
    (idx, err)
}

/// The R5G6B5 of float RGB bytes, each channel rounded and clamped.
fn quantize_f(c: [f64; 3]) -> u16 {
    let q = |v: f64, levels: f64| (v.clamp(0.0, 255.0) * levels / 255.0).round() as u32;
    (q(c[0], 31.0) | q(c[1], 63.0) << 5 | q(c[2], 31.0) << 11) as u16
}

/// Encodes 1 to [`BLOCK`] colour words as a block: its ends word and its choices.
pub(crate) fn encode_block(values: &[u32]) -> (u32, u32) {
    let n = values.len().max(1) as f64;
    let px: Vec<[f64; 3]> = values.iter().map(|&v| rgb(v).map(f64::from)).collect();
    let mean: [f64; 3] = std::array::from_fn(|k| px.iter().map(|p| p[k]).sum::<f64>() / n);
    // The principal axis of the colours (power iteration on the covariance).
    let mut cov = [[0.0f64; 3]; 3];
    for p in &px {
        for i in 0..3 {
            for j in 0..3 {
                cov[i][j] += (p[i] - mean[i]) * (p[j] - mean[j]);
            }
        }
    }
    // Start from the covariance's column of the channel that varies most: never orthogonal
    // to the principal axis when the colours vary at all.
    let widest = (0..3).fold(0, |m, k| if cov[k][k] > cov[m][m] { k } else { m });
    let mut axis = [cov[0][widest], cov[1][widest], cov[2][widest]];
    for _ in 0..8 {
        let next: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| cov[i][j] * axis[j]).sum());
        let len = next.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(len > 1e-12) {
            break;
        }
        axis = next.map(|v| v / len);
    }
    let along = |p: &[f64; 3]| (0..3).map(|k| (p[k] - mean[k]) * axis[k]).sum::<f64>();
    let (lo, hi) = px.iter().fold((0.0f64, 0.0f64), |(lo, hi), p| {
        let t = along(p);
        (lo.min(t), hi.max(t))
    });
    let at = |t: f64| -> [f64; 3] { std::array::from_fn(|k| mean[k] + axis[k] * t) };
    let ends = |a: [f64; 3], b: [f64; 3]| u32::from(quantize_f(a)) | u32::from(quantize_f(b)) << 16;
    let mut best_ends = ends(at(lo), at(hi));
    let (mut best_idx, mut best_err) = choose(values, &palette(best_ends));
    // Least-squares ends for the choices made, twice: each value `(1 - w) a + w b` with `w`
    // its choice's weight (0, 1, 1/3, 2/3).
    for _ in 0..2 {
        let (mut aa, mut ab, mut bb) = (0.0f64, 0.0f64, 0.0f64);
        let (mut ax, mut bx) = ([0.0f64; 3], [0.0f64; 3]);
        for (k, p) in px.iter().enumerate() {
            let w = [0.0, 1.0, 1.0 / 3.0, 2.0 / 3.0][(best_idx >> (2 * k) & 3) as usize];
            let u = 1.0 - w;
            aa += u * u;
            ab += u * w;
            bb += w * w;
            for c in 0..3 {
                ax[c] += u * p[c];
                bx[c] += w * p[c];
            }
        }
        let det = aa * bb - ab * ab;
        if !(det.abs() > 1e-9) {
            break;
        }
        let a: [f64; 3] = std::array::from_fn(|c| (bb * ax[c] - ab * bx[c]) / det);
        let b: [f64; 3] = std::array::from_fn(|c| (aa * bx[c] - ab * ax[c]) / det);
        let e = ends(a, b);
        let (idx, err) = choose(values, &palette(e));
        if err >= best_err {
            break;
        }
        (best_ends, best_idx, best_err) = (e, idx, err);
    }
    (best_ends, best_idx)
}

/// The colour words a block decodes to: value `k` of `count` is the palette's entry chosen
/// in bits `2k..` of `choices`.
pub(crate) fn decode_block(ends: u32, choices: u32, count: usize) -> impl Iterator<Item = u32> {
    let pal = palette(ends);
    (0..count).map(move |k| pal[(choices >> (2 * k) & 3) as usize])
}

/// `values` as a reader of `bits` bits (4, 16 or 32) gets them back.
#[cfg_attr(not(feature = "trace"), allow(dead_code))]
pub(crate) fn round_trip(values: &mut [u32], bits: u8) {
    match bits {
        4 => {
            for block in values.chunks_mut(BLOCK) {
                let (ends, choices) = encode_block(block);
                let n = block.len();
                for (v, d) in block.iter_mut().zip(decode_block(ends, choices, n)) {
                    *v = d;
                }
            }
        }
        16 => values.iter_mut().for_each(|v| *v = from_565(to_565(*v))),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every R5G6B5 value comes back from its word, and a colour's 16-bit form is within
    /// half a level of each channel (4 and 2 byte steps).
    #[test]
    fn rgb565_round_trips() {
        for c in 0..=u16::MAX {
            assert_eq!(to_565(from_565(c)), c);
        }
        for v in (0..1u32 << 24).step_by(997) {
            let back = rgb(from_565(to_565(v)));
            let [r, g, b] = rgb(v);
            assert!(
                back[0].abs_diff(r) <= 4 && back[1].abs_diff(g) <= 2 && back[2].abs_diff(b) <= 4
            );
        }
    }

    /// A block of one colour, of two colours and of a ramp comes back within the 4-colour
    /// form's error; the encoder does not depend on anything but the values.
    #[test]
    fn blocks_keep_colours_close() {
        let grey = [0xFFCC_CCCCu32; 16];
        let (e, i) = encode_block(&grey);
        for d in decode_block(e, i, 16) {
            let c = rgb(d);
            assert!(c.iter().all(|&v| v.abs_diff(0xCC) <= 4), "{c:?}");
        }
        let two: Vec<u32> = (0..16)
            .map(|k| if k % 3 == 0 { 0x0000_00FF } else { 0x00FF_0000 })
            .collect();
        let (e, i) = encode_block(&two);
        for (d, v) in decode_block(e, i, 16).zip(&two) {
            assert!(distance(rgb(d), rgb(*v)) <= 3 * 16, "{d:#x} {v:#x}");
        }
        let ramp: Vec<u32> = (0..11u32)
            .map(|k| (k * 20) | ((k * 10) << 8) | ((200 - k * 15) << 16))
            .collect();
        let (e, i) = encode_block(&ramp);
        assert_eq!((e, i), encode_block(&ramp));
        let worst = decode_block(e, i, ramp.len())
            .zip(&ramp)
            .map(|(d, v)| distance(rgb(d), rgb(*v)))
            .max()
            .unwrap();
        // Eleven steps on four colours: at most about a third of the span off, per channel.
        assert!(worst <= 3 * 40 * 40, "{worst}");
        assert_eq!(stream_bits(16, 4), Some(64));
        assert_eq!(stream_bits(17, 4), Some(64 + 34));
        assert_eq!(stream_bits(5, 16), Some(80));
    }
}
