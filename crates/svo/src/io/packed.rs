//! Channels stored on a level (`docs/format.md`, section 12, "Values on a level"): in a file
//! of the DAG layout, a channel may hold one value for each node of the tree on a level above
//! the leaves, which the leaves below take, each value in a given number of bits (normals in
//! fewer than 32). This module packs such a channel for the writer, and for the reader
//! unpacks it (checks 17 and 18), and spreads it over the leaves where a reader makes the
//! tree.

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
/// normal, its element's for any other channel.
pub(crate) fn stored_bits(kind: u8, normal_bits: u8) -> u8 {
    if kind == 0 {
        normal_bits
    } else {
        element_bits(kind) as u8
    }
}

/// A little-endian element of 1 to 4 bytes as a word.
pub(crate) fn word(b: &[u8]) -> u32 {
    let mut w = [0u8; 4];
    w[..b.len()].copy_from_slice(b);
    u32::from_le_bytes(w)
}

/// Whether a channel of `kind` may be stored in `bits` bits: its element's, or for a normal
/// an even number from 4 to 32.
pub(crate) fn bits_allowed(kind: u8, bits: u8) -> bool {
    let b = u32::from(bits);
    b == element_bits(kind) || (kind == 0 && b % 2 == 0 && (4..=32).contains(&b))
}

/// The bytes of `count` values of `bits` bits: a little-endian bit stream (value `i` in bits
/// `i * bits ..`, lowest bit first), rounded up to whole bytes.
pub(crate) fn packed_len(count: u64, bits: u8) -> Option<u64> {
    count.checked_mul(u64::from(bits)).map(|b| b.div_ceil(8))
}

/// Packs `values` (of a channel of `kind`, as words) in `bits` bits each: a normal in fewer
/// than 32 bits as its two octahedral components ([`quantize`]), any other value as it is.
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
}

impl Packer {
    /// A packer of values of a channel of `kind` in `bits` bits each.
    pub(crate) fn new(kind: u8, bits: u8) -> Self {
        Self {
            kind,
            bits: u32::from(bits),
            pending: 0,
            held: 0,
        }
    }

    /// Appends value `v` (a word), its full bytes to `out`.
    #[inline]
    pub(crate) fn push(&mut self, v: u32, out: &mut Vec<u8>) {
        let b = self.bits;
        let v = if self.kind == 0 && b < 32 {
            quantize(v, b).0
        } else {
            v
        };
        self.pending |= (u64::from(v) & ((1u64 << b) - 1)) << self.held;
        self.held += b;
        while self.held >= 8 {
            out.push(self.pending as u8);
            self.pending >>= 8;
            self.held -= 8;
        }
    }

    /// Appends the last partial byte, if any.
    pub(crate) fn finish(self, out: &mut Vec<u8>) {
        if self.held > 0 {
            out.push(self.pending as u8);
        }
    }
}

/// The values of a channel stored on a level whose tree has `count` nodes: check 17 (the
/// stream's length), then check 18 (no bit set after the last value; no normal with one
/// component alone at its interior value), as a channel of `count` values.
pub(crate) fn unpack_channel(p: &PackedRaw, count: u64) -> Result<LeafAttributes, (Check, String)> {
    let want = packed_len(count, p.bits).unwrap_or(u64::MAX);
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
    let total_bits = count * u64::from(b);
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
    let value = |i: u64| {
        let bit = i * u64::from(b);
        let (byte, shift) = ((bit / 8) as usize, (bit % 8) as u32);
        let mut w = 0u64;
        for k in 0..(shift + b).div_ceil(8) as usize {
            w |= u64::from(p.bytes[byte + k]) << (8 * k);
        }
        ((w >> shift) & ((1u64 << b) - 1)) as u32
    };
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
        let normals: Vec<u32> = (0..9u32).map(|i| (i * 3000) | ((i * 1700) << 16)).collect();
        for bits in [4u8, 10, 16, 24, 32] {
            let bytes = pack(0, bits, normals.iter().copied());
            assert_eq!(bytes.len() as u64, packed_len(9, bits).unwrap());
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
