//! Channels stored on a level (`docs/format.md`, section 12, "Values on a level"): in a file
//! of the DAG layout, a channel may hold one value for each node of the tree on a level above
//! the leaves, which the leaves below take, each value in a given number of bits (normals in
//! fewer than 32, colours in 16 or in blocks at 4). This module packs such a channel for the writer, and for the reader
//! unpacks it (checks 17 and 18), and spreads it over the leaves where a reader makes the
//! tree.

use crate::octree::colour_encoding::{self, BLOCK};
use crate::octree::format_check::Check;
use crate::octree::normal_encoding::{quantize, unpack};
use crate::octree::tree::{Channel, ChannelKind, LeafAttributes, Node};

/// A channel stored on a level, as read: its bytes, checked against the graph's counts later.
#[derive(Clone, Debug)]
pub(crate) struct PackedRaw {
    pub kind: u8,
    pub level: u8,
    pub bits: u8,
    pub bytes: Vec<u8>,
}

/// The bits of a channel's element (32, 32, 32, 8, 8, 16 for kinds 0 to 5).
pub(crate) fn element_bits(kind: u8) -> u32 {
    8 * ChannelKind::ALL[usize::from(kind)].element_size() as u32
}

/// The bits a value of a channel of `kind` is stored in on a level: `normal_bits` for a
/// normal, `colour_bits` for a colour, its element's for any other channel.
pub(crate) fn stored_bits(kind: u8, normal_bits: u8, colour_bits: u8) -> u8 {
    match kind {
        0 => normal_bits,
        2 => colour_bits,
        _ => element_bits(kind) as u8,
    }
}

/// A little-endian element of 1 to 4 bytes as a word.
pub(crate) fn word(b: &[u8]) -> u32 {
    let mut w = [0u8; 4];
    w[..b.len()].copy_from_slice(b);
    u32::from_le_bytes(w)
}

/// Whether a channel of `kind` may be stored in `bits` bits: its element's, for a normal an
/// even number from 4 to 32, for a colour 16 or 4.
pub(crate) fn bits_allowed(kind: u8, bits: u8) -> bool {
    let b = u32::from(bits);
    b == element_bits(kind)
        || (kind == 0 && b % 2 == 0 && (4..=32).contains(&b))
        || (kind == 2 && (b == 16 || b == 4))
}

/// The bits of `count` values of a channel of `kind` in `bits` bits: `count * bits`, except
/// colours in 4 bits, whose blocks of 16 take 64 bits and a last block of `r` values
/// `32 + 2 r`.
fn stream_bits(kind: u8, count: u64, bits: u8) -> Option<u64> {
    if kind == 2 {
        colour_encoding::stream_bits(count, bits)
    } else {
        count.checked_mul(u64::from(bits))
    }
}

/// The bytes of `count` values of a channel of `kind` in `bits` bits: a little-endian bit
/// stream (value `i` in bits `i * bits ..`, lowest bit first; colours in 4 bits block after
/// block), rounded up to whole bytes.
pub(crate) fn packed_len(kind: u8, count: u64, bits: u8) -> Option<u64> {
    stream_bits(kind, count, bits).map(|b| b.div_ceil(8))
}

/// Packs `values` (of a channel of `kind`, as words) in `bits` bits each: a normal in fewer
/// than 32 bits as its two octahedral components ([`quantize`]), a colour in 16 as R5G6B5
/// and in 4 as blocks ([`colour_encoding`]), any other value as it is.
pub(crate) fn pack(kind: u8, bits: u8, values: impl Iterator<Item = u32>) -> Vec<u8> {
    let mut out = Vec::new();
    let mut packer = Packer::new(kind, bits);
    for v in values {
        packer.push(v, &mut out);
    }
    packer.finish(&mut out);
    out
}

/// [`pack`] a value at a time, for a writer that streams a channel: each value's whole bytes
/// appended as they fill, the last partial byte by [`Packer::finish`].
pub(crate) struct Packer {
    kind: u8,
    bits: u32,
    pending: u64,
    held: u32,
    /// Colours waiting for their block to fill (colours in 4 bits).
    block: Vec<u32>,
}

impl Packer {
    /// A packer of values of a channel of `kind` in `bits` bits each.
    pub(crate) fn new(kind: u8, bits: u8) -> Self {
        Self {
            kind,
            bits: u32::from(bits),
            pending: 0,
            held: 0,
            block: Vec::new(),
        }
    }

    /// Appends the `n` lowest bits of `v`, the full bytes to `out`.
    #[inline]
    fn put(&mut self, v: u32, n: u32, out: &mut Vec<u8>) {
        self.pending |= (u64::from(v) & ((1u64 << n) - 1)) << self.held;
        self.held += n;
        while self.held >= 8 {
            out.push(self.pending as u8);
            self.pending >>= 8;
            self.held -= 8;
        }
    }

    /// Appends the waiting colours as a block.
    fn flush_block(&mut self, out: &mut Vec<u8>) {
        if self.block.is_empty() {
            return;
        }
        let (ends, choices) = colour_encoding::encode_block(&self.block);
        let n = self.block.len() as u32;
        self.put(ends, 32, out);
        self.put(choices, 2 * n, out);
        self.block.clear();
    }

    /// Appends value `v` (a word), its full bytes to `out`.
    #[inline]
    pub(crate) fn push(&mut self, v: u32, out: &mut Vec<u8>) {
        let b = self.bits;
        let v = match (self.kind, b) {
            (0, ..32) => quantize(v, b).0,
            (2, 16) => u32::from(colour_encoding::to_565(v)),
            (2, 4) => {
                self.block.push(v);
                if self.block.len() == BLOCK {
                    self.flush_block(out);
                }
                return;
            }
            _ => v,
        };
        self.put(v, b, out);
    }

    /// Appends the last block (colours in 4 bits) and the last partial byte, if any.
    pub(crate) fn finish(mut self, out: &mut Vec<u8>) {
        self.flush_block(out);
        if self.held > 0 {
            out.push(self.pending as u8);
        }
    }
}

/// The values of a channel stored on a level whose tree has `count` nodes: check 17 (the
/// stream's length), then check 18 (no bit set after the last value; no normal with one
/// component alone at its interior value), as a channel of `count` values.
pub(crate) fn unpack_channel(p: &PackedRaw, count: u64) -> Result<LeafAttributes, (Check, String)> {
    let want = packed_len(p.kind, count, p.bits).unwrap_or(u64::MAX);
    if p.bytes.len() as u64 != want {
        return Err((
            Check::LeafOrder,
            format!(
                "the {} channel on level {} holds {} bytes; {count} values of {} bits take {want}",
                ChannelKind::ALL[usize::from(p.kind)].name(),
                p.level,
                p.bytes.len(),
                p.bits
            ),
        ));
    }
    let b = u32::from(p.bits);
    let total_bits = stream_bits(p.kind, count, p.bits).unwrap_or(u64::MAX);
    let last = p.bytes.last().copied().unwrap_or(0);
    let used = (total_bits % 8) as u32;
    if used != 0 && last >> used != 0 {
        return Err((
            Check::Values,
            format!(
                "bits set after the last value of the {} channel",
                ChannelKind::ALL[usize::from(p.kind)].name()
            ),
        ));
    }
    // The `n` bits (at most 32) from bit `bit` of the stream.
    let field = |bit: u64, n: u32| {
        let (byte, shift) = ((bit / 8) as usize, (bit % 8) as u32);
        let mut w = 0u64;
        for k in 0..(shift + n).div_ceil(8) as usize {
            w |= u64::from(p.bytes[byte + k]) << (8 * k);
        }
        ((w >> shift) & ((1u64 << n) - 1)) as u32
    };
    let value = |i: u64| field(i * u64::from(b), b);
    let mut a = LeafAttributes::default();
    let n = count as usize;
    match p.kind {
        0 => {
            let mut v = Vec::with_capacity(n);
            for i in 0..count {
                let Some(w) = unpack(value(i), b) else {
                    return Err((
                        Check::Values,
                        format!(
                            "value {i} of the normal channel on level {}: one component alone at its interior value",
                            p.level
                        ),
                    ));
                };
                v.push(w);
            }
            a.normal = Channel::PerLeaf(v);
        }
        1 => a.contour = Channel::PerLeaf((0..count).map(value).collect()),
        2 if b == 4 => {
            let mut v = Vec::with_capacity(n);
            for start in (0..count).step_by(BLOCK) {
                let k = (count - start).min(BLOCK as u64);
                let bit = start * 4;
                let (ends, choices) = (field(bit, 32), field(bit + 32, 2 * k as u32));
                v.extend(colour_encoding::decode_block(ends, choices, k as usize));
            }
            a.colour = Channel::PerLeaf(v);
        }
        2 if b == 16 => {
            a.colour = Channel::PerLeaf(
                (0..count)
                    .map(|i| colour_encoding::from_565(value(i) as u16))
                    .collect(),
            );
        }
        2 => a.colour = Channel::PerLeaf((0..count).map(value).collect()),
        3 => a.reflectivity = Channel::PerLeaf((0..count).map(|i| value(i) as u8).collect()),
        4 => a.refractivity = Channel::PerLeaf((0..count).map(|i| value(i) as u8).collect()),
        _ => a.ior = Channel::PerLeaf((0..count).map(|i| value(i) as u16).collect()),
    }
    Ok(a)
}

/// `values` (one for each node on `level` of the tree `nodes`, of `depth` levels, in
/// canonical depth-first order) spread over the tree's leaves: each leaf its ancestor's.
pub(crate) fn spread<T: Copy>(values: &[T], nodes: &[Node], depth: u8, level: u8) -> Vec<T> {
    let mut out = Vec::new();
    let Some(&first) = values.first() else {
        return out;
    };
    let mut next = 0usize;
    let mut current = first;
    let mut stack = vec![(0u32, 0u8)];
    while let Some((i, l)) = stack.pop() {
        let Some(n) = nodes.get(i as usize) else {
            continue;
        };
        if l == level {
            current = values.get(next).copied().unwrap_or(current);
            next += 1;
        }
        let kids = n.child_mask().count_ones();
        if n.is_leaf_parent() {
            for _ in 0..kids {
                if level == depth {
                    current = values.get(next).copied().unwrap_or(current);
                    next += 1;
                }
                out.push(current);
            }
            continue;
        }
        for k in (0..kids).rev() {
            stack.push((n.first + k, l + 1));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Packing and unpacking give the values back (normals as kept in their bits), and a set
    /// bit after the last value or a wrong length fails its check.
    #[test]
    fn packed_values_come_back() {
        let words: Vec<u32> = (0..37u32).map(|i| i.wrapping_mul(0x9e37_79b9)).collect();
        for (kind, bits) in [(2u8, 32u8), (3, 8), (5, 16)] {
            let mask = if bits == 32 {
                u32::MAX
            } else {
                (1 << bits) - 1
            };
            let bytes = pack(kind, bits, words.iter().map(|w| w & mask));
            let p = PackedRaw {
                kind,
                level: 3,
                bits,
                bytes,
            };
            let a = unpack_channel(&p, 37).unwrap();
            let got: Vec<u32> = (0..37)
                .map(|i| match kind {
                    2 => a.colour.get(i).unwrap(),
                    3 => u32::from(a.reflectivity.get(i).unwrap()),
                    _ => u32::from(a.ior.get(i).unwrap()),
                })
                .collect();
            let want: Vec<u32> = words.iter().map(|w| w & mask).collect();
            assert_eq!(got, want, "kind {kind}");
        }
        // Colours in 16 bits and in blocks at 4 come back as the writer's round trip gives
        // them, whole blocks and a last partial one; a set bit after the last block fails.
        for (bits, count) in [(16u8, 37usize), (4, 37), (4, 32), (4, 1)] {
            let colours: Vec<u32> = (0..count as u32)
                .map(|i| i.wrapping_mul(0x0103_0507) ^ (i << 20))
                .collect();
            let bytes = pack(2, bits, colours.iter().copied());
            assert_eq!(
                bytes.len() as u64,
                packed_len(2, count as u64, bits).unwrap()
            );
            let mut want = colours.clone();
            colour_encoding::round_trip(&mut want, bits);
            let p = PackedRaw {
                kind: 2,
                level: 3,
                bits,
                bytes,
            };
            let a = unpack_channel(&p, count as u64).unwrap();
            let got: Vec<u32> = (0..count).map(|i| a.colour.get(i).unwrap()).collect();
            assert_eq!(got, want, "{bits} bits, {count} colours");
            let used = stream_bits(2, count as u64, bits).unwrap() % 8;
            if used != 0 {
                let mut q = p.clone();
                *q.bytes.last_mut().unwrap() |= 0x80;
                assert_eq!(
                    unpack_channel(&q, count as u64).unwrap_err().0,
                    Check::Values
                );
            }
        }
        let normals: Vec<u32> = (0..9u32).map(|i| (i * 3000) | ((i * 1700) << 16)).collect();
        for bits in [4u8, 10, 16, 24, 32] {
            let bytes = pack(0, bits, normals.iter().copied());
            assert_eq!(bytes.len() as u64, packed_len(0, 9, bits).unwrap());
            let p = PackedRaw {
                kind: 0,
                level: 2,
                bits,
                bytes,
            };
            let a = unpack_channel(&p, 9).unwrap();
            for (i, &n) in normals.iter().enumerate() {
                let w = quantize(n, u32::from(bits)).1;
                assert_eq!(a.normal.get(i), Some(w), "{bits} bits, value {i}");
            }
            // A wrong count is a wrong length; a set bit after the last value fails check 18.
            assert_eq!(unpack_channel(&p, 40).unwrap_err().0, Check::LeafOrder);
            let mut q = p.clone();
            if (9 * u32::from(bits)) % 8 != 0 {
                *q.bytes.last_mut().unwrap() |= 0x80;
                assert_eq!(unpack_channel(&q, 9).unwrap_err().0, Check::Values);
            }
        }
    }
}
