//! Showing a frame: a render pipeline (`shaders/blit.wgsl`) that draws the tracer's pixel
//! buffer over a surface texture, scaled when the frame is smaller than the window. It only
//! needs wgpu, so it is built (and its layout tested) with or without the window feature.

use crate::gpu_context::{GpuContext, GpuError};
use bytemuck::{Pod, Zeroable};

/// The WGSL source of the blit.
pub const BLIT_WGSL: &str = include_str!("shaders/blit.wgsl");

/// The blit's uniforms (WGSL `BlitParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct BlitParams {
    /// The frame's size.
    pub frame: [u32; 2],
    /// The size drawn to (the window).
    pub dest: [u32; 2],
}

/// The blit pipeline for one target format.
pub struct Blit {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
}

impl Blit {
    /// A blit into textures of `format` (sRGB formats encode by themselves; others get the
    /// sRGB curve in the shader).
    pub fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> Result<Self, GpuError> {
        let dev = &ctx.device;
        let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("blit.wgsl"),
            source: wgpu::ShaderSource::Wgsl(BLIT_WGSL.into()),
        });
        let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("blit"),
            entries: &[
                entry(0, wgpu::BufferBindingType::Storage { read_only: true }),
                entry(1, wgpu::BufferBindingType::Uniform),
            ],
        });
        let pipeline_layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("blit"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let constants = [("SRGB_ENCODE", if format.is_srgb() { 0.0 } else { 1.0 })];
        let pipeline = dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("blit"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    zero_initialize_workgroup_memory: false,
                },
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let params = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("blit params"),
            size: size_of::<BlitParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        ctx.check()?;
        Ok(Self {
            pipeline,
            layout,
            params,
            bind_group: None,
        })
    }

    /// Points the blit at `pixels` (after the renderer made a new pixel buffer) and sets the
    /// sizes.
    pub fn set_source(&mut self, ctx: &GpuContext, pixels: &wgpu::Buffer, p: BlitParams) {
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        self.bind_group = Some(ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("blit"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: pixels.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.params.as_entire_binding(),
                },
            ],
        }));
    }

    /// Draws the frame into `pass` (nothing before [`Self::set_source`]).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        if let Some(bg) = &self.bind_group {
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, bg, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}
