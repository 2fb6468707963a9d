//! The structs the CPU shares with the tracer's shader (its module `bindings.wesl`), defined
//! once here (`#[repr(C)]`, `bytemuck::Pod`), and the shader variant: the
//! pipeline-overridable constants that leave out what a scene does not need.
//!
//! `tests/it/gpu_layout.rs` parses the linked WGSL with naga and checks every struct's size and
//! member offsets against these (and [`svo::octree::Node`] against the shader's `Node`).

use crate::gpu_tree::GpuTree;
use bytemuck::{Pod, Zeroable};
use svo::octree::{Channel, LeafAttributes};
use svo::render::{
    Camera, CameraError, FresnelMode, MAX_BOUNCES, OctreeSurfaces, Phong, PointLight, ShadowMode,
    Sky, Surfaces, TraceOptions,
};
use svo::trace::HitMode;

/// The most point lights the shader takes (they live in the uniform buffer).
pub const MAX_LIGHTS: usize = 16;

/// The scene and camera constants of a frame (WGSL `Params`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuParams {
    /// The eye in grid space.
    pub eye: [f32; 3],
    /// Grid units per scene unit.
    pub scale: f32,
    /// Camera basis: forward (`CameraRays::f32_basis`).
    pub forward: [f32; 3],
    /// Offset of secondary and shadow rays, cells.
    pub bias: f32,
    /// Camera basis: right.
    pub right: [f32; 3],
    /// `2 / width`.
    pub px_scale_x: f32,
    /// Camera basis: up.
    pub up: [f32; 3],
    /// `2 / height`.
    pub px_scale_y: f32,
    /// Sky colour at the zenith.
    pub sky_zenith: [f32; 3],
    /// Half the image plane's width at distance 1.
    pub half_w: f32,
    /// Sky colour at the horizon.
    pub sky_horizon: [f32; 3],
    /// Half the image plane's height at distance 1.
    pub half_h: f32,
    /// Sky colour straight down.
    pub sky_ground: [f32; 3],
    /// Phong ambient factor.
    pub ambient: f32,
    /// The sky's up direction.
    pub sky_up: [f32; 3],
    /// Phong diffuse factor.
    pub diffuse: f32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tree depth.
    pub depth: u32,
    /// Traversal step cap per ray.
    pub max_steps: u32,
    /// Lights in use.
    pub n_lights: u32,
    /// Reflection depth limit.
    pub max_reflections: u32,
    /// Refraction depth limit.
    pub max_refractions: u32,
    /// Nodes in the node buffer.
    pub n_nodes: u32,
    /// Constant channel values (used where the channel is constant).
    pub const_normal: u32,
    /// Constant contour word.
    pub const_contour: u32,
    /// Constant colour word.
    pub const_colour: u32,
    /// Constant reflectivity byte.
    pub const_reflectivity: u32,
    /// Constant refractivity byte.
    pub const_refractivity: u32,
    /// Constant IOR word.
    pub const_ior: u32,
    /// Phong specular factor.
    pub specular: f32,
    /// Phong exponent.
    pub shininess: f32,
    /// `+inf` (WGSL constant expressions may not overflow).
    pub infinity: f32,
    /// The shadow mode (0 none, 1 opaque, 2 max, 3 product) when the shader reads it at run
    /// time ([`ShaderVariant::everything`]).
    pub shadow_mode: u32,
    /// Word offset of the node array in the arena (set by the renderer).
    pub nodes_at: u32,
    /// Word offset of the normal channel.
    pub normal_at: u32,
    /// Word offset of the contour channel.
    pub contour_at: u32,
    /// Word offset of the colour channel.
    pub colour_at: u32,
    /// Word offset of the reflectivity channel.
    pub reflectivity_at: u32,
    /// Word offset of the refractivity channel.
    pub refractivity_at: u32,
    /// Word offset of the IOR channel.
    pub ior_at: u32,
    /// log2 of the words per arena chunk.
    pub arena_shift: u32,
    /// The most reflections and refractions together along one path.
    pub max_path_bounces: u32,
    /// Word offset of the 64-ary view (where the traversal walks it).
    pub view_at: u32,
    /// Word offset of the inner nodes' normal channel (where the variant has a level of
    /// detail and reads it per node).
    pub node_normal_at: u32,
    /// Word offset of the inner nodes' contour channel.
    pub node_contour_at: u32,
    /// Word offset of the inner nodes' colour channel.
    pub node_colour_at: u32,
    /// Word offset of the inner nodes' reflectivity channel.
    pub node_reflectivity_at: u32,
    /// Word offset of the inner nodes' refractivity channel.
    pub node_refractivity_at: u32,
    /// Word offset of the inner nodes' IOR channel.
    pub node_ior_at: u32,
    /// The primary rays' cone spread (`Camera::pixel_cone`) under the level of detail.
    pub lod_spread: f32,
    /// Word offset of a graph's child references ([`svo::dag::FlatDag::refs`]; its node
    /// records are at `nodes_at`).
    pub dag_refs_at: u32,
    /// Word offset of a graph's bricks.
    pub dag_bricks_at: u32,
    /// Word offset of a graph's leaf parents' box codes.
    pub dag_boxes_at: u32,
    /// Which nodes a graph's leaf indices count ([`svo::dag::FlatDag::values`]).
    pub dag_values: u32,
    /// Padding.
    pub pad: u32,
}

/// A point light in grid space (WGSL `Light`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// Position, grid space.
    pub position: [f32; 3],
    /// Intensity (irradiance scale at one scene unit).
    pub intensity: f32,
    /// Linear RGB colour.
    pub colour: [f32; 3],
    /// Padding.
    pub pad: f32,
}

/// The uniform buffer (WGSL `Uniforms`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuUniforms {
    /// Scene and camera constants.
    pub params: GpuParams,
    /// Lights; the first `params.n_lights` are used.
    pub lights: [GpuLight; MAX_LIGHTS],
    /// `srgb_to_linear` of the bytes 0..=255, four a row (the CPU's table, so colours match
    /// bit for bit).
    pub srgb: [[f32; 4]; 64],
}

/// One pixel of output (WGSL `Pixel`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPixel {
    /// Linear RGB.
    pub colour: [f32; 3],
    /// Primary hit distance, scene units; `+inf` on a miss.
    pub depth: f32,
    /// Primary shading normal; zero on a miss.
    pub normal: [f32; 3],
    /// Primary hit leaf; `u32::MAX` on a miss.
    pub leaf: u32,
    /// Traversal steps of the primary ray.
    pub primary_steps: u32,
    /// Traversal steps of all rays.
    pub steps: u32,
    /// Primary and secondary rays (low 16 bits) and shadow rays (high 16 bits).
    pub rays: u32,
    /// Rays stopped by the step cap.
    pub capped: u32,
}

/// A ray of a batch, in grid space (WGSL `RayIn`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRay {
    /// Origin.
    pub origin: [f32; 3],
    /// Start of the parameter range.
    pub tmin: f32,
    /// Direction.
    pub dir: [f32; 3],
    /// End of the parameter range.
    pub tmax: f32,
}

/// The first hit of a batch ray (WGSL `RayOut`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRayHit {
    /// Hit parameter; `+inf` on a miss.
    pub t: f32,
    /// Leaf; `u32::MAX` on a miss.
    pub leaf: u32,
    /// Traversal steps.
    pub steps: u32,
    /// 1 if the step cap stopped the ray.
    pub capped: u32,
}

/// How a channel reaches the shader: 0 absent, 1 constant, 2 per leaf.
fn channel_kind<T>(c: &Channel<T>) -> u32 {
    match c {
        Channel::Absent => 0,
        Channel::Constant(_) => 1,
        Channel::PerLeaf(_) => 2,
    }
}

fn channel_const<T: Copy + Into<u32>>(c: &Channel<T>) -> u32 {
    match c {
        Channel::Constant(v) => (*v).into(),
        _ => 0,
    }
}

/// How an inner-node channel reaches the shader, beside the leaves' channel `leaf`: 0
/// absent, 1 the leaves' constant (read from `Params`), 2 per node (a constant of its own is
/// uploaded as a per-node array).
fn node_channel_kind<T: PartialEq>(leaf: &Channel<T>, node: &Channel<T>) -> u32 {
    match (leaf, node) {
        (_, Channel::Absent) => 0,
        (Channel::Constant(a), Channel::Constant(b)) if a == b => 1,
        _ => 2,
    }
}

/// Whether some leaf has a non-zero value in channel `c`.
fn any_nonzero(c: &Channel<u8>) -> bool {
    match c {
        Channel::Absent => false,
        Channel::Constant(v) => *v > 0,
        Channel::PerLeaf(v) => v.iter().any(|&x| x > 0),
    }
}

/// The shader's number for a shadow mode.
fn shadow_code(m: ShadowMode) -> u32 {
    match m {
        ShadowMode::None => 0,
        ShadowMode::Opaque => 1,
        ShadowMode::MaxRefractivity => 2,
        _ => 3,
    }
}

/// The shader variant a scene and its settings need: the values of the WGSL
/// pipeline-overridable constants. Paths nothing in the scene can take are switched off,
/// so the compiled shader does not carry them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShaderVariant {
    /// 0 cube, 1 contour (exact is not available on the GPU).
    pub hit_mode: u32,
    /// The reflection and refraction block (some leaf reflects or refracts, and the
    /// limits allow a bounce).
    pub reflections: bool,
    /// The refraction and Fresnel path (some leaf refracts).
    pub refractions: bool,
    /// 0 none, 1 opaque, 2 max refractivity, 3 product (none when there are no lights);
    /// 4: every mode compiled in, the one used read at run time.
    pub shadows: u32,
    /// Schlick's Fresnel instead of the exact one.
    pub fresnel_schlick: bool,
    /// Volumetric media (transparent leaves without normals).
    pub media: bool,
    /// Interior leaves of a solid bake (normal word `NO_NORMAL`), which rays pass through.
    pub interior: bool,
    /// Per channel: 0 absent, 1 constant, 2 per leaf.
    pub channels: [u32; 6],
    /// Pending rays a pixel can have: the bounce limits (the smaller of their sum and the
    /// path limit) plus two; one without bounces.
    pub ray_stack: u32,
    /// A level of detail: rays stop at inner nodes as wide as their cones
    /// ([`TraceOptions::lod`] above 0, on a tree whose inner nodes carry attributes).
    pub lod: bool,
    /// Per channel of the inner nodes (with [`Self::lod`]): 0 absent, 1 the leaves' constant,
    /// 2 per node.
    pub node_channels: [u32; 6],
}

impl ShaderVariant {
    /// The variant for `tree` rendered with `opts` and `n_lights` lights.
    pub fn for_scene<'a>(
        tree: impl Into<GpuTree<'a>>,
        opts: &TraceOptions,
        n_lights: usize,
    ) -> Self {
        let tree = tree.into();
        let a = tree.attributes();
        // A graph keeps no inner-node values: it has no level of detail.
        let lod = opts.lod > 0.0
            && tree
                .tree()
                .is_some_and(|t| OctreeSurfaces::new(t, opts.mode).level_of_detail());
        let none = LeafAttributes::default();
        let na = tree.node_attributes().unwrap_or(&none);
        let reflective = any_nonzero(&a.reflectivity);
        let refractive = any_nonzero(&a.refractivity);
        let bounces = opts.max_path_bounces > 0
            && ((opts.max_reflections > 0 && (reflective || refractive))
                || (opts.max_refractions > 0 && refractive));
        Self {
            hit_mode: u32::from(opts.mode == HitMode::Contour),
            reflections: bounces,
            refractions: bounces && refractive,
            shadows: if n_lights == 0 {
                0
            } else {
                shadow_code(opts.shadows)
            },
            fresnel_schlick: opts.fresnel == FresnelMode::Schlick,
            media: matches!(a.normal, Channel::Absent) && refractive,
            interior: a.has_interior(),
            ray_stack: if bounces {
                (u32::from(opts.max_reflections.min(MAX_BOUNCES))
                    + u32::from(opts.max_refractions.min(MAX_BOUNCES)))
                .min(u32::from(opts.max_path_bounces))
                    + 2
            } else {
                1
            },
            channels: [
                channel_kind(&a.normal),
                channel_kind(&a.contour),
                channel_kind(&a.colour),
                channel_kind(&a.reflectivity),
                channel_kind(&a.refractivity),
                channel_kind(&a.ior),
            ],
            lod,
            node_channels: if lod {
                [
                    node_channel_kind(&a.normal, &na.normal),
                    node_channel_kind(&a.contour, &na.contour),
                    node_channel_kind(&a.colour, &na.colour),
                    node_channel_kind(&a.reflectivity, &na.reflectivity),
                    node_channel_kind(&a.refractivity, &na.refractivity),
                    node_channel_kind(&a.ior, &na.ior),
                ]
            } else {
                [0; 6]
            },
        }
    }

    /// `self` with nothing left out: every shading path compiled in (the shadow mode read
    /// at run time, the hit mode kept) and every present channel read per leaf (the
    /// renderer then uploads constant channels as per-leaf arrays). The image is the same;
    /// the difference in time is what leaving things out saves.
    pub fn everything(self) -> Self {
        Self {
            reflections: true,
            refractions: true,
            shadows: 4,
            ray_stack: crate::shader::MAX_RAY_STACK,
            media: true,
            interior: true,
            channels: self.channels.map(|c| if c == 0 { 0 } else { 2 }),
            node_channels: self.node_channels.map(|c| if c == 0 { 0 } else { 2 }),
            ..self
        }
    }

    /// The pipeline constants, by WGSL name.
    pub fn constants(&self) -> Vec<(&'static str, f64)> {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        let names = [
            "NORMAL_CH",
            "CONTOUR_CH",
            "COLOUR_CH",
            "REFLECTIVITY_CH",
            "REFRACTIVITY_CH",
            "IOR_CH",
        ];
        let mut c = vec![
            ("HIT_MODE", f64::from(self.hit_mode)),
            ("REFLECTIONS", b(self.reflections)),
            ("REFRACTIONS", b(self.refractions)),
            ("SHADOWS", f64::from(self.shadows)),
            ("FRESNEL_SCHLICK", b(self.fresnel_schlick)),
            ("MEDIA", b(self.media)),
            ("INTERIOR", b(self.interior)),
        ];
        c.extend(
            names
                .iter()
                .zip(self.channels)
                .map(|(n, v)| (*n, f64::from(v))),
        );
        c.push(("LOD", b(self.lod)));
        let node_names = [
            "NODE_NORMAL_CH",
            "NODE_CONTOUR_CH",
            "NODE_COLOUR_CH",
            "NODE_REFLECTIVITY_CH",
            "NODE_REFRACTIVITY_CH",
            "NODE_IOR_CH",
        ];
        c.extend(
            node_names
                .iter()
                .zip(self.node_channels)
                .map(|(n, v)| (*n, f64::from(v))),
        );
        c
    }

    /// A short description for reports: the paths compiled in.
    pub fn describe(&self) -> String {
        let mut parts = vec![if self.hit_mode == 1 {
            "contour"
        } else {
            "cube"
        }];
        if self.reflections {
            parts.push("reflection");
        }
        if self.refractions {
            parts.push("refraction");
        }
        parts.push(match self.shadows {
            0 => "no shadows",
            1 => "opaque shadows",
            2 => "max shadows",
            3 => "product shadows",
            _ => "all shadow modes",
        });
        if self.media {
            parts.push("media");
        }
        if self.interior {
            parts.push("interior");
        }
        if self.lod {
            parts.push("level of detail");
        }
        parts.join(", ")
    }
}

/// The uniforms that depend on the tree and settings alone (no camera, lights or sky):
/// enough for the ray-batch entry point.
pub fn tree_uniforms<'a>(tree: impl Into<GpuTree<'a>>, opts: &TraceOptions) -> GpuUniforms {
    let tree = tree.into();
    let depth = tree.depth();
    let a = tree.attributes();
    let params = GpuParams {
        scale: ((1u64 << depth) as f64 / tree.root().side) as f32,
        bias: opts.bias_cells,
        depth: u32::from(depth),
        // Below u32::MAX, so that the shader's step counter always passes it (its loops run
        // without wgpu's loop bounds: gpu_render.rs).
        max_steps: opts.max_steps.min(u32::MAX - 1),
        max_reflections: u32::from(opts.max_reflections),
        max_refractions: u32::from(opts.max_refractions),
        max_path_bounces: u32::from(opts.max_path_bounces),
        // A graph's walk has no node count to check (its references were checked on reading).
        n_nodes: tree.tree().map_or(0, |t| t.nodes.len() as u32),
        const_normal: channel_const(&a.normal),
        const_contour: channel_const(&a.contour),
        const_colour: channel_const(&a.colour),
        const_reflectivity: channel_const(&a.reflectivity),
        const_refractivity: channel_const(&a.refractivity),
        const_ior: channel_const(&a.ior),
        infinity: f32::INFINITY,
        ..GpuParams::default()
    };
    let mut srgb = [[0.0f32; 4]; 64];
    for (i, v) in srgb.iter_mut().flatten().enumerate() {
        *v = svo::mesh::srgb_to_linear(i as u8);
    }
    GpuUniforms {
        params,
        lights: [GpuLight::default(); MAX_LIGHTS],
        srgb,
    }
}

/// The uniforms of a frame: `tree` seen through `camera`, with the lights (at most
/// [`MAX_LIGHTS`]), sky and Phong factors; an error for invalid camera settings.
pub fn uniforms<'a>(
    tree: impl Into<GpuTree<'a>>,
    camera: &Camera,
    lights: &[PointLight],
    sky: &Sky,
    phong: &Phong,
    opts: &TraceOptions,
) -> Result<GpuUniforms, CameraError> {
    let tree = tree.into();
    let rays = camera.rays()?;
    let mut u = tree_uniforms(tree, opts);
    let (basis, px_scale, half) = rays.f32_basis();
    let p = &mut u.params;
    // The eye in grid space, as the CPU renderer converts it.
    p.eye = tree
        .root()
        .to_grid(camera.eye, tree.depth())
        .as_vec3()
        .to_array();
    p.forward = basis[0].to_array();
    p.right = basis[1].to_array();
    p.up = basis[2].to_array();
    p.px_scale_x = px_scale.x;
    p.px_scale_y = px_scale.y;
    p.half_w = half.x;
    p.half_h = half.y;
    p.sky_zenith = sky.zenith.to_array();
    p.sky_horizon = sky.horizon.to_array();
    p.sky_ground = sky.ground.to_array();
    p.sky_up = sky.up.to_array();
    p.ambient = phong.ambient;
    p.diffuse = phong.diffuse;
    p.specular = phong.specular;
    p.shininess = phong.shininess;
    p.width = camera.width;
    p.height = camera.height;
    p.lod_spread = camera.pixel_cone(opts.lod).spread;
    p.n_lights = lights.len().min(MAX_LIGHTS) as u32;
    p.shadow_mode = if lights.is_empty() {
        0
    } else {
        shadow_code(opts.shadows)
    };
    for (g, l) in u.lights.iter_mut().zip(lights) {
        *g = GpuLight {
            position: tree
                .root()
                .to_grid(l.position, tree.depth())
                .as_vec3()
                .to_array(),
            intensity: l.intensity,
            colour: l.colour.to_array(),
            pad: 0.0,
        };
    }
    Ok(u)
}
