//! The CPU tracer's error against run time on a mesh (the bunny by default): for each depth
//! and hit mode (cube, contour, exact triangles), the time per frame of a shaded render
//! beside its image error against the triangle reference (RMSE, PSNR, hit/miss
//! disagreement) and its geometric error (how far each primary hit lies from the reference's,
//! in cells), and the octree against the dense-grid DDA on the same primary rays. Prints
//! Markdown and draws two plots (PNG, plotters) into the output folder.
//!
//! `cargo run --release -p svo-examples --example trace_tables -- [mesh] [WxH] [runs] [min_depth] [max_depth] [out_dir]`

use glam::Vec3;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;
use svo::camera::{Camera, CameraRays};
use svo::exact_surfaces::exact_surfaces;
use svo::grid_dda::{DenseGrid, MAX_DDA_DEPTH, traverse_dda};
use svo::grid_ray::GridRay;
use svo::leaf_hit::{HitMode, cast, leaf_hit};
use svo::mesh_reference::MeshSurfaces;
use svo::octree_traverse::MAX_STEPS;
use svo::render::{Frame, render_timed};
use svo::shading::{Phong, PointLight};
use svo::sky::Sky;
use svo::surfaces::{OctreeSurfaces, Surfaces};
use svo::whitted::{TraceOptions, Tracer};
use svo::{BakeOptions, bake_mesh};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Renders `runs` times after a warm-up; the last frame and the median seconds.
fn timed<S: Surfaces>(t: &Tracer<S>, cam: &Camera, runs: u32) -> (Frame, f64) {
    let (f, times) = render_timed(t, cam, Some(runs)).expect("camera");
    (f, median(times))
}

/// Depth error of the primary hits against the reference, in cells: mean and 95th
/// percentile over pixels where both hit.
fn depth_error(a: &Frame, r: &Frame, cells_per_unit: f64) -> (f64, f64) {
    let mut e: Vec<f64> = a
        .depth
        .iter()
        .zip(&r.depth)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| f64::from((x - y).abs()) * cells_per_unit)
        .collect();
    if e.is_empty() {
        return (0.0, 0.0);
    }
    let mean = e.iter().sum::<f64>() / e.len() as f64;
    let k = ((e.len() - 1) as f64 * 0.95) as usize;
    let p95 = *e.select_nth_unstable_by(k, f64::total_cmp).1;
    (mean, p95)
}

/// Casts every primary ray of `rays` with `cast` (cube hits) in parallel rows; returns the
/// hit parameters and the median seconds.
fn primary_only(
    rays: &CameraRays,
    w: u32,
    h: u32,
    eye: Vec3,
    scale: f32,
    runs: u32,
    cast: &(dyn Fn(&GridRay) -> Option<f32> + Sync),
) -> (Vec<Option<f32>>, f64) {
    use rayon::prelude::*;
    let once = || -> Vec<Option<f32>> {
        (0..h)
            .into_par_iter()
            .flat_map_iter(|y| {
                (0..w).map(move |x| {
                    let d = rays.dir_f32(x, y);
                    cast(&GridRay {
                        origin: eye,
                        dir: d * scale,
                    })
                })
            })
            .collect()
    };
    let mut out = once();
    let mut times = Vec::new();
    for _ in 0..runs {
        let t0 = Instant::now();
        out = once();
        times.push(t0.elapsed().as_secs_f64());
    }
    (out, median(times))
}

/// One point of the error-against-time plot.
struct Row {
    depth: u8,
    mode: &'static str,
    ms: f64,
    psnr: f64,
}

fn register_font() -> anyhow::Result<()> {
    for p in [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/TTF/DejaVuSans.ttf",
        "/Library/Fonts/Arial.ttf",
    ] {
        if let Ok(bytes) = std::fs::read(p) {
            plotters::style::register_font(
                "sans-serif",
                FontStyle::Normal,
                Box::leak(bytes.into_boxed_slice()),
            )
            .map_err(|_| anyhow::anyhow!("cannot use the font {p}"))?;
            return Ok(());
        }
    }
    anyhow::bail!("no TrueType font found for the plots (install fonts-dejavu-core)")
}

fn plot_error_vs_time(rows: &[Row], reference_ms: &[(u8, f64)], path: &Path) -> anyhow::Result<()> {
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let max_ms = rows.iter().map(|r| r.ms).fold(1.0, f64::max) * 1.1;
    let psnr = |r: &Row| r.psnr.min(70.0);
    let (lo, hi) = rows
        .iter()
        .map(psnr)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let mut c = ChartBuilder::on(&root)
        .caption(
            "Image error against time per frame (bunny, triangle reference)",
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..max_ms, (lo - 2.0).floor()..(hi + 2.0).ceil())?;
    c.configure_mesh()
        .x_desc("ms per frame (median)")
        .y_desc("PSNR vs triangles, dB (capped at 70)")
        .draw()?;
    for (mode, colour) in [("cube", RED), ("contour", BLUE), ("exact", GREEN)] {
        let pts: Vec<(f64, f64, u8)> = rows
            .iter()
            .filter(|r| r.mode == mode)
            .map(|r| (r.ms, psnr(r), r.depth))
            .collect();
        c.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), &colour))?
            .label(mode)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        c.draw_series(pts.iter().map(|&(x, y, d)| {
            EmptyElement::at((x, y))
                + Circle::new((0, 0), 3, colour.filled())
                + Text::new(format!("d{d}"), (5, -12), ("sans-serif", 12))
        }))?;
    }
    // The triangle reference takes about the same time at every depth: one marker at its
    // median.
    if !reference_ms.is_empty() {
        let ms = median(reference_ms.iter().map(|r| r.1).collect());
        let y = (lo - 1.0).floor();
        c.draw_series(std::iter::once(
            EmptyElement::at((ms, y))
                + TriangleMarker::new((0, 0), 6, BLACK.filled())
                + Text::new("triangles (BVH), median", (8, -6), ("sans-serif", 13)),
        ))?;
    }
    c.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    root.present()?;
    Ok(())
}

fn plot_octree_vs_dda(rows: &[(u8, f64, f64)], path: &Path) -> anyhow::Result<()> {
    let root = BitMapBackend::new(path, (900, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let max_ms = rows.iter().map(|r| r.1.max(r.2)).fold(1.0, f64::max) * 1.15;
    let (d0, d1) = (
        rows.first().map_or(4, |r| r.0),
        rows.last().map_or(10, |r| r.0),
    );
    let mut c = ChartBuilder::on(&root)
        .caption(
            "Primary rays, cube hits: octree against dense-grid DDA",
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(f64::from(d0) - 0.3..f64::from(d1) + 0.3, 0.0..max_ms)?;
    c.configure_mesh()
        .x_desc("depth")
        .y_desc("ms per frame (median)")
        .draw()?;
    for (i, (name, colour)) in [("octree", BLUE), ("DDA", RED)].into_iter().enumerate() {
        c.draw_series(LineSeries::new(
            rows.iter()
                .map(|r| (f64::from(r.0), if i == 0 { r.1 } else { r.2 })),
            &colour,
        ))?
        .label(name)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        c.draw_series(rows.iter().map(|r| {
            Circle::new(
                (f64::from(r.0), if i == 0 { r.1 } else { r.2 }),
                3,
                colour.filled(),
            )
        }))?;
    }
    c.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    root.present()?;
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "../shared/models/stanford/stanford-bunny.obj".into());
    let (w, h) = svo::render_job::parse_size(&args.next().unwrap_or_else(|| "960x540".into()))
        .map_err(anyhow::Error::msg)?;
    let runs: u32 = args.next().map_or(Ok(3), |s| s.parse())?;
    let d0: u8 = args.next().map_or(Ok(4), |s| s.parse())?;
    let d1: u8 = args.next().map_or(Ok(10), |s| s.parse())?;
    let out = PathBuf::from(args.next().unwrap_or_else(|| "docs/bench".into()));
    let mesh = svo::import::load_mesh(Path::new(&path))?;
    let threads = rayon::current_num_threads();
    println!(
        "{path}: {} triangles, {w}x{h}, {threads} threads, median of {runs} frames after a warm-up\n",
        mesh.triangles.len()
    );
    println!(
        "| depth | leaves | hit | ms/frame | RMSE | PSNR dB | hit/miss differs | depth error mean / p95 (cells) | steps per primary ray |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    let mut ref_ms = Vec::new();
    let mut dda_rows = Vec::new();
    for depth in d0..=d1 {
        let opts = BakeOptions {
            depth,
            ..BakeOptions::default()
        };
        let (tree, _) = bake_mesh(&mesh, &opts, &|_, _| {})?;
        let (lo, hi) = svo::render_job::occupied_bounds(&tree);
        let cam = Camera::framing(lo, hi, w, h, 40.0);
        let rays = cam.rays()?;
        let dist = (cam.eye - cam.target).length();
        let centre = (lo + hi) * 0.5;
        let light_pos = cam.eye + (rays.up() * 0.8 + rays.right() * 0.5) * dist;
        let light = PointLight {
            position: light_pos,
            colour: Vec3::ONE,
            intensity: (light_pos - centre).length_squared() as f32,
        };
        let topts = TraceOptions::default();
        fn tracer_for<S: Surfaces>(s: S, light: PointLight, o: TraceOptions) -> Tracer<S> {
            Tracer::new(s, &[light], Sky::default(), Phong::default(), o)
        }
        let (reference, rms) = timed(
            &tracer_for(
                MeshSurfaces::new(mesh.clone(), tree.root, depth),
                light,
                topts,
            ),
            &cam,
            runs,
        );
        ref_ms.push((depth, rms * 1e3));
        let cells_per_unit = f64::from(1u32 << depth) / tree.root.side;
        let mut emit = |mode: &'static str, f: &Frame, s: f64| {
            let d = svo::image_compare::compare(f, &reference).expect("same size");
            let (dm, dp) = depth_error(f, &reference, cells_per_unit);
            let steps = f.stats.primary_steps as f64 / f.stats.primary_rays.max(1) as f64;
            println!(
                "| {depth} | {} | {mode} | {:.1} | {:.2} | {:.2} | {:.3}% | {:.3} / {:.3} | {:.1} |",
                tree.leaf_count,
                s * 1e3,
                d.rmse,
                d.psnr_db,
                100.0 * d.hit_mismatch,
                dm,
                dp,
                steps
            );
            rows.push(Row {
                depth,
                mode,
                ms: s * 1e3,
                psnr: d.psnr_db,
            });
        };
        for mode in [HitMode::Cube, HitMode::Contour] {
            let (f, s) = timed(
                &tracer_for(OctreeSurfaces::new(&tree, mode), light, topts),
                &cam,
                runs,
            );
            emit(mode.name(), &f, s);
        }
        let exact = exact_surfaces(&tree, &mesh).map_err(anyhow::Error::msg)?;
        let (f, s) = timed(&tracer_for(exact, light, topts), &cam, runs);
        emit("exact", &f, s);
        println!(
            "| {depth} | | triangles (BVH) | {:.1} | 0 | inf | 0 | 0 | |",
            rms * 1e3
        );

        // Octree against DDA: the same primary rays, cube hits, no shading.
        if depth <= MAX_DDA_DEPTH {
            let grid = DenseGrid::new(&tree)?;
            let eye = tree.root.to_grid(cam.eye, depth).as_vec3();
            let scale = cells_per_unit as f32;
            let oct = |r: &GridRay| {
                cast(&tree, r, 0.0, f32::INFINITY, HitMode::Cube, None, MAX_STEPS)
                    .hit
                    .map(|h| h.t)
            };
            let dda = |r: &GridRay| {
                traverse_dda(&grid, &tree, r, 0.0, f32::INFINITY, MAX_STEPS, |e| {
                    leaf_hit(&tree, r, e, HitMode::Cube)
                })
                .hit
                .map(|h| h.t)
            };
            let (a, ta) = primary_only(&rays, w, h, eye, scale, runs, &oct);
            let (b, tb) = primary_only(&rays, w, h, eye, scale, runs, &dda);
            let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            dda_rows.push((depth, ta * 1e3, tb * 1e3, differ, grid.bytes()));
        }
    }
    println!(
        "\n| depth | octree ms/frame | DDA ms/frame | DDA / octree | pixels that differ | DDA grid bytes |"
    );
    println!("|---|---|---|---|---|---|");
    for &(d, a, b, differ, bytes) in &dda_rows {
        println!(
            "| {d} | {a:.1} | {b:.1} | {:.2}x | {differ} | {bytes} |",
            b / a
        );
    }
    std::fs::create_dir_all(&out)?;
    register_font()?;
    let p1 = out.join("trace_error_vs_time.png");
    plot_error_vs_time(&rows, &ref_ms, &p1)?;
    let dd: Vec<(u8, f64, f64)> = dda_rows.iter().map(|r| (r.0, r.1, r.2)).collect();
    let p2 = out.join("trace_octree_vs_dda.png");
    plot_octree_vs_dda(&dd, &p2)?;
    println!("\nplots: {} and {}", p1.display(), p2.display());
    Ok(())
}
