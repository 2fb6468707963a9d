//! `svo-view`: render `.svo` files, or print their header and statistics.
//!
//! ```text
//! svo-view bunny.svo                                 # the window (GPU)
//! svo-view bunny.svo --headless -o bunny.png          # GPU, no window
//! svo-view bunny.svo --headless --bench 100 --vs-cpu  # GPU timing, checked against the CPU
//! svo-view bunny.svo --cpu -o bunny.png               # the CPU reference tracer
//! svo-view bunny.svo --cpu --aov cost -o cost.png
//! svo-view bunny.svo --info
//! ```
//! The work is in the library: the CPU path is [`svo_view::cpu_render::render_file`], the
//! GPU path [`svo_view::headless::run`], the window `svo_view::window::run`; this file parses
//! arguments and prints the report.
#![forbid(unsafe_code)]

use anyhow::Context;
use clap::Parser;
use glam::DVec3;
use std::path::PathBuf;
use svo::render::{Aov, LightSpec, TraceOptions};
use svo_view::cpu_render::render_file;
use svo_view::job::RenderJob;

/// Render a sparse voxel octree (.svo) file on the GPU or with the CPU ray tracer, or inspect it.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The .svo file.
    file: PathBuf,
    /// Print the header and statistics instead of rendering.
    #[arg(long)]
    info: bool,
    /// Render with the CPU reference tracer.
    #[arg(long, conflicts_with = "headless")]
    cpu: bool,
    /// Render on the GPU without a window (write -o, or benchmark with --bench).
    #[arg(long)]
    headless: bool,
    /// With --headless: render the same frame with the CPU tracer too and print how the two
    /// images differ.
    #[arg(long, requires = "headless")]
    vs_cpu: bool,
    /// With --headless: compile every shader path in (reflection, refraction, shadows,
    /// media) and read every channel per leaf, instead of leaving out what the scene does
    /// not need; the image is the same, the time shows what leaving out saves.
    #[arg(long, requires = "headless")]
    full_shader: bool,
    /// With --headless: the traversal walks the tree's 64-ary view (4x4x4 cells a node,
    /// built on upload) instead of the octree: faster where rays bounce
    /// (docs/gpu-benchmarks.md), slower for the bunny's primary rays alone. The image is the
    /// same; the steps count the view's cells.
    #[arg(long, requires = "headless")]
    wide_view: bool,
    /// In the window: close after this many frames (with -o, saving the last as a PNG).
    #[arg(long, conflicts_with_all = ["cpu", "headless"])]
    quit_after: Option<u32>,
    /// Output image: .png, or .pfm / .exr for `--aov depth`. Default: the file's name with
    /// .png (.pfm for depth); none with --bench unless given. In the window: where the
    /// screenshot key (P) saves.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Camera position x,y,z (scene units). Default: frame the model.
    #[arg(long, value_parser = parse_dvec3)]
    eye: Option<DVec3>,
    /// Point the camera looks at, x,y,z. Default: the model's centre.
    #[arg(long, value_parser = parse_dvec3)]
    target: Option<DVec3>,
    /// Up direction x,y,z. Default: 0,1,0.
    #[arg(long, value_parser = parse_dvec3)]
    up: Option<DVec3>,
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 40.0)]
    fov: f64,
    /// A camera view stored in the file (by name or index), with its field of view. Default:
    /// the file's first view, unless --eye is given.
    #[arg(long, conflicts_with_all = ["eye", "target", "up"])]
    view: Option<String>,
    /// Read only the file's top K levels, as a coarser tree whose leaves are the nodes of
    /// level K (a version-4 file is read as a prefix, a version-3 one chunk by chunk, a
    /// version-2 one whole, then cut).
    #[arg(long, value_name = "K")]
    max_depth: Option<u8>,
    /// Level of detail, in pixels: a ray stops at the first inner node no wider than PIXELS
    /// times its pixel's footprint there and hits the node's contour with the node's
    /// attributes (a file baked with --lod filtered; not with --wide-view). 0 walks to the
    /// leaves.
    #[arg(
        long,
        value_name = "PIXELS",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    lod: f32,
    /// How leaves are hit: cube, contour, or exact (the mesh's triangles in each leaf; needs
    /// --mesh or --reference).
    #[arg(long, default_value = "contour")]
    hit: svo::trace::HitMode,
    /// Reflection and refraction depth limit (each).
    #[arg(long, default_value_t = 3)]
    bounces: u8,
    /// Reflection depth limit (overrides --bounces).
    #[arg(long)]
    reflections: Option<u8>,
    /// Refraction depth limit (overrides --bounces).
    #[arg(long)]
    refractions: Option<u8>,
    /// The most reflections and refractions together along one ray path (the depth of the ray
    /// tree). 1 is the 2015 thesis's tracer: primary, reflection and refraction rays, no more.
    /// Default: only the limits above
    #[arg(long)]
    path_bounces: Option<u8>,
    /// Point light `x,y,z[:r,g,b[:intensity]]` (repeatable). Default: the file's lights, else
    /// one white light above the camera; intensity defaults to the squared distance to the
    /// model's centre.
    #[arg(long, value_parser = parse_light)]
    light: Vec<LightSpec>,
    /// Shadows: none, opaque, max (the 2019 report's max-refractivity rule) or product
    /// (transmittance product).
    #[arg(long, default_value = "product")]
    shadows: svo::render::ShadowMode,
    /// Fresnel formula: exact or schlick.
    #[arg(long, default_value = "exact")]
    fresnel: svo::render::FresnelMode,
    /// Write an AOV instead of the colour: depth (float .pfm/.exr, +inf on a miss), normal,
    /// leaf, cost (traversal steps heat map).
    #[arg(long)]
    aov: Option<Aov>,
    /// With --cpu: trace every primary ray from the eye, without the prepass (the projection
    /// of the octree front to back that decides the primary rays of a band of rows at once).
    /// The image is the same.
    #[arg(long)]
    no_prepass: bool,
    /// With --cpu: walk every ray alone, instead of the rays of four neighbouring pixels
    /// together where that applies (primary rays without the prepass; shadow rays where no
    /// ray bounces). The image is the same.
    #[arg(long)]
    no_packets: bool,
    /// Offset of secondary and shadow rays from the surface, in cells.
    #[arg(long, default_value_t = TraceOptions::default().bias_cells)]
    bias: f32,
    /// Render this many timed frames after a warm-up and print the median.
    #[arg(long, num_args = 0..=1, default_missing_value = "10")]
    bench: Option<u32>,
    /// With --bench: cast the primary rays alone (the first hit and its distance per pixel;
    /// no shading and no image), as a ray-casting library such as Embree returns them.
    #[arg(long, requires = "bench", requires = "cpu")]
    cast: bool,
    /// Render this triangle mesh (the reference) instead of the octree; with --compare,
    /// render both and print RMSE, PSNR and the hit/miss disagreement (beside the output,
    /// the reference's image in the same AOV as NAME.reference.EXT, and the colour difference,
    /// scaled by 4, always as the PNG NAME.diff.png whatever the AOV).
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Render the octree and the --reference mesh and compare them.
    #[arg(long, requires = "reference")]
    compare: bool,
    /// The mesh the tree was baked from, for --hit exact (default: the --reference mesh).
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// A cube-map sky: a folder with px, nx, py, ny, pz, nz (.png or .jpg, square, OpenGL
    /// orientation). Default: a procedural gradient.
    #[arg(long)]
    sky: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// `println!` that returns the error instead of panicking, so that a closed pipe
/// (`svo-view ... | head`) ends the program quietly.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($t)*)?;
    }};
}

fn main() {
    if let Err(e) = real_main() {
        // The reader of stdout went away (`| head`): nothing is wrong with the work.
        if e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        {
            return;
        }
        eprintln!("svo-view: error: {e:#}");
        std::process::exit(1);
    }
}

fn real_main() -> anyhow::Result<()> {
    let args = Args::parse();
    if args.info {
        let text = svo::io::describe_file(&args.file)
            .with_context(|| format!("loading {}", args.file.display()))?;
        say!("{}\n{}", args.file.display(), text);
        return Ok(());
    }
    let aov = args.aov.unwrap_or_default();
    let output = args.output.clone().or_else(|| {
        args.bench.is_none().then(|| {
            let ext = if aov == Aov::Depth { "pfm" } else { "png" };
            args.file.with_extension(ext)
        })
    });
    let job = RenderJob {
        input: args.file.clone(),
        output,
        width: args.size.0,
        height: args.size.1,
        eye: args.eye,
        target: args.target,
        up: args.up,
        fov_deg: args.fov,
        trace: TraceOptions {
            mode: args.hit,
            max_reflections: args.reflections.unwrap_or(args.bounces),
            max_refractions: args.refractions.unwrap_or(args.bounces),
            max_path_bounces: args.path_bounces.unwrap_or(u8::MAX),
            shadows: args.shadows,
            fresnel: args.fresnel,
            bias_cells: args.bias,
            prepass: !args.no_prepass,
            packets: !args.no_packets,
            lod: args.lod,
            ..TraceOptions::default()
        },
        lights: args.light.clone(),
        view: args.view.clone(),
        aov,
        bench_frames: args.bench,
        cast: args.cast,
        threads: args.threads,
        reference: args.reference.clone(),
        compare: args.compare,
        mesh: args.mesh.clone(),
        sky_cube_map: args.sky.clone(),
        max_depth: args.max_depth,
    };
    if args.cast && !args.cpu {
        anyhow::bail!("--cast times the CPU tracer's primary rays: it goes with --cpu --bench");
    }
    if (args.vs_cpu || args.full_shader) && !args.headless {
        anyhow::bail!("--vs-cpu and --full-shader go with --headless");
    }
    if args.headless {
        let opts = svo_view::headless::HeadlessOptions {
            vs_cpu: args.vs_cpu,
            everything: args.full_shader,
            layout: svo_view::gpu_render::GpuLayout {
                wide_view: args.wide_view,
                ..Default::default()
            },
        };
        let report = svo_view::headless::run(&job, &opts)
            .with_context(|| format!("rendering {} on the GPU", args.file.display()))?;
        if args.json {
            say!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            say!("{report}");
        }
        return Ok(());
    }
    if !args.cpu {
        return window(&args, &job);
    }
    let report = render_file(&job).with_context(|| format!("rendering {}", args.file.display()))?;
    if args.json {
        say!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        say!("{report}");
    }
    Ok(())
}

#[cfg(feature = "window")]
fn window(args: &Args, job: &RenderJob) -> anyhow::Result<()> {
    let opts = svo_view::window::WindowOptions {
        quit_after: args.quit_after,
        screenshot: args.output.clone(),
    };
    let report = svo_view::window::run(job, &opts)
        .with_context(|| format!("showing {}", args.file.display()))?;
    if report.frames > 0 {
        say!(
            "{}: {} frames, first after {:.0} ms, median {:.2} ms/frame",
            report.adapter,
            report.frames,
            report.startup_ms,
            report.median_frame_ms
        );
    }
    for p in &report.screenshots {
        say!("wrote {}", p.display());
    }
    Ok(())
}

#[cfg(not(feature = "window"))]
fn window(_args: &Args, _job: &RenderJob) -> anyhow::Result<()> {
    anyhow::bail!(
        "this svo-view was built without the window feature: render with --headless (GPU) or --cpu"
    )
}

/// Parses a point light, `x,y,z[:r,g,b[:intensity]]`.
fn parse_light(s: &str) -> Result<LightSpec, String> {
    let mut parts = s.split(':');
    let position = parse_dvec3(parts.next().unwrap_or(""))
        .map_err(|e| format!("light {s:?}: position: {e}"))?;
    let colour = parts
        .next()
        .map(|c| parse_dvec3(c).map(DVec3::as_vec3))
        .transpose()
        .map_err(|e| format!("light {s:?}: colour: {e}"))?;
    if colour.is_some_and(|c| c.min_element() < 0.0) {
        return Err(format!("light {s:?}: colour must not be negative"));
    }
    let intensity = parts
        .next()
        .map(|i| match i.trim().parse::<f32>() {
            Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
            _ => Err(format!(
                "light {s:?}: intensity {i:?} is not a non-negative number"
            )),
        })
        .transpose()?;
    if parts.next().is_some() {
        return Err(format!("light {s:?}: expected x,y,z[:r,g,b[:intensity]]"));
    }
    Ok(LightSpec {
        position,
        colour,
        intensity,
    })
}

/// Parses `x,y,z` into finite numbers.
fn parse_dvec3(s: &str) -> Result<DVec3, String> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    if v.len() != 3 {
        return Err(format!("{s:?} is not x,y,z"));
    }
    let mut out = [0.0f64; 3];
    for (o, t) in out.iter_mut().zip(&v) {
        *o = t
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{t:?} in {s:?} is not a finite number"))?;
    }
    Ok(DVec3::from_array(out))
}

/// Parses `WIDTHxHEIGHT`.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {s:?} is not WIDTHxHEIGHT"))?;
    let p = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("size {s:?} is not WIDTHxHEIGHT"))
    };
    Ok((p(w)?, p(h)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn light_specs() {
        let l = parse_light("1,2,3").unwrap();
        assert_eq!(l.position, DVec3::new(1.0, 2.0, 3.0));
        assert!(l.colour.is_none() && l.intensity.is_none());
        let l = parse_light("1,2,3:1,0.5,0:40").unwrap();
        assert_eq!(l.colour, Some(Vec3::new(1.0, 0.5, 0.0)));
        assert_eq!(l.intensity, Some(40.0));
        for bad in [
            "",
            "1,2",
            "1,2,x",
            "1,2,3:1,1",
            "1,2,3:1,1,1:-1",
            "1,2,3:1,1,1:1:1",
            "nan,1,1",
            "1,2,3:-1,0,0",
        ] {
            assert!(parse_light(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn sizes() {
        assert_eq!(parse_size("1920x1080"), Ok((1920, 1080)));
        assert!(
            parse_size("1920").is_err()
                && parse_size("ax2").is_err()
                && parse_size("-1x2").is_err()
        );
    }
}
