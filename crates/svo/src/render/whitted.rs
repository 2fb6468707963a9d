//! Whitted ray tracing over the octree with an explicit ray stack (no recursion: the shape
//! the WGSL port needs, as in the 2019 report's iteration array).
//!
//! Each ray on the stack carries its *weight* (the product of the reflection and
//! transmission factors that led to it), so a hit adds `weight * local` to the pixel at
//! once and pushes its reflected and refracted rays with their weights: the same sum as the
//! report's backward pass over its iteration tree, without storing the tree.
//!
//! ## Material model (per leaf: colour, reflectivity `kr`, refractivity `kt`, IOR)
//! - Local (Phong) light weighs `1 - kr - kt`: ambient plus, for each point light that a
//!   shadow ray reaches, diffuse and specular with inverse-square falloff.
//! - Where `kt > 0` the boundary is a dielectric: Fresnel's reflectance `F` (exact or
//!   Schlick) moves `kt * F` to the reflection, which weighs `kr + kt F`, and the refraction
//!   (Snell) weighs `kt (1 - F)`, tinted by the leaf colour. Total internal reflection sends
//!   it all to the reflection.
//! - The medium: a ray arriving against the leaf normal enters, one arriving along it leaves.
//!   Each ray carries the IORs of the media it is in, two deep (the one it travels in, and
//!   the one around that; air outside): entering goes from the current medium's IOR to the
//!   leaf's (`1 -> IOR` from air), leaving from the leaf's IOR to the surrounding medium's
//!   (`IOR -> 1` into air). So glass in water refracts at `1.33 -> 1.5`. A third level of
//!   nesting forgets the outermost medium (it is taken as air on the way out). Transparent leaves without a normal
//!   (solid blocks from the builder) form volumetric media ([`crate::render::surfaces::Medium`]): a
//!   ray refracted into one passes through its cells and meets the boundary where it leaves
//!   them, as the 2019 report's "hit where the material changes" rule.
//! - An opaque surface whose shading normal faces away from the viewer (a voxel normal at a
//!   silhouette) is shaded with the normal turned until it just faces the viewer.
//! - Separate limits for reflection and refraction depths.
//!
//! ## Shadows
//! [`ShadowMode`]: none, opaque (any leaf blocks), the 2019 report's compromise (the light
//! passes with the *largest* refractivity met, and not at all if an opaque leaf is met), or a
//! transmittance product (each surface crossing multiplies by its refractivity; leaves
//! closer than half a cell to the previous one belong to the same crossing).
//!
//! ## Self-intersection
//! A secondary or shadow ray ignores the leaf it starts from and starts `bias` cells off
//! the surface (along the facing normal, or against it for refraction): the offset scales
//! with the cell size, as DESIGN.md asks.

use crate::geometry::grid::RootCube;
use crate::octree::encoding::{ior_decode, ior_encode};
use crate::render::camera::Camera;
use crate::render::shading::{Phong, PointLight, fresnel_exact, fresnel_schlick, reflect, refract};
use crate::render::sky::Sky;
use crate::render::surfaces::{Medium, Query, Skip, SurfaceHit, Surfaces, Traced, Walked};
use crate::trace::cone::Cone;
use crate::trace::grid_ray::GridRay;
use crate::trace::leaf_hit::HitMode;
use crate::trace::packet::LANES;
use crate::trace::traverse::MAX_STEPS;
use glam::Vec3;

/// The most reflection (and, separately, refraction) bounces a ray may take.
pub const MAX_BOUNCES: u8 = 16;

/// How shadow rays treat semi-transparent leaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum ShadowMode {
    /// No shadow rays.
    None,
    /// Every leaf blocks the light.
    Opaque,
    /// The 2019 report's rule: the largest refractivity met along the ray.
    MaxRefractivity,
    /// The product of the refractivities of the surfaces crossed.
    #[default]
    Transmittance,
}

impl ShadowMode {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Opaque => "opaque",
            Self::MaxRefractivity => "max",
            Self::Transmittance => "product",
        }
    }
}

impl std::str::FromStr for ShadowMode {
    type Err = String;

    /// Parses a command-line name: `none`, `opaque`, `max` or `product`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(Self::None),
            "opaque" => Ok(Self::Opaque),
            "max" => Ok(Self::MaxRefractivity),
            "product" => Ok(Self::Transmittance),
            _ => Err(format!(
                "unknown shadow mode {s:?} (expected none, opaque, max or product)"
            )),
        }
    }
}

/// Which Fresnel formula dielectric leaves use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum FresnelMode {
    /// The exact unpolarized dielectric reflectance.
    #[default]
    Exact,
    /// Schlick's approximation.
    Schlick,
}

impl std::str::FromStr for FresnelMode {
    type Err = String;

    /// Parses a command-line name: `exact` or `schlick`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "exact" => Ok(Self::Exact),
            "schlick" => Ok(Self::Schlick),
            _ => Err(format!(
                "unknown Fresnel formula {s:?} (expected exact or schlick)"
            )),
        }
    }
}

/// Settings of the tracer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceOptions {
    /// How leaves are hit (octree scenes).
    pub mode: HitMode,
    /// Reflection depth limit (at most [`MAX_BOUNCES`]).
    pub max_reflections: u8,
    /// Refraction depth limit (at most [`MAX_BOUNCES`]).
    pub max_refractions: u8,
    /// The most reflections and refractions together along one path (the depth of the ray
    /// tree). `1` is the 2015 thesis's tracer: a primary ray that hits a surface spawns its
    /// reflection and refraction rays, and those spawn none. `u8::MAX` (the default): only
    /// the two limits above apply.
    pub max_path_bounces: u8,
    /// Shadow rays.
    pub shadows: ShadowMode,
    /// Fresnel formula.
    pub fresnel: FresnelMode,
    /// Offset of secondary and shadow ray origins from the surface, in cells.
    pub bias_cells: f32,
    /// Traversal step cap per ray.
    pub max_steps: u32,
    /// Let renders decide primary rays a band of rows at a time by projecting the octree
    /// front to back (the primary prepass) instead of walking it once per pixel. The
    /// image is the same either way; only the work (and the steps counted) differ.
    pub prepass: bool,
    /// Walk rays of neighbouring pixels four at a time ([`crate::trace::traverse_packet`])
    /// where that applies: primary rays cast without the prepass, and the shadow rays of a
    /// render in which no ray bounces. The image, the hits and the steps are the same either
    /// way.
    pub packets: bool,
    /// Level of detail, in pixels: a ray may stop at an inner node (of a tree whose inner
    /// nodes carry attributes) no wider than `lod` times its pixel's cone there, and hit the
    /// node's contour with the node's attributes. `0` (the default) is the exact walk to the
    /// leaves. Reflection and refraction rays keep the cone's width at the hit and its
    /// spread; shadow rays keep that width toward the light; secondary and shadow rays from a
    /// node start the bias times the node's side off it. The prepass and the packets walk
    /// rays with a footprint as the single walk does: the image is the same with or without
    /// them.
    pub lod: f32,
}

impl Default for TraceOptions {
    fn default() -> Self {
        Self {
            mode: HitMode::Contour,
            max_reflections: 3,
            max_refractions: 3,
            max_path_bounces: u8::MAX,
            shadows: ShadowMode::Transmittance,
            fresnel: FresnelMode::Exact,
            bias_cells: 0.75,
            max_steps: MAX_STEPS,
            prepass: true,
            packets: true,
            lod: 0.0,
        }
    }
}

/// A scene ready to trace: its surfaces (the octree, or the triangle reference), lights in
/// grid space, sky and options.
#[derive(Clone, Debug)]
pub struct Tracer<S> {
    surfaces: S,
    /// The grid the rays live in.
    root: RootCube,
    depth: u8,
    /// Grid units per scene unit.
    scale: f32,
    lights: Vec<(Vec3, PointLight)>,
    sky: Sky,
    phong: Phong,
    opts: TraceOptions,
}

/// Counters of one traced sample (all rays it spawned).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleStats {
    /// Primary, reflection and refraction rays cast.
    pub rays: u32,
    /// Shadow rays cast.
    pub shadow_rays: u32,
    /// Traversal steps of all of them.
    pub steps: u32,
    /// Rays stopped by the step cap.
    pub capped: u32,
}

/// What the render's prepass knows of a primary ray ([`Tracer::trace_primary`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimaryStart {
    /// A lower bound of the first hit's parameter (scene units): the ray is traced from
    /// there.
    From(f32),
    /// The first hit, decided by the prepass: the traversal's entry of the leaf hit, the
    /// hit's parameter and the leaf tests and walk steps the prepass spent on this pixel.
    Leaf {
        /// The leaf as the traversal hands it to the leaf's hit test.
        entry: crate::trace::traverse::LeafEntry,
        /// The hit's parameter (scene units).
        t: f32,
        /// Leaf tests and walk steps made for this pixel.
        tests: u32,
    },
    /// The ray hits nothing, decided by the prepass after this many leaf tests.
    Miss {
        /// Leaf tests made for this pixel.
        tests: u32,
    },
}

impl PrimaryStart {
    /// Nothing known but a lower bound of the first hit.
    pub fn from(tmin: f32) -> Self {
        Self::From(tmin)
    }

    /// Whether the prepass proved that the ray hits nothing.
    pub fn is_miss(&self) -> bool {
        matches!(self, Self::Miss { .. })
    }
}

/// What tracing one primary ray gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Linear RGB radiance.
    pub colour: Vec3,
    /// The primary hit.
    pub hit: Option<SurfaceHit>,
    /// The primary hit's shading normal.
    pub normal: Vec3,
    /// Traversal steps of the primary ray alone.
    pub primary_steps: u32,
    /// Counters over all rays.
    pub stats: SampleStats,
}

#[derive(Clone, Copy, Debug)]
struct Task {
    origin: Vec3,
    dir: Vec3,
    weight: Vec3,
    refl: u8,
    refr: u8,
    /// The leaf or triangle the ray starts on.
    skip: Option<Skip>,
    /// The volumetric medium the ray travels in, [`NO_MEDIUM`] for none.
    medium: u64,
    /// The IORs of the media the ray is in, as [`ior_encode`] codes: the current one in the
    /// low 16 bits, the one around it in the high 16 (0: air).
    iors: u32,
    /// The ray's footprint.
    cone: Cone,
}

const NO_MEDIUM: u64 = u64::MAX;

/// An all-zero task: the stack is initialized with it (one `memset`).
const EMPTY: Task = Task {
    origin: Vec3::ZERO,
    dir: Vec3::ZERO,
    weight: Vec3::ZERO,
    refl: 0,
    refr: 0,
    skip: None,
    medium: 0,
    iors: 0,
    cone: Cone::EXACT,
};

/// The normal that faces a ray in direction `dir` at a surface with shading normal `n_s`:
/// `n_s` where the ray enters, its opposite where it leaves a refractive surface.
#[inline]
fn facing(n_s: Vec3, dir: Vec3, refractivity: f32) -> Vec3 {
    if n_s.dot(dir) < 0.0 {
        n_s
    } else if refractivity > 0.0 {
        -n_s
    } else {
        // An opaque surface seen from behind its shading normal (a voxel normal at a
        // silhouette): turn the normal until it just faces the viewer, rather than shading
        // the far side.
        (n_s - dir * (n_s.dot(dir) + 1e-3)).normalize_or(-dir)
    }
}

/// The direction and grid distance from hit point `p` to light `lp`, unless the light is
/// behind the facing normal `n_f` (or at the point).
#[inline]
fn toward(p: Vec3, n_f: Vec3, lp: Vec3) -> Option<(Vec3, f32)> {
    let to = lp - p;
    let dist_grid = to.length();
    if !(dist_grid > 0.0) {
        return None;
    }
    let l = to / dist_grid;
    if n_f.dot(l) <= 0.0 {
        return None;
    }
    Some((l, dist_grid))
}

/// What the local light at a primary hit needs ([`Tracer::trace_primary4`]).
#[derive(Clone, Copy, Debug)]
struct Lit {
    albedo: Vec3,
    /// The hit point.
    p: Vec3,
    /// The normal facing the ray.
    n_f: Vec3,
    /// Toward the eye.
    v: Vec3,
    /// The local light's weight (`1 - reflectivity - refractivity`).
    local_w: f32,
    /// Where its shadow rays start, the leaf they skip and their footprint.
    from: Vec3,
    skip: Skip,
    cone: Cone,
}

/// A shadow ray's walk through the surfaces it meets, front to back, under a shadow mode.
#[derive(Clone, Copy, Debug)]
struct ShadowWalk {
    mode: ShadowMode,
    half_cell: f32,
    any: bool,
    max_kt: f32,
    trans: f32,
    last_exit: f32,
}

impl ShadowWalk {
    fn new(mode: ShadowMode, half_cell: f32) -> Self {
        Self {
            mode,
            half_cell,
            any: false,
            max_kt: 0.0,
            trans: 1.0,
            last_exit: f32::NEG_INFINITY,
        }
    }

    /// Takes the next surface; `true` when it blocks the light.
    #[inline]
    fn visit(&mut self, h: &SurfaceHit) -> bool {
        if self.mode == ShadowMode::Opaque {
            return true;
        }
        let kt = h.material.refractivity;
        if kt <= 0.0 {
            self.trans = 0.0;
            return true;
        }
        self.any = true;
        self.max_kt = self.max_kt.max(kt);
        if h.t > self.last_exit + self.half_cell {
            self.trans *= kt;
        }
        self.last_exit = h.t_exit;
        false
    }

    /// The light's fraction that gets through, once the walk is over.
    fn visibility(&self, blocked: bool) -> f32 {
        if blocked {
            return 0.0;
        }
        match self.mode {
            ShadowMode::MaxRefractivity if self.any => self.max_kt,
            ShadowMode::Transmittance => self.trans,
            _ => 1.0,
        }
    }
}

const STACK: usize = 2 * MAX_BOUNCES as usize + 2;
const SMALL_STACK: usize = 8;

impl<S: Surfaces> Tracer<S> {
    /// Prepares `surfaces` with `lights` (scene space) for tracing.
    pub fn new(
        surfaces: S,
        lights: &[PointLight],
        sky: Sky,
        phong: Phong,
        opts: TraceOptions,
    ) -> Self {
        let (root, depth) = surfaces.grid();
        let scale = ((1u64 << depth) as f64 / root.side) as f32;
        let lights = lights
            .iter()
            .map(|l| (root.to_grid(l.position, depth).as_vec3(), *l))
            .collect();
        let mut opts = opts;
        opts.max_reflections = opts.max_reflections.min(MAX_BOUNCES);
        opts.max_refractions = opts.max_refractions.min(MAX_BOUNCES);
        Self {
            surfaces,
            root,
            depth,
            scale,
            lights,
            sky,
            phong,
            opts,
        }
    }

    /// The options in use.
    pub fn options(&self) -> &TraceOptions {
        &self.opts
    }

    /// Grid units per scene unit.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The surfaces traced.
    pub fn surfaces(&self) -> &S {
        &self.surfaces
    }

    /// The scene point of grid point `g`.
    pub fn to_scene(&self, g: Vec3) -> glam::DVec3 {
        self.root.to_scene(g.as_dvec3(), self.depth)
    }

    /// The colour of a primary ray in unit direction `dir` that is known to hit nothing
    /// (what [`Self::trace`] returns for it, without casting it).
    pub fn miss_colour(&self, dir: Vec3) -> Vec3 {
        self.sky.colour(dir)
    }

    /// The grid point of scene point `p`.
    pub fn to_grid(&self, p: glam::DVec3) -> Vec3 {
        self.root.to_grid(p, self.depth).as_vec3()
    }

    /// Traces the ray from grid point `origin` in unit grid direction `dir`.
    pub fn trace(&self, origin: Vec3, dir: Vec3) -> Sample {
        self.trace_from(origin, dir, 0.0)
    }

    /// [`Self::trace`] with the primary ray starting at parameter `tmin` (a lower bound of
    /// its first hit, from the render's prepass; secondary rays are not affected).
    pub fn trace_from(&self, origin: Vec3, dir: Vec3, tmin: f32) -> Sample {
        self.trace_primary(origin, dir, PrimaryStart::from(tmin), Cone::EXACT)
    }

    /// The footprint of the primary rays of `camera`'s pixels under the level of detail
    /// [`TraceOptions::lod`] ([`Camera::pixel_cone`]); [`Cone::EXACT`] where the surfaces have
    /// no level of detail ([`Surfaces::level_of_detail`]).
    pub fn primary_cone(&self, camera: &Camera) -> Cone {
        if !self.surfaces.level_of_detail() {
            return Cone::EXACT;
        }
        camera.pixel_cone(self.opts.lod)
    }

    /// [`Self::trace`] with what the render's prepass knows of the primary ray (secondary
    /// rays are not affected).
    /// The most reflections and refractions along a path. A depth-first ray stack holds at
    /// most one pending ray per bounce plus two; a stack sized for the limits keeps its
    /// initialization small (without bounces it is the primary ray alone).
    fn bounces(&self) -> usize {
        (usize::from(self.opts.max_reflections) + usize::from(self.opts.max_refractions))
            .min(usize::from(self.opts.max_path_bounces))
    }

    pub(crate) fn trace_primary(
        &self,
        origin: Vec3,
        dir: Vec3,
        start: PrimaryStart,
        cone: Cone,
    ) -> Sample {
        let bounces = self.bounces();
        if bounces == 0 {
            self.trace_with::<1>(origin, dir, start, cone)
        } else if bounces + 2 <= SMALL_STACK {
            self.trace_with::<SMALL_STACK>(origin, dir, start, cone)
        } else {
            self.trace_with::<STACK>(origin, dir, start, cone)
        }
    }

    fn trace_with<const STACK: usize>(
        &self,
        origin: Vec3,
        dir: Vec3,
        start: PrimaryStart,
        cone: Cone,
    ) -> Sample {
        let mut sample = Sample {
            colour: Vec3::ZERO,
            hit: None,
            normal: Vec3::ZERO,
            primary_steps: 0,
            stats: SampleStats::default(),
        };
        let mut stack = [EMPTY; STACK];
        stack[0] = Task {
            origin,
            dir,
            weight: Vec3::ONE,
            refl: 0,
            refr: 0,
            skip: None,
            medium: NO_MEDIUM,
            iors: 0,
            cone,
        };
        let mut len = 1usize;
        let mut first = true;
        let bias = self.opts.bias_cells;
        while len > 0 {
            len -= 1;
            let task = stack[len];
            let ray = GridRay {
                origin: task.origin,
                dir: task.dir * self.scale,
            };
            let q = Query {
                // A decided hit is rebuilt with the traversal's own entry from 0.
                tmin: match start {
                    PrimaryStart::From(t) if first => t,
                    _ => 0.0,
                },
                tmax: f32::INFINITY,
                skip: task.skip,
                medium: (task.medium != NO_MEDIUM).then_some(Medium(task.medium)),
                max_steps: self.opts.max_steps,
                cone: task.cone,
            };
            let r = if first {
                self.surfaces.closest_primary(&ray, &q, &start)
            } else {
                self.surfaces.closest(&ray, &q)
            };
            sample.stats.rays += 1;
            sample.stats.steps += r.steps;
            sample.stats.capped += u32::from(r.capped);
            if first {
                sample.primary_steps = r.steps;
                sample.hit = r.hit;
            }
            let Some(h) = r.hit else {
                sample.colour += task.weight * self.sky.colour(task.dir);
                first = false;
                continue;
            };
            let m = h.material;
            let p = ray.at(h.t);
            let n_s = if h.normal == Vec3::ZERO {
                -task.dir
            } else {
                h.normal
            };
            if first {
                sample.normal = n_s;
                first = false;
            }
            let entering = n_s.dot(task.dir) < 0.0;
            let n_f = facing(n_s, task.dir, m.refractivity);
            let v = -task.dir;

            // Local light.
            let kr = m.reflectivity;
            let kt = m.refractivity;
            let local_w = (1.0 - kr - kt).max(0.0);
            if local_w > 0.0 {
                let mut local = m.albedo * self.phong.ambient;
                let from = p + n_f * (bias * h.side as f32);
                let shadow_cone = cone_from_hit(&task.cone, h.t * self.scale, 0.0);
                for (lp, light) in &self.lights {
                    let Some((l, dist_grid)) = toward(p, n_f, *lp) else {
                        continue;
                    };
                    let vis = self.shadow(from, *lp, Skip::of(&h), shadow_cone, &mut sample.stats);
                    if vis > 0.0 {
                        local += self.light_term(light, dist_grid, vis, m.albedo, n_f, l, v);
                    }
                }
                sample.colour += task.weight * local_w * local;
            }

            self.spawn(&task, &h, p, n_f, entering, &mut stack, &mut len);
        }
        sample
    }

    /// The reflection and refraction rays of `task`'s hit `h` at `p` (facing normal `n_f`),
    /// pushed onto `stack` while the path has bounces left.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn spawn<const STACK: usize>(
        &self,
        task: &Task,
        h: &SurfaceHit,
        p: Vec3,
        n_f: Vec3,
        entering: bool,
        stack: &mut [Task; STACK],
        len: &mut usize,
    ) {
        let m = h.material;
        let (kr, kt) = (m.reflectivity, m.refractivity);
        let v = -task.dir;
        let bias = self.opts.bias_cells * h.side as f32;
        let cone = cone_from_hit(&task.cone, h.t * self.scale, task.cone.spread);
        // Reflection and refraction, while the path has bounces left.
        let path_left =
            u16::from(task.refl) + u16::from(task.refr) < u16::from(self.opts.max_path_bounces);
        let limits_left =
            task.refl < self.opts.max_reflections || task.refr < self.opts.max_refractions;
        if !path_left || !limits_left || *len >= STACK {
            // Nothing could be pushed: skip the Fresnel terms and the refracted direction.
            return;
        }
        // From the medium the ray is in into the leaf's, or out of the leaf's into the
        // one around it.
        let (here, around) = (task.iors & 0xFFFF, task.iors >> 16);
        let (n1, n2, iors_after) = if entering {
            (
                ior_decode(here as u16),
                m.ior,
                u32::from(ior_encode(m.ior)) | here << 16,
            )
        } else {
            (m.ior, ior_decode(around as u16), around)
        };
        let cos_i = n_f.dot(v);
        let (mut fr, mut ft) = (kr, 0.0);
        let mut t_dir = None;
        if kt > 0.0 {
            let f = match self.opts.fresnel {
                FresnelMode::Exact => fresnel_exact(cos_i, n1, n2),
                FresnelMode::Schlick => fresnel_schlick(cos_i, n1, n2),
            };
            t_dir = refract(task.dir, n_f, n1, n2);
            if t_dir.is_some() {
                fr += kt * f;
                ft = kt * (1.0 - f);
            } else {
                fr += kt;
            }
        }
        if fr > 0.0 && task.refl < self.opts.max_reflections && *len < STACK {
            stack[*len] = Task {
                origin: p + n_f * bias,
                dir: reflect(task.dir, n_f).normalize(),
                weight: task.weight * fr,
                refl: task.refl + 1,
                refr: task.refr,
                skip: Some(Skip::of(h)),
                // A reflection stays on its side of the boundary.
                medium: task.medium,
                iors: task.iors,
                cone,
            };
            *len += 1;
        }
        if let Some(td) = t_dir
            && ft > 0.0
            && task.refr < self.opts.max_refractions
            && *len < STACK
        {
            stack[*len] = Task {
                origin: p - n_f * bias,
                dir: td,
                weight: task.weight * ft * m.albedo,
                refl: task.refl,
                refr: task.refr + 1,
                skip: Some(Skip::of(h)),
                // Entering a volumetric medium puts the ray inside it; leaving one
                // puts it outside.
                medium: match h.medium {
                    Some(m) if entering => m.0,
                    _ => NO_MEDIUM,
                },
                iors: iors_after,
                cone,
            };
            *len += 1;
        }
    }

    /// The contribution of `light`, seen from a hit in direction `l` at grid distance
    /// `dist_grid` through visibility `vis`, to the local light.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn light_term(
        &self,
        light: &PointLight,
        dist_grid: f32,
        vis: f32,
        albedo: Vec3,
        n_f: Vec3,
        l: Vec3,
        v: Vec3,
    ) -> Vec3 {
        light.falloff(dist_grid / self.scale) * vis * self.phong.direct(albedo, n_f, l, v)
    }

    /// The shadow ray from grid point `from` to grid point `light`, and where it stops
    /// (just short of the light).
    #[inline]
    fn shadow_ray(&self, from: Vec3, light: Vec3) -> (GridRay, f32) {
        let to = light - from;
        let l = to.normalize_or_zero();
        let dist = to.length() / self.scale;
        let ray = GridRay {
            origin: from,
            dir: l * self.scale,
        };
        (ray, dist * (1.0 - 1e-5))
    }

    /// The fraction of the light at grid point `light` that reaches grid point `from` (the
    /// shadow ray's vector is only made when shadows are on).
    fn shadow(
        &self,
        from: Vec3,
        light: Vec3,
        skip: Skip,
        cone: Cone,
        stats: &mut SampleStats,
    ) -> f32 {
        if self.opts.shadows == ShadowMode::None {
            return 1.0;
        }
        stats.shadow_rays += 1;
        let (ray, tmax) = self.shadow_ray(from, light);
        let mut w = ShadowWalk::new(self.opts.shadows, 0.5 / self.scale);
        let r = self.surfaces.walk(
            &ray,
            tmax,
            Some(skip),
            cone,
            self.opts.max_steps,
            &mut |h| w.visit(h),
        );
        stats.steps += r.steps;
        stats.capped += u32::from(r.capped);
        w.visibility(r.blocked)
    }

    /// Whether renders trace four neighbouring pixels at a time ([`Self::trace_primary4`]):
    /// where packets are on and a pixel can have rays after its primary one (shadow rays, or
    /// bounces). A frame of primary rays alone gains nothing from them and pays their
    /// bookkeeping (the framed bunny without shadows: 47 against 56 ms).
    pub(crate) fn packs(&self) -> bool {
        let shadows = self.opts.shadows != ShadowMode::None && !self.lights.is_empty();
        self.opts.packets && (self.bounces() > 0 || shadows)
    }

    /// [`Self::trace_primary`] for the first `n` of four primary rays from grid point
    /// `origin`: the four pixels' ray trees are traced in lockstep, each lane popping its
    /// next ray from its own stack, and the rays of a round (after the primary rays, which
    /// the prepass decides one by one) and their shadow rays toward each light walk as
    /// packets. Each lane takes its own rays in its own order and sums its light as the
    /// single path does, so the samples are the same bit for bit (colours, hits, normals and
    /// counters).
    pub(crate) fn trace_primary4(
        &self,
        origin: Vec3,
        dirs: &[Vec3; LANES],
        starts: &[PrimaryStart; LANES],
        n: usize,
        cone: Cone,
    ) -> [Sample; LANES] {
        let bounces = self.bounces();
        if bounces == 0 {
            self.trace4::<1>(origin, dirs, starts, n, cone)
        } else if bounces + 2 <= SMALL_STACK {
            self.trace4::<SMALL_STACK>(origin, dirs, starts, n, cone)
        } else {
            self.trace4::<STACK>(origin, dirs, starts, n, cone)
        }
    }

    fn trace4<const STACK: usize>(
        &self,
        origin: Vec3,
        dirs: &[Vec3; LANES],
        starts: &[PrimaryStart; LANES],
        n: usize,
        cone: Cone,
    ) -> [Sample; LANES] {
        let mut out = [Sample {
            colour: Vec3::ZERO,
            hit: None,
            normal: Vec3::ZERO,
            primary_steps: 0,
            stats: SampleStats::default(),
        }; LANES];
        let mut stacks = [[EMPTY; STACK]; LANES];
        let mut lens = [0usize; LANES];
        let mut first = [false; LANES];
        for l in 0..n.min(LANES) {
            stacks[l][0] = Task {
                origin,
                dir: dirs[l],
                weight: Vec3::ONE,
                refl: 0,
                refr: 0,
                skip: None,
                medium: NO_MEDIUM,
                iors: 0,
                cone,
            };
            lens[l] = 1;
            first[l] = true;
        }
        let bias = self.opts.bias_cells;
        let unused = GridRay {
            origin: Vec3::ZERO,
            dir: Vec3::X,
        };
        loop {
            // Each lane's next ray.
            let mut tasks = [EMPTY; LANES];
            let mut active = 0u8;
            for l in 0..LANES {
                if lens[l] > 0 {
                    lens[l] -= 1;
                    tasks[l] = stacks[l][lens[l]];
                    active |= 1 << l;
                }
            }
            if active == 0 {
                break;
            }
            let rays: [GridRay; LANES] = std::array::from_fn(|l| GridRay {
                origin: tasks[l].origin,
                dir: tasks[l].dir * self.scale,
            });
            let q: [Query; LANES] = std::array::from_fn(|l| Query {
                // A decided hit is rebuilt with the traversal's own entry from 0.
                tmin: match starts[l] {
                    PrimaryStart::From(t) if first[l] => t,
                    _ => 0.0,
                },
                tmax: f32::INFINITY,
                skip: tasks[l].skip,
                medium: (tasks[l].medium != NO_MEDIUM).then_some(Medium(tasks[l].medium)),
                max_steps: self.opts.max_steps,
                cone: tasks[l].cone,
            });
            // Primary rays one by one (the prepass decides most), the others together.
            let primary = (0..LANES)
                .filter(|&l| first[l] && active >> l & 1 != 0)
                .fold(0u8, |m, l| m | 1 << l);
            let mut traced = if active & !primary != 0 {
                self.surfaces.closest4(&rays, &q, active & !primary)
            } else {
                [Traced::NONE; LANES]
            };
            for l in 0..LANES {
                if primary >> l & 1 != 0 {
                    traced[l] = self.surfaces.closest_primary(&rays[l], &q[l], &starts[l]);
                }
            }
            // Each lane's hit, up to its local light.
            let mut lit: [Option<Lit>; LANES] = [None; LANES];
            let mut hits: [Option<(SurfaceHit, Vec3, Vec3, bool)>; LANES] = [None; LANES];
            for l in 0..LANES {
                if active >> l & 1 == 0 {
                    continue;
                }
                let (task, r, sample) = (&tasks[l], traced[l], &mut out[l]);
                sample.stats.rays += 1;
                sample.stats.steps += r.steps;
                sample.stats.capped += u32::from(r.capped);
                if first[l] {
                    sample.primary_steps = r.steps;
                    sample.hit = r.hit;
                }
                let Some(h) = r.hit else {
                    sample.colour += task.weight * self.sky.colour(task.dir);
                    first[l] = false;
                    continue;
                };
                let m = h.material;
                let p = rays[l].at(h.t);
                let n_s = if h.normal == Vec3::ZERO {
                    -task.dir
                } else {
                    h.normal
                };
                if first[l] {
                    sample.normal = n_s;
                    first[l] = false;
                }
                let entering = n_s.dot(task.dir) < 0.0;
                let n_f = facing(n_s, task.dir, m.refractivity);
                let local_w = (1.0 - m.reflectivity - m.refractivity).max(0.0);
                if local_w > 0.0 {
                    lit[l] = Some(Lit {
                        albedo: m.albedo,
                        p,
                        n_f,
                        v: -task.dir,
                        local_w,
                        from: p + n_f * (bias * h.side as f32),
                        skip: Skip::of(&h),
                        cone: cone_from_hit(&task.cone, h.t * self.scale, 0.0),
                    });
                }
                hits[l] = Some((h, p, n_f, entering));
            }
            // The local lights, their shadow rays toward each light together.
            let mut local: [Vec3; LANES] = std::array::from_fn(|l| {
                lit[l].map_or(Vec3::ZERO, |x| x.albedo * self.phong.ambient)
            });
            let mode = self.opts.shadows;
            for (lp, light) in &self.lights {
                let mut seen: [Option<(Vec3, f32)>; LANES] = [None; LANES];
                let mut shadow_rays = [unused; LANES];
                let mut tmax = [0.0f32; LANES];
                let mut skip = [None; LANES];
                let mut cones = [Cone::EXACT; LANES];
                let mut walking = 0u8;
                for l in 0..LANES {
                    let Some(x) = lit[l] else {
                        continue;
                    };
                    seen[l] = toward(x.p, x.n_f, *lp);
                    if seen[l].is_some() && mode != ShadowMode::None {
                        out[l].stats.shadow_rays += 1;
                        (shadow_rays[l], tmax[l]) = self.shadow_ray(x.from, *lp);
                        skip[l] = Some(x.skip);
                        cones[l] = x.cone;
                        walking |= 1 << l;
                    }
                }
                let mut walks = [ShadowWalk::new(mode, 0.5 / self.scale); LANES];
                let walked = if walking == 0 {
                    [Walked::NONE; LANES]
                } else {
                    self.surfaces.walks(
                        &shadow_rays,
                        tmax,
                        skip,
                        cones,
                        walking,
                        self.opts.max_steps,
                        &mut |l, h| walks[l].visit(h),
                    )
                };
                for l in 0..LANES {
                    let (Some(x), Some((dir_l, dist_grid))) = (lit[l], seen[l]) else {
                        continue;
                    };
                    let vis = if mode == ShadowMode::None {
                        1.0
                    } else {
                        out[l].stats.steps += walked[l].steps;
                        out[l].stats.capped += u32::from(walked[l].capped);
                        walks[l].visibility(walked[l].blocked)
                    };
                    if vis > 0.0 {
                        local[l] +=
                            self.light_term(light, dist_grid, vis, x.albedo, x.n_f, dir_l, x.v);
                    }
                }
            }
            // Each lane's light, and the rays its hit spawns.
            for l in 0..LANES {
                if let Some(x) = lit[l] {
                    out[l].colour += tasks[l].weight * x.local_w * local[l];
                }
                if let Some((h, p, n_f, entering)) = hits[l] {
                    self.spawn(
                        &tasks[l],
                        &h,
                        p,
                        n_f,
                        entering,
                        &mut stacks[l],
                        &mut lens[l],
                    );
                }
            }
        }
        out
    }
}

/// The footprint of the rays a hit `d` grid cells along a ray with `cone` spawns: the cone's
/// width there, spreading by `spread`. Reflection and refraction rays keep the cone's spread
/// (a flat surface's rule: the ray-cone rule of Akenine-Möller et al. 2019 without the
/// surface's curvature term); shadow rays keep the width toward the light (spread 0).
#[inline]
fn cone_from_hit(cone: &Cone, d: f32, spread: f32) -> Cone {
    if cone.is_exact() {
        return Cone::EXACT;
    }
    Cone {
        width: cone.width_at(d),
        spread,
    }
}
