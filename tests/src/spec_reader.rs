//! A `.svo` reader written from `docs/format.md` alone, sharing no code with svo (only the
//! xxHash crate for the checksums): it applies the document's 22 checks in order and returns
//! the number of the first one a file fails. The conformance test requires it to agree with
//! the corpus's manifest, which shows that the document says enough to write a reader.

const MAGIC: [u8; 8] = *b"\x89SVO\r\n\x1a\n";

struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.b.get(self.at..end)?;
        self.at = end;
        Some(s)
    }
    fn u8(&mut self) -> Option<u8> {
        Some(self.take(1)?[0])
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn f32(&mut self) -> Option<f32> {
        Some(f32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn v3(&mut self) -> Option<[f64; 3]> {
        Some([self.f64()?, self.f64()?, self.f64()?])
    }
    fn string(&mut self) -> Option<&'a str> {
        let n = usize::try_from(self.u64()?).ok()?;
        std::str::from_utf8(self.take(n)?).ok()
    }
}

enum Storage {
    Constant(u32),
    PerLeaf(u64, u64),
    /// Section 12, values on a level: `level`, `bits`, `offset`, `len`.
    Packed(u8, u8, u64, u64),
}

struct Camera {
    name_len: usize,
    eye: [f64; 3],
    target: [f64; 3],
    up: [f64; 3],
    fov: f64,
}

struct Header {
    origin: [f64; 3],
    side: f64,
    depth: u8,
    /// Version 3: chunk level, chunk count, chunk table (offset, len).
    chunks: Option<(u8, u64, (u64, u64))>,
    node_count: u64,
    leaf_count: u64,
    nodes: (u64, u64),
    channels: Vec<(u8, Storage)>,
    lights: Vec<([f64; 3], [f32; 3], f32)>,
    cameras: Vec<Camera>,
    /// Version 4 (section 11): the layout byte, the level table (`nodes`, `offset`, `len`,
    /// `hash`) and the inner-node channels (`None`: per node).
    levels: Option<Levels>,
}

/// Version 4's layout byte, level table (`nodes`, `offset`, `len`, `hash`) and inner-node
/// channels (`None`: per node).
type Levels = (u8, Vec<[u64; 4]>, Vec<(u8, Option<u32>)>);

/// Section 3: the header in `raw` (exactly), by the version's layout.
fn decode(raw: &[u8], version: u32) -> Option<Header> {
    let mut c = Cursor { b: raw, at: 0 };
    let (origin, side, depth) = (c.v3()?, c.f64()?, c.u8()?);
    let level_count = if version == 3 {
        Some((c.u8()?, c.u64()?))
    } else {
        None
    };
    let layout = if version == 4 { Some(c.u8()?) } else { None };
    let (node_count, leaf_count) = (c.u64()?, c.u64()?);
    let mut levels = None;
    if let Some(layout) = layout {
        let mut table = Vec::new();
        for _ in 0..c.u64()? {
            table.push([c.u64()?, c.u64()?, c.u64()?, c.u64()?]);
        }
        let mut node_channels = Vec::new();
        for _ in 0..c.u64()? {
            let kind = c.u8()?;
            let storage = match c.u32()? {
                0 => Some(c.u32()?),
                1 => None,
                _ => return None,
            };
            node_channels.push((kind, storage));
        }
        levels = Some((layout, table, node_channels));
    }
    let chunks = match level_count {
        Some((level, count)) => Some((level, count, (c.u64()?, c.u64()?))),
        None => None,
    };
    let nodes = if levels.is_some() {
        (0, 0)
    } else {
        (c.u64()?, c.u64()?)
    };
    let mut channels = Vec::new();
    for _ in 0..c.u64()? {
        let kind = c.u8()?;
        let storage = match c.u32()? {
            0 => Storage::Constant(c.u32()?),
            1 => Storage::PerLeaf(c.u64()?, c.u64()?),
            2 => Storage::Packed(c.u8()?, c.u8()?, c.u64()?, c.u64()?),
            _ => return None,
        };
        channels.push((kind, storage));
    }
    c.string()?;
    c.string()?;
    c.u64()?;
    let (mut lights, mut cameras) = (Vec::new(), Vec::new());
    if version >= 2 {
        for _ in 0..c.u64()? {
            lights.push((c.v3()?, [c.f32()?, c.f32()?, c.f32()?], c.f32()?));
        }
        for _ in 0..c.u64()? {
            let name_len = c.string()?.len();
            let (eye, target, up, fov) = (c.v3()?, c.v3()?, c.v3()?, c.f64()?);
            cameras.push(Camera {
                name_len,
                eye,
                target,
                up,
                fov,
            });
        }
    }
    (c.at == raw.len()).then_some(Header {
        origin,
        side,
        depth,
        chunks,
        node_count,
        leaf_count,
        nodes,
        channels,
        lights,
        cameras,
        levels,
    })
}

fn pad8(x: u64) -> u64 {
    x.div_ceil(8) * 8
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn scene_ok(h: &Header) -> bool {
    let fin = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
    let lights = h.lights.iter().all(|(p, c, i)| {
        fin(p) && c.iter().all(|x| x.is_finite() && *x >= 0.0) && i.is_finite() && *i >= 0.0
    });
    let cameras = h.cameras.iter().all(|c| {
        let d = [0, 1, 2].map(|k| c.target[k] - c.eye[k]);
        let dd = dot(d, d);
        if !(c.name_len <= 256
            && fin(&c.eye)
            && fin(&c.target)
            && fin(&c.up)
            && dd.is_finite()
            && dd > 0.0)
        {
            return false;
        }
        let u = d.map(|x| x * (1.0 / dd.sqrt()));
        let r = 1.0 / dot(c.up, c.up).sqrt();
        let w = if r.is_finite() && r > 0.0 {
            c.up.map(|x| x * r)
        } else {
            [0.0; 3]
        };
        let x = [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ];
        dot(x, x).sqrt() > 1e-9 && c.fov > 0.0 && c.fov < 180.0
    });
    lights && cameras
}

/// `Ok` for a valid file, else the number of the first check it fails, in the order of
/// section 6: the preamble and checksum (1-5), the header (6-11), the layout (12-13), the
/// chunk table of version 3 (19), the trees (14-17) and the values (18).
pub fn check(b: &[u8]) -> Result<(), u8> {
    let (version, hl) = preamble(b)?;
    let h = decode(&b[16..16 + hl], version).ok_or(6u8)?;
    header_values(&h)?;
    match &h.levels {
        Some((1, _, _)) => return check_dag(b, &h, hl),
        Some(_) => return check_levels(b, &h, hl),
        None => {}
    }
    layout(b, &h, hl)?;
    let trees = chunk_table(b, &h)?;
    let nodes = Nodes {
        b,
        base: h.nodes.0 as usize,
    };
    if (0..h.node_count as usize).any(|i| nodes.info(i) >> 8 != 0) {
        return Err(14);
    }
    for t in &trees {
        tree_shape(&nodes, t)?;
    }
    for t in &trees {
        leaf_order(&nodes, t)?;
    }
    values(b, &h, version)
}

/// The little-endian `u32` at byte `i` of `b`.
/// Section 12: the bits of a reference to a level of `count` nodes, the fewest (at least 1)
/// that hold `count - 1`.
fn reference_bits(count: u64) -> u32 {
    (1..64).find(|&w| count <= 1u64 << w).unwrap_or(64)
}

fn u32at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes(b[i..i + 4].try_into().unwrap())
}

/// A channel's element size in bytes, by kind.
fn size(kind: u8) -> u64 {
    [4u64, 4, 4, 1, 1, 2][usize::from(kind)]
}

/// Checks 1 to 5 (section 2, the layout): the magic, the size, the version, the header's length
/// and the checksum; the version and the header's length.
fn preamble(b: &[u8]) -> Result<(u32, usize), u8> {
    let l = b.len();
    if l < 8 || b[..8] != MAGIC {
        return Err(1);
    }
    if l < 24 {
        return Err(2);
    }
    let version = u32at(b, 8);
    if !(1..=4).contains(&version) {
        return Err(3);
    }
    let hl = u32at(b, 12) as usize;
    let e = 16 + hl + if version == 4 { 8 } else { 0 };
    if hl > 65_536 || e > l - 8 {
        return Err(4);
    }
    if u64::from_le_bytes(b[l - 8..].try_into().unwrap()) != xxhash_rust::xxh3::xxh3_64(&b[..l - 8])
    {
        return Err(5);
    }
    if version == 4
        && u64::from_le_bytes(b[16 + hl..e].try_into().unwrap())
            != xxhash_rust::xxh3::xxh3_64(&b[..16 + hl])
    {
        return Err(20);
    }
    Ok((version, hl))
}

/// Checks 7 to 11 (section 3): the depth and chunk level, the root cube, the counts, the
/// channels and the scene.
fn header_values(h: &Header) -> Result<(), u8> {
    if !(1..=30).contains(&h.depth) || h.chunks.is_some_and(|(c, _, _)| c >= h.depth || c > 21) {
        return Err(7);
    }
    let far_corner = h.origin.map(|x| x + h.side);
    if !(h.origin.iter().all(|x| x.is_finite())
        && h.side.is_finite()
        && h.side > 0.0
        && far_corner.iter().all(|x| x.is_finite()))
    {
        return Err(8);
    }
    let dag = matches!(h.levels, Some((1, _, _)));
    let counts_ok = match h.chunks {
        None if dag => h.node_count >= 1 && h.leaf_count <= 1 << 48,
        None => h.node_count >= 1 && h.leaf_count <= 1 << 31,
        Some((c, count, _)) => count <= h.node_count && count <= 1 << (3 * c),
    };
    if !counts_ok || (!dag && h.leaf_count > h.node_count.saturating_mul(8)) {
        return Err(9);
    }
    let mut last = -1i16;
    for (kind, s) in &h.channels {
        if *kind > 5 || i16::from(*kind) <= last {
            return Err(10);
        }
        last = i16::from(*kind);
        if let Storage::Constant(v) = s
            && size(*kind) < 4
            && u64::from(*v) >> (8 * size(*kind)) != 0
        {
            return Err(10);
        }
    }
    let has = |k: u8| h.channels.iter().any(|(kind, _)| *kind == k);
    if has(1) && !has(0) {
        return Err(10);
    }
    // Values on a level (section 12): the DAG layout only; a level from 1 to the depth; the
    // element's bits, a normal's even 4 to 32, or a colour's 16 or 4; a contour on the leaves';
    // one level for all.
    let mut on_level = None;
    for (kind, s) in &h.channels {
        let level = match *s {
            Storage::Constant(_) => continue,
            Storage::PerLeaf(..) => h.depth,
            Storage::Packed(level, bits, _, _) => {
                let element = 8 * size(*kind) as u8;
                let bits_ok = bits == element
                    || (*kind == 0 && bits % 2 == 0 && (4..=32).contains(&bits))
                    || (*kind == 2 && (bits == 16 || bits == 4));
                if !dag
                    || !(1..=h.depth).contains(&level)
                    || !bits_ok
                    || (*kind == 1 && level != h.depth)
                {
                    return Err(10);
                }
                level
            }
        };
        if on_level.is_some_and(|l| l != level) {
            return Err(10);
        }
        on_level = Some(level);
    }
    if let Some((_, _, node_channels)) = &h.levels
        && !node_channels.is_empty()
    {
        let kinds: Vec<u8> = h.channels.iter().map(|c| c.0).collect();
        let node_kinds: Vec<u8> = node_channels.iter().map(|c| c.0).collect();
        let too_wide = node_channels
            .iter()
            .any(|(k, v)| v.is_some_and(|v| size(*k) < 4 && u64::from(v) >> (8 * size(*k)) != 0));
        if kinds != node_kinds || too_wide {
            return Err(10);
        }
    }
    if !scene_ok(h) {
        return Err(11);
    }
    if let Some((layout, table, _)) = &h.levels {
        let mut sum = 0u64;
        for (l, e) in table.iter().enumerate() {
            let grows = l > 0 && e[0] > table[l - 1][0].saturating_mul(8);
            if grows || (l == 0 && e[0] != 1) {
                return Err(21);
            }
            sum = sum.saturating_add(e[0]);
        }
        let (levels, node_channels) = (table.len(), h.levels.as_ref().map_or(0, |l| l.2.len()));
        let shape_ok = match layout {
            0 => levels == usize::from(h.depth),
            1 => h.depth >= 2 && levels + 1 == usize::from(h.depth) && node_channels == 0,
            _ => false,
        };
        if !shape_ok || sum != h.node_count {
            return Err(21);
        }
    }
    Ok(())
}

/// Checks 12 and 13 (section 2, the layout): the arrays where the canonical layout puts them, and zero
/// padding between them.
fn layout(b: &[u8], h: &Header, hl: usize) -> Result<(), u8> {
    let data_end = (b.len() - 8) as u64;
    let mut arrays = Vec::new();
    if let Some((_, count, table)) = h.chunks {
        arrays.push((table, count * 24));
    }
    arrays.push((h.nodes, h.node_count.checked_mul(8).ok_or(12u8)?));
    for (kind, s) in &h.channels {
        match s {
            Storage::PerLeaf(o, n) => arrays.push(((*o, *n), h.leaf_count * size(*kind))),
            Storage::Packed(_, _, o, n) => arrays.push(((*o, *n), *n)),
            Storage::Constant(_) => {}
        }
    }
    let e = 16 + hl as u64;
    place(b, &arrays, pad8(e), vec![(e, pad8(e))], data_end)
}

/// Checks 12 and 13 on the arrays `arrays` (`(offset, len)` as stored, and the length their
/// counts give) placed from `at` on, after the padding gaps `gaps` already placed: each at
/// the next multiple of 8, the last one padded to the checksum, every padding byte zero.
fn place(
    b: &[u8],
    arrays: &[((u64, u64), u64)],
    mut at: u64,
    mut gaps: Vec<(u64, u64)>,
    data_end: u64,
) -> Result<(), u8> {
    for ((off, len), want) in arrays {
        if len != want || *off != at || off + len > data_end {
            return Err(12);
        }
        gaps.push((off + len, pad8(off + len)));
        at = pad8(off + len);
    }
    if at != data_end {
        return Err(12);
    }
    if gaps
        .iter()
        .any(|&(a, z)| b[a as usize..z as usize].iter().any(|&x| x != 0))
    {
        return Err(13);
    }
    Ok(())
}

/// A tree of the node array: the whole tree, or a version-3 chunk.
struct Tree {
    /// Its first node in the node array.
    start: usize,
    /// Its nodes.
    nodes: usize,
    /// Its levels.
    levels: u8,
    /// Its leaves.
    leaves: u64,
    /// Whether its root may have no children (the whole tree may be empty; a chunk may not).
    empty_root: bool,
}

/// Check 19 (section 10, version 3): the chunk table; the trees to check, each chunk a tree
/// of its own (version 2: the whole tree).
fn chunk_table(b: &[u8], h: &Header) -> Result<Vec<Tree>, u8> {
    let Some((c, count, (table, _))) = h.chunks else {
        return Ok(vec![Tree {
            start: 0,
            nodes: h.node_count as usize,
            levels: h.depth,
            leaves: h.leaf_count,
            empty_root: true,
        }]);
    };
    let u64at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap());
    let mut trees = Vec::new();
    let (mut at, mut nodes, mut leaves) = (0usize, 0u64, 0u64);
    let mut last = None;
    for j in 0..count as usize {
        let r = table as usize + 24 * j;
        let (code, cn, cl) = (u64at(r), u64at(r + 8), u64at(r + 16));
        if code >= 1 << (3 * c) || last.is_some_and(|l| code <= l) {
            return Err(19);
        }
        if !(1..=1 << 31).contains(&cn) || !(1..=1 << 31).contains(&cl) || cl > 8 * cn {
            return Err(19);
        }
        last = Some(code);
        nodes += cn;
        leaves += cl;
        if nodes <= h.node_count {
            trees.push(Tree {
                start: at,
                nodes: cn as usize,
                levels: h.depth - c,
                leaves: cl,
                empty_root: false,
            });
        }
        at += cn as usize;
    }
    if nodes != h.node_count || leaves != h.leaf_count {
        return Err(19);
    }
    Ok(trees)
}

/// The node array, read in place.
struct Nodes<'a> {
    b: &'a [u8],
    /// Its offset in the file.
    base: usize,
}

impl Nodes<'_> {
    /// Node `i`'s info word.
    fn info(&self, i: usize) -> u32 {
        u32at(self.b, self.base + 8 * i)
    }

    /// Node `i`'s first-child word.
    fn first(&self, i: usize) -> u32 {
        u32at(self.b, self.base + 8 * i + 4)
    }
}

/// Checks 15 and 16 (section 4, the node array): the tree's shape (leaf parents exactly at the last level,
/// no childless node but an empty root) and the canonical node order.
fn tree_shape(nodes: &Nodes<'_>, t: &Tree) -> Result<(), u8> {
    let info = |i: usize| nodes.info(t.start + i);
    let first = |i: usize| nodes.first(t.start + i);
    let mut next = 1usize;
    let mut stack = vec![(0usize, 0u8)];
    while let Some((i, lv)) = stack.pop() {
        let k = (info(i) & 0xFF).count_ones() as usize;
        if k == 0 {
            if i != 0 || !t.empty_root {
                return Err(15);
            }
            if first(i) != 0 {
                return Err(16);
            }
            continue;
        }
        let leafy = lv + 1 == t.levels;
        if leafy != ((first(i) as i32) < 0) {
            return Err(15);
        }
        if leafy {
            continue;
        }
        if first(i) as usize != next || next + k > t.nodes {
            return Err(16);
        }
        stack.extend((next..next + k).map(|j| (j, lv + 1)));
        next += k;
    }
    if next != t.nodes {
        return Err(16);
    }
    Ok(())
}

/// Check 17 (section 4, the node array): leaves numbered in depth-first child order, from 0.
fn leaf_order(nodes: &Nodes<'_>, t: &Tree) -> Result<(), u8> {
    let info = |i: usize| nodes.info(t.start + i);
    let first = |i: usize| nodes.first(t.start + i);
    let mut seen = 0u64;
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let k = (info(i) & 0xFF).count_ones() as usize;
        if (first(i) as i32) < 0 {
            if (-i64::from(first(i) as i32) - 1) as u64 != seen {
                return Err(17);
            }
            seen += k as u64;
        } else {
            stack.extend((first(i) as usize..first(i) as usize + k).rev());
        }
    }
    if seen != t.leaves {
        return Err(17);
    }
    Ok(())
}

/// Check 18 (section 5, the channels): the normal and contour values, constant or per leaf.
fn values(b: &[u8], h: &Header, version: u32) -> Result<(), u8> {
    let word = |kind: u8, leaf: u64| -> Option<u32> {
        h.channels
            .iter()
            .find(|(k, _)| *k == kind)
            .and_then(|(_, s)| match s {
                Storage::Constant(v) => Some(*v),
                Storage::PerLeaf(o, _) => Some(u32at(b, *o as usize + 4 * leaf as usize)),
                // On the leaves' level, each leaf's value; above it, checked value by value
                // in check_dag.
                Storage::Packed(level, bits, o, _) if *level == h.depth => {
                    let v = packed_value(b, *o, *bits, leaf);
                    if kind == 0 && *bits < 32 {
                        packed_normal(v, *bits)
                    } else {
                        Some(v)
                    }
                }
                Storage::Packed(..) => None,
            })
    };
    let constant = |kind: u8| {
        h.channels.iter().find_map(|(k, s)| match s {
            Storage::Constant(v) if *k == kind => Some(*v),
            _ => None,
        })
    };
    let normal_ok = |w: u32| {
        !((w & 0xFFFF == 0x8000 || w >> 16 == 0x8000) && (w != 0x8000_8000 || version < 2))
    };
    let contour_ok = |c: u32| c & 0xFFFF <= c >> 16;
    if constant(0).is_some_and(|w| !normal_ok(w)) || constant(1).is_some_and(|c| !contour_ok(c)) {
        return Err(18);
    }
    for leaf in 0..h.leaf_count {
        let (nw, cw) = (word(0, leaf), word(1, leaf));
        if nw.is_some_and(|w| !normal_ok(w))
            || cw.is_some_and(|c| !contour_ok(c))
            || (nw == Some(0x8000_8000) && cw.is_some_and(|c| c != 0xFFFF_0000))
        {
            return Err(18);
        }
    }
    Ok(())
}

/// A version-4 file after check 21 (section 11): checks 12, 13, 22, 14, 15 to 17 in level
/// order, and 18 on the leaves' and the inner nodes' values.
fn check_levels(b: &[u8], h: &Header, hl: usize) -> Result<(), u8> {
    let Some((_, table, node_channels)) = &h.levels else {
        return Ok(());
    };
    let depth = usize::from(h.depth);
    let data_end = (b.len() - 8) as u64;
    let e = 16 + hl as u64 + 8;
    let mut at = pad8(e);
    let mut gaps = vec![(e, at)];
    // 12: each level's block, then the per-leaf arrays.
    let per_node: Vec<u8> = node_channels
        .iter()
        .filter(|c| c.1.is_none())
        .map(|c| c.0)
        .collect();
    let mut blocks = Vec::new();
    for (l, entry) in table.iter().enumerate() {
        let n = entry[0];
        let mut lens = vec![n.checked_mul(8).ok_or(12u8)?];
        if l + 2 <= depth {
            for k in &per_node {
                lens.push(n.checked_mul(size(*k)).ok_or(12u8)?);
            }
        }
        let offset = at;
        let mut arrays = Vec::new();
        let mut end = at;
        for len in lens {
            end = at.checked_add(len).ok_or(12u8)?;
            arrays.push((at, len));
            at = pad8(end);
        }
        if entry[1] != offset || entry[2] != end - offset {
            return Err(12);
        }
        for &(o, len) in &arrays {
            if o + len > data_end {
                return Err(12);
            }
            gaps.push((o + len, pad8(o + len)));
        }
        blocks.push((offset, end - offset, arrays));
    }
    // 12 and 13: the per-leaf arrays after the blocks, and the padding.
    place(b, &leaf_arrays(h), at, gaps, data_end)?;
    // 22: the levels' checksums.
    for ((o, len, _), entry) in blocks.iter().zip(table) {
        if xxhash_rust::xxh3::xxh3_64(&b[*o as usize..(o + len) as usize]) != entry[3] {
            return Err(22);
        }
    }
    // 14: the node words, level after level.
    let node = |i: u64| -> (u32, u32) {
        let mut i = i;
        for (l, entry) in table.iter().enumerate() {
            if i < entry[0] {
                let at = blocks[l].0 as usize + 8 * i as usize;
                return (u32at(b, at), u32at(b, at + 4));
            }
            i -= entry[0];
        }
        (0, 0)
    };
    if (0..h.node_count).any(|i| node(i).0 >> 8 != 0) {
        return Err(14);
    }
    // 15 and 16: level by level.
    let (mut start, mut next) = (0u64, 1u64);
    for l in 0..depth {
        let end = start + table[l][0];
        let below = end + table.get(l + 1).map_or(0, |e| e[0]);
        for i in start..end {
            let (info, first) = node(i);
            let k = u64::from((info & 0xFF).count_ones());
            if k == 0 {
                if i != 0 {
                    return Err(15);
                }
                if first != 0 {
                    return Err(16);
                }
                continue;
            }
            let leafy = l + 1 == depth;
            if leafy != ((first as i32) < 0) {
                return Err(15);
            }
            if leafy {
                continue;
            }
            if u64::from(first) != next || next + k > below {
                return Err(16);
            }
            next += k;
        }
        if l + 1 < depth && next != below {
            return Err(16);
        }
        start = end;
    }
    // 17: the leaf parents, level depth - 1 in order.
    let mut seen = 0u64;
    for i in start - table[depth - 1][0]..start {
        let (info, first) = node(i);
        if (first as i32) < 0 {
            if (-i64::from(first as i32) - 1) as u64 != seen {
                return Err(17);
            }
            seen += u64::from((info & 0xFF).count_ones());
        }
    }
    if seen != h.leaf_count {
        return Err(17);
    }
    // 18: the leaves' values as in every version, then the inner nodes'.
    values(b, h, 4)?;
    let normal_ok = |w: u32| !(w & 0xFFFF == 0x8000 || w >> 16 == 0x8000);
    let contour_ok = |c: u32| c & 0xFFFF <= c >> 16;
    let mut array = 0;
    for (kind, storage) in node_channels {
        let ok = |w: u32| match kind {
            0 => normal_ok(w),
            1 => contour_ok(w),
            _ => true,
        };
        match storage {
            Some(v) if !ok(*v) => return Err(18),
            Some(_) => {}
            None => {
                array += 1;
                for (l, (_, _, arrays)) in blocks.iter().enumerate() {
                    if l + 2 > depth || *kind > 1 {
                        continue;
                    }
                    let (o, len) = arrays[array];
                    if (0..len / 4).any(|j| !ok(u32at(b, o as usize + 4 * j as usize))) {
                        return Err(18);
                    }
                }
            }
        }
    }
    Ok(())
}

/// A file of the DAG layout after check 21 (section 12): checks 12 and 13 (each level's block
/// as long as its entry says, within what its nodes can take), 22, then level by level the
/// nodes (15, 16, 14), then level by level the level above's references to them and their
/// being distinct (16), then the leaves the graph holds (17) and the leaves' values (18).
fn check_dag(b: &[u8], h: &Header, hl: usize) -> Result<(), u8> {
    let Some((_, table, _)) = &h.levels else {
        return Ok(());
    };
    let bricks_level = table.len() - 1;
    let data_end = (b.len() - 8) as u64;
    let e = 16 + hl as u64 + 8;
    let mut at = pad8(e);
    let mut gaps = vec![(e, at)];
    for (l, &[n, offset, len, _]) in table.iter().enumerate() {
        let fits = if l == bricks_level {
            n.checked_mul(8) == Some(len)
        } else {
            let width = u64::from(reference_bits(table[l + 1][0]));
            n <= len && n.checked_mul(1 + width).is_some_and(|m| len <= m)
        };
        let end = offset.checked_add(len).ok_or(12u8)?;
        if !fits || offset != at || end > data_end {
            return Err(12);
        }
        gaps.push((end, pad8(end)));
        at = pad8(end);
    }
    place(b, &leaf_arrays(h), at, gaps, data_end)?;
    for &[_, offset, len, hash] in table {
        if xxhash_rust::xxh3::xxh3_64(&b[offset as usize..(offset + len) as usize]) != hash {
            return Err(22);
        }
    }
    // The nodes, level by level: a node above the bricks is its mask and its references
    // (indices on the next level), read from the block's bit stream; a brick its 64 bits.
    let brick = |i: usize| {
        u64::from_le_bytes(
            b[table[bricks_level][1] as usize + 8 * i..][..8]
                .try_into()
                .unwrap(),
        )
    };
    let mut node_levels: Vec<Vec<(u32, Vec<u64>)>> = Vec::new();
    for (l, &[count, offset, len, _]) in table.iter().enumerate() {
        if l == bricks_level {
            for i in 0..count as usize {
                if brick(i) == 0 && !(l == 0 && i == 0) {
                    return Err(15);
                }
            }
            break;
        }
        let block = &b[offset as usize..(offset + len) as usize];
        let bit = |i: u64| block[(i / 8) as usize] >> (i % 8) & 1 == 1;
        let total = 8 * len;
        let width = u64::from(reference_bits(table[l + 1][0]));
        let mut at = 0u64;
        let read = |w: u64, at: &mut u64| -> Option<u64> {
            if *at + w > total {
                return None;
            }
            let v = (0..w).fold(0u64, |v, i| v | u64::from(bit(*at + i)) << i);
            *at += w;
            Some(v)
        };
        let mut nodes = Vec::new();
        for i in 0..count {
            let mask = read(8, &mut at).ok_or(16u8)? as u32;
            if mask == 0 && !(l == 0 && i == 0) {
                return Err(15);
            }
            let mut refs = Vec::new();
            for _ in 0..mask.count_ones() {
                refs.push(read(width, &mut at).ok_or(16u8)?);
            }
            nodes.push((mask, refs));
        }
        if total - at >= 8 || (at..total).any(bit) {
            return Err(14);
        }
        node_levels.push(nodes);
    }
    // Level by level from 1: the references of the level above, each to a node of this level,
    // the first references in order, every node referred to; no node twice.
    for l in 0..=bricks_level {
        let count = table[l][0] as usize;
        if l > 0 {
            let mut referred = 0usize;
            for (_, refs) in &node_levels[l - 1] {
                for &p in refs {
                    let p = p as usize;
                    if p >= count || p > referred {
                        return Err(16);
                    }
                    referred += usize::from(p == referred);
                }
            }
            if referred != count {
                return Err(16);
            }
        }
        let all: Vec<Vec<u64>> = (0..count)
            .map(|i| {
                if l == bricks_level {
                    vec![brick(i)]
                } else {
                    let (m, refs) = &node_levels[l][i];
                    std::iter::once(u64::from(*m))
                        .chain(refs.iter().copied())
                        .collect()
                }
            })
            .collect();
        for i in 0..all.len() {
            if all[..i].contains(&all[i]) {
                return Err(16);
            }
        }
    }
    let nodes_of_levels: Vec<Vec<(usize, Vec<usize>)>> = node_levels
        .iter()
        .map(|level| {
            level
                .iter()
                .map(|(_, refs)| (0, refs.iter().map(|&r| r as usize).collect()))
                .collect()
        })
        .collect();
    // 17: the leaves, from the bricks up.
    let mut leaves: Vec<u64> = (0..table[bricks_level][0] as usize)
        .map(|i| u64::from(brick(i).count_ones()))
        .collect();
    for level in nodes_of_levels.iter().rev() {
        leaves = level
            .iter()
            .map(|(_, kids)| kids.iter().map(|&k| leaves[k]).sum())
            .collect();
    }
    if leaves.first().copied().unwrap_or(0) != h.leaf_count {
        return Err(17);
    }
    // The tree's nodes on each level: how many paths reach each graph node, from the root.
    let depth = usize::from(h.depth);
    let mut per_level = vec![0u64; depth + 1];
    let mut times = vec![1u64];
    for (l, level) in node_levels.iter().enumerate() {
        per_level[l] = times.iter().sum();
        let mut next = vec![0u64; table[l + 1][0] as usize];
        for ((_, refs), &t) in level.iter().zip(&times) {
            for &r in refs {
                next[r as usize] += t;
            }
        }
        times = next;
    }
    let bricks: Vec<u64> = (0..table[bricks_level][0] as usize).map(brick).collect();
    let over = |f: &dyn Fn(u64) -> u64| {
        bricks
            .iter()
            .zip(&times)
            .map(|(&x, &t)| t * f(x))
            .sum::<u64>()
    };
    per_level[depth - 2] = times.iter().sum();
    per_level[depth - 1] = over(&|x| x.to_le_bytes().iter().filter(|&&y| y != 0).count() as u64);
    per_level[depth] = over(&|x| u64::from(x.count_ones()));
    for (kind, s) in &h.channels {
        if let Storage::Packed(level, bits, o, n) = *s {
            let count = per_level[usize::from(level)];
            let total = stream_bits(*kind, bits, count);
            if n != total.div_ceil(8) {
                return Err(17);
            }
            let _ = o;
        }
    }
    // 18 on the values stored on a level: no bit after the last one; normals of fewer than
    // 32 bits with both components or neither at their interior value, the words (32 bits)
    // as for leaves.
    for (kind, s) in &h.channels {
        if let Storage::Packed(level, bits, o, n) = *s {
            let count = per_level[usize::from(level)];
            let total = stream_bits(*kind, bits, count);
            if (total..8 * n).any(|at| b[(o + at / 8) as usize] >> (at % 8) & 1 == 1) {
                return Err(18);
            }
            for i in 0..count {
                let v = packed_value(b, o, bits, i);
                let word = match (*kind, bits) {
                    (0, 32) | (1, _) => v,
                    (0, _) => packed_normal(v, bits).ok_or(18u8)?,
                    _ => continue,
                };
                let bad = if *kind == 0 {
                    (word & 0xFFFF == 0x8000 || word >> 16 == 0x8000) && word != 0x8000_8000
                } else {
                    word & 0xFFFF > word >> 16
                };
                if bad {
                    return Err(18);
                }
            }
        }
    }
    values(b, h, 4)
}

/// The per-leaf arrays of `h` (`(offset, len)` as stored, and the length the leaf count gives),
/// which follow version 4's blocks.
fn leaf_arrays(h: &Header) -> Vec<((u64, u64), u64)> {
    h.channels
        .iter()
        .filter_map(|(kind, s)| match s {
            Storage::PerLeaf(o, n) => Some(((*o, *n), h.leaf_count * size(*kind))),
            // Its length is checked against its level's node count (check 17).
            Storage::Packed(_, _, o, n) => Some(((*o, *n), *n)),
            Storage::Constant(_) => None,
        })
        .collect()
}

/// The bits of `count` values of a channel of `kind` on a level in `bits` bits: `count * bits`,
/// except colours in 4 bits, in blocks of 16 values of 64 bits (32 for the two ends, 2 a
/// value), the last block of `r < 16` values `32 + 2 r`.
fn stream_bits(kind: u8, bits: u8, count: u64) -> u64 {
    if kind == 2 && bits == 4 {
        64 * (count / 16)
            + if !count.is_multiple_of(16) {
                32 + 2 * (count % 16)
            } else {
                0
            }
    } else {
        count * u64::from(bits)
    }
}

/// Value `i` of `bits` bits of the little-endian bit stream at `o` in `b`.
fn packed_value(b: &[u8], o: u64, bits: u8, i: u64) -> u32 {
    let start = i * u64::from(bits);
    (0..u64::from(bits)).fold(0u32, |v, k| {
        let at = start + k;
        v | u32::from(b[(o + at / 8) as usize] >> (at % 8) & 1) << k
    })
}

/// A normal of `bits < 32` bits as the word it stands for (section 12), `None` for a value
/// with one component alone at `-(m + 1)`.
fn packed_normal(v: u32, bits: u8) -> Option<u32> {
    let h = u32::from(bits / 2);
    let m = (1i64 << (h - 1)) - 1;
    let comp = |f: u32| {
        let x = i64::from(f & ((1 << h) - 1));
        if x > m { x - (1 << h) } else { x }
    };
    let (x, y) = (comp(v), comp(v >> h));
    match (x == -(m + 1), y == -(m + 1)) {
        (true, true) => Some(0x8000_8000),
        (false, false) => {
            // round(c * 32767 / m), halves away from zero.
            let half = |c: i64| {
                let q = (2 * c.abs() * 32767 + m) / (2 * m);
                u32::from((if c < 0 { -q } else { q }) as i16 as u16)
            };
            Some(half(x) | half(y) << 16)
        }
        _ => None,
    }
}
