//! `svo-view FILE`: the interactive window (winit), ray traced on the GPU every frame by the
//! same pipeline as `--headless`, shown by [`crate::window_blit`], with an egui overlay.
//!
//! Mouse: left drag turns (orbit around the target, or look around in fly mode), right or
//! middle drag pans, the wheel zooms. Keys: `Tab` orbit/fly, `W A S D Q E` fly (`Shift`
//! faster), `1` cube / `2` contour hits, `[` `]` bounces, `L` lights on/off, `G` shadow
//! mode, `-` `=` render scale, `P` screenshot, `R` reset the view, `V` the next camera view
//! stored in the file, `F1` overlay, `Esc` quit.
//!
//! Each change of hit mode, bounces, lights or shadows picks the shader variant the scene
//! then needs ([`ShaderVariant::for_scene`]); pipelines are compiled once and kept.

use crate::camera_control::{CameraControl, CameraMode};
use crate::gpu_context::{GpuContext, GpuError};
use crate::gpu_render::{
    BASE_ARENA_CHUNKS, GpuLayout, GpuRenderer, adapter_capacity, arena_bytes, arena_capacity,
    read_buffer,
};
use crate::gpu_tree::GpuTree;
use crate::gpu_types::{ShaderVariant, uniforms};
use crate::headless::check_gpu_support;
use crate::job::{JobError, RenderJob, write_output};
use crate::window_blit::{Blit, BlitParams};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use svo::Octree;
use svo::dag::DagTree;
use svo::render::{Aov, MAX_BOUNCES, ShadowMode, Stage, TraceOptions};
use svo::trace::HitMode;
use thiserror::Error;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// Errors of the window.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum WindowError {
    /// Loading the scene or writing a screenshot failed.
    #[error(transparent)]
    Job(#[from] JobError),
    /// The GPU failed or refused.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// No window could be opened.
    #[error("cannot open a window: {0} (without a display, use --headless or --cpu)")]
    NoWindow(String),
}

/// What the window does besides showing the job's scene.
#[derive(Clone, Debug, Default)]
pub struct WindowOptions {
    /// Close after this many frames (scripted captures and tests).
    pub quit_after: Option<u32>,
    /// Where `P` (and the last frame with `quit_after`) saves a screenshot; default
    /// `svo-view-N.png` in the working folder.
    pub screenshot: Option<PathBuf>,
}

/// What a window did while it was open.
#[derive(Clone, Debug)]
pub struct WindowReport {
    /// The adapter.
    pub adapter: String,
    /// Frames shown.
    pub frames: u32,
    /// Milliseconds from the start to the first frame shown.
    pub startup_ms: f64,
    /// Median milliseconds between frames.
    pub median_frame_ms: f64,
    /// Screenshots written.
    pub screenshots: Vec<PathBuf>,
}

/// The settings the overlay and keys change.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Settings {
    trace: TraceOptions,
    lights_on: bool,
    /// Frame size = window size / render scale.
    render_scale: u32,
    overlay: bool,
}

/// Opens the window on `job`'s scene and runs until it is closed.
pub fn run(job: &RenderJob, opts: &WindowOptions) -> Result<WindowReport, WindowError> {
    let start = Instant::now();
    check_gpu_support(&job.trace, job.sky_cube_map.is_some(), job.lights.len())?;
    // A version-4 file larger than an adapter's smallest arena: read as deep as this
    // machine's adapter holds, by its header (the window's adapter may differ: the tree read
    // is measured again once it is open).
    let sizes = crate::fit::level_sizes(job, &GpuLayout::default())?;
    let lod = job.trace.lod > 0.0;
    let smallest = arena_capacity(128 << 20, BASE_ARENA_CHUNKS);
    let limit = match &sizes {
        Some(s) if crate::fit::prefix_depth(s, smallest, lod).is_some() => {
            GpuContext::new().map_or(smallest, |c| adapter_capacity(&c, &GpuLayout::default()))
        }
        _ => u64::MAX,
    };
    let (shown, stage, read) = if job.max_depth.is_none() && is_dag(job)? {
        // A DAG file: its graph, walked on the GPU as its tree would be.
        let (dag, build) = svo::io::read_dag_file(&job.input).map_err(setup_error)?;
        let (lo, hi) = dag.occupied_bounds();
        let stage = job
            .setup()?
            .stage(dag.depth(), lo, hi, &build.scene)
            .map_err(JobError::from)?;
        (Shown::Graph(dag), stage, None)
    } else {
        let (scene, read) = crate::fit::open_fitting(job, sizes, limit)?;
        let (tree, stage) = scene.into_parts();
        (Shown::Tree(tree), stage, read)
    };
    check_gpu_support(&job.trace, false, stage.lights.len())?;
    let event_loop = EventLoop::new().map_err(|e| WindowError::NoWindow(e.to_string()))?;
    let (lo, hi) = shown.gpu().occupied_bounds();
    let control = CameraControl::from_camera(&stage.camera, (hi - lo).length());
    let mut app = App {
        title: format!("svo-view: {}", job.input.display()),
        size: (job.width, job.height),
        settings: Settings {
            trace: job.trace,
            lights_on: true,
            render_scale: 1,
            overlay: true,
        },
        control,
        shown,
        stage,
        job: job.clone(),
        read,
        view: 0,
        opts: opts.clone(),
        start,
        running: None,
        error: None,
        held: Held::default(),
        last_frame: None,
        frame_ms: Vec::new(),
        startup_ms: None,
        screenshots: Vec::new(),
        display: event_loop.owned_display_handle(),
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| WindowError::NoWindow(e.to_string()))?;
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    let mut ms = app.frame_ms.clone();
    ms.sort_by(f64::total_cmp);
    Ok(WindowReport {
        adapter: app
            .running
            .as_ref()
            .map_or_else(String::new, |r| r.ctx.adapter_name()),
        frames: app.frame_ms.len() as u32 + u32::from(app.startup_ms.is_some()),
        startup_ms: app.startup_ms.unwrap_or(0.0),
        median_frame_ms: ms.get(ms.len() / 2).copied().unwrap_or(0.0),
        screenshots: app.screenshots,
    })
}

/// Whether `job`'s file is of the DAG layout.
fn is_dag(job: &RenderJob) -> Result<bool, JobError> {
    svo::io::is_dag_file(&job.input).map_err(setup_error)
}

fn setup_error(e: svo::io::FormatError) -> JobError {
    JobError::from(svo::render::SetupError::from(e))
}

/// What the window traces: a tree, or a DAG file's graph (its tree never made).
enum Shown {
    Tree(Octree),
    Graph(DagTree),
}

impl Shown {
    fn gpu(&self) -> GpuTree<'_> {
        match self {
            Self::Tree(t) => t.into(),
            Self::Graph(d) => d.into(),
        }
    }
}

/// Buttons and keys held down.
#[derive(Default)]
struct Held {
    turn: bool,
    pan: bool,
    cursor: Option<(f64, f64)>,
    keys: Vec<KeyCode>,
    shift: bool,
}

/// The GPU side, made when the window exists.
struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    ctx: GpuContext,
    renderer: GpuRenderer,
    blit: Blit,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
}

struct App {
    title: String,
    size: (u32, u32),
    settings: Settings,
    control: CameraControl,
    shown: Shown,
    stage: Stage,
    /// The job, to read the file's top levels where its graph does not fit the adapter.
    job: RenderJob,
    /// What of the file was left unread because the adapter would not hold it.
    read: Option<crate::fit::Prefix>,
    /// Which stored view `V` showed last.
    view: usize,
    opts: WindowOptions,
    start: Instant,
    running: Option<Running>,
    error: Option<WindowError>,
    held: Held,
    last_frame: Option<Instant>,
    frame_ms: Vec<f64>,
    startup_ms: Option<f64>,
    screenshots: Vec<PathBuf>,
    display: winit::event_loop::OwnedDisplayHandle,
}

impl App {
    fn fail(&mut self, el: &ActiveEventLoop, e: WindowError) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        el.exit();
    }

    fn lights(&self) -> Vec<svo::render::PointLight> {
        if self.settings.lights_on {
            self.stage.lights.clone()
        } else {
            Vec::new()
        }
    }

    fn variant(&self) -> ShaderVariant {
        ShaderVariant::for_scene(self.shown.gpu(), &self.settings.trace, self.lights().len())
    }

    fn frame_size(&self, r: &Running) -> (u32, u32) {
        let s = self.settings.render_scale.max(1);
        ((r.config.width / s).max(1), (r.config.height / s).max(1))
    }

    fn start_gpu(&mut self, el: &ActiveEventLoop) -> Result<Running, WindowError> {
        let attrs = Window::default_attributes()
            .with_title(self.title.clone())
            .with_inner_size(winit::dpi::PhysicalSize::new(self.size.0, self.size.1));
        let window = Arc::new(
            el.create_window(attrs)
                .map_err(|e| WindowError::NoWindow(e.to_string()))?,
        );
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(
                Box::new(self.display.clone()),
            ));
        let surface = instance
            .create_surface(Arc::clone(&window))
            .map_err(|e| WindowError::NoWindow(e.to_string()))?;
        let ctx = GpuContext::open(&instance, Some(&surface))?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&ctx.adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| {
                WindowError::NoWindow("the adapter cannot present to this window".into())
            })?;
        // Window captures (the last frame of --quit-after) copy the surface texture.
        if surface
            .get_capabilities(&ctx.adapter)
            .usages
            .contains(wgpu::TextureUsages::COPY_SRC)
        {
            config.usage |= wgpu::TextureUsages::COPY_SRC;
        }
        surface.configure(&ctx.device, &config);
        // Software adapters render at half resolution to stay interactive.
        if ctx.is_software() {
            self.settings.render_scale = 2;
        }
        // A graph larger than the adapter: the tree's top levels that fit, as for a tree.
        let layout = GpuLayout::default();
        let limit = adapter_capacity(&ctx, &layout);
        if matches!(self.shown, Shown::Graph(_))
            && arena_bytes(self.shown.gpu(), &self.variant()) > limit
        {
            let sizes = crate::fit::level_sizes(&self.job, &layout)?;
            let (scene, read) = crate::fit::open_fitting(&self.job, sizes, limit)?;
            self.shown = Shown::Tree(scene.tree);
            self.read = read;
        }
        // A tree larger than the adapter: the deepest prefix of its levels that fits.
        let lights = self.stage.lights.len();
        if let Shown::Tree(tree) = &mut self.shown {
            let trace = &self.settings.trace;
            let cut = crate::fit::fit_tree(&ctx, tree, lights, trace, &layout)?;
            if let Some(p) = crate::fit::said_of_file(cut, self.read.take()) {
                eprintln!("svo-view: {p}");
            }
        }
        let variant = self.variant();
        let s = self.settings.render_scale;
        let renderer = GpuRenderer::new(
            &ctx,
            self.shown.gpu(),
            variant,
            (config.width / s).max(1),
            (config.height / s).max(1),
        )?;
        let mut blit = Blit::new(&ctx, config.format)?;
        show_frame(&ctx, &renderer, &mut blit, &config);
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(ctx.limits.max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(
            &ctx.device,
            config.format,
            egui_wgpu::RendererOptions::default(),
        );
        ctx.check()?;
        Ok(Running {
            window,
            surface,
            config,
            ctx,
            renderer,
            blit,
            egui_ctx,
            egui_state,
            egui_renderer,
        })
    }

    /// Applies a settings change: the shader variant and the frame size.
    fn apply(&mut self) -> Result<(), WindowError> {
        let variant = self.variant();
        let Some(mut r) = self.running.take() else {
            return Ok(());
        };
        let size = self.frame_size(&r);
        let res = r
            .renderer
            .set_variant(&r.ctx, variant)
            .and_then(|()| r.renderer.resize(&r.ctx, size.0, size.1));
        show_frame(&r.ctx, &r.renderer, &mut r.blit, &r.config);
        self.running = Some(r);
        res.map_err(WindowError::from)
    }

    fn key(&mut self, el: &ActiveEventLoop, code: KeyCode) -> Result<(), WindowError> {
        let t = &mut self.settings.trace;
        match code {
            KeyCode::Escape => el.exit(),
            KeyCode::Tab => self.control.toggle_mode(),
            KeyCode::KeyR => self.control.reset(),
            KeyCode::KeyV if !self.stage.views.is_empty() => {
                // The next camera view stored in the file.
                self.view = (self.view + 1) % self.stage.views.len();
                let (lo, hi) = self.shown.gpu().occupied_bounds();
                let mode = self.control.mode;
                self.control =
                    CameraControl::from_camera(&self.stage.views[self.view].1, (hi - lo).length());
                self.control.mode = mode;
            }
            KeyCode::F1 => self.settings.overlay = !self.settings.overlay,
            KeyCode::Digit1 => t.mode = HitMode::Cube,
            KeyCode::Digit2 => t.mode = HitMode::Contour,
            KeyCode::BracketLeft => {
                t.max_reflections = t.max_reflections.saturating_sub(1);
                t.max_refractions = t.max_reflections;
            }
            KeyCode::BracketRight => {
                t.max_reflections = (t.max_reflections + 1).min(MAX_BOUNCES);
                t.max_refractions = t.max_reflections;
            }
            KeyCode::KeyL => self.settings.lights_on = !self.settings.lights_on,
            KeyCode::KeyG => {
                t.shadows = match t.shadows {
                    ShadowMode::None => ShadowMode::Opaque,
                    ShadowMode::Opaque => ShadowMode::MaxRefractivity,
                    ShadowMode::MaxRefractivity => ShadowMode::Transmittance,
                    _ => ShadowMode::None,
                };
            }
            KeyCode::Minus => self.settings.render_scale = (self.settings.render_scale + 1).min(8),
            KeyCode::Equal => {
                self.settings.render_scale = self.settings.render_scale.saturating_sub(1).max(1);
            }
            KeyCode::KeyP => {
                self.screenshot()?;
            }
            _ => {}
        }
        self.apply()
    }

    /// Writes the last frame as a PNG: the given path, or the next free `svo-view-N.png`.
    fn screenshot(&mut self) -> Result<(), WindowError> {
        let Some(r) = &self.running else {
            return Ok(());
        };
        let path = match &self.opts.screenshot {
            Some(p) => p.clone(),
            None => (1..)
                .map(|n| PathBuf::from(format!("svo-view-{n}.png")))
                .find(|p| !p.exists())
                .unwrap_or_else(|| PathBuf::from("svo-view.png")),
        };
        let frame = r.renderer.read_frame(&r.ctx, std::time::Duration::ZERO)?;
        write_output(&frame, Aov::Colour, &path, 1).map_err(JobError::from)?;
        eprintln!("svo-view: wrote {}", path.display());
        self.screenshots.push(path);
        Ok(())
    }

    /// Moves the camera by the fly keys held, for `dt` seconds since the last frame.
    fn fly(&mut self, dt: f64) {
        if self.control.mode != CameraMode::Fly {
            return;
        }
        let k = |c: KeyCode| f64::from(u8::from(self.held.keys.contains(&c)));
        let f = k(KeyCode::KeyW) - k(KeyCode::KeyS);
        let s = k(KeyCode::KeyD) - k(KeyCode::KeyA);
        let u = k(KeyCode::KeyE) - k(KeyCode::KeyQ);
        let boost = if self.held.shift { 4.0 } else { 1.0 };
        self.control.fly(f, s, u, dt.min(0.25) * boost);
    }

    fn redraw(&mut self, el: &ActiveEventLoop) -> Result<(), WindowError> {
        let now = Instant::now();
        let dt = self
            .last_frame
            .map_or(0.0, |t| now.duration_since(t).as_secs_f64());
        self.fly(dt);
        let lights = self.lights();
        let trace = self.settings.trace;
        let last = self
            .opts
            .quit_after
            .is_some_and(|n| self.frame_ms.len() as u32 + 2 > n);
        let Some(r) = self.running.as_mut() else {
            return Ok(());
        };
        let (fw, fh) = r.renderer.size();
        let camera = self.control.camera(fw, fh);
        let tree = self.shown.gpu();
        let u = uniforms(
            tree,
            &camera,
            &lights,
            &self.stage.sky,
            &self.stage.phong,
            &trace,
        )
        .map_err(JobError::from)?;
        r.renderer.write_uniforms(&r.ctx, &u);
        let Some(texture) = next_texture(r) else {
            return Ok(());
        };
        let overlay = Overlay {
            adapter: r.ctx.adapter_name(),
            ms: self.frame_ms.last().copied().unwrap_or(0.0),
            size: (fw, fh),
            depth: tree.depth(),
            leaves: tree.leaf_count(),
            settings: self.settings,
            variant: r.renderer.variant().describe(),
        };
        let capture = draw_frame(r, texture, &overlay, last && self.opts.screenshot.is_some())?;
        self.end_frame(el, last, capture)
    }

    /// Counts the frame just shown; after the last one (`quit_after`), saves it where asked
    /// and closes, else asks for the next.
    fn end_frame(
        &mut self,
        el: &ActiveEventLoop,
        last: bool,
        capture: Option<Capture>,
    ) -> Result<(), WindowError> {
        let now = Instant::now();
        match self.last_frame {
            None => self.startup_ms = Some(now.duration_since(self.start).as_secs_f64() * 1e3),
            Some(t) => self
                .frame_ms
                .push(now.duration_since(t).as_secs_f64() * 1e3),
        }
        self.last_frame = Some(now);
        let Some(r) = &self.running else {
            return Ok(());
        };
        if !last {
            r.window.request_redraw();
            return Ok(());
        }
        // Wait for the frame, then save it: the window as shown (frame and overlay) where
        // the surface can be copied, else the frame.
        r.ctx.wait()?;
        match (capture, &self.opts.screenshot) {
            (Some(c), Some(path)) => {
                let rgb = read_capture(&r.ctx, &c)?;
                svo::render::write_png(path, c.width, c.height, &rgb).map_err(JobError::from)?;
                self.screenshots.push(path.clone());
            }
            (None, Some(_)) => self.screenshot()?,
            _ => {}
        }
        el.exit();
        Ok(())
    }
}

/// The surface's next texture to draw into; `None` when there is none now (the surface
/// reconfigured, or the window hidden: winit says when it shows again).
fn next_texture(r: &mut Running) -> Option<wgpu::SurfaceTexture> {
    match r.surface.get_current_texture() {
        wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
            Some(t)
        }
        wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
            r.surface.configure(&r.ctx.device, &r.config);
            r.window.request_redraw();
            None
        }
        // Hidden or minimized: no frames until winit says the window shows again
        // (WindowEvent::Occluded(false)), rather than asking again at once.
        wgpu::CurrentSurfaceTexture::Occluded => None,
        _ => {
            r.window.request_redraw();
            None
        }
    }
}

/// What the overlay shows.
struct Overlay {
    adapter: String,
    /// The last frame's milliseconds (0 before the second frame).
    ms: f64,
    /// The frame size.
    size: (u32, u32),
    depth: u8,
    leaves: u64,
    settings: Settings,
    /// The shader variant's paths.
    variant: String,
}

impl Overlay {
    /// The overlay's window, unless it is turned off.
    fn show(&self, ctx: &egui::Context) {
        if !self.settings.overlay {
            return;
        }
        let (ms, (fw, fh), trace) = (self.ms, self.size, self.settings.trace);
        let mrays = if ms > 0.0 {
            f64::from(fw) * f64::from(fh) / (ms * 1e3)
        } else {
            0.0
        };
        egui::Window::new("svo-view")
            .default_pos(egui::pos2(8.0, 8.0))
            .resizable(false)
            .show(ctx, |ui| {
                ui.label(self.adapter.as_str());
                ui.label(format!(
                    "{:.1} fps, {ms:.2} ms/frame, {mrays:.1} Mrays/s primary",
                    if ms > 0.0 { 1e3 / ms } else { 0.0 }
                ));
                ui.label(format!(
                    "{fw}x{fh} (1/{}), depth {}, {} leaves",
                    self.settings.render_scale, self.depth, self.leaves
                ));
                let path = if trace.max_path_bounces == u8::MAX {
                    String::new()
                } else {
                    format!(" (at most {} a path)", trace.max_path_bounces)
                };
                ui.label(format!(
                    "hit {} [1/2], bounces {}{path} [ [ ] ], lights {} [L], shadows {} [G]",
                    trace.mode.name(),
                    trace.max_reflections,
                    if self.settings.lights_on { "on" } else { "off" },
                    trace.shadows.name()
                ));
                ui.label(format!("shader: {}", self.variant));
                ui.label("drag: turn, right drag: pan, wheel: zoom, Tab: orbit/fly");
                ui.label("P: screenshot, R: reset, -/=: render scale, F1: overlay");
            });
    }
}

/// Traces the frame, draws it and the overlay into `texture` and presents it; with
/// `capture`, also copies the surface for a screenshot.
fn draw_frame(
    r: &mut Running,
    texture: wgpu::SurfaceTexture,
    overlay: &Overlay,
    capture: bool,
) -> Result<Option<Capture>, WindowError> {
    let view = texture
        .texture
        .create_view(&wgpu::TextureViewDescriptor::default());
    let input = r.egui_state.take_egui_input(&r.window);
    let out = r.egui_ctx.run_pass(input, |ctx| overlay.show(ctx));
    r.egui_state
        .handle_platform_output(&r.window, out.platform_output);
    let prims = r.egui_ctx.tessellate(out.shapes, out.pixels_per_point);
    let sd = egui_wgpu::ScreenDescriptor {
        size_in_pixels: [r.config.width, r.config.height],
        pixels_per_point: out.pixels_per_point,
    };
    // Take the texture changes out (epaint checks that none is dropped unapplied).
    let mut textures = out.textures_delta;
    let (set, free) = (
        std::mem::take(&mut textures.set),
        std::mem::take(&mut textures.free),
    );
    for (id, deltas) in &set {
        for delta in deltas {
            r.egui_renderer
                .update_texture(&r.ctx.device, &r.ctx.queue, *id, delta);
        }
    }
    let mut enc = r
        .ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("window frame"),
        });
    r.renderer.encode(&mut enc);
    let extra = r
        .egui_renderer
        .update_buffers(&r.ctx.device, &r.ctx.queue, &mut enc, &prims, &sd);
    {
        let mut pass = enc
            .begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("blit and overlay"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            })
            .forget_lifetime();
        r.blit.draw(&mut pass);
        r.egui_renderer.render(&mut pass, &prims, &sd);
    }
    let capture = if capture {
        capture_copy(r, &texture.texture, &mut enc)
    } else {
        None
    };
    r.ctx
        .queue
        .submit(extra.into_iter().chain(std::iter::once(enc.finish())));
    r.ctx.queue.present(texture);
    for id in &free {
        r.egui_renderer.free_texture(id);
    }
    r.ctx.check()?;
    Ok(capture)
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.start_gpu(el) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => self.fail(el, e),
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let consumed = match self.running.as_mut() {
            Some(r) => r.egui_state.on_window_event(&r.window, &event).consumed,
            None => false,
        };
        let res = match event {
            WindowEvent::CloseRequested => {
                el.exit();
                Ok(())
            }
            WindowEvent::Resized(size) => {
                if let Some(r) = self.running.as_mut() {
                    r.config.width = size.width.max(1);
                    r.config.height = size.height.max(1);
                    r.surface.configure(&r.ctx.device, &r.config);
                    r.window.request_redraw();
                }
                self.apply()
            }
            WindowEvent::RedrawRequested => self.redraw(el),
            WindowEvent::Occluded(false) => {
                if let Some(r) = &self.running {
                    r.window.request_redraw();
                }
                Ok(())
            }
            WindowEvent::ModifiersChanged(m) => {
                self.held.shift = m.state().shift_key();
                Ok(())
            }
            WindowEvent::KeyboardInput { event, .. } if !consumed => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    match event.state {
                        ElementState::Pressed => {
                            if !self.held.keys.contains(&code) {
                                self.held.keys.push(code);
                            }
                            if event.repeat {
                                Ok(())
                            } else {
                                self.key(el, code)
                            }
                        }
                        ElementState::Released => {
                            self.held.keys.retain(|k| *k != code);
                            Ok(())
                        }
                    }
                } else {
                    Ok(())
                }
            }
            WindowEvent::MouseInput { state, button, .. } if !consumed => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => self.held.turn = down,
                    MouseButton::Right | MouseButton::Middle => self.held.pan = down,
                    _ => {}
                }
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let Some(last) = self.held.cursor
                    && !consumed
                {
                    let (dx, dy) = (p.0 - last.0, p.1 - last.1);
                    if self.held.turn {
                        self.control.turn(dx, dy);
                    } else if self.held.pan {
                        let h = self.running.as_ref().map_or(1, |r| r.config.height);
                        self.control.pan(dx, dy, h);
                    }
                }
                self.held.cursor = Some(p);
                Ok(())
            }
            WindowEvent::MouseWheel { delta, .. } if !consumed => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.control.zoom(steps);
                Ok(())
            }
            _ => Ok(()),
        };
        if let Err(e) = res {
            self.fail(el, e);
        }
    }
}

/// A surface texture copied into a buffer for a window capture.
struct Capture {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
    bytes_per_row: u32,
    /// Blue first (BGRA formats).
    bgra: bool,
}

/// Records a copy of the surface texture `tex` (8-bit RGBA or BGRA formats only) into a new
/// buffer.
fn capture_copy(
    r: &Running,
    tex: &wgpu::Texture,
    enc: &mut wgpu::CommandEncoder,
) -> Option<Capture> {
    use wgpu::TextureFormat as F;
    if !r.config.usage.contains(wgpu::TextureUsages::COPY_SRC) {
        return None;
    }
    let bgra = match r.config.format {
        F::Bgra8Unorm | F::Bgra8UnormSrgb => true,
        F::Rgba8Unorm | F::Rgba8UnormSrgb => false,
        _ => return None,
    };
    let (width, height) = (r.config.width, r.config.height);
    let bytes_per_row = (width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = r.ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("window capture"),
        size: u64::from(bytes_per_row) * u64::from(height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: tex,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(bytes_per_row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    Some(Capture {
        buffer,
        width,
        height,
        bytes_per_row,
        bgra,
    })
}

/// The captured window as RGB bytes.
fn read_capture(ctx: &GpuContext, c: &Capture) -> Result<Vec<u8>, GpuError> {
    let bytes: Vec<u8> = read_buffer(ctx, &c.buffer)?;
    let mut rgb = Vec::with_capacity((c.width * c.height * 3) as usize);
    for row in bytes
        .chunks(c.bytes_per_row as usize)
        .take(c.height as usize)
    {
        for px in row[..(c.width * 4) as usize].chunks_exact(4) {
            if c.bgra {
                rgb.extend_from_slice(&[px[2], px[1], px[0]]);
            } else {
                rgb.extend_from_slice(&px[..3]);
            }
        }
    }
    Ok(rgb)
}

/// Points the blit at the renderer's pixel buffer with the frame and window sizes: after
/// the buffer or either size changes, not every frame.
fn show_frame(
    ctx: &GpuContext,
    renderer: &GpuRenderer,
    blit: &mut Blit,
    config: &wgpu::SurfaceConfiguration,
) {
    let (fw, fh) = renderer.size();
    blit.set_source(
        ctx,
        renderer.pixels(),
        BlitParams {
            frame: [fw, fh],
            dest: [config.width, config.height],
        },
    );
}
