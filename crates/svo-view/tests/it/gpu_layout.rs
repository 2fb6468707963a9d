//! CPU-only checks of the shaders: naga parses and validates every `.wgsl` file and the
//! tracer's modules linked for each walk, the structs shared with the GPU
//! (`svo_view::gpu_types`, `svo::octree::Node`) have the sizes and member offsets the WGSL
//! gives them, and the constants the shader shares with Rust have the Rust values.

use naga::valid::{Capabilities, ValidationFlags, Validator};
use std::mem::{offset_of, size_of};
use std::path::Path;
use svo::octree::Node;
use svo_tests::harness::Test;
use svo_tests::trial;
use svo_view::gpu_types::{GpuLight, GpuParams, GpuPixel, GpuRay, GpuRayHit, GpuUniforms};
use svo_view::shader::{MAX_RAY_STACK, ShaderLink, trace_source};

fn shader_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src/shaders")
}

fn parse(src: &str, name: &str) -> naga::Module {
    naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)))
}

/// The tracer's WGSL linked for `link`, parsed and validated.
fn linked(link: &ShaderLink) -> (String, naga::Module) {
    let src = trace_source(link).unwrap_or_else(|e| panic!("{link:?}: {e}"));
    let m = parse(&src, &format!("the tracer linked for {link:?}"));
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&m)
        .unwrap_or_else(|e| panic!("{link:?}: {}", e.emit_to_string(&src)));
    (src.to_string(), m)
}

/// The default link: the octree walk, stacks of the most the shader allows.
fn default_link() -> ShaderLink {
    ShaderLink {
        wide_view: false,
        dag: false,
        many_bindings: false,
        depth: 30,
        ray_stack: MAX_RAY_STACK,
    }
}

fn every_wgsl_file_parses_and_validates() {
    let mut n = 0;
    for entry in std::fs::read_dir(shader_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "wgsl") {
            let src = std::fs::read_to_string(&path).unwrap();
            let name = path.display().to_string();
            let module = parse(&src, &name);
            Validator::new(ValidationFlags::all(), Capabilities::empty())
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
            n += 1;
        }
    }
    assert!(n >= 1, "no shaders found");
    // The tracer's modules, linked for the three walks (the octree, the 64-ary view, the
    // graph): each link keeps its walk's pieces alone and both entry points.
    // Each with the arena's four bindings, and with its sixteen.
    let walks = [(false, false), (true, false), (false, true)];
    for (wide_view, dag, many_bindings) in
        walks.map(|(w, d)| [(w, d, false), (w, d, true)]).concat()
    {
        let (src, m) = linked(&ShaderLink {
            wide_view,
            dag,
            many_bindings,
            ..default_link()
        });
        let has = |name: &str| {
            m.global_variables
                .iter()
                .any(|(_, g)| g.name.as_deref() == Some(name))
        };
        assert_eq!(has("wstack"), wide_view, "{src}");
        assert_eq!(has("tstack"), !wide_view, "{src}");
        assert_eq!(has("bstack"), dag, "{src}");
        assert!(has("arena3"), "{src}");
        assert_eq!(has("arena15"), many_bindings, "{src}");
        for entry in ["main", "cast_rays"] {
            assert!(m.entry_points.iter().any(|e| e.name == entry), "{entry}");
        }
    }
    // Every module is a file of the folder, and every file a module of the shader.
    let files = std::fs::read_dir(shader_dir().join("trace"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "wesl")
        })
        .count();
    assert_eq!(files, svo_view::shader::module_count());
}

/// The WGSL struct `name`: its size and `(member, offset)` in order.
fn wgsl_struct(module: &naga::Module, name: &str) -> (usize, Vec<(String, usize)>) {
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name)
            && let naga::TypeInner::Struct { members, span } = &ty.inner
        {
            return (
                *span as usize,
                members
                    .iter()
                    .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
                    .collect(),
            );
        }
    }
    panic!("no struct {name} in the shader");
}

macro_rules! rust_struct {
    ($t:ty; $($f:ident),* $(,)?) => {
        (size_of::<$t>(), vec![$((stringify!($f).to_string(), offset_of!($t, $f))),*])
    };
}

fn shared_structs_match_the_wgsl() {
    let (_, m) = linked(&default_link());
    let cases = [
        (
            "Params",
            rust_struct!(GpuParams; eye, scale, forward, bias, right, px_scale_x, up, px_scale_y,
                sky_zenith, half_w, sky_horizon, half_h, sky_ground, ambient, sky_up, diffuse,
                width, height, depth, max_steps, n_lights, max_reflections, max_refractions,
                n_nodes, const_normal, const_contour, const_colour, const_reflectivity,
                const_refractivity, const_ior, specular, shininess, infinity, shadow_mode,
                nodes_at, normal_at, contour_at, colour_at, reflectivity_at, refractivity_at,
                ior_at, arena_shift, max_path_bounces, view_at, node_normal_at, node_contour_at,
                node_colour_at, node_reflectivity_at, node_refractivity_at, node_ior_at,
                lod_spread, dag_refs_at, dag_bricks_at, dag_boxes_at, dag_values, pad),
        ),
        (
            "Light",
            rust_struct!(GpuLight; position, intensity, colour, pad),
        ),
        ("Uniforms", rust_struct!(GpuUniforms; params, lights, srgb)),
        (
            "Pixel",
            rust_struct!(GpuPixel; colour, depth, normal, leaf, primary_steps, steps, rays,
                capped),
        ),
        ("Node", rust_struct!(Node; info, first)),
        ("RayIn", rust_struct!(GpuRay; origin, tmin, dir, tmax)),
        ("RayOut", rust_struct!(GpuRayHit; t, leaf, steps, capped)),
    ];
    for (name, rust) in cases {
        let wgsl = wgsl_struct(&m, name);
        assert_eq!(wgsl, rust, "struct {name}: WGSL (size, members) vs Rust");
    }
    // The blit shader reads the same pixels, and its parameters are two uvec2.
    let blit = parse(svo_view::window_blit::BLIT_WGSL, "blit.wgsl");
    assert_eq!(
        wgsl_struct(&blit, "Pixel"),
        rust_struct!(GpuPixel; colour, depth, normal, leaf, primary_steps, steps, rays, capped)
    );
    assert_eq!(
        wgsl_struct(&blit, "BlitParams"),
        rust_struct!(svo_view::window_blit::BlitParams; frame, dest)
    );
}

fn shader_constants_name_real_overrides() {
    // Every pipeline constant the variant sets exists in the shader (a typo would make
    // pipeline creation fail at run time, and only on a GPU).
    let (_, m) = linked(&default_link());
    let names: Vec<String> = m
        .overrides
        .iter()
        .filter_map(|(_, o)| o.name.clone())
        .collect();
    let v = svo_view::gpu_types::ShaderVariant::everything(
        svo_view::gpu_types::ShaderVariant::for_scene(
            &svo::Octree::from_cells(
                svo::octree::RootCube {
                    origin: glam::DVec3::ZERO,
                    side: 1.0,
                },
                2,
                [(glam::UVec3::ZERO, svo::octree::Voxel::default())],
            )
            .unwrap(),
            &svo::render::TraceOptions::default(),
            1,
        ),
    );
    // The renderer adds the arena's chunk count; BOUNCES is derived in the shader.
    let mut constants = v.constants();
    constants.push(("ARENA_CHUNKS", 1.0));
    for (c, _) in &constants {
        assert!(
            names.iter().any(|n| n == c),
            "{c} is not an override of the shader"
        );
    }
    assert!(names.iter().any(|n| n == "BOUNCES"));
    assert_eq!(names.len(), constants.len() + 1, "overrides {names:?}");
}

/// The value of the WGSL constant `name` of `m`, as `f64` (u32 or f32 literals).
fn constant(m: &naga::Module, name: &str) -> f64 {
    let (_, c) = m
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no constant {name}"));
    match m.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::U32(v)) => f64::from(v),
        naga::Expression::Literal(naga::Literal::F32(v)) => f64::from(v),
        ref other => panic!("{name} = {other:?}"),
    }
}

fn constants_shared_with_rust_have_the_rust_values() {
    // The module `constants` is generated from the Rust values; what naga reads from the
    // linked WGSL is each value exactly, the float to the bit.
    let (_, m) = linked(&default_link());
    let tiny = constant(&m, "TINY") as f32;
    assert_eq!(tiny.to_bits(), svo::trace::TINY.to_bits());
    for (name, v) in [
        ("MAX_LIGHTS", svo_view::gpu_types::MAX_LIGHTS as u32),
        ("NO_LEAF", svo::render::NO_LEAF),
        ("NO_NORMAL_WORD", svo::octree::NO_NORMAL),
        ("WG_X", svo_view::shader::WORKGROUP[0]),
        ("WG_Y", svo_view::shader::WORKGROUP[1]),
    ] {
        assert_eq!(constant(&m, name), f64::from(v), "{name}");
    }
    // The uniform table of lights is the Rust array's size.
    let (_, members) = wgsl_struct(&m, "Uniforms");
    assert_eq!(
        members[2].1 - members[1].1,
        size_of::<[GpuLight; svo_view::gpu_types::MAX_LIGHTS]>()
    );
}

fn stacks_sized_for_the_scene_still_validate() {
    // The link sizes the two private stacks for the scene (function arrays cannot be sized
    // by pipeline constants): each size must land, and the result must still validate.
    for (rays, depth) in [(1, 1), (4, 8), (8, 10), (MAX_RAY_STACK, 30)] {
        for (wide_view, dag) in [(false, false), (true, false), (false, true)] {
            let (_, m) = linked(&ShaderLink {
                wide_view,
                dag,
                many_bindings: false,
                depth,
                ray_stack: rays,
            });
            let len = |ty: naga::Handle<naga::Type>| match &m.types[ty].inner {
                naga::TypeInner::Array {
                    size: naga::ArraySize::Constant(n),
                    ..
                } => n.get(),
                other => panic!("not a sized array: {other:?}"),
            };
            if !wide_view {
                let tstack = m.global_variables.iter().map(|(_, g)| g);
                let tstack = tstack.filter(|g| g.name.as_deref() == Some("tstack"));
                let tstack: Vec<u32> = tstack.map(|g| len(g.ty)).collect();
                assert_eq!(tstack, [depth], "the ancestor stack");
            }
            let main = m.entry_points.iter().find(|e| e.name == "main").unwrap();
            let locals = main.function.local_variables.iter().map(|(_, l)| l);
            let rstack: Vec<u32> = locals
                .filter(|l| l.name.as_deref() == Some("stack"))
                .map(|l| len(l.ty))
                .collect();
            assert_eq!(rstack, [rays], "the ray stack");
        }
    }
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(every_wgsl_file_parses_and_validates),
        trial!(shared_structs_match_the_wgsl),
        trial!(shader_constants_name_real_overrides),
        trial!(constants_shared_with_rust_have_the_rust_values),
        trial!(stacks_sized_for_the_scene_still_validate),
    ]
}
