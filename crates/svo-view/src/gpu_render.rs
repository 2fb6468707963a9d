//! The GPU renderer: the octree's arrays uploaded as storage buffers without reformatting,
//! the traversal and Whitted shading of `shaders/trace.wgsl` as a compute pipeline built for
//! the scene's [`ShaderVariant`], one invocation per pixel, and the read-back into an
//! [`svo::render::Frame`], the CPU renderer's own output type, so the same image writers,
//! AOVs and comparisons apply.

use crate::gpu_context::{GpuContext, GpuError};
use crate::gpu_types::{GpuPixel, GpuUniforms, ShaderVariant};
use glam::Vec3;
use std::time::{Duration, Instant};
use svo::octree::{Channel, Octree};
use svo::render::{Frame, NO_LEAF, RenderStats};

/// The WGSL source of the tracer.
pub const TRACE_WGSL: &str = include_str!("shaders/trace.wgsl");

/// Threads per workgroup side (`@workgroup_size(8, 8, 1)` in the shader).
const WORKGROUP: u32 = 8;

/// The bytes of a channel as the shader reads them: per-leaf arrays as stored, padded to a
/// whole `u32`; a placeholder word for constant or absent channels, unless `expand` asks for
/// a constant as a per-leaf array (`ShaderVariant::everything`).
fn channel_bytes<T: bytemuck::Pod>(c: &Channel<T>, expand: bool, leaves: usize) -> Vec<u8> {
    let mut b = match c {
        Channel::PerLeaf(v) => bytemuck::cast_slice::<T, u8>(v).to_vec(),
        Channel::Constant(v) if expand => bytemuck::cast_slice::<T, u8>(&vec![*v; leaves]).to_vec(),
        _ => Vec::new(),
    };
    let padded = b.len().next_multiple_of(4).max(4);
    b.resize(padded, 0);
    b
}

/// A tree on the GPU with a pipeline for one shader variant and buffers for one image size.
pub struct GpuRenderer {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    uniforms: wgpu::Buffer,
    pixels: wgpu::Buffer,
    readback: wgpu::Buffer,
    width: u32,
    height: u32,
    variant: ShaderVariant,
    /// Bytes of tree data uploaded.
    pub tree_bytes: u64,
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
        let dev = &ctx.device;
        let a = &tree.attributes;
        let node_bytes: &[u8] = bytemuck::cast_slice(&tree.nodes);
        if node_bytes.is_empty() {
            return Err(GpuError::Unsupported("the tree has no nodes".into()));
        }
        let n = tree.leaf_count as usize;
        let per_leaf = |k: usize| variant.channels[k] == 2;
        let chans = [
            ("normal", channel_bytes(&a.normal, per_leaf(0), n)),
            ("contour", channel_bytes(&a.contour, per_leaf(1), n)),
            ("colour", channel_bytes(&a.colour, per_leaf(2), n)),
            ("reflectivity", channel_bytes(&a.reflectivity, per_leaf(3), n)),
            ("refractivity", channel_bytes(&a.refractivity, per_leaf(4), n)),
            ("ior", channel_bytes(&a.ior, per_leaf(5), n)),
        ];
        ctx.fits("the node array", node_bytes.len() as u64)?;
        for (name, b) in &chans {
            ctx.fits(&format!("the {name} channel"), b.len() as u64)?;
        }
        let pixel_bytes = u64::from(width) * u64::from(height) * size_of::<GpuPixel>() as u64;
        ctx.fits(&format!("a {width}x{height} frame"), pixel_bytes)?;

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
        let nodes = storage("nodes", node_bytes);
        let chan_bufs: Vec<wgpu::Buffer> = chans.iter().map(|(n, b)| storage(n, b)).collect();
        let tree_bytes =
            node_bytes.len() as u64 + chans.iter().map(|(_, b)| b.len() as u64).sum::<u64>();
        let uniforms = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("uniforms"),
            size: size_of::<GpuUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pixels = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pixels"),
            size: pixel_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: pixel_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });

        let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("trace.wgsl"),
            source: wgpu::ShaderSource::Wgsl(TRACE_WGSL.into()),
        });
        let constants = variant.constants();
        let pipeline = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("trace"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        });
        ctx.check()?;
        let layout = pipeline.get_bind_group_layout(0);
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: nodes.as_entire_binding(),
            },
        ];
        for (i, b) in chan_bufs.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: 2 + i as u32,
                resource: b.as_entire_binding(),
            });
        }
        entries.push(wgpu::BindGroupEntry {
            binding: 8,
            resource: pixels.as_entire_binding(),
        });
        let bind_group = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace"),
            layout: &layout,
            entries: &entries,
        });
        ctx.check()?;
        Ok(Self {
            pipeline,
            bind_group,
            uniforms,
            pixels,
            readback,
            width,
            height,
            variant,
            tree_bytes,
        })
    }

    /// The shader variant in use.
    pub fn variant(&self) -> &ShaderVariant {
        &self.variant
    }

    /// Renders one frame with `u` and waits for it: the wall time from submission to
    /// completion.
    pub fn render(&self, ctx: &GpuContext, u: &GpuUniforms) -> Result<Duration, GpuError> {
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(u));
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("trace"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(
                self.width.div_ceil(WORKGROUP),
                self.height.div_ceil(WORKGROUP),
                1,
            );
        }
        let start = Instant::now();
        ctx.queue.submit([enc.finish()]);
        ctx.wait()?;
        Ok(start.elapsed())
    }

    /// Reads the last frame back.
    pub fn read_frame(&self, ctx: &GpuContext, elapsed: Duration) -> Result<Frame, GpuError> {
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("read") });
        enc.copy_buffer_to_buffer(&self.pixels, 0, &self.readback, 0, self.pixels.size());
        ctx.queue.submit([enc.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        self.readback
            .map_async(wgpu::MapMode::Read, .., move |r| {
                let _ = tx.send(r);
            });
        ctx.wait()?;
        rx.recv()
            .map_err(|e| GpuError::Wgpu(e.to_string()))?
            .map_err(|e| GpuError::Wgpu(e.to_string()))?;
        let px: Vec<GpuPixel> = {
            let view = self
                .readback
                .get_mapped_range(..)
                .map_err(|e| GpuError::Wgpu(e.to_string()))?;
            bytemuck::pod_collect_to_vec(&view)
        };
        self.readback.unmap();
        Ok(to_frame(&px, self.width, self.height, elapsed))
    }
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
