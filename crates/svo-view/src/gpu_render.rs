//! The GPU renderer: the octree's arrays uploaded without reformatting, the traversal and Whitted shading of `shaders/trace.wgsl` as a compute pipeline built for
//! the scene's [`ShaderVariant`], one invocation per pixel, and the read-back into an
//! [`svo::render::Frame`], the CPU renderer's own output type, so the same image writers,
//! AOVs and comparisons apply.
//!
//! ## The arena
//! The node array and the per-leaf channels are copied as they are stored, one after the
//! other, into one arena of `u32` words, followed by the tree's 64-ary view where
//! [`GpuLayout::wide_view`] asks for it ([`crate::wide_view`]); the shader finds each array
//! by its word offset.
//! The arena is split into up to [`MAX_ARENA_CHUNKS`] bindings of `2^k` words, `2^k` the
//! largest power of two the adapter's per-binding limit allows (lavapipe: 128 MiB), so a tree
//! larger than one binding still fits; with one chunk the shader's chunk selection compiles
//! away. It also keeps the storage buffers per stage at 7 (the WebGPU default allows 8).

use crate::gpu_context::{GpuContext, GpuError};
use crate::gpu_types::{GpuPixel, GpuRay, GpuRayHit, GpuUniforms, ShaderVariant};
use glam::Vec3;
use std::time::{Duration, Instant};
use svo::octree::{Channel, Octree};
use svo::render::{Frame, NO_LEAF, RenderStats};

/// The WGSL source of the tracer.
pub const TRACE_WGSL: &str = include_str!("shaders/trace.wgsl");

/// The line of [`TRACE_WGSL`] that sizes the traversal's private ancestor stack.
const MAX_DEPTH_LINE: &str = "const MAX_DEPTH: u32 = 30u;";
/// The line of [`TRACE_WGSL`] that sizes the private Whitted ray stack.
const RAY_STACK_LINE: &str = "const RAY_STACK: u32 = 34u;";

/// [`TRACE_WGSL`] with its two private stacks sized for a tree of `depth` levels and
/// `ray_stack` pending rays ([`ShaderVariant::ray_stack`]) instead of the most the shader
/// allows (30 levels, 34 rays). WGSL zero-initializes private and function variables, and
/// the drivers store every element of an array that is indexed at run time: each pixel
/// pays for its whole ancestor stack (12 bytes an entry) and its whole ray stack (56 bytes
/// an entry). Arrays cannot be sized by pipeline constants, so the text is edited before
/// compilation.
pub fn trace_source(ray_stack: u32, depth: u32) -> String {
    debug_assert!(TRACE_WGSL.contains(MAX_DEPTH_LINE) && TRACE_WGSL.contains(RAY_STACK_LINE));
    TRACE_WGSL
        .replacen(
            MAX_DEPTH_LINE,
            &format!("const MAX_DEPTH: u32 = {}u;", depth.clamp(1, 30)),
            1,
        )
        .replacen(
            RAY_STACK_LINE,
            &format!("const RAY_STACK: u32 = {}u;", ray_stack.clamp(1, 34)),
            1,
        )
}

/// How the renderer lays its work out on the device: the defaults suit every adapter; the
/// others are for tests and measurements.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuLayout {
    /// The most bytes of one arena chunk (binding); `None`: the adapter's limit.
    pub chunk_limit: Option<u64>,
    /// Where the traversal's and the ray tracer's stacks live.
    pub stacks: StackPlacement,
    /// The render's workgroup, pixels across and down (`WG_X`, `WG_Y` in the shader);
    /// `None`: [`DEFAULT_WORKGROUP`].
    pub workgroup: Option<[u32; 2]>,
    /// Which of wgpu's run-time checks the shader gets (index clamps, loop bounds).
    pub checks: ShaderChecks,
    /// Rays spawned at a primary hit descend the hit's path without reading its nodes
    /// (`HIT_PATHS` in the shader); off (the default: on lavapipe it costs more than the
    /// reads it saves, docs/gpu-benchmarks.md), they descend from the root as any ray. The
    /// image and the steps are the same.
    pub hit_paths: bool,
    /// The traversal walks the tree's 64-ary view ([`crate::wide_view`]: 4x4x4 cells a
    /// node, built when the tree is uploaded) instead of the octree, where the tree has one
    /// (leaves in depth-first order, as every tree `svo` builds or reads); off by default.
    /// The image is the same; the steps count the view's cells. Hit paths go with the
    /// octree's walk, so they are off with it.
    pub wide_view: bool,
}

/// The render's workgroup unless one is given: on the H100 (docs/gpu-benchmarks.md) 8x8 was
/// the fastest shape or within a few percent of it for every scene, with and without
/// bounces, once the traversal stepped over empty children in an inner loop (before that,
/// 16x16 had been faster for scenes without bounces).
pub const DEFAULT_WORKGROUP: [u32; 2] = [8, 8];

impl Default for GpuLayout {
    fn default() -> Self {
        Self {
            chunk_limit: None,
            stacks: StackPlacement::Auto,
            workgroup: None,
            checks: ShaderChecks::NoLoopBounds,
            hit_paths: false,
            wide_view: false,
        }
    }
}

/// Parses a workgroup shape `XxY` (at most 256 invocations, at least 1 a side).
pub fn parse_workgroup(s: &str) -> Result<[u32; 2], String> {
    let bad = || format!("workgroup '{s}': expected WIDTHxHEIGHT, at most 256 invocations");
    let (x, y) = s.split_once('x').ok_or_else(bad)?;
    let (x, y): (u32, u32) = (x.parse().map_err(|_| bad())?, y.parse().map_err(|_| bad())?);
    if x == 0 || y == 0 || x.saturating_mul(y) > 256 {
        return Err(bad());
    }
    Ok([x, y])
}

/// The most bindings the arena is split over (`arena0` to `arena3` in the shader).
pub const MAX_ARENA_CHUNKS: usize = 4;

/// Where the tree's arrays sit in the arena.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct ArenaLayout {
    /// Word offsets: nodes, then the six channels in `ChannelKind` order, then the 64-ary
    /// view.
    at: [u32; 8],
    /// Whether the 64-ary view is there ([`GpuLayout::wide_view`], where the tree has one).
    wide: bool,
    /// log2 of the words per chunk.
    shift: u32,
    /// Chunks in use.
    chunks: u32,
}

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
        p.arena_shift = self.shift;
    }
}

/// The arena of `tree` for `variant` (constant channels expanded when it reads them per
/// leaf), with the 64-ary view after them when `wide` asks for it and the tree has one, in
/// chunks of at most `chunk_limit` bytes: the layout and the chunks' bytes.
fn build_arena(
    tree: &Octree,
    variant: &ShaderVariant,
    chunk_limit: u64,
    wide: bool,
) -> Result<(ArenaLayout, Vec<Vec<u8>>), GpuError> {
    let a = &tree.attributes;
    let n = tree.leaf_count as usize;
    let per_leaf = |k: usize| variant.channels[k] == 2;
    let view = if wide {
        crate::wide_view::build(tree)
    } else {
        None
    };
    let parts: [Vec<u8>; 8] = [
        bytemuck::cast_slice(&tree.nodes).to_vec(),
        channel_bytes(&a.normal, per_leaf(0), n),
        channel_bytes(&a.contour, per_leaf(1), n),
        channel_bytes(&a.colour, per_leaf(2), n),
        channel_bytes(&a.reflectivity, per_leaf(3), n),
        channel_bytes(&a.refractivity, per_leaf(4), n),
        channel_bytes(&a.ior, per_leaf(5), n),
        view.as_ref()
            .map(|v| bytemuck::cast_slice(v).to_vec())
            .unwrap_or_default(),
    ];
    let total: u64 = parts.iter().map(|p| p.len() as u64).sum();
    // Words per chunk: the largest power of two within the limit (at least 256 bytes).
    let words_limit = (chunk_limit / 4).max(64);
    let shift = 63 - words_limit.leading_zeros();
    let chunk_bytes = 4u64 << shift;
    let chunks = total.div_ceil(chunk_bytes).max(1);
    if chunks > MAX_ARENA_CHUNKS as u64 || total / 4 > u64::from(u32::MAX) {
        return Err(GpuError::TooLarge {
            what: format!(
                "the tree ({} nodes, {} leaves, in {MAX_ARENA_CHUNKS} bindings at most)",
                tree.nodes.len(),
                tree.leaf_count
            ),
            bytes: total,
            limit: chunk_bytes * MAX_ARENA_CHUNKS as u64,
        });
    }
    let mut layout = ArenaLayout {
        shift,
        chunks: chunks as u32,
        wide: view.is_some(),
        ..ArenaLayout::default()
    };
    let mut arena = Vec::with_capacity(total as usize);
    for (k, p) in parts.iter().enumerate() {
        layout.at[k] = (arena.len() / 4) as u32;
        arena.extend_from_slice(p);
    }
    let out = arena
        .chunks(chunk_bytes as usize)
        .map(<[u8]>::to_vec)
        .collect();
    Ok((layout, out))
}

/// The bytes of a channel as the shader reads them: per-leaf arrays as stored, padded to a
/// whole `u32`; nothing for constant or absent channels, unless `expand` asks for a constant
/// as a per-leaf array (`ShaderVariant::everything`).
fn channel_bytes<T: bytemuck::Pod>(c: &Channel<T>, expand: bool, leaves: usize) -> Vec<u8> {
    let mut b = match c {
        Channel::PerLeaf(v) => bytemuck::cast_slice::<T, u8>(v).to_vec(),
        Channel::Constant(v) if expand => bytemuck::cast_slice::<T, u8>(&vec![*v; leaves]).to_vec(),
        _ => Vec::new(),
    };
    let padded = b.len().next_multiple_of(4);
    b.resize(padded, 0);
    b
}

/// Bindings 0-8 of the shader (uniforms, four arena chunks, pixels, batch rays in and out,
/// the primary tiles), declared once for every entry point.
fn bind_group_layout(dev: &wgpu::Device) -> wgpu::BindGroupLayout {
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
    entries.push(entry(8, write));
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
    /// The primary tiles' start parameters (a float per 8x8 block of pixels).
    tiles: wgpu::Buffer,
    /// The `tile_bounds` pipeline, compiled when a variant first needs it (it uses nothing
    /// that differs between the variants of one tree).
    tile_pipeline: Option<wgpu::ComputePipeline>,
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

/// Pixels across and down a primary tile (`TILE` in the shader).
const TILE: u32 = 8;

/// The primary tiles' buffer for a `width` x `height` frame: a float per block.
fn tile_buffer(ctx: &GpuContext, width: u32, height: u32) -> wgpu::Buffer {
    let blocks = u64::from(width.div_ceil(TILE)) * u64::from(height.div_ceil(TILE));
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("primary tiles"),
        size: (blocks * 4).max(4),
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

impl GpuRenderer {
    /// Uploads `tree` and builds the pipeline for `variant` and `width` x `height` images.
    pub fn new(
        ctx: &GpuContext,
        tree: &Octree,
        variant: ShaderVariant,
        width: u32,
        height: u32,
    ) -> Result<Self, GpuError> {
        Self::with_options(ctx, tree, variant, width, height, &GpuLayout::default())
    }

    /// [`Self::new`] laid out as `gpu_layout` says: arena chunks of at most its `chunk_limit`
    /// bytes (the adapter's limit, or less to test the split), the stacks placed as its
    /// `stacks` says, its workgroup shape.
    pub fn with_options(
        ctx: &GpuContext,
        tree: &Octree,
        variant: ShaderVariant,
        width: u32,
        height: u32,
        gpu_layout: &GpuLayout,
    ) -> Result<Self, GpuError> {
        let dev = &ctx.device;
        let chunk_limit = gpu_layout
            .chunk_limit
            .unwrap_or_else(|| ctx.binding_limit());
        if tree.nodes.is_empty() {
            return Err(GpuError::Unsupported("the tree has no nodes".into()));
        }
        let (arena, chunks) = build_arena(tree, &variant, chunk_limit, gpu_layout.wide_view)?;
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
        while tree_buffers.len() < 1 + MAX_ARENA_CHUNKS {
            tree_buffers.push(unused_chunk.clone());
        }

        let layout = bind_group_layout(dev);
        let pipeline_layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("trace"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let placement = Placement {
            chunks: arena.chunks,
            depth: u32::from(tree.depth),
            stacks: gpu_layout.stacks,
            workgroup: gpu_layout.workgroup,
            checks: gpu_layout.checks,
            hit_paths: gpu_layout.hit_paths,
            wide_view: arena.wide,
        };
        let pipeline = compute_pipeline(dev, &pipeline_layout, "main", &variant, &placement);
        let tile_pipeline = variant
            .primary_tiles
            .then(|| compute_pipeline(dev, &pipeline_layout, "tile_bounds", &variant, &placement));
        ctx.check()?;
        let (unused_in, unused_out) = (dummy_buffer(dev), dummy_buffer(dev));
        let tiles = tile_buffer(ctx, width, height);
        let bind_group = bind_group(
            dev,
            &layout,
            &tree_buffers,
            [&pixels, &unused_in, &unused_out, &tiles],
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
            tiles,
            tile_pipeline,
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

    /// Whether the current variant keeps (its ancestor stack, its ray stack) in workgroup
    /// memory.
    pub fn workgroup_stacks(&self) -> (bool, bool) {
        self.placement.decide(&self.variant)
    }

    /// The current variant's workgroup, pixels across and down.
    pub fn workgroup(&self) -> [u32; 2] {
        self.placement.workgroup()
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
        );
        let bg = bind_group(
            dev,
            &self.layout,
            &self.tree_buffers,
            [&self.pixels, &ray_in, &ray_out, &self.tiles],
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
                );
                ctx.check()?;
                p
            }
        };
        if variant.primary_tiles && self.tile_pipeline.is_none() {
            self.tile_pipeline = Some(compute_pipeline(
                &ctx.device,
                &self.pipeline_layout,
                "tile_bounds",
                &variant,
                &self.placement,
            ));
            ctx.check()?;
        }
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
        let tiles = tile_buffer(ctx, width, height);
        self.bind_group = bind_group(
            &ctx.device,
            &self.layout,
            &self.tree_buffers,
            [&pixels, &self.unused_in, &self.unused_out, &tiles],
        );
        self.tiles = tiles;
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
        if let Some(tp) = self
            .tile_pipeline
            .as_ref()
            .filter(|_| self.variant.primary_tiles)
        {
            // Its own pass, before the frame's: the frame reads what it writes.
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("primary tiles"),
                timestamp_writes: None,
            });
            pass.set_pipeline(tp);
            pass.set_bind_group(0, &self.bind_group, &[]);
            // Workgroups of 8x8 blocks.
            pass.dispatch_workgroups(
                self.width.div_ceil(TILE).div_ceil(8),
                self.height.div_ceil(TILE).div_ceil(8),
                1,
            );
        }
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("trace"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        let [wx, wy] = self.placement.workgroup();
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

/// Where a pipeline's stacks go, and the arena's chunk count: the constants the renderer
/// adds to a variant's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Placement {
    chunks: u32,
    depth: u32,
    stacks: StackPlacement,
    /// The render's workgroup shape, if given.
    workgroup: Option<[u32; 2]>,
    /// [`GpuLayout::checks`].
    checks: ShaderChecks,
    /// [`GpuLayout::hit_paths`].
    hit_paths: bool,
    /// Whether the arena holds the 64-ary view, which the traversal then walks.
    wide_view: bool,
}

impl Placement {
    /// The render's workgroup: the given one, or [`DEFAULT_WORKGROUP`].
    fn workgroup(&self) -> [u32; 2] {
        self.workgroup.unwrap_or(DEFAULT_WORKGROUP)
    }

    /// `(ancestors in workgroup memory, pending rays in workgroup memory)` for `variant`.
    fn decide(&self, variant: &ShaderVariant) -> (bool, bool) {
        match self.stacks {
            // Measured on the H100 (docs/gpu-benchmarks.md): with the private stacks sized
            // for the scene and the ancestors zeroed once per pixel, private beats workgroup
            // memory everywhere (1.2-1.4x without bounces, at the wider workgroup; 2.7-4.3x
            // with bounces, where the shared memory lets fewer workgroups run at once).
            StackPlacement::Auto | StackPlacement::Private => (false, false),
            StackPlacement::Workgroup => (true, variant.reflections),
        }
    }

    fn constants(&self, variant: &ShaderVariant) -> Vec<(&'static str, f64)> {
        let (wt, wr) = self.decide(variant);
        let [wx, wy] = self.workgroup();
        // Flags, and entries per invocation (one where the stack is not there).
        let flag = |on: bool| f64::from(u8::from(on));
        let entries = |on: bool, n: u32| if on { f64::from(n.max(1)) } else { 1.0 };
        vec![
            ("ARENA_CHUNKS", f64::from(self.chunks)),
            ("WG_TRAVERSE", flag(wt)),
            ("TSTACK", entries(wt, self.depth)),
            ("WG_RAYS", flag(wr)),
            ("RSTACK", entries(wr, variant.ray_stack)),
            ("WG_X", f64::from(wx)),
            ("WG_Y", f64::from(wy)),
            // The view's walk records no paths: hit paths go with the octree's walk.
            ("HIT_PATHS", flag(self.hit_paths && !self.wide_view)),
            ("WIDE_VIEW", flag(self.wide_view)),
        ]
    }
}

/// Where the traversal's ancestor stack and the Whitted ray stack live. WGSL zero-initializes
/// function variables, so private stacks cost their whole size in stores for every ray;
/// workgroup memory is not initialized (the pipelines turn that off) and is sized for the
/// tree's depth and the bounce limits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StackPlacement {
    /// What measured fastest (docs/gpu-benchmarks.md): private, now that the private
    /// stacks are sized for the scene.
    #[default]
    Auto,
    /// Private (function) memory.
    Private,
    /// Workgroup memory for both (the pipeline fails where it does not fit).
    Workgroup,
}

impl std::str::FromStr for StackPlacement {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "auto" => Ok(Self::Auto),
            "private" => Ok(Self::Private),
            "workgroup" => Ok(Self::Workgroup),
            _ => Err(format!(
                "unknown stack placement '{s}': auto, private or workgroup"
            )),
        }
    }
}

/// Which of wgpu's run-time checks the tracer's shader gets. Its index clamps (on the stacks,
/// the uniform tables) cost nothing measurable and always stay; the loop bounds that wgpu
/// adds to every loop by default (a counter per iteration, so that a loop without an end
/// cannot hang the device) cost 6-18% of a frame on the H100 (docs/gpu-benchmarks.md), and the
/// shader's loops all end on their own (the "Loops" comment in `shaders/trace.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ShaderChecks {
    /// Index clamps and loop bounds: wgpu's default, for measuring what the bounds cost.
    Full,
    /// Index clamps only (the default).
    #[default]
    NoLoopBounds,
}

impl std::str::FromStr for ShaderChecks {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "full" => Ok(Self::Full),
            "no-loop-bounds" => Ok(Self::NoLoopBounds),
            _ => Err(format!(
                "unknown shader checks '{s}': full or no-loop-bounds"
            )),
        }
    }
}

/// The pipeline of `entry` for `variant` with the renderer's `placement`.
fn compute_pipeline(
    dev: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    entry: &str,
    variant: &ShaderVariant,
    placement: &Placement,
) -> wgpu::ComputePipeline {
    let desc = wgpu::ShaderModuleDescriptor {
        label: Some("trace.wgsl"),
        source: wgpu::ShaderSource::Wgsl(trace_source(variant.ray_stack, placement.depth).into()),
    };
    let module = match placement.checks {
        ShaderChecks::Full => dev.create_shader_module(desc),
        ShaderChecks::NoLoopBounds => {
            let mut checks = wgpu::ShaderRuntimeChecks::checked();
            checks.force_loop_bounding = false;
            // SAFETY: the contract of `create_shader_module_trusted` is the checks turned
            // off: with bounds checks kept, only the loop bounds are, and every loop of
            // trace.wgsl ends on its own (the shader's "Loops" comment): `traverse` counts a
            // step in every pass of its outer and inner loops and returns past `max_steps`
            // (at most `u32::MAX - 1`: `gpu_types::tree_uniforms` clamps it), its pop loop
            // shrinks the stack each pass, the light loop counts to a constant, and the
            // Whitted loop takes a ray off its stack each pass and pushes at most two with a
            // reflection or refraction count one higher, below the bounce limits; the
            // primary tiles' walk counts a visit each pass and stops past `TILE_VISITS`.
            #[allow(unsafe_code)]
            unsafe {
                dev.create_shader_module_trusted(desc, checks)
            }
        }
    };

    let mut constants = variant.constants();
    constants.extend(placement.constants(variant));
    dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants: &constants,
            zero_initialize_workgroup_memory: false,
        },
        cache: None,
    })
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

/// Bindings 0-4 from `tree` (uniforms, arena chunks) and 5-8 from `rest`.
fn bind_group(
    dev: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    tree: &[wgpu::Buffer],
    rest: [&wgpu::Buffer; 4],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = tree
        .iter()
        .chain(rest)
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
