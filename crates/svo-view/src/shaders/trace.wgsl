// The GPU port of svo's CPU reference tracer: the octree traversal of
// `trace/traverse.rs` / `trace/grid_ray.rs`, the leaf hits of `trace/leaf_hit.rs`, the octree surfaces
// of `render/surfaces.rs` and the Whitted loop of `render/whitted.rs`, one invocation per pixel.
// Every function names the Rust function it ports; keep the two in step (the golden tests
// compare their images).
//
// The structs at the top are mirrored by `gpu_types.rs` (a CPU test checks sizes and
// offsets through naga). What the scene does not need is left out by pipeline-overridable
// constants: the compiler drops the refraction, reflection and shadow paths and the absent
// attribute channels.

// ---- pipeline-overridable constants (gpu_types::ShaderVariant) --------------------------
override HIT_MODE: u32 = 1u;          // 0: cube, 1: contour
override REFLECTIONS: bool = true;    // some leaf reflects, or refracts (Fresnel reflection)
override REFRACTIONS: bool = true;    // some leaf refracts
override SHADOWS: u32 = 3u;           // 0: none, 1: opaque, 2: max refractivity, 3: product,
                                      // 4: chosen at run time (Params.shadow_mode)
override FRESNEL_SCHLICK: bool = false;
override MEDIA: bool = false;         // transparent leaves without normals (volumes)
override INTERIOR: bool = false;      // interior leaves of a solid bake (passed through)
// Whether rays spawn rays: without, the ray stack is never touched and compiles away.
override BOUNCES: bool = REFLECTIONS || REFRACTIONS;
// Where the stacks live. WGSL zero-initializes private stacks (the renderer sizes them for
// the scene, see MAX_DEPTH and RAY_STACK); workgroup memory is not initialized (the pipeline
// turns that off) and is sized here for the tree and the bounce limits: each of the
// WORKGROUP invocations of a workgroup owns TSTACK ancestor entries and RSTACK pending rays.
override WG_TRAVERSE: bool = false;
override TSTACK: u32 = 1u;
override WG_RAYS: bool = false;
override RSTACK: u32 = 1u;
// Channels: 0 absent, 1 constant (the value in `Params`), 2 per leaf (the buffer).
override NORMAL_CH: u32 = 2u;
override CONTOUR_CH: u32 = 2u;
override COLOUR_CH: u32 = 1u;
override REFLECTIVITY_CH: u32 = 1u;
override REFRACTIVITY_CH: u32 = 1u;
override IOR_CH: u32 = 1u;
// Primary rays start where the primary tiles pass says (tile_bounds), not at the eye.
override PRIMARY_TILES: bool = false;
// Rays spawned at the primary hit descend the primary hit's path without reading its nodes
// (traverse, hpath); for measuring (`--hit-paths`).
override HIT_PATHS: bool = false;
// The tree's arrays live in one arena of u32 words split over this many bindings (1-4), so a
// tree larger than one storage binding still fits (gpu_render.rs).
override ARENA_CHUNKS: u32 = 1u;
// The traversal walks the tree's 64-ary view (wide_view.rs) instead of the octree.
override WIDE_VIEW: bool = false;

const MAX_LIGHTS: u32 = 16u;
// The private stacks' sizes: the most the shader allows (RAY_STACK: 2 * MAX_BOUNCES + 2, as
// render/whitted.rs). The renderer edits both lines to the scene's sizes before compiling
// (gpu_render::trace_source), since function arrays cannot be sized by pipeline constants.
const MAX_DEPTH: u32 = 30u;
const RAY_STACK: u32 = 34u;
// The render's workgroup shape (pixels), and the invocations of the largest workgroup (the
// render's or cast_rays's 64), which size the workgroup stacks.
override WG_X: u32 = 8u;
override WG_Y: u32 = 8u;
override WORKGROUP: u32 = max(WG_X * WG_Y, 64u);
const TINY: f32 = 7.888609e-31;       // 2^-100, trace/grid_ray.rs TINY
const DONE: u32 = 8u;
const NO_SKIP: u32 = 0xffffffffu;
const NO_LEAF: u32 = 0xffffffffu;

struct Params {
    eye: vec3<f32>,            // grid space
    scale: f32,                // grid units per scene unit
    forward: vec3<f32>,
    bias: f32,                 // secondary ray offset, cells
    right: vec3<f32>,
    px_scale_x: f32,
    up: vec3<f32>,
    px_scale_y: f32,
    sky_zenith: vec3<f32>,
    half_w: f32,
    sky_horizon: vec3<f32>,
    half_h: f32,
    sky_ground: vec3<f32>,
    ambient: f32,
    sky_up: vec3<f32>,
    diffuse: f32,
    width: u32,
    height: u32,
    depth: u32,
    max_steps: u32,
    n_lights: u32,
    max_reflections: u32,
    max_refractions: u32,
    n_nodes: u32,
    const_normal: u32,
    const_contour: u32,
    const_colour: u32,
    const_reflectivity: u32,
    const_refractivity: u32,
    const_ior: u32,
    specular: f32,
    shininess: f32,
    infinity: f32,             // +inf (a constant expression may not overflow)
    shadow_mode: u32,          // the mode when SHADOWS is 4
    // Where each array starts in the arena, in words, and log2 of the words per chunk.
    nodes_at: u32,
    normal_at: u32,
    contour_at: u32,
    colour_at: u32,
    reflectivity_at: u32,
    refractivity_at: u32,
    ior_at: u32,
    arena_shift: u32,
    max_path_bounces: u32,     // reflections and refractions together along one path
    view_at: u32,              // the 64-ary view (WIDE_VIEW), 4 words a node
}

struct Light {
    position: vec3<f32>,       // grid space
    intensity: f32,
    colour: vec3<f32>,
    pad: f32,
}

struct Uniforms {
    params: Params,
    lights: array<Light, MAX_LIGHTS>,
    srgb: array<vec4<f32>, 64>,   // srgb_to_linear of bytes 0..255
}

struct Node {
    info: u32,
    first: u32,
}

struct Pixel {
    colour: vec3<f32>,         // linear RGB
    depth: f32,                // primary hit, scene units; +inf on a miss
    normal: vec3<f32>,         // primary shading normal; zero on a miss
    leaf: u32,                 // NO_LEAF on a miss
    primary_steps: u32,
    steps: u32,                // all rays
    rays: u32,                 // primary + secondary (low 16 bits), shadow (high 16 bits)
    capped: u32,
}

@group(0) @binding(0) var<uniform> u: Uniforms;
// The arena: the node array (2 words a node) and the per-leaf channels as stored (normal,
// contour, colour: a word a leaf; reflectivity, refractivity: 4 bytes a word; IOR: 2 a word),
// one after the other, split into chunks of 2^arena_shift words.
@group(0) @binding(1) var<storage, read> arena0: array<u32>;
@group(0) @binding(2) var<storage, read> arena1: array<u32>;
@group(0) @binding(3) var<storage, read> arena2: array<u32>;
@group(0) @binding(4) var<storage, read> arena3: array<u32>;
@group(0) @binding(5) var<storage, read_write> pixels: array<Pixel>;

// The ray-batch entry point (cast_rays): rays in grid space, first hits out.
struct RayIn {
    origin: vec3<f32>,
    tmin: f32,
    dir: vec3<f32>,
    tmax: f32,
}

struct RayOut {
    t: f32,                    // +inf on a miss
    leaf: u32,                 // NO_LEAF on a miss
    steps: u32,
    capped: u32,
}

@group(0) @binding(6) var<storage, read> ray_in: array<RayIn>;
@group(0) @binding(7) var<storage, read_write> ray_out: array<RayOut>;
// Per TILE x TILE block of pixels, the ray parameter its primary rays start at (tile_bounds).
@group(0) @binding(8) var<storage, read_write> tiles: array<f32>;

// Word i of the arena.
fn word(i: u32) -> u32 {
    if ARENA_CHUNKS == 1u {
        return arena0[i];
    }
    let shift = u.params.arena_shift;
    let j = i & ((1u << shift) - 1u);
    switch i >> shift {
        case 0u: {
            return arena0[j];
        }
        case 1u: {
            return arena1[j];
        }
        case 2u: {
            return arena2[j];
        }
        default: {
            return arena3[j];
        }
    }
}

fn node_at(i: u32) -> Node {
    let k = u.params.nodes_at + 2u * i;
    return Node(word(k), word(k + 1u));
}

// ---- leaf attributes (octree/tree.rs, octree/normal_encoding.rs, octree/contour.rs) -------------------------

fn sign_not_zero(v: f32) -> f32 {
    return select(-1.0, 1.0, v >= 0.0);
}

// normal_encoding::decode
fn decode_normal(e: u32) -> vec3<f32> {
    let x = max(f32(bitcast<i32>(e << 16u) >> 16u), -32767.0) / 32767.0;
    let y = max(f32(bitcast<i32>(e) >> 16u), -32767.0) / 32767.0;
    let z = 1.0 - abs(x) - abs(y);
    var n = vec3<f32>(x, y, z);
    if z < 0.0 {
        n.x = (1.0 - abs(y)) * sign_not_zero(x);
        n.y = (1.0 - abs(x)) * sign_not_zero(y);
    }
    return normalize(n);
}

fn has_normal() -> bool {
    return NORMAL_CH != 0u;
}

fn normal_word(leaf: u32) -> u32 {
    if NORMAL_CH == 2u {
        return word(u.params.normal_at + leaf);
    }
    return u.params.const_normal;
}

// octree::NO_NORMAL: the normal word of an interior leaf of a solid bake.
const NO_NORMAL_WORD: u32 = 0x80008000u;

// LeafAttributes::is_interior
fn is_interior(leaf: u32) -> bool {
    return INTERIOR && NORMAL_CH != 0u && normal_word(leaf) == NO_NORMAL_WORD;
}

fn contour_word(leaf: u32) -> u32 {
    if CONTOUR_CH == 2u {
        return word(u.params.contour_at + leaf);
    }
    return u.params.const_contour;
}

fn byte_of(w: u32, leaf: u32) -> u32 {
    return (w >> ((leaf & 3u) * 8u)) & 0xffu;
}

fn reflectivity_byte(leaf: u32) -> u32 {
    if REFLECTIVITY_CH == 2u {
        return byte_of(word(u.params.reflectivity_at + (leaf >> 2u)), leaf);
    }
    return u.params.const_reflectivity;
}

fn refractivity_byte(leaf: u32) -> u32 {
    if REFRACTIVITY_CH == 2u {
        return byte_of(word(u.params.refractivity_at + (leaf >> 2u)), leaf);
    }
    return u.params.const_refractivity;
}

fn ior_word(leaf: u32) -> u32 {
    if IOR_CH == 2u {
        return (word(u.params.ior_at + (leaf >> 1u)) >> ((leaf & 1u) * 16u)) & 0xffffu;
    }
    return u.params.const_ior;
}

fn colour_word(leaf: u32) -> u32 {
    if COLOUR_CH == 2u {
        return word(u.params.colour_at + leaf);
    }
    return u.params.const_colour;
}

fn srgb(b: u32) -> f32 {
    return u.srgb[b >> 2u][b & 3u];
}

struct Material {
    albedo: vec3<f32>,
    reflectivity: f32,
    refractivity: f32,
    ior: f32,
}

// OctreeSurfaces::material: defaults grey 0.8, not reflective, opaque, IOR 1.5.
fn material(leaf: u32) -> Material {
    var m = Material(vec3<f32>(0.8), 0.0, 0.0, 1.5);
    if COLOUR_CH != 0u {
        let c = colour_word(leaf);
        m.albedo = vec3<f32>(srgb(c & 0xffu), srgb((c >> 8u) & 0xffu), srgb((c >> 16u) & 0xffu));
    }
    if REFLECTIVITY_CH != 0u {
        m.reflectivity = f32(reflectivity_byte(leaf)) / 255.0;
    }
    if REFRACTIVITY_CH != 0u {
        m.refractivity = f32(refractivity_byte(leaf)) / 255.0;
    }
    if IOR_CH != 0u {
        m.ior = 1.0 + f32(ior_word(leaf)) / 16384.0;
    }
    return m;
}

// OctreeSurfaces::medium_of: transparent leaves without a normal; (kt | ior << 8, colour).
const NO_MEDIUM: vec2<u32> = vec2<u32>(0xffffffffu, 0xffffffffu);

fn medium_of(leaf: u32) -> vec2<u32> {
    if !MEDIA || has_normal() {
        return NO_MEDIUM;
    }
    var kt = 0u;
    if REFRACTIVITY_CH != 0u {
        kt = refractivity_byte(leaf);
    }
    if kt == 0u {
        return NO_MEDIUM;
    }
    var ior = 0u;
    if IOR_CH != 0u {
        ior = ior_word(leaf);
    }
    var col = 0u;
    if COLOUR_CH != 0u {
        col = colour_word(leaf);
    }
    return vec2<u32>(kt | (ior << 8u), col);
}

// The shadow mode: compiled in, or read at run time by the full shader.
fn shadows() -> u32 {
    if SHADOWS == 4u {
        return u.params.shadow_mode;
    }
    return SHADOWS;
}

// ---- rays (trace/grid_ray.rs) ------------------------------------------------------------------

struct MRay {
    o: vec3<f32>,
    inv: vec3<f32>,
    mask: u32,
    n: u32,
    // Mirrored plane p is real plane (p ^ flip) + add: n - p on mirrored axes, in integers.
    flip: vec3<u32>,
    add: vec3<u32>,
    valid: bool,
}

fn finite(v: vec3<f32>) -> bool {
    let b = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(b != vec3<u32>(0x7f800000u));
}

// MirroredRay::new
fn mirror(origin: vec3<f32>, dir: vec3<f32>, n: u32) -> MRay {
    var r: MRay;
    r.valid = finite(origin) && finite(dir) && any(dir != vec3<f32>(0.0));
    // Per axis at once (no loop over a vector's components, which compilers may keep in
    // memory): the sign bit decides, so -0.0 mirrors.
    let neg = (bitcast<vec3<u32>>(dir) >> vec3<u32>(31u)) != vec3<u32>(0u);
    let d = select(max(dir, vec3<f32>(TINY)), min(dir, vec3<f32>(-TINY)), neg);
    let mask = select(0u, 4u, neg.x) | select(0u, 2u, neg.y) | select(0u, 1u, neg.z);
    r.o = origin;
    r.inv = vec3<f32>(1.0) / d;
    r.mask = mask;
    r.n = n;
    r.flip = select(vec3<u32>(0u), vec3<u32>(0xffffffffu), neg);
    r.add = select(vec3<u32>(0u), vec3<u32>(n + 1u), neg);
    return r;
}

// MirroredRay::t_planes
fn t_planes(r: MRay, p: vec3<u32>) -> vec3<f32> {
    let real = vec3<f32>(bitcast<vec3<i32>>((p ^ r.flip) + r.add));
    return (real - r.o) * r.inv;
}

fn min3(v: vec3<f32>) -> f32 {
    return min(v.x, min(v.y, v.z));
}

fn max3(v: vec3<f32>) -> f32 {
    return max(v.x, max(v.y, v.z));
}

fn unmirror_cell(r: MRay, m: vec3<u32>) -> vec3<u32> {
    let flip = vec3<bool>((r.mask & 4u) != 0u, (r.mask & 2u) != 0u, (r.mask & 1u) != 0u);
    return select(m, vec3<u32>(r.n - 1u) - m, flip);
}

// MirroredRay::entry_normal
fn entry_normal(r: MRay, axis: u32) -> vec3<f32> {
    let s = select(-1.0, 1.0, (r.mask & (4u >> axis)) != 0u);
    return select(vec3<f32>(0.0), vec3<f32>(s), vec3<u32>(0u, 1u, 2u) == vec3<u32>(axis));
}

fn entry_normal_of(r: MRay, c0: vec3<f32>, tmin: f32) -> vec3<f32> {
    if max3(c0) < tmin {
        return vec3<f32>(0.0);
    }
    var axis = 2u;
    if c0.x >= c0.y && c0.x >= c0.z {
        axis = 0u;
    } else if c0.y >= c0.z {
        axis = 1u;
    }
    return entry_normal(r, axis);
}

fn exit_normal_of(r: MRay, c1: vec3<f32>) -> vec3<f32> {
    var axis = 2u;
    if c1.x <= c1.y && c1.x <= c1.z {
        axis = 0u;
    } else if c1.y <= c1.z {
        axis = 1u;
    }
    return -entry_normal(r, axis);
}

// ---- the traversal (trace/traverse.rs) ----------------------------------------------

fn high(c: u32) -> vec3<bool> {
    return vec3<bool>((c & 4u) != 0u, (c & 2u) != 0u, (c & 1u) != 0u);
}

fn child_bits(c: u32) -> vec3<u32> {
    return vec3<u32>((c >> 2u) & 1u, (c >> 1u) & 1u, c & 1u);
}

// Revelles's first_node: bit set where the mid plane is at or before the entry.
// bounds::swap_mask: the nibbles of a node's box that trade places on the mirrored axes.
fn swap_mask(mask: u32) -> u32 {
    return select(0u, 0xfu, (mask & 4u) != 0u) | select(0u, 0xf0u, (mask & 2u) != 0u)
        | select(0u, 0xf00u, (mask & 1u) != 0u);
}

// The traversal's test of the box of a child's leaves (octree/bounds.rs, kept in bits 8-31 of
// its info word; zero is the whole child): whether the ray, within [t_enter, t_exit], passes
// beside it. `origin` is the child's mirrored minimum cell and `side` its side.
fn passes_beside(r: MRay, swap: u32, info: u32, origin: vec3<u32>, side: u32, t_enter: f32, t_exit: f32) -> bool {
    let e = info >> 8u;
    if e == 0u {
        return false;
    }
    let d = (e ^ (e >> 12u)) & swap;
    let f = e ^ d ^ (d << 12u);
    let sh = vec3<u32>(max(countTrailingZeros(side), 4u) - 4u);
    let lo = vec3<u32>(f & 15u, (f >> 4u) & 15u, (f >> 8u) & 15u) << sh;
    let from_hi = vec3<u32>((f >> 12u) & 15u, (f >> 16u) & 15u, (f >> 20u) & 15u) << sh;
    let b0 = t_planes(r, origin + lo);
    let b1 = t_planes(r, origin + vec3<u32>(side) - from_hi);
    return min(min3(b1), t_exit) < max(max3(b0), t_enter);
}

fn first_child(tm: vec3<f32>, t: f32) -> u32 {
    let b = tm <= vec3<f32>(t);
    return select(0u, 4u, b.x) | select(0u, 2u, b.y) | select(0u, 1u, b.z);
}

// The current node: the node, its mirrored corner and size, the next child and its entry.
struct Frame {
    node: Node,
    origin: vec3<u32>,
    half: u32,
    next: u32,
    enter: f32,
}

// An ancestor on the stack, three words: its first child's index, its child mask with the
// next child above it, and that child's entry. Its size is implied by its level and its
// mirrored corner by the current cell's (the corner of a node of size s is the corner of any
// cell inside it with the bits below s cleared), and its plane parameters are recomputed
// from the corner when it is popped (t_planes of integer planes, so they are the values it
// had).
struct Saved {
    first: u32,
    mask_next: u32,            // child mask | next << 8
    enter: f32,
}

var<workgroup> wg_tstack: array<Saved, WORKGROUP * TSTACK>;
// The invocation's index in its workgroup (set by the entry points).
var<private> lane: u32;
// The traversal's ancestor stack, where WG_TRAVERSE does not put it in workgroup memory.
// Private (module scope), not a function variable: WGSL zero-initializes both, a function
// variable at every call of traverse (primary, secondary and shadow rays alike), a private
// one once per invocation. Traversals never nest, so they can share it.
var<private> tstack: array<Saved, MAX_DEPTH>;

// What a traversal is for: the closest surface (kind 0), or the light through a shadow
// ray (kind 1).
struct Query {
    kind: u32,
    tmin: f32,
    tmax: f32,
    skip: u32,
    medium: vec2<u32>,
    half_cell: f32,            // shadow rays: half a cell in ray parameter
    path: u32,                 // 1: record the hit's path (a primary ray); 2: start on it
}

// The primary hit's path, recorded by the primary ray's traversal where it stops: the inner
// nodes from the root down to the hit leaf's parent (the traversal's ancestors and its
// current node there) and the leaf's cell. A ray spawned at that hit starts next to the
// leaf, so its own descent from the root mostly goes through the same nodes.
var<private> hpath: array<Node, MAX_DEPTH>;
var<private> hpath_len: u32;
var<private> hpath_cell: vec3<u32>;

struct Outcome {
    hit: bool,
    t: f32,
    t_exit: f32,
    leaf: u32,
    normal: vec3<f32>,
    steps: u32,
    capped: bool,
    // Shadow rays.
    blocked: bool,
    any_kt: bool,
    max_kt: f32,
    trans: f32,
    last_exit: f32,
}

// LeafShape::hit for the hit modes (leaf_hit::leaf_hit + the stored normal): the
// parameter and shading normal of the hit inside the cell, if any.
struct ShapeHit {
    hit: bool,
    t: f32,
    normal: vec3<f32>,
}

fn shape_hit(ray_o: vec3<f32>, ray_d: vec3<f32>, leaf: u32, cell: vec3<u32>, t_enter: f32,
             t_exit: f32, entry_n: vec3<f32>) -> ShapeHit {
    var h = ShapeHit(true, t_enter, entry_n);
    if is_interior(leaf) {
        // OctreeSurfaces::surface_hit: inside a solid, the surface leaves are the interfaces.
        h.hit = false;
        return h;
    }
    if HIT_MODE == 1u && NORMAL_CH != 0u && CONTOUR_CH != 0u {
        // leaf_hit::slab_hit, relative to the cell centre.
        let n = decode_normal(normal_word(leaf));
        let cw = contour_word(leaf);
        let e = 0.5 * (abs(n.x) + abs(n.y) + abs(n.z));
        let a = f32(cw & 0xffffu) / 65535.0;
        let b = f32(cw >> 16u) / 65535.0;
        let near = (2.0 * a - 1.0) * e;
        let far = (2.0 * b - 1.0) * e;
        let centre = vec3<f32>(cell) + vec3<f32>(0.5);
        let sd = dot(n, ray_d);
        let s = dot(n, ray_o - centre) + t_enter * sd;
        if s < near {
            if !(sd > 0.0) {
                h.hit = false;
                return h;
            }
            h.t = t_enter + (near - s) / sd;
            h.normal = -n;
        } else if s > far {
            if !(sd < 0.0) {
                h.hit = false;
                return h;
            }
            h.t = t_enter + (far - s) / sd;
            h.normal = n;
        }
        if !(h.t <= t_exit) {
            h.hit = false;
            return h;
        }
    }
    if has_normal() {
        h.normal = decode_normal(normal_word(leaf));
    }
    return h;
}

// Loops: the renderer compiles this shader without wgpu's loop bounds (gpu_render.rs,
// ShaderChecks), so every loop here must end on its own. traverse's outer loop and its inner
// loop over a node's children count a step in every pass and return past max_steps (below
// u32::MAX), its pop loop shrinks the stack in every pass, its descent along a hit's path
// deepens the stack in every pass and stops at the path's end, and the copy of a path
// counts to the stack's length; traverse_wide's loops do the same (a step counted in every
// pass of its cell loop, its pop loop shrinking its stack); the light loop counts to a constant; the Whitted loop takes a ray off its stack in every pass and pushes at most
// two, each with a reflection or refraction count one higher and below its limit.
//
// traverse + the callbacks of OctreeSurfaces::closest (kind 0) and Tracer::shadow over
// OctreeSurfaces::walk (kind 1).
fn traverse(ray_o: vec3<f32>, ray_d: vec3<f32>, q: Query) -> Outcome {
    if WIDE_VIEW {
        return traverse_wide(ray_o, ray_d, q);
    }
    return traverse_octree(ray_o, ray_d, q);
}

// ---- the walk of the 64-ary view (wide_view.rs) ----------------------------------------
//
// A DDA through each view node's 4x4x4 cells in the mirrored space: a cell's exit is the
// least of its three far planes, and the next cell adds one on every axis whose plane ties
// there; the node is done when such an axis was on its last cell. The cell a ray enters a
// node in is, per axis, the octree's two first_child decisions (mid plane, then the mid
// plane of that half), and the planes are the octree walk's own integer planes through
// t_planes, so a ray meets the same leaves with the same parameters as traverse_octree (the
// golden tests compare the images bit for bit); the steps count cells. A child view node is
// entered only where the ray meets its box of leaves (passes_beside, as the octree walk);
// the boxes of the odd levels in between are not kept, which only adds steps.

// An ancestor: its mask and first index, its next cell (2 bits an axis) with bit 6 set when
// none is left, and that cell's entry.
struct WideSaved {
    lo: u32,
    hi: u32,
    first: u32,
    cell_done: u32,
    enter: f32,
}

// Ancestors of a tree of depth 30 at most: 14 view levels above the leaves' parents.
var<private> wstack: array<WideSaved, 15>;

fn view_word(i: u32) -> u32 {
    return word(u.params.view_at + i);
}

// The cell of a node (mirrored corner `origin`, cells of `qs`, `last` + 1 of them an axis)
// that a ray entering at `t` starts in: per axis, the octree's first_child decisions, two
// for 4x4x4 cells, one for the 2x2x2 root of an odd depth.
fn first_cell(r: MRay, origin: vec3<u32>, qs: u32, last: u32, t: f32) -> vec3<u32> {
    let tv = vec3<f32>(t);
    let one = vec3<u32>(1u);
    let zero = vec3<u32>(0u);
    if last == 1u {
        return select(zero, one, t_planes(r, origin + vec3<u32>(qs)) <= tv);
    }
    // The mid plane's decision, then the quarter plane of the half it picks: the planes'
    // parameters grow with the mirrored coordinate, so this counts the three planes at or
    // before t with two of them computed.
    let half = select(zero, vec3<u32>(2u), t_planes(r, origin + vec3<u32>(2u * qs)) <= tv);
    return half + select(zero, one, t_planes(r, origin + (half + one) * qs) <= tv);
}

// traverse_octree's leaves, entries, callbacks and outcome, walked through the view.
fn traverse_wide(ray_o: vec3<f32>, ray_d: vec3<f32>, q: Query) -> Outcome {
    var out: Outcome;
    out.hit = false;
    out.steps = 0u;
    out.capped = false;
    out.blocked = false;
    out.any_kt = false;
    out.max_kt = 0.0;
    out.trans = 1.0;
    out.last_exit = -u.params.infinity;
    // Inside a medium: the run of its cells ends at (run_t, run_n, run_leaf).
    var run = false;
    var run_t = 0.0;
    var run_n = vec3<f32>(0.0);
    var run_leaf = 0u;

    let depth = u.params.depth;
    let root = node_at(0u);
    if (root.info & 0xffu) == 0u || depth == 0u || depth > MAX_DEPTH {
        return out;
    }
    let n = 1u << depth;
    let r = mirror(ray_o, ray_d, n);
    if !r.valid || !(q.tmin <= q.tmax) {
        return out;
    }
    let rt0 = t_planes(r, vec3<u32>(0u));
    let rt1 = t_planes(r, vec3<u32>(n));
    let enter0 = max(max3(rt0), q.tmin);
    if !(enter0 <= min(min3(rt1), q.tmax)) {
        return out;
    }
    let mask = r.mask;
    let swap = swap_mask(mask);
    // A cell's bit in a node's mask from its mirrored coordinates: mirroring an axis flips
    // both its bits (outer and inner) of the bit index; in the 2x2x2 root of an odd depth
    // (cells 0 and 1, so no outer bits) only the inner one.
    let flip_bits = (mask << 3u) | mask;
    let odd = depth & 1u;
    var lo = view_word(0u);
    var hi = view_word(1u);
    var first = view_word(2u);
    var origin = vec3<u32>(0u);
    var qs = n >> (2u - odd);
    var last = select(3u, 1u, odd == 1u);
    var flip = select(flip_bits, mask, odd == 1u);
    var cell = first_cell(r, origin, qs, last, enter0);
    var enter = enter0;
    var done = false;
    var len = 0u;
    loop {
        if done {
            var found = false;
            loop {
                if len == 0u {
                    break;
                }
                len -= 1u;
                let sv = wstack[len];
                if (sv.cell_done & 64u) == 0u {
                    found = true;
                    lo = sv.lo;
                    hi = sv.hi;
                    first = sv.first;
                    cell = vec3<u32>(sv.cell_done & 3u, (sv.cell_done >> 2u) & 3u, (sv.cell_done >> 4u) & 3u);
                    enter = sv.enter;
                    break;
                }
            }
            if !found {
                break;
            }
            done = false;
            let root = len == 0u;
            let side = select(n >> (2u * len - odd), n, root);
            origin &= vec3<u32>(~(side - 1u));
            last = select(3u, 1u, root && odd == 1u);
            flip = select(flip_bits, mask, root && odd == 1u);
            qs = side / (last + 1u);
        }
        var c = vec3<u32>(0u);
        var t_enter = 0.0;
        var c1 = vec3<f32>(0.0);
        var m = 0.0;
        var b = 0u;
        var exists = false;
        loop {
            c = cell;
            t_enter = enter;
            c1 = t_planes(r, origin + (c + vec3<u32>(1u)) * qs);
            m = min3(c1);
            let tied = c1 == vec3<f32>(m);
            done = any(tied & (c == vec3<u32>(last)));
            cell = c + select(vec3<u32>(0u), vec3<u32>(1u), tied);
            enter = select(q.tmin, m, m > q.tmin);
            out.steps += 1u;
            if out.steps > u.params.max_steps {
                out.capped = true;
                return out;
            }
            b = (((c.x >> 1u) << 5u) | ((c.y >> 1u) << 4u) | ((c.z >> 1u) << 3u)
                | ((c.x & 1u) << 2u) | ((c.y & 1u) << 1u) | (c.z & 1u)) ^ flip;
            exists = ((select(hi, lo, b < 32u) >> (b & 31u)) & 1u) != 0u;
            if exists || done {
                break;
            }
        }
        if !exists {
            continue;
        }
        if t_enter > q.tmax {
            break;
        }
        let t_exit = select(q.tmax, m, m < q.tmax);
        if t_exit < t_enter {
            continue;
        }
        let below = (1u << (b & 31u)) - 1u;
        let rank = select(countOneBits(lo) + countOneBits(hi & below), countOneBits(lo & below), b < 32u);
        let corg = origin + c * qs;
        if qs == 1u {
            // The callbacks, as traverse_octree's (inline: a shared function with pointers to
            // the outcome made both walks 2-8% slower on an H200). `real` is the leaf's cell
            // (`cell` is the next cell of this node's walk).
            let c0 = t_planes(r, corg);
            let leaf = first + rank;
            let real = unmirror_cell(r, corg);
            if q.kind == 0u {
                if MEDIA && q.medium.x != NO_MEDIUM.x {
                    if run && t_enter > run_t {
                        break;
                    }
                    if all(medium_of(leaf) == q.medium) {
                        run = true;
                        run_t = t_exit;
                        run_n = exit_normal_of(r, c1);
                        run_leaf = leaf;
                        continue;
                    }
                }
                if leaf == q.skip {
                    continue;
                }
                let h = shape_hit(ray_o, ray_d, leaf, real, t_enter, t_exit, entry_normal_of(r, c0, q.tmin));
                if h.hit {
                    out.hit = true;
                    out.t = h.t;
                    out.t_exit = t_exit;
                    out.leaf = leaf;
                    out.normal = h.normal;
                    return out;
                }
            } else {
                if leaf == q.skip {
                    continue;
                }
                let h = shape_hit(ray_o, ray_d, leaf, real, t_enter, t_exit, entry_normal_of(r, c0, q.tmin));
                if !h.hit {
                    continue;
                }
                if shadows() == 1u {
                    out.blocked = true;
                    return out;
                }
                let kt = material(leaf).refractivity;
                if kt <= 0.0 {
                    out.trans = 0.0;
                    out.blocked = true;
                    return out;
                }
                out.any_kt = true;
                out.max_kt = max(out.max_kt, kt);
                if h.t > out.last_exit + q.half_cell {
                    out.trans *= kt;
                }
                out.last_exit = t_exit;
            }
        } else {
            if len >= 15u {
                continue;
            }
            let k = 4u * (first + rank);
            let clo = view_word(k);
            let chi = view_word(k + 1u);
            let cfirst = view_word(k + 2u);
            let cinfo = view_word(k + 3u);
            if passes_beside(r, swap, cinfo, corg, qs, t_enter, t_exit) {
                continue;
            }
            wstack[len] = WideSaved(lo, hi, first, (cell.x & 3u) | ((cell.y & 3u) << 2u) | ((cell.z & 3u) << 4u) | select(0u, 64u, done), enter);
            len += 1u;
            lo = clo;
            hi = chi;
            first = cfirst;
            origin = corg;
            qs = qs / 4u;
            last = 3u;
            flip = flip_bits;
            cell = first_cell(r, origin, qs, last, t_enter);
            enter = t_enter;
            done = false;
        }
    }
    if MEDIA && q.kind == 0u && run && !out.capped {
        out.hit = true;
        out.t = run_t;
        out.t_exit = run_t;
        out.leaf = run_leaf;
        out.normal = run_n;
    }
    return out;
}

fn traverse_octree(ray_o: vec3<f32>, ray_d: vec3<f32>, q: Query) -> Outcome {
    var out: Outcome;
    out.hit = false;
    out.steps = 0u;
    out.capped = false;
    out.blocked = false;
    out.any_kt = false;
    out.max_kt = 0.0;
    out.trans = 1.0;
    out.last_exit = -u.params.infinity;
    // Inside a medium: the run of its cells ends at (run_t, run_n, run_leaf).
    var run = false;
    var run_t = 0.0;
    var run_n = vec3<f32>(0.0);
    var run_leaf = 0u;

    let depth = u.params.depth;
    let root = node_at(0u);
    if (root.info & 0xffu) == 0u || depth == 0u || depth > MAX_DEPTH {
        return out;
    }
    let n = 1u << depth;
    let r = mirror(ray_o, ray_d, n);
    if !r.valid || !(q.tmin <= q.tmax) {
        return out;
    }
    let rt0 = t_planes(r, vec3<u32>(0u));
    let rt1 = t_planes(r, vec3<u32>(n));
    let enter0 = max(max3(rt0), q.tmin);
    if !(enter0 <= min(min3(rt1), q.tmax)) {
        return out;
    }
    var cur: Frame;
    cur.node = root;
    cur.origin = vec3<u32>(0u);
    cur.half = n / 2u;
    var t1 = rt1;
    var tm = t_planes(r, vec3<u32>(cur.half));
    cur.next = first_child(tm, enter0);
    cur.enter = enter0;
    let cap = select(MAX_DEPTH, TSTACK, WG_TRAVERSE);
    let base = lane * TSTACK;
    var len = 0u;
    let mask = r.mask;
    let swap = swap_mask(mask);
    // A ray spawned at the primary hit (q.path 2): while its next child is the next node of
    // the hit's path, the loop's step for that child, push and all, with the node taken from
    // the path instead of read from the tree. Anything the loop would do otherwise (a child
    // off the path, past tmax or the step cap, a full stack) stops this and is left to the
    // loop, which then finds the state it would have reached itself: the same leaves, steps
    // and image.
    if BOUNCES && HIT_PATHS && q.path == 2u {
        loop {
            if len + 1u >= hpath_len || len >= depth {
                break;
            }
            let s = depth - 1u - len;
            let on_path = (((hpath_cell.x >> s) & 1u) << 2u) | (((hpath_cell.y >> s) & 1u) << 1u)
                | ((hpath_cell.z >> s) & 1u);
            let c = cur.next;
            if c == DONE || (c ^ mask) != on_path || len == cap || cur.half < 2u {
                break;
            }
            let t_enter = cur.enter;
            let c1 = select(tm, t1, high(c));
            let m = min3(c1);
            let t_exit = select(q.tmax, m, m < q.tmax);
            if t_enter > q.tmax || t_exit < t_enter || out.steps >= u.params.max_steps {
                break;
            }
            if passes_beside(r, swap, hpath[len + 1u].info, cur.origin + child_bits(c) * cur.half, cur.half, t_enter, t_exit) {
                break;
            }
            let tied = select(0u, 4u, c1.x == m) | select(0u, 2u, c1.y == m) | select(0u, 1u, c1.z == m);
            cur.next = select(c | tied, DONE, (c & tied) != 0u);
            cur.enter = select(q.tmin, m, m > q.tmin);
            out.steps += 1u;
            let origin = cur.origin + child_bits(c) * cur.half;
            let half = cur.half / 2u;
            let saved = Saved(cur.node.first, (cur.node.info & 0xffu) | (cur.next << 8u), cur.enter);
            if WG_TRAVERSE {
                wg_tstack[base + len] = saved;
            } else {
                tstack[len] = saved;
            }
            len += 1u;
            cur.node = hpath[len];
            cur.origin = origin;
            cur.half = half;
            t1 = c1;
            tm = t_planes(r, origin + vec3<u32>(half));
            cur.next = first_child(tm, t_enter);
            cur.enter = t_enter;
        }
    }
    loop {
        if cur.next == DONE {
            // Pop to the nearest ancestor with a child left (an ancestor whose next is DONE
            // would only be popped in turn), then visit that child in this same iteration.
            var sv = Saved(0u, DONE << 8u, 0.0);
            loop {
                if len == 0u {
                    break;
                }
                len -= 1u;
                if WG_TRAVERSE {
                    sv = wg_tstack[base + len];
                } else {
                    sv = tstack[len];
                }
                if (sv.mask_next >> 8u) != DONE {
                    break;
                }
            }
            if (sv.mask_next >> 8u) == DONE {
                break;
            }
            cur.node = Node(sv.mask_next & 0xffu, sv.first);
            cur.half = n >> (len + 1u);
            cur.origin &= vec3<u32>(~(2u * cur.half - 1u));
            cur.next = sv.mask_next >> 8u;
            cur.enter = sv.enter;
            tm = t_planes(r, cur.origin + vec3<u32>(cur.half));
            t1 = t_planes(r, cur.origin + vec3<u32>(2u * cur.half));
        }
        // Step over the node's children in the ray's order until one exists (or none is
        // left): the cheap part of a step in a tight loop, so that the lanes of a warp
        // meet again before the costly parts (a leaf's test, a push).
        let child_mask = cur.node.info & 0xffu;
        var c = 0u;
        var t_enter = 0.0;
        var c1 = vec3<f32>(0.0);
        var m = 0.0;
        var real = 0u;
        loop {
            c = cur.next;
            t_enter = cur.enter;
            c1 = select(tm, t1, high(c));
            m = min3(c1);
            let tied = select(0u, 4u, c1.x == m) | select(0u, 2u, c1.y == m) | select(0u, 1u, c1.z == m);
            cur.next = select(c | tied, DONE, (c & tied) != 0u);
            cur.enter = select(q.tmin, m, m > q.tmin);
            out.steps += 1u;
            if out.steps > u.params.max_steps {
                out.capped = true;
                return out;
            }
            real = c ^ mask;
            if ((child_mask >> real) & 1u) != 0u || cur.next == DONE {
                break;
            }
        }
        if ((child_mask >> real) & 1u) == 0u {
            continue;
        }
        if t_enter > q.tmax {
            break;
        }
        let t_exit = select(q.tmax, m, m < q.tmax);
        if t_exit < t_enter {
            continue;
        }
        let rank = countOneBits(child_mask & ((1u << real) - 1u));
        let origin = cur.origin + child_bits(c) * cur.half;
        if bitcast<i32>(cur.node.first) < 0 {
            // A leaf: the callbacks. The cell's entry planes, the values the traversal would
            // have carried down (the same integer planes).
            let c0 = t_planes(r, origin);
            let leaf = u32(-(bitcast<i32>(cur.node.first) + 1)) + rank;
            let cell = unmirror_cell(r, origin);
            if q.kind == 0u {
                if MEDIA && q.medium.x != NO_MEDIUM.x {
                    if run && t_enter > run_t {
                        // A gap after the medium's cells: the ray left it there.
                        break;
                    }
                    if all(medium_of(leaf) == q.medium) {
                        run = true;
                        run_t = t_exit;
                        run_n = exit_normal_of(r, c1);
                        run_leaf = leaf;
                        continue;
                    }
                }
                if leaf == q.skip {
                    continue;
                }
                let h = shape_hit(ray_o, ray_d, leaf, cell, t_enter, t_exit, entry_normal_of(r, c0, q.tmin));
                if h.hit {
                    out.hit = true;
                    out.t = h.t;
                    out.t_exit = t_exit;
                    out.leaf = leaf;
                    out.normal = h.normal;
                    if BOUNCES && HIT_PATHS && q.path == 1u && len < MAX_DEPTH {
                        for (var i = 0u; i < len; i++) {
                            var sv: Saved;
                            if WG_TRAVERSE {
                                sv = wg_tstack[base + i];
                            } else {
                                sv = tstack[i];
                            }
                            hpath[i] = Node(sv.mask_next & 0xffu, sv.first);
                        }
                        hpath[len] = cur.node;
                        hpath_len = len + 1u;
                        hpath_cell = cell;
                        // The stack keeps the ancestors' child masks but not their bounds,
                        // which the descent along the path tests as the loop would.
                        for (var i = 1u; i <= len; i++) {
                            let s = depth - i;
                            let on_path = (((cell.x >> s) & 1u) << 2u) | (((cell.y >> s) & 1u) << 1u)
                                | ((cell.z >> s) & 1u);
                            let parent = hpath[i - 1u];
                            let idx = parent.first + countOneBits(parent.info & 0xffu & ((1u << on_path) - 1u));
                            if idx < u.params.n_nodes {
                                hpath[i] = node_at(idx);
                            }
                        }
                    }
                    return out;
                }
            } else {
                if leaf == q.skip {
                    continue;
                }
                let h = shape_hit(ray_o, ray_d, leaf, cell, t_enter, t_exit, entry_normal_of(r, c0, q.tmin));
                if !h.hit {
                    continue;
                }
                if shadows() == 1u {
                    out.blocked = true;
                    return out;
                }
                let kt = material(leaf).refractivity;
                if kt <= 0.0 {
                    out.trans = 0.0;
                    out.blocked = true;
                    return out;
                }
                out.any_kt = true;
                out.max_kt = max(out.max_kt, kt);
                if h.t > out.last_exit + q.half_cell {
                    out.trans *= kt;
                }
                out.last_exit = t_exit;
            }
        } else {
            if len == cap || cur.half < 2u {
                continue;
            }
            let idx = cur.node.first + rank;
            if idx >= u.params.n_nodes {
                continue;
            }
            let child = node_at(idx);
            if passes_beside(r, swap, child.info, origin, cur.half, t_enter, t_exit) {
                continue;
            }
            let half = cur.half / 2u;
            let saved = Saved(cur.node.first, child_mask | (cur.next << 8u), cur.enter);
            if WG_TRAVERSE {
                wg_tstack[base + len] = saved;
            } else {
                tstack[len] = saved;
            }
            len += 1u;
            cur.node = child;
            cur.origin = origin;
            cur.half = half;
            t1 = c1;
            tm = t_planes(r, origin + vec3<u32>(half));
            cur.next = first_child(tm, t_enter);
            cur.enter = t_enter;
        }
    }
    // The closest query inside a medium: the end of the run is the boundary.
    if MEDIA && q.kind == 0u && run && !out.capped {
        out.hit = true;
        out.t = run_t;
        out.t_exit = run_t;
        out.leaf = run_leaf;
        out.normal = run_n;
    }
    return out;
}

// ---- shading (render/shading.rs, render/sky.rs) -------------------------------------------------------

fn sky_colour(d: vec3<f32>) -> vec3<f32> {
    let p = u.params;
    let h = clamp(dot(d, p.sky_up), -1.0, 1.0);
    if h >= 0.0 {
        return mix(p.sky_horizon, p.sky_zenith, sqrt(h));
    }
    return mix(p.sky_horizon, p.sky_ground, sqrt(-h));
}

fn reflect_dir(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

// shading::cos2_transmitted
fn cos2_transmitted(cos_i: f32, eta: f32) -> f32 {
    let e2 = eta * eta;
    return (1.0 - e2) + e2 * (cos_i * cos_i);
}

fn fresnel_exact(cos_in: f32, n1: f32, n2: f32) -> f32 {
    let cos_i = clamp(cos_in, 0.0, 1.0);
    let cos2_t = cos2_transmitted(cos_i, n1 / n2);
    if cos2_t <= 0.0 {
        return 1.0;
    }
    let cos_t = sqrt(cos2_t);
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    return 0.5 * (rs * rs + rp * rp);
}

fn fresnel_schlick(cos_in: f32, n1: f32, n2: f32) -> f32 {
    let cos_i = clamp(cos_in, 0.0, 1.0);
    let r0 = ((n1 - n2) / (n1 + n2)) * ((n1 - n2) / (n1 + n2));
    var c = cos_i;
    if n1 > n2 {
        let cos2_t = cos2_transmitted(cos_i, n1 / n2);
        if cos2_t <= 0.0 {
            return 1.0;
        }
        c = sqrt(cos2_t);
    }
    let k = 1.0 - c;
    return r0 + (1.0 - r0) * (k * k * k * k * k);
}

// Phong::direct
fn phong_direct(albedo: vec3<f32>, n: vec3<f32>, l: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let p = u.params;
    let ndl = dot(n, l);
    if ndl <= 0.0 {
        return vec3<f32>(0.0);
    }
    let rr = reflect_dir(-l, n);
    let spec = pow(max(dot(rr, v), 0.0), p.shininess);
    return albedo * (p.diffuse * ndl) + vec3<f32>(p.specular * spec);
}

// Tracer::shadow
struct ShadowResult {
    vis: f32,
    steps: u32,
    capped: bool,
}

fn shadow(start: vec3<f32>, light: vec3<f32>, skip: u32) -> ShadowResult {
    var res = ShadowResult(1.0, 0u, false);
    let scale = u.params.scale;
    let to = light - start;
    let len2 = dot(to, to);
    var l = vec3<f32>(0.0);
    if len2 > 0.0 {
        l = to / sqrt(len2);
    }
    let dist = length(to) / scale;
    var q: Query;
    q.kind = 1u;
    q.tmin = 0.0;
    q.tmax = dist * (1.0 - 1e-5);
    q.skip = skip;
    q.medium = NO_MEDIUM;
    q.half_cell = 0.5 / scale;
    q.path = 0u;
    let o = traverse(start, l * scale, q);
    res.steps = o.steps;
    res.capped = o.capped;
    if o.blocked {
        res.vis = 0.0;
    } else if shadows() == 2u && o.any_kt {
        res.vis = o.max_kt;
    } else if shadows() == 3u {
        res.vis = o.trans;
    }
    return res;
}

// ---- the Whitted loop (render/whitted.rs, Tracer::trace_with) ---------------------------------

struct Task {
    origin: vec3<f32>,
    refl: u32,
    dir: vec3<f32>,
    refr: u32,
    weight: vec3<f32>,
    skip: u32,
    medium: vec2<u32>,
    // IOR codes of the media the ray is in: current (low 16 bits), around it (high 16).
    iors: u32,
}

// A pending ray as stored on a stack: 14 scalars (56 bytes, no vec3 padding).
struct Pending {
    ox: f32, oy: f32, oz: f32,
    dx: f32, dy: f32, dz: f32,
    wx: f32, wy: f32, wz: f32,
    bounces: u32,              // reflections | refractions << 16
    skip: u32,
    m0: u32,
    m1: u32,
    iors: u32,
}

fn pack_task(t: Task) -> Pending {
    return Pending(t.origin.x, t.origin.y, t.origin.z, t.dir.x, t.dir.y, t.dir.z,
                   t.weight.x, t.weight.y, t.weight.z, t.refl | (t.refr << 16u), t.skip,
                   t.medium.x, t.medium.y, t.iors);
}

fn unpack_task(p: Pending) -> Task {
    return Task(vec3<f32>(p.ox, p.oy, p.oz), p.bounces & 0xffffu, vec3<f32>(p.dx, p.dy, p.dz),
                p.bounces >> 16u, vec3<f32>(p.wx, p.wy, p.wz), p.skip, vec2<u32>(p.m0, p.m1),
                p.iors);
}

var<workgroup> wg_rstack: array<Pending, WORKGROUP * RSTACK>;

fn refract_dir(d: vec3<f32>, n: vec3<f32>, n1: f32, n2: f32, ok: ptr<function, bool>) -> vec3<f32> {
    let eta = n1 / n2;
    let cos_i = -dot(d, n);
    let k = cos2_transmitted(cos_i, eta);
    *ok = k >= 0.0;
    if !(*ok) {
        return vec3<f32>(0.0);
    }
    return normalize(eta * d + (eta * cos_i - sqrt(k)) * n);
}

// CameraRays::dir_f32: the primary ray of pixel (x, y).
fn camera_dir(x: u32, y: u32) -> vec3<f32> {
    let p = u.params;
    let sx = ((f32(x) + 0.5) * p.px_scale_x - 1.0) * p.half_w;
    let sy = (1.0 - (f32(y) + 0.5) * p.px_scale_y) * p.half_h;
    return normalize(p.forward + p.right * sx + p.up * sy);
}

@compute @workgroup_size(WG_X, WG_Y, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(local_invocation_index) lidx: u32) {
    lane = lidx;
    let p = u.params;
    if gid.x >= p.width || gid.y >= p.height {
        return;
    }
    let dir0 = camera_dir(gid.x, gid.y);
    // Where the primary ray starts: no leaf cell of its tile lies nearer (tile_bounds).
    var primary_tmin = 0.0;
    if PRIMARY_TILES {
        primary_tmin = tiles[(gid.y / TILE) * ((p.width + TILE - 1u) / TILE) + gid.x / TILE];
    }

    var px: Pixel;
    px.colour = vec3<f32>(0.0);
    px.depth = p.infinity;
    px.normal = vec3<f32>(0.0);
    px.leaf = NO_LEAF;
    px.primary_steps = 0u;
    px.steps = 0u;
    var rays = 0u;
    var shadow_rays = 0u;
    var capped = 0u;

    var stack: array<Pending, RAY_STACK>;   // used only with BOUNCES and not WG_RAYS
    let rcap = select(RAY_STACK, RSTACK, WG_RAYS);
    let rbase = lane * RSTACK;
    let primary = Task(p.eye, 0u, dir0, 0u, vec3<f32>(1.0), NO_SKIP, NO_MEDIUM, 0u);
    var len = 1u;
    var first = true;
    let bias = p.bias;
    loop {
        if len == 0u {
            break;
        }
        len -= 1u;
        var task = primary;
        if BOUNCES && !first {
            if WG_RAYS {
                task = unpack_task(wg_rstack[rbase + len]);
            } else {
                task = unpack_task(stack[len]);
            }
        }
        let ray_d = task.dir * p.scale;
        var q: Query;
        q.kind = 0u;
        q.tmin = select(0.0, primary_tmin, first);
        q.tmax = p.infinity;
        q.skip = task.skip;
        q.medium = task.medium;
        q.half_cell = 0.0;
        // The primary ray records its hit's path; the rays spawned at that hit (one bounce
        // on their path) start on it.
        q.path = select(select(0u, 2u, task.refl + task.refr == 1u), 1u, first);
        let h = traverse(task.origin, ray_d, q);
        rays += 1u;
        px.steps += h.steps;
        capped += select(0u, 1u, h.capped);
        if first {
            px.primary_steps = h.steps;
            if h.hit {
                px.depth = h.t;
                px.leaf = h.leaf;
            }
        }
        if !h.hit {
            px.colour += task.weight * sky_colour(task.dir);
            first = false;
            continue;
        }
        let m = material(h.leaf);
        let hp = task.origin + ray_d * h.t;
        var n_s = h.normal;
        if all(n_s == vec3<f32>(0.0)) {
            n_s = -task.dir;
        }
        if first {
            px.normal = n_s;
            first = false;
        }
        let entering = dot(n_s, task.dir) < 0.0;
        var n_f = n_s;
        if !entering {
            if m.refractivity > 0.0 {
                n_f = -n_s;
            } else {
                // An opaque surface seen from behind its shading normal: turn the normal
                // until it just faces the viewer (Vec3::normalize_or).
                let t = n_s - task.dir * (dot(n_s, task.dir) + 1e-3);
                let tl = length(t);
                n_f = select(-task.dir, t / tl, tl > 0.0 && tl < p.infinity);
            }
        }
        let v = -task.dir;

        // Local light.
        let kr = m.reflectivity;
        let kt = m.refractivity;
        let local_w = max(1.0 - kr - kt, 0.0);
        if local_w > 0.0 {
            var local = m.albedo * p.ambient;
            let shadow_from = hp + n_f * bias;
            for (var li = 0u; li < min(p.n_lights, MAX_LIGHTS); li++) {
                let light = u.lights[li];
                let to = light.position - hp;
                let dist_grid = length(to);
                if !(dist_grid > 0.0) {
                    continue;
                }
                let l = to / dist_grid;
                if dot(n_f, l) <= 0.0 {
                    continue;
                }
                var vis = 1.0;
                if shadows() != 0u {
                    shadow_rays += 1u;
                    let s = shadow(shadow_from, light.position, h.leaf);
                    vis = s.vis;
                    px.steps += s.steps;
                    capped += select(0u, 1u, s.capped);
                }
                if vis > 0.0 {
                    let dist = dist_grid / p.scale;
                    let falloff = light.colour * (light.intensity / max(dist * dist, 1e-12));
                    local += falloff * vis * phong_direct(m.albedo, n_f, l, v);
                }
            }
            px.colour += task.weight * local_w * local;
        }

        // Reflection and refraction.
        if BOUNCES {
            // render/whitted.rs: from the medium the ray is in into the leaf's, or out of the
            // leaf's into the one around it.
            let here = task.iors & 0xffffu;
            let around = task.iors >> 16u;
            var n1 = m.ior;
            var n2 = 1.0 + f32(around) / 16384.0;
            var iors_after = around;
            if entering {
                n1 = 1.0 + f32(here) / 16384.0;
                n2 = m.ior;
                iors_after = ior_word(h.leaf) | (here << 16u);
            }
            let cos_i = dot(n_f, v);
            var fr = kr;
            var ft = 0.0;
            var t_ok = false;
            var t_dir = vec3<f32>(0.0);
            if REFRACTIONS && kt > 0.0 {
                var f: f32;
                if FRESNEL_SCHLICK {
                    f = fresnel_schlick(cos_i, n1, n2);
                } else {
                    f = fresnel_exact(cos_i, n1, n2);
                }
                t_dir = refract_dir(task.dir, n_f, n1, n2, &t_ok);
                if t_ok {
                    fr += kt * f;
                    ft = kt * (1.0 - f);
                } else {
                    fr += kt;
                }
            }
            // render/whitted.rs: while the path has bounces left.
            let path_left = task.refl + task.refr < p.max_path_bounces;
            if fr > 0.0 && path_left && task.refl < p.max_reflections && len < rcap {
                let t = pack_task(Task(hp + n_f * bias, task.refl + 1u,
                                       normalize(reflect_dir(task.dir, n_f)), task.refr,
                                       task.weight * fr, h.leaf, task.medium, task.iors));
                if WG_RAYS {
                    wg_rstack[rbase + len] = t;
                } else {
                    stack[len] = t;
                }
                len += 1u;
            }
            if REFRACTIONS && t_ok && ft > 0.0 && path_left && task.refr < p.max_refractions
                && len < rcap {
                var med = NO_MEDIUM;
                if MEDIA && entering {
                    med = medium_of(h.leaf);
                }
                let t = pack_task(Task(hp - n_f * bias, task.refl, t_dir, task.refr + 1u,
                                       task.weight * ft * m.albedo, h.leaf, med, iors_after));
                if WG_RAYS {
                    wg_rstack[rbase + len] = t;
                } else {
                    stack[len] = t;
                }
                len += 1u;
            }
        }
    }
    px.rays = min(rays, 0xffffu) | (min(shadow_rays, 0xffffu) << 16u);
    px.capped = capped;
    pixels[gid.y * p.width + gid.x] = px;
}

// The first hit of each ray of a batch (leaf_hit::cast with nothing skipped), for checking
// the traversal against the CPU on arbitrary rays.
@compute @workgroup_size(64, 1, 1)
fn cast_rays(@builtin(global_invocation_id) gid: vec3<u32>,
             @builtin(local_invocation_index) lidx: u32) {
    lane = lidx;
    let i = gid.x;
    if i >= arrayLength(&ray_in) {
        return;
    }
    let r = ray_in[i];
    var q: Query;
    q.kind = 0u;
    q.tmin = r.tmin;
    q.tmax = r.tmax;
    q.skip = NO_SKIP;
    q.medium = NO_MEDIUM;
    q.half_cell = 0.0;
    q.path = 0u;
    let o = traverse(r.origin, r.dir, q);
    var out = RayOut(u.params.infinity, NO_LEAF, o.steps, select(0u, 1u, o.capped));
    if o.hit {
        out.t = o.t;
        out.leaf = o.leaf;
    }
    ray_out[i] = out;
}

// ---- primary tiles: where a block of primary rays may start ------------------------------
//
// One invocation per TILE x TILE block of pixels (the last row and column of blocks may be
// smaller). The block's rays all leave the eye inside the cone around their mean direction
// through its four corner pixels' rays (the rays of a rectangle of pixels span a convex patch
// of directions, farthest from the mean at a corner), widened for rounding. The walk goes
// down the tree, nearest octant first, into the children whose bounding spheres meet the
// cone and that are nearer than the nearest leaf cell found so far. No ray of the block
// enters a leaf cell nearer than that distance, so its primary rays start their traversal at
// the distance's ray parameter less a margin (1e-4 of it, far above the rounding of a plane
// parameter): every leaf cell a ray enters it enters at the same plane parameter as from the
// eye, so its leaves, hits and image are those of a traversal from the eye, bit for bit, and
// only the empty space before them is skipped. Nothing in the cone: the block's rays miss
// (+inf). A walk past TILE_VISITS children, or a malformed tree, starts the block at the eye.
// The walk's loop ends on its own: every pass counts a visit and the walk stops past
// TILE_VISITS.
const TILE: u32 = 8u;
const TILE_VISITS: u32 = 4096u;

// Whether a sphere of radius r around v (relative to the cone's apex) meets the solid cone
// of unit axis `axis` and half-angle t (sin_t, cos_t; t below 90 degrees). In the plane of
// the axis and v, the point nearest v on the cone is the apex when v projects behind the
// cone's edge, else on the edge, at the signed distance perp cos t - along sin t.
fn cone_meets(v: vec3<f32>, axis: vec3<f32>, sin_t: f32, cos_t: f32, r: f32) -> bool {
    let len_v = length(v);
    if len_v <= r {
        return true;
    }
    let along = dot(v, axis);
    let perp = length(cross(v, axis));
    if along * cos_t + perp * sin_t < 0.0 {
        return false;
    }
    return perp * cos_t - along * sin_t <= r;
}

// The ray parameter the primary rays of block i (of tiles_x across) start at.
fn tile_start(i: u32, tiles_x: u32) -> f32 {
    let p = u.params;
    let x0 = (i % tiles_x) * TILE;
    let y0 = (i / tiles_x) * TILE;
    let x1 = min(x0 + TILE - 1u, p.width - 1u);
    let y1 = min(y0 + TILE - 1u, p.height - 1u);
    let d0 = camera_dir(x0, y0);
    let d1 = camera_dir(x1, y0);
    let d2 = camera_dir(x0, y1);
    let d3 = camera_dir(x1, y1);
    let axis = normalize(d0 + d1 + d2 + d3);
    let cos_min = min(min(dot(axis, d0), dot(axis, d1)), min(dot(axis, d2), dot(axis, d3)));
    if !(cos_min > 0.5) {
        // A block wider than 60 degrees (or a camera that makes no directions).
        return 0.0;
    }
    // The sine of the widest angle, from cross products (exact to a few ulps at any angle,
    // where 1 - cos is not), widened.
    let s = max(max(length(cross(axis, d0)), length(cross(axis, d1))),
                max(length(cross(axis, d2)), length(cross(axis, d3))));
    let sin_t = s * 1.001 + 1e-5;
    let cos_t = sqrt(max(1.0 - sin_t * sin_t, 0.0));
    let depth = p.depth;
    if depth == 0u || depth > MAX_DEPTH {
        return 0.0;
    }
    let eye = p.eye;
    let oct = select(0u, 4u, axis.x < 0.0) | select(0u, 2u, axis.y < 0.0) | select(0u, 1u, axis.z < 0.0);
    // Ancestors: their child mask with the next child's rank in the nearest-first order
    // above it, and their first child's index.
    var stack: array<vec2<u32>, MAX_DEPTH>;
    var len = 0u;
    var node = node_at(0u);
    var corner = vec3<u32>(0u);
    var side = 1u << depth;
    var k = 0u;
    var best = p.infinity;
    var visits = 0u;
    loop {
        if k == 8u {
            if len == 0u {
                break;
            }
            len -= 1u;
            let f = stack[len];
            node = Node(f.x & 0xffu, f.y);
            k = f.x >> 8u;
            side *= 2u;
            corner &= vec3<u32>(~(side - 1u));
            continue;
        }
        visits += 1u;
        if visits > TILE_VISITS {
            return 0.0;
        }
        let c = k ^ oct;
        k += 1u;
        if ((node.info >> c) & 1u) == 0u {
            continue;
        }
        let half = side / 2u;
        let lo_u = corner + child_bits(c) * half;
        let lo = vec3<f32>(lo_u);
        let hs = f32(half);
        let dist = length(max(max(lo - eye, eye - (lo + vec3<f32>(hs))), vec3<f32>(0.0)));
        if dist >= best {
            continue;
        }
        let v = lo + vec3<f32>(0.5 * hs) - eye;
        if !cone_meets(v, axis, sin_t, cos_t, 0.8660254 * hs * 1.001 + 1e-5 * length(v)) {
            continue;
        }
        if bitcast<i32>(node.first) < 0 {
            best = dist;
            continue;
        }
        let idx = node.first + countOneBits(node.info & 0xffu & ((1u << c) - 1u));
        if idx >= p.n_nodes || len == MAX_DEPTH || half < 2u {
            return 0.0;
        }
        stack[len] = vec2<u32>((node.info & 0xffu) | (k << 8u), node.first);
        len += 1u;
        node = node_at(idx);
        corner = lo_u;
        side = half;
        k = 0u;
    }
    return best / p.scale * (1.0 - 1e-4);
}

// An invocation per block: x the block's column, y its row.
@compute @workgroup_size(8, 8, 1)
fn tile_bounds(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = u.params;
    let tiles_x = (p.width + TILE - 1u) / TILE;
    if gid.x >= tiles_x || gid.y >= (p.height + TILE - 1u) / TILE {
        return;
    }
    let i = gid.y * tiles_x + gid.x;
    tiles[i] = tile_start(i, tiles_x);
}
