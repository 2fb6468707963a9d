//! The GPU renderer: the octree's arrays uploaded without reformatting, the traversal and
//! Whitted shading of the tracer's shader ([`crate::shader`]) as a compute pipeline built for
//! the scene's [`ShaderVariant`], one invocation per pixel, and the read-back into an
//! [`svo::render::Frame`], the CPU renderer's own output type, so the same image writers,
//! AOVs and comparisons apply.
//!
//! ## The arena
//! The node array and the per-leaf channels are copied as they are stored, one after the
//! other, into one arena of `u32` words, followed by the tree's 64-ary view where
//! [`GpuLayout::wide_view`] asks for it ([`crate::wide_view`]), then, where the variant has a
//! level of detail, the inner nodes' channels it reads per node; the shader finds each array
//! by its word offset.
//! The arena is split into bindings of `2^k` words, `2^k` the largest power of two the
//! adapter's per-binding limit allows (lavapipe: 128 MiB), so a tree larger than one binding
//! still fits: up to [`BASE_ARENA_CHUNKS`], which keeps the storage buffers per stage at 7
//! (the WebGPU default allows 8), or, where the arena needs more and the adapter allows 19
//! storage buffers a stage, up to [`MAX_ARENA_CHUNKS`] (the shader linked with its feature
//! `many_bindings`). With one chunk the shader's chunk selection compiles away.

use crate::gpu_context::{GpuContext, GpuError};
use crate::gpu_tree::GpuTree;
use crate::gpu_types::{GpuPixel, GpuRay, GpuRayHit, GpuUniforms, ShaderVariant};
use crate::shader::{ShaderLink, WORKGROUP, trace_source};
use glam::Vec3;
use std::borrow::Cow;
use std::time::{Duration, Instant};
use svo::octree::Channel;
use svo::render::{Frame, NO_LEAF, RenderStats};

/// How the renderer lays its work out on the device: the defaults suit every adapter; the
/// others are for tests and measurements.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuLayout {
    /// The most bytes of one arena chunk (binding); `None`: the adapter's limit.
    pub chunk_limit: Option<u64>,
    /// The traversal walks the tree's 64-ary view ([`crate::wide_view`]: 4x4x4 cells a
    /// node, built when the tree is uploaded) instead of the octree, where the tree has one
    /// (leaves in depth-first order, as every tree `svo` builds or reads); off by default.
    /// The image is the same; the steps count the view's cells.
    pub wide_view: bool,
}

/// The bindings the arena is split over on any adapter (`arena0` to `arena3` in the shader):
/// with the pixels and the two ray batches, 7 storage buffers, within WebGPU's default of 8.
pub const BASE_ARENA_CHUNKS: usize = 4;

/// The most bindings the arena is split over (`arena0` to `arena15`), on adapters that allow
/// 19 storage buffers a stage or more (lavapipe allows 32), where the arena needs more than
/// [`BASE_ARENA_CHUNKS`].
pub const MAX_ARENA_CHUNKS: usize = 16;

/// The most bindings an adapter with `limits` lets the arena take.
pub fn arena_bindings(limits: &wgpu::Limits) -> usize {
    if limits.max_storage_buffers_per_shader_stage as usize >= MAX_ARENA_CHUNKS + 3 {
        MAX_ARENA_CHUNKS
    } else {
        BASE_ARENA_CHUNKS
    }
}

/// Where the tree's arrays sit in the arena.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct ArenaLayout {
    /// Word offsets: nodes (a graph's node records), then the six channels in `ChannelKind`
    /// order, then the 64-ary view, then the inner nodes' six channels (with a level of
    /// detail), then a graph's references, bricks and leaf parents' box codes.
    at: [u32; PARTS],
    /// Whether the 64-ary view is there ([`GpuLayout::wide_view`], where the tree has one).
    wide: bool,
    /// Whether the nodes are a graph's ([`GpuTree::Dag`]), which the walk then follows.
    dag: bool,
    /// Which nodes a graph's leaf indices count ([`svo::dag::FlatDag::values`]).
    dag_values: u32,
    /// log2 of the words per chunk.
    shift: u32,
    /// Chunks in use.
    chunks: u32,
    /// Bindings declared for them: [`BASE_ARENA_CHUNKS`], or [`MAX_ARENA_CHUNKS`] where more
    /// chunks are in use.
    bindings: u32,
}

/// The arrays of the arena.
const PARTS: usize = 17;

impl ArenaLayout {
    fn apply(&self, p: &mut crate::gpu_types::GpuParams) {
        p.nodes_at = self.at[0];
        p.normal_at = self.at[1];
        p.contour_at = self.at[2];
        p.colour_at = self.at[3];
        p.reflectivity_at = self.at[4];
        p.refractivity_at = self.at[5];
        p.ior_at = self.at[6];
        p.view_at = self.at[7];
        p.node_normal_at = self.at[8];
        p.node_contour_at = self.at[9];
        p.node_colour_at = self.at[10];
        p.node_reflectivity_at = self.at[11];
        p.node_refractivity_at = self.at[12];
        p.node_ior_at = self.at[13];
        p.dag_refs_at = self.at[14];
        p.dag_bricks_at = self.at[15];
        p.dag_boxes_at = self.at[16];
        p.dag_values = self.dag_values;
        p.arena_shift = self.shift;
    }
}

/// The arena of `tree` for `variant` (constant channels expanded when it reads them per
/// leaf), with the 64-ary view after them when `wide` asks for it and the tree has one, in
/// chunks of at most `chunk_limit` bytes over at most `bindings` bindings: the layout and the
/// chunks' bytes.
fn build_arena(
    tree: GpuTree<'_>,
    variant: &ShaderVariant,
    chunk_limit: u64,
    bindings: usize,
    wide: bool,
) -> Result<(ArenaLayout, Vec<Vec<u8>>), GpuError> {
    let view = match tree {
        GpuTree::Tree(t) if wide => crate::wide_view::build(t),
        _ => None,
    };
    // Checked before anything is copied.
    let view_bytes = view
        .as_ref()
        .map_or(0, |v| size_of_val(v.as_slice()) as u64);
    let total = arena_bytes(tree, variant) + view_bytes;
    let shift = chunk_shift(chunk_limit);
    let chunk_bytes = 4u64 << shift;
    let chunks = total.div_ceil(chunk_bytes).max(1);
    if total > arena_capacity(chunk_limit, bindings) {
        return Err(GpuError::TooLarge {
            what: match tree {
                GpuTree::Tree(t) => format!(
                    "the tree ({} nodes, {} leaves, in {bindings} bindings at most)",
                    t.nodes.len(),
                    t.leaf_count
                ),
                GpuTree::Dag(d) => format!(
                    "the graph ({} words, {} leaves, in {bindings} bindings at most)",
                    d.flat_words(),
                    d.leaf_count()
                ),
            },
            bytes: total,
            limit: arena_capacity(chunk_limit, bindings),
        });
    }
    let flat = match tree {
        GpuTree::Dag(d) => Some(d.flat()),
        GpuTree::Tree(_) => None,
    };
    let nodes: Cow<'_, [u8]> = match (tree, &flat) {
        (GpuTree::Tree(t), _) => Cow::Borrowed(bytemuck::cast_slice(&t.nodes)),
        (GpuTree::Dag(_), f) => words(f.as_ref().map(|f| f.nodes.as_slice())),
    };
    let a = tree.attributes();
    let none = svo::octree::LeafAttributes::default();
    let na = tree.node_attributes().unwrap_or(&none);
    let n = tree.leaf_count() as usize;
    let m = tree.tree().map_or(0, |t| t.nodes.len());
    let per_leaf = |k: usize| variant.channels[k] == 2;
    let per_node = |k: usize| variant.node_channels[k] == 2;
    let parts: [Cow<'_, [u8]>; PARTS] = [
        nodes,
        channel_bytes(&a.normal, per_leaf(0), n),
        channel_bytes(&a.contour, per_leaf(1), n),
        channel_bytes(&a.colour, per_leaf(2), n),
        channel_bytes(&a.reflectivity, per_leaf(3), n),
        channel_bytes(&a.refractivity, per_leaf(4), n),
        channel_bytes(&a.ior, per_leaf(5), n),
        view.as_ref().map_or(Cow::Borrowed(&[][..]), |v| {
            Cow::Borrowed(bytemuck::cast_slice(v))
        }),
        node_bytes(&na.normal, per_node(0), m),
        node_bytes(&na.contour, per_node(1), m),
        node_bytes(&na.colour, per_node(2), m),
        node_bytes(&na.reflectivity, per_node(3), m),
        node_bytes(&na.refractivity, per_node(4), m),
        node_bytes(&na.ior, per_node(5), m),
        words(flat.as_ref().map(|f| f.refs.as_slice())),
        words(flat.as_ref().map(|f| f.bricks.as_slice())),
        words(flat.as_ref().map(|f| f.leaf_parent_boxes.as_slice())),
    ];
    debug_assert_eq!(parts.iter().map(|p| p.len() as u64).sum::<u64>(), total);
    let mut layout = ArenaLayout {
        shift,
        chunks: chunks as u32,
        bindings: if chunks > BASE_ARENA_CHUNKS as u64 {
            MAX_ARENA_CHUNKS as u32
        } else {
            BASE_ARENA_CHUNKS as u32
        },
        wide: view.is_some(),
        dag: tree.is_dag(),
        dag_values: flat.as_ref().map_or(0, |f| f.values),
        ..ArenaLayout::default()
    };
    // The parts one after another, cut into chunks as they are copied.
    let mut out: Vec<Vec<u8>> = Vec::with_capacity(chunks as usize);
    let mut at = 0u64;
    for (k, p) in parts.iter().enumerate() {
        layout.at[k] = (at / 4) as u32;
        let mut rest: &[u8] = p;
        while !rest.is_empty() {
            if out.last().is_none_or(|c| c.len() as u64 == chunk_bytes) {
                let left = total - at;
                out.push(Vec::with_capacity(left.min(chunk_bytes) as usize));
            }
            let Some(c) = out.last_mut() else { break };
            let n = rest.len().min((chunk_bytes - c.len() as u64) as usize);
            c.extend_from_slice(&rest[..n]);
            rest = &rest[n..];
            at += n as u64;
        }
    }
    if out.is_empty() {
        out.push(Vec::new());
    }
    Ok((layout, out))
}

/// An array of words as bytes (none for `None`).
fn words(w: Option<&[u32]>) -> Cow<'_, [u8]> {
    Cow::Borrowed(bytemuck::cast_slice(w.unwrap_or(&[])))
}

/// log2 of the words of an arena chunk of at most `chunk_limit` bytes: the largest power of
/// two within the limit (at least 256 bytes).
fn chunk_shift(chunk_limit: u64) -> u32 {
    let words_limit = (chunk_limit / 4).max(64);
    63 - words_limit.leading_zeros()
}

/// The most bytes the arena holds on `ctx`'s adapter laid out as `layout` says (its chunk
/// limit, else the adapter's; the bindings the adapter allows).
pub fn adapter_capacity(ctx: &GpuContext, layout: &GpuLayout) -> u64 {
    let chunk_limit = layout.chunk_limit.unwrap_or_else(|| ctx.binding_limit());
    arena_capacity(chunk_limit, arena_bindings(&ctx.limits))
}

/// The most bytes an arena of chunks of at most `chunk_limit` bytes holds in `bindings`
/// bindings, and what 32-bit word offsets reach.
pub fn arena_capacity(chunk_limit: u64, bindings: usize) -> u64 {
    (bindings as u64 * (4u64 << chunk_shift(chunk_limit))).min(4 * u64::from(u32::MAX))
}

/// The bytes of the arena of `tree` for `variant`, without the 64-ary view: what
/// [`GpuRenderer::new`] uploads (and checks against [`arena_capacity`] before it copies
/// anything), worked out without copying anything.
pub fn arena_bytes<'a>(tree: impl Into<GpuTree<'a>>, variant: &ShaderVariant) -> u64 {
    fn len<T>(c: &Channel<T>, expand: bool, n: usize) -> u64 {
        let b = match c {
            Channel::PerLeaf(v) => size_of_val(v.as_slice()),
            Channel::Constant(_) if expand => n * size_of::<T>(),
            _ => 0,
        };
        b.next_multiple_of(4) as u64
    }
    let tree = tree.into();
    let a = tree.attributes();
    let n = tree.leaf_count() as usize;
    let leaf = |k: usize| variant.channels[k] == 2;
    let leaves = len(&a.normal, leaf(0), n)
        + len(&a.contour, leaf(1), n)
        + len(&a.colour, leaf(2), n)
        + len(&a.reflectivity, leaf(3), n)
        + len(&a.refractivity, leaf(4), n)
        + len(&a.ior, leaf(5), n);
    let t = match tree {
        GpuTree::Dag(d) => return 4 * d.flat_words() + leaves,
        GpuTree::Tree(t) => t,
    };
    let na = &t.node_attributes;
    let m = t.nodes.len();
    let node = |k: usize| variant.node_channels[k] == 2;
    let node_len = |k: usize, b: u64| if node(k) { b } else { 0 };
    8 * m as u64
        + leaves
        + node_len(0, len(&na.normal, true, m))
        + node_len(1, len(&na.contour, true, m))
        + node_len(2, len(&na.colour, true, m))
        + node_len(3, len(&na.reflectivity, true, m))
        + node_len(4, len(&na.refractivity, true, m))
        + node_len(5, len(&na.ior, true, m))
}

/// The bytes of an inner-node channel the shader reads per node (`on`), constants expanded;
/// nothing otherwise.
fn node_bytes<T: bytemuck::Pod>(c: &Channel<T>, on: bool, nodes: usize) -> Cow<'_, [u8]> {
    if on {
        channel_bytes(c, true, nodes)
    } else {
        Cow::Borrowed(&[])
    }
}

/// The bytes of a channel as the shader reads them: per-leaf arrays as stored, padded to a
/// whole `u32`; nothing for constant or absent channels, unless `expand` asks for a constant
/// as a per-leaf array (`ShaderVariant::everything`).
fn channel_bytes<T: bytemuck::Pod>(c: &Channel<T>, expand: bool, leaves: usize) -> Cow<'_, [u8]> {
    let b: &[u8] = match c {
        Channel::PerLeaf(v) => bytemuck::cast_slice::<T, u8>(v),
        Channel::Constant(v) if expand => {
            let mut b = bytemuck::cast_slice::<T, u8>(&vec![*v; leaves]).to_vec();
            b.resize(b.len().next_multiple_of(4), 0);
            return Cow::Owned(b);
        }
        _ => &[],
    };
    if b.len().is_multiple_of(4) {
        Cow::Borrowed(b)
    } else {
        let mut b = b.to_vec();
        b.resize(b.len().next_multiple_of(4), 0);
        Cow::Owned(b)
    }
}

/// Bindings 0-7 of the shader (uniforms, four arena chunks, pixels, batch rays in and out),
/// declared once for every entry point.
fn bind_group_layout(dev: &wgpu::Device, bindings: u32) -> wgpu::BindGroupLayout {
    let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let read = wgpu::BufferBindingType::Storage { read_only: true };
    let write = wgpu::BufferBindingType::Storage { read_only: false };
    let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform)];
    entries.extend((1..=4).map(|b| entry(b, read)));
    entries.push(entry(5, write));
    entries.push(entry(6, read));
    entries.push(entry(7, write));
    let more = bindings.saturating_sub(BASE_ARENA_CHUNKS as u32);
    entries.extend((8..8 + more).map(|b| entry(b, read)));
    dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("trace"),
        entries: &entries,
    })
}

/// A tree on the GPU with a pipeline for one shader variant and buffers for one image size.
pub struct GpuRenderer {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    /// Bindings 0-4 (uniforms, the arena's chunks), shared by both entry points.
    tree_buffers: Vec<wgpu::Buffer>,
    arena: ArenaLayout,
    placement: Placement,
    bind_group: wgpu::BindGroup,
    pixels: wgpu::Buffer,
    readback: wgpu::Buffer,
    unused_in: wgpu::Buffer,
    unused_out: wgpu::Buffer,
    width: u32,
    height: u32,
    variant: ShaderVariant,
    /// Pipelines compiled before, by variant (the window switches among them).
    pipelines: Vec<(ShaderVariant, wgpu::ComputePipeline)>,
    /// Bytes of tree data uploaded.
    pub tree_bytes: u64,
}

/// The pixel buffer of a `width` x `height` frame and the buffer it is read back through.
fn frame_buffers(
    ctx: &GpuContext,
    width: u32,
    height: u32,
) -> Result<(wgpu::Buffer, wgpu::Buffer), GpuError> {
    let bytes = u64::from(width) * u64::from(height) * size_of::<GpuPixel>() as u64;
    ctx.fits(&format!("a {width}x{height} frame"), bytes)?;
    let make = |label: &str, usage: wgpu::BufferUsages| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    Ok((
        make(
            "pixels",
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        ),
        make(
            "readback",
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        ),
    ))
}

impl GpuRenderer {
    /// Uploads `tree` and builds the pipeline for `variant` and `width` x `height` images.
    pub fn new<'a>(
        ctx: &GpuContext,
        tree: impl Into<GpuTree<'a>>,
        variant: ShaderVariant,
        width: u32,
        height: u32,
    ) -> Result<Self, GpuError> {
        Self::with_options(ctx, tree, variant, width, height, &GpuLayout::default())
    }

    /// [`Self::new`] laid out as `gpu_layout` says: arena chunks of at most its `chunk_limit`
    /// bytes (the adapter's limit, or less to test the split), and the walk.
    pub fn with_options<'a>(
        ctx: &GpuContext,
        tree: impl Into<GpuTree<'a>>,
        variant: ShaderVariant,
        width: u32,
        height: u32,
        gpu_layout: &GpuLayout,
    ) -> Result<Self, GpuError> {
        let tree = tree.into();
        let dev = &ctx.device;
        let chunk_limit = gpu_layout
            .chunk_limit
            .unwrap_or_else(|| ctx.binding_limit());
        if tree.tree().is_some_and(|t| t.nodes.is_empty()) {
            return Err(GpuError::Unsupported("the tree has no nodes".into()));
        }
        if tree.is_dag() && gpu_layout.wide_view {
            return Err(GpuError::Unsupported(
                "a DAG file's graph is walked as an octree: the 64-ary view is made from a tree"
                    .into(),
            ));
        }
        if variant.lod && gpu_layout.wide_view {
            return Err(GpuError::Unsupported(
                "the 64-ary view walks every ray to the leaves: a level of detail needs the octree walk"
                    .into(),
            ));
        }
        let bindings = arena_bindings(&ctx.limits);
        let (arena, chunks) =
            build_arena(tree, &variant, chunk_limit, bindings, gpu_layout.wide_view)?;
        for c in &chunks {
            ctx.fits("an arena chunk", c.len() as u64)?;
        }
        let (pixels, readback) = frame_buffers(ctx, width, height)?;
        let storage = |label: &str, data: &[u8]| {
            let buf = dev.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: data.len() as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.queue.write_buffer(&buf, 0, data);
            buf
        };
        let tree_bytes = chunks.iter().map(|c| c.len() as u64).sum::<u64>();
        let uniforms = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("uniforms"),
            size: size_of::<GpuUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut tree_buffers = vec![uniforms];
        tree_buffers.extend(chunks.iter().map(|c| storage("arena", c)));
        // Chunks not in use are bound to a placeholder (one for all: read-only bindings may
        // share a buffer, a read-write one may not share it with anything).
        let unused_chunk = dummy_buffer(dev);
        while tree_buffers.len() < 1 + arena.bindings as usize {
            tree_buffers.push(unused_chunk.clone());
        }

        let layout = bind_group_layout(dev, arena.bindings);
        let pipeline_layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("trace"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let placement = Placement {
            chunks: arena.chunks,
            depth: u32::from(tree.depth()),
            wide_view: arena.wide,
            dag: arena.dag,
            many_bindings: arena.bindings > BASE_ARENA_CHUNKS as u32,
        };
        let pipeline = compute_pipeline(dev, &pipeline_layout, "main", &variant, &placement)?;
        ctx.check()?;
        let (unused_in, unused_out) = (dummy_buffer(dev), dummy_buffer(dev));
        let bind_group = bind_group(
            dev,
            &layout,
            &tree_buffers,
            [&pixels, &unused_in, &unused_out],
        );
        ctx.check()?;
        Ok(Self {
            pipeline,
            layout,
            pipeline_layout,
            tree_buffers,
            arena,
            placement,
            bind_group,
            pixels,
            readback,
            unused_in,
            unused_out,
            width,
            height,
            variant,
            pipelines: Vec::new(),
            tree_bytes,
        })
    }

    /// Whether the traversal walks the tree's 64-ary view ([`GpuLayout::wide_view`]).
    pub fn wide_view(&self) -> bool {
        self.arena.wide
    }

    /// Bindings the arena is split over.
    pub fn arena_chunks(&self) -> u32 {
        self.arena.chunks
    }

    /// The first hits of a batch of grid-space rays (the `cast_rays` entry point: the
    /// traversal and leaf hit of the variant's hit mode, nothing skipped).
    pub fn cast(
        &self,
        ctx: &GpuContext,
        u: &GpuUniforms,
        rays: &[GpuRay],
    ) -> Result<Vec<GpuRayHit>, GpuError> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let dev = &ctx.device;
        let in_bytes: &[u8] = bytemuck::cast_slice(rays);
        let out_len = (rays.len() * size_of::<GpuRayHit>()) as u64;
        ctx.fits("the ray batch", in_bytes.len() as u64)?;
        let ray_in = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rays"),
            size: in_bytes.len() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        ctx.queue.write_buffer(&ray_in, 0, in_bytes);
        let ray_out = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hits"),
            size: out_len,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hits readback"),
            size: out_len,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pipeline = compute_pipeline(
            dev,
            &self.pipeline_layout,
            "cast_rays",
            &self.variant,
            &self.placement,
        )?;
        let bg = bind_group(
            dev,
            &self.layout,
            &self.tree_buffers,
            [&self.pixels, &ray_in, &ray_out],
        );
        ctx.check()?;
        self.write_uniforms(ctx, u);
        let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cast"),
        });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cast_rays"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bg, &[]);
            // At most 65,535 workgroups of 64 a dispatch in x: larger batches would need a
            // second dimension.
            let groups = rays.len().div_ceil(64);
            if groups > 65_535 {
                return Err(GpuError::Unsupported(format!(
                    "a batch of {} rays; at most {} at once",
                    rays.len(),
                    65_535 * 64
                )));
            }
            pass.dispatch_workgroups(groups as u32, 1, 1);
        }
        enc.copy_buffer_to_buffer(&ray_out, 0, &readback, 0, out_len);
        ctx.queue.submit([enc.finish()]);
        read_buffer(ctx, &readback)
    }

    /// Switches to `variant` (compiling its pipeline the first time). Its channels must be
    /// those the tree was uploaded for.
    pub fn set_variant(
        &mut self,
        ctx: &GpuContext,
        variant: ShaderVariant,
    ) -> Result<(), GpuError> {
        if variant == self.variant {
            return Ok(());
        }
        if variant.channels != self.variant.channels {
            return Err(GpuError::Unsupported(
                "a shader variant with other channels needs the tree uploaded again".into(),
            ));
        }
        let pipeline = match self.pipelines.iter().position(|(v, _)| *v == variant) {
            Some(i) => self.pipelines.swap_remove(i).1,
            None => {
                let p = compute_pipeline(
                    &ctx.device,
                    &self.pipeline_layout,
                    "main",
                    &variant,
                    &self.placement,
                )?;
                ctx.check()?;
                p
            }
        };
        let old = std::mem::replace(&mut self.pipeline, pipeline);
        self.pipelines.push((self.variant, old));
        self.variant = variant;
        Ok(())
    }

    /// Makes the frame `width` x `height`.
    pub fn resize(&mut self, ctx: &GpuContext, width: u32, height: u32) -> Result<(), GpuError> {
        if (width, height) == (self.width, self.height) {
            return Ok(());
        }
        let (pixels, readback) = frame_buffers(ctx, width, height)?;
        self.bind_group = bind_group(
            &ctx.device,
            &self.layout,
            &self.tree_buffers,
            [&pixels, &self.unused_in, &self.unused_out],
        );
        self.pixels = pixels;
        self.readback = readback;
        self.width = width;
        self.height = height;
        ctx.check()
    }

    /// The frame's pixel buffer (`GpuPixel`s, row-major), for a pass that shows it.
    pub fn pixels(&self) -> &wgpu::Buffer {
        &self.pixels
    }

    /// The frame size.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Records one frame into `enc` with the uniforms written before (the window's path:
    /// the blit and the overlay follow in the same encoder).
    pub fn encode(&self, enc: &mut wgpu::CommandEncoder) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("trace"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        let [wx, wy] = WORKGROUP;
        pass.dispatch_workgroups(self.width.div_ceil(wx), self.height.div_ceil(wy), 1);
    }

    /// Writes the uniforms of the next frame (with the arena's offsets, which only the
    /// renderer knows).
    pub fn write_uniforms(&self, ctx: &GpuContext, u: &GpuUniforms) {
        let mut u = *u;
        self.arena.apply(&mut u.params);
        ctx.queue
            .write_buffer(&self.tree_buffers[0], 0, bytemuck::bytes_of(&u));
    }

    /// The shader variant in use.
    pub fn variant(&self) -> &ShaderVariant {
        &self.variant
    }

    /// Renders one frame with `u` and waits for it: the wall time from submission to
    /// completion.
    pub fn render(&self, ctx: &GpuContext, u: &GpuUniforms) -> Result<Duration, GpuError> {
        self.write_uniforms(ctx, u);
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        self.encode(&mut enc);
        let start = Instant::now();
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        Ok(start.elapsed())
    }

    /// Reads the last frame back.
    pub fn read_frame(&self, ctx: &GpuContext, elapsed: Duration) -> Result<Frame, GpuError> {
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("read"),
            });
        enc.copy_buffer_to_buffer(&self.pixels, 0, &self.readback, 0, self.pixels.size());
        ctx.queue.submit([enc.finish()]);
        let px: Vec<GpuPixel> = read_buffer(ctx, &self.readback)?;
        Ok(to_frame(&px, self.width, self.height, elapsed))
    }
}

/// What the renderer adds to a variant's pipeline: the arena's chunk count, the tree's depth
/// (which sizes the ancestor stack) and the walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Placement {
    chunks: u32,
    depth: u32,
    /// Whether the arena holds the 64-ary view, which the traversal then walks.
    wide_view: bool,
    /// Whether the arena holds a graph, which the traversal then walks.
    dag: bool,
    /// Whether the arena takes more than [`BASE_ARENA_CHUNKS`] bindings.
    many_bindings: bool,
}

/// The pipeline of `entry` for `variant` with the renderer's `placement`.
fn compute_pipeline(
    dev: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    entry: &str,
    variant: &ShaderVariant,
    placement: &Placement,
) -> Result<wgpu::ComputePipeline, GpuError> {
    let source = trace_source(&ShaderLink {
        wide_view: placement.wide_view,
        dag: placement.dag,
        many_bindings: placement.many_bindings,
        depth: placement.depth,
        ray_stack: variant.ray_stack,
    })?;
    let desc = wgpu::ShaderModuleDescriptor {
        label: Some("trace"),
        source: wgpu::ShaderSource::Wgsl(String::from(&*source).into()),
    };
    // wgpu's default checks bound every loop (a counter per iteration, so that a loop
    // without an end cannot hang the device), which cost 6-18% of a frame on the H100
    // (docs/gpu-benchmarks.md); the index clamps cost nothing measurable and stay.
    let mut checks = wgpu::ShaderRuntimeChecks::checked();
    checks.force_loop_bounding = false;
    // SAFETY: the contract of `create_shader_module_trusted` is the checks turned off: with
    // bounds checks kept, only the loop bounds are, and every loop of the shader ends on its
    // own (the "Loops" comment of `shaders/trace/traverse.wesl`): the traversal counts a step
    // in every pass of its outer and inner loops and returns past `max_steps` (at most
    // `u32::MAX - 1`: `gpu_types::tree_uniforms` clamps it), its pop loop shrinks the stack
    // each pass, the light loop counts to a constant, and the Whitted loop takes a ray off its
    // stack each pass and pushes at most two with a reflection or refraction count one
    // higher, below the bounce limits.
    #[allow(unsafe_code)]
    let module = unsafe { dev.create_shader_module_trusted(desc, checks) };
    let mut constants = variant.constants();
    constants.push(("ARENA_CHUNKS", f64::from(placement.chunks)));
    Ok(
        dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: true,
            },
            cache: None,
        }),
    )
}

/// A small placeholder for bindings an entry point does not use.
fn dummy_buffer(dev: &wgpu::Device) -> wgpu::Buffer {
    dev.create_buffer(&wgpu::BufferDescriptor {
        label: Some("unused binding"),
        size: 256,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

/// Bindings 0-4 from `tree` (uniforms, arena chunks) and 5-7 from `rest`.
fn bind_group(
    dev: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    tree: &[wgpu::Buffer],
    rest: [&wgpu::Buffer; 3],
) -> wgpu::BindGroup {
    // Bindings 0-4 (uniforms, the first four chunks), 5-7 (`rest`), then the other chunks
    // from 8.
    let base = 1 + BASE_ARENA_CHUNKS;
    let entries: Vec<wgpu::BindGroupEntry<'_>> = tree[..base]
        .iter()
        .chain(rest)
        .chain(&tree[base..])
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("trace"),
        layout,
        entries: &entries,
    })
}

/// Maps `buf` (after the queued copy into it) and reads it as `T`s.
pub(crate) fn read_buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    buf: &wgpu::Buffer,
) -> Result<Vec<T>, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buf.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv()
        .map_err(|e| GpuError::Wgpu(e.to_string()))?
        .map_err(|e| GpuError::Wgpu(e.to_string()))?;
    let v = {
        let view = buf
            .get_mapped_range(..)
            .map_err(|e| GpuError::Wgpu(e.to_string()))?;
        bytemuck::pod_collect_to_vec(&view)
    };
    buf.unmap();
    Ok(v)
}

/// The GPU's pixels as a CPU [`Frame`] with its counters.
fn to_frame(px: &[GpuPixel], width: u32, height: u32, elapsed: Duration) -> Frame {
    let mut s = RenderStats::default();
    for p in px {
        let rays = p.rays & 0xffff;
        s.primary_rays += 1;
        s.primary_hits += u64::from(p.leaf != NO_LEAF);
        s.secondary_rays += u64::from(rays.saturating_sub(1));
        s.shadow_rays += u64::from(p.rays >> 16);
        s.steps += u64::from(p.steps);
        s.primary_steps += u64::from(p.primary_steps);
        s.max_primary_steps = s.max_primary_steps.max(p.primary_steps);
        s.capped += u64::from(p.capped);
    }
    Frame {
        width,
        height,
        colour: px.iter().map(|p| Vec3::from(p.colour)).collect(),
        depth: px.iter().map(|p| p.depth).collect(),
        normal: px.iter().map(|p| Vec3::from(p.normal)).collect(),
        leaf: px.iter().map(|p| p.leaf).collect(),
        cost: px.iter().map(|p| p.primary_steps).collect(),
        stats: s,
        elapsed,
    }
}
