//! The tracer's shader: WESL modules (`src/shaders/trace/*.wesl`, embedded in the binary)
//! linked into one WGSL source by the `wesl` crate when a pipeline is made.
//!
//! The link chooses the walk (the WESL feature `wide_view`) and supplies the module
//! `package::constants`, generated here from the Rust values the shader shares: the light
//! table's size, the markers of a miss and of an interior leaf, the traversal's smallest
//! direction component, the workgroup shape, and the two private stacks' sizes (arrays that
//! pipeline constants cannot size: WGSL zero-initializes private arrays and drivers store
//! every element of one indexed at run time, so each pixel pays for its whole stacks, which
//! are therefore sized for the tree and the bounce limits). Everything else a scene does not
//! need is left out by the pipeline-overridable constants of `package::variant`
//! ([`crate::gpu_types::ShaderVariant`]). Names are not mangled: the overrides keep the
//! names the pipeline sets, and the modules' items are named uniquely.

use crate::gpu_types::MAX_LIGHTS;
use std::borrow::Cow;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use svo::render::MAX_BOUNCES;
use thiserror::Error;
use wesl::{CompileOptions, ManglerKind, ModulePath, VirtualResolver, Wesl};

/// The shader's modules by name, the root (`trace`) first.
const MODULES: [(&str, &str); 11] = [
    ("trace", include_str!("shaders/trace/trace.wesl")),
    ("variant", include_str!("shaders/trace/variant.wesl")),
    ("bindings", include_str!("shaders/trace/bindings.wesl")),
    ("attributes", include_str!("shaders/trace/attributes.wesl")),
    ("ray", include_str!("shaders/trace/ray.wesl")),
    ("leaf_hit", include_str!("shaders/trace/leaf_hit.wesl")),
    (
        "octree_walk",
        include_str!("shaders/trace/octree_walk.wesl"),
    ),
    ("wide_walk", include_str!("shaders/trace/wide_walk.wesl")),
    ("dag_walk", include_str!("shaders/trace/dag_walk.wesl")),
    ("traverse", include_str!("shaders/trace/traverse.wesl")),
    ("shading", include_str!("shaders/trace/shading.wesl")),
];

/// How many modules the shader has (the generated `constants` aside).
pub fn module_count() -> usize {
    MODULES.len()
}

/// The render's workgroup, pixels across and down (`WG_X`, `WG_Y`): on the H100 and H200
/// (docs/gpu-benchmarks.md) 8x8 was the fastest shape or within a few percent of it for
/// every scene measured, with and without bounces.
pub const WORKGROUP: [u32; 2] = [8, 8];

/// The most pending rays of a pixel (`RAY_STACK` at most): two per bounce allowed, plus two.
pub const MAX_RAY_STACK: u32 = 2 * (MAX_BOUNCES as u32) + 2;

/// What a linked shader is for: the walk and the private stacks' sizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShaderLink {
    /// Walk the tree's 64-ary view instead of the octree (the WESL feature `wide_view`).
    pub wide_view: bool,
    /// Walk a tree's graph ([`svo::dag::FlatDag`]) instead of its node array (the WESL
    /// feature `dag`; not with `wide_view`).
    pub dag: bool,
    /// Declare the arena's sixteen bindings instead of four (the WESL feature
    /// `many_bindings`: [`crate::gpu_render::MAX_ARENA_CHUNKS`]).
    pub many_bindings: bool,
    /// The tree's depth, which sizes the ancestor stack (1 to [`svo::MAX_DEPTH`]).
    pub depth: u32,
    /// Pending rays a pixel can have (1 to [`MAX_RAY_STACK`]).
    pub ray_stack: u32,
}

/// A failed link of the shader's modules: a fault of the shader's sources.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ShaderError {
    /// The WESL compiler refused the modules.
    #[error("the tracer's shader modules do not link: {0}")]
    Link(String),
}

/// The `package::constants` module for `link`: WGSL `const` declarations of the values the
/// shader shares with Rust (floats in Rust's shortest form that reads back as the same
/// `f32`).
pub fn constants_module(link: &ShaderLink) -> String {
    let u32s = [
        ("MAX_LIGHTS", MAX_LIGHTS as u32),
        ("NO_LEAF", svo::render::NO_LEAF),
        ("NODE_ID", svo::render::NODE_ID),
        ("NO_NORMAL_WORD", svo::octree::NO_NORMAL),
        ("WG_X", WORKGROUP[0]),
        ("WG_Y", WORKGROUP[1]),
        ("MAX_DEPTH", link.depth.clamp(1, u32::from(svo::MAX_DEPTH))),
        ("RAY_STACK", link.ray_stack.clamp(1, MAX_RAY_STACK)),
    ];
    let mut s: String = u32s
        .iter()
        .map(|(name, v)| format!("const {name}: u32 = {v}u;\n"))
        .collect();
    s.push_str(&format!("const TINY: f32 = {:e}f;\n", svo::trace::TINY));
    s
}

/// The tracer's WGSL for `link`: the modules linked from the root, unused items stripped.
/// Each link is made once a process and kept (a viewer that switches walks, or a benchmark
/// that makes pipelines for many scenes, links each shader once).
pub fn trace_source(link: &ShaderLink) -> Result<Arc<str>, ShaderError> {
    static LINKED: OnceLock<Mutex<HashMap<ShaderLink, Arc<str>>>> = OnceLock::new();
    let linked = LINKED.get_or_init(Default::default);
    // A poisoned lock only means another thread panicked while linking: the map holds
    // finished links only.
    let cached = linked
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .get(link)
        .cloned();
    if let Some(source) = cached {
        return Ok(source);
    }
    let source: Arc<str> = link_modules(link)?.into();
    linked
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .insert(*link, Arc::clone(&source));
    Ok(source)
}

/// Links the modules for `link` (what [`trace_source`] keeps).
fn link_modules(link: &ShaderLink) -> Result<String, ShaderError> {
    let mut resolver = VirtualResolver::new();
    let path = |name: &str| {
        format!("package::{name}")
            .parse::<ModulePath>()
            .map_err(|e| ShaderError::Link(format!("module path {name}: {e}")))
    };
    for (name, source) in MODULES {
        resolver.add_module(path(name)?, Cow::Borrowed(source));
    }
    resolver.add_module(path("constants")?, Cow::Owned(constants_module(link)));
    let mut compiler = Wesl::new_barebones().set_custom_resolver(resolver);
    compiler.set_mangler(ManglerKind::None);
    compiler.set_options(CompileOptions {
        imports: true,
        condcomp: true,
        strip: true,
        // The result is parsed and validated by naga (wgpu), and the CPU tests validate
        // every link; the compiler's own validation is behind a feature not built.
        validate: false,
        ..CompileOptions::default()
    });
    compiler.set_feature("wide_view", link.wide_view);
    compiler.set_feature("dag", link.dag);
    compiler.set_feature("many_bindings", link.many_bindings);
    compiler
        .compile(&path("trace")?)
        .map(|r| r.to_string())
        .map_err(|e| ShaderError::Link(e.to_string()))
}
