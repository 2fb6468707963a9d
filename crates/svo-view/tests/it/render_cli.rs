//! `svo-view --cpu` rendering end to end: colour and AOV images, the depth file read back, the
//! comparison with the triangle reference, the benchmark line, and one-line errors with no
//! output left behind for bad input.

use std::process::Command;
use svo_tests::harness::Test;
use svo_tests::trial;

use crate::common;
use common::torus_obj;
use common::torus_svo;

/// Runs `svo-view --cpu ARGS` (these tests are about the CPU renderer; the GPU path has
/// `headless_cli.rs`).
fn view(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_svo-view"))
        .arg("--cpu")
        .args(args.iter().filter(|a| **a != "--cpu"))
        .output()
        .expect("run svo-view")
}

/// The PSNR (dB) of the `--compare` line in a report.
fn psnr_of(report: &str) -> f64 {
    let line = report
        .lines()
        .find(|l| l.contains("PSNR"))
        .unwrap_or_else(|| panic!("no PSNR in {report}"));
    let v = line
        .split("PSNR ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap();
    v.parse().unwrap()
}

fn ok(o: &std::process::Output) -> String {
    assert!(
        o.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn renders_colour_and_aovs() {
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let s = svo.to_str().unwrap();
    let png = d.path().join("t.png");
    let out = ok(&view(&[
        s,
        "--cpu",
        "-o",
        png.to_str().unwrap(),
        "--size",
        "64x48",
    ]));
    assert!(
        out.contains("64x48 depth 5") && out.contains("Mrays/s"),
        "{out}"
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (64, 48));
    // The torus is in the middle: the centre column has pixels unlike the sky corners.
    let corner = *img.get_pixel(0, 0);
    assert!((0..48).any(|y| *img.get_pixel(32, y) != corner));

    for aov in ["normal", "leaf", "cost"] {
        let p = d.path().join(format!("{aov}.png"));
        ok(&view(&[
            s,
            "--aov",
            aov,
            "-o",
            p.to_str().unwrap(),
            "--size",
            "32x24",
        ]));
        assert_eq!(image::open(&p).unwrap().width(), 32);
    }

    // Depth as PFM: +inf where the ray misses, finite positive distances on the torus.
    let pfm = d.path().join("depth.pfm");
    ok(&view(&[
        s,
        "--aov",
        "depth",
        "-o",
        pfm.to_str().unwrap(),
        "--size",
        "40x30",
    ]));
    let (w, h, v) = svo::render::read_pfm(&std::fs::read(&pfm).unwrap()).unwrap();
    assert_eq!((w, h, v.len()), (40, 30, 1200));
    assert!(v[0].is_infinite() && v[0] > 0.0);
    let hits: Vec<f32> = v.iter().copied().filter(|x| x.is_finite()).collect();
    assert!(hits.len() > 50 && hits.iter().all(|&x| x > 0.0));
    // A cube-map sky of six one-colour faces: the image's corners show the sky, so they take
    // a face's colour.
    let sky = d.path().join("sky");
    std::fs::create_dir(&sky).unwrap();
    for (i, f) in ["px", "nx", "py", "ny", "pz", "nz"].iter().enumerate() {
        let c = [40 * i as u8 + 20, 200, 30];
        image::RgbImage::from_pixel(4, 4, image::Rgb(c))
            .save(sky.join(format!("{f}.png")))
            .unwrap();
    }
    let png_sky = d.path().join("sky.png");
    ok(&view(&[
        s,
        "--sky",
        sky.to_str().unwrap(),
        "-o",
        png_sky.to_str().unwrap(),
        "--size",
        "32x24",
        "--bounces",
        "0",
    ]));
    let img = image::open(&png_sky).unwrap().to_rgb8();
    assert_eq!(
        img.get_pixel(0, 0)[1],
        200,
        "the corner shows a cube-map face"
    );
    // A face missing: a clear error.
    std::fs::remove_file(sky.join("nz.png")).unwrap();
    let r = view(&[
        s,
        "--sky",
        sky.to_str().unwrap(),
        "-o",
        png_sky.to_str().unwrap(),
    ]);
    assert!(!r.status.success() && String::from_utf8_lossy(&r.stderr).contains("nz.png"));

    // EXR by extension.
    let exr = d.path().join("depth.exr");
    ok(&view(&[
        s,
        "--aov",
        "depth",
        "-o",
        exr.to_str().unwrap(),
        "--size",
        "40x30",
    ]));
    assert!(std::fs::metadata(&exr).unwrap().len() > 100);
}

/// With any AOV and any output extension, `--compare` writes the reference in that AOV beside
/// the output and the colour difference as the PNG `NAME.diff.png`.
fn compare_writes_a_png_diff_for_every_aov() {
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let obj = torus_obj();
    for (aov, out, reference) in [
        ("depth", "d.pfm", "d.reference.pfm"),
        ("normal", "n.png", "n.reference.png"),
        ("cost", "c.png", "c.reference.png"),
    ] {
        let report = ok(&view(&[
            svo.to_str().unwrap(),
            "--reference",
            obj.to_str().unwrap(),
            "--compare",
            "--aov",
            aov,
            "-o",
            d.path().join(out).to_str().unwrap(),
            "--size",
            "32x24",
        ]));
        let stem = out.split('.').next().unwrap();
        let diff = d.path().join(format!("{stem}.diff.png"));
        let bytes = std::fs::read(&diff).unwrap_or_else(|e| panic!("{aov}: {e}"));
        assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "{aov}: not a PNG");
        let img = image::load_from_memory(&bytes).unwrap();
        assert_eq!((img.width(), img.height()), (32, 24), "{aov}");
        assert!(d.path().join(reference).exists(), "{aov}");
        assert!(!d.path().join(format!("{stem}.diff.pfm")).exists(), "{aov}");
        assert!(report.contains(&diff.display().to_string()), "{report}");
    }
}

fn compare_with_the_triangle_reference_and_bench() {
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let s = svo.to_str().unwrap();
    let obj = torus_obj();
    let o = obj.to_str().unwrap();
    let png = d.path().join("c.png");
    let mut psnr = Vec::new();
    for hit in ["cube", "contour", "exact"] {
        let out = ok(&view(&[
            s,
            "--hit",
            hit,
            "--reference",
            o,
            "--compare",
            "-o",
            png.to_str().unwrap(),
            "--size",
            "64x48",
        ]));
        psnr.push(psnr_of(&out));
    }
    // Contours beat cubes, exact triangles beat contours.
    assert!(psnr[0] < psnr[1] && psnr[1] < psnr[2], "{psnr:?}");
    assert!(d.path().join("c.reference.png").exists() && d.path().join("c.diff.png").exists());

    let out = ok(&view(&[
        s,
        "--bench",
        "2",
        "--size",
        "32x24",
        "--bounces",
        "0",
        "--shadows",
        "none",
    ]));
    let last = out.trim_end().lines().last().unwrap();
    assert!(
        last.starts_with("2 frame(s): median") && last.ends_with("Mrays/s"),
        "{last}"
    );
    // --bench writes nothing unless asked.
    assert!(!svo.with_extension("png").exists());
    // --cast times the first hits alone: the same hits as the shaded frames.
    let hits = |extra: &[&str]| {
        let mut args = vec![
            s, "--bench", "2", "--size", "32x24", "--hit", "cube", "--json",
        ];
        args.extend_from_slice(extra);
        let j: serde_json::Value = serde_json::from_str(&ok(&view(&args))).unwrap();
        assert_eq!(j["stats"]["primary_rays"], 32 * 24);
        assert!(j["primary_mrays_per_s"].as_f64().unwrap() > 0.0);
        j["stats"]["primary_hits"].as_u64().unwrap()
    };
    let cast = hits(&["--cast"]);
    assert!(cast > 0);
    assert_eq!(cast, hits(&["--bounces", "0", "--shadows", "none"]));
    assert!(!svo.with_extension("png").exists());

    // JSON report.
    let out = ok(&view(&[
        s,
        "--json",
        "--size",
        "16x16",
        "-o",
        png.to_str().unwrap(),
    ]));
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["width"], 16);
    assert!(j["stats"]["primary_rays"].as_u64() == Some(256));
}

fn bad_input_gives_one_line_and_no_output() {
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let s = svo.to_str().unwrap();
    let out = d.path().join("out.png");
    let o = out.to_str().unwrap();
    let obj = torus_obj();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["missing.svo", "-o", o], "missing.svo"),
        (vec![s, "-o", o, "--size", "0x10"], "size"),
        (vec![s, "-o", o, "--size", "20000x10"], "size"),
        (vec![s, "-o", o, "--size", "16384x16384"], "pixels"),
        (vec![s, "--bench", "0"], "--bench takes"),
        (vec![s, "--cast"], "--bench"),
        (vec![s, "--cast", "--bench", "2", "-o", o], "without -o"),
        (vec![s, "--bench", "99999999"], "--bench takes"),
        (vec![s, "-o", o, "--threads", "0"], "threads"),
        (vec![s, "-o", o, "--threads", "100000"], "threads"),
        (vec![s, "-o", o, "--size", "wide"], "WIDTHxHEIGHT"),
        (vec![s, "-o", o, "--fov", "0"], "field of view"),
        (vec![s, "-o", o, "--eye", "1,2"], "x,y,z"),
        (
            vec![s, "-o", o, "--eye", "0,0,0", "--target", "0,0,0"],
            "eye equals target",
        ),
        (vec![s, "-o", o, "--light", "1,2,3:1,1"], "light"),
        (vec![s, "-o", o, "--aov", "albedo"], "unknown AOV"),
        (vec![s, "--aov", "depth", "-o", o], ".pfm or .exr"),
        (vec![s, "-o", o, "--hit", "exact"], "--mesh or --reference"),
        (vec![s, "-o", o, "--hit", "sphere"], "unknown hit mode"),
        (vec![s, "-o", o, "--bounces", "99"], "bounces"),
        (vec![s, "-o", o, "--reference", "nope.obj"], "nope.obj"),
        (vec![s, "-o", "/nonexistent-dir/x.png"], "does not exist"),
        (vec![obj.to_str().unwrap(), "-o", o], "not an .svo file"),
    ];
    for (args, want) in cases {
        let r = view(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{args:?} succeeded");
        assert!(err.contains(want), "{args:?}: {err:?} lacks {want:?}");
        assert!(!out.exists(), "{args:?} left {o}");
    }
    // A mesh that is not the tree's source: exact mode refuses it.
    let other = d.path().join("tri.obj");
    std::fs::write(&other, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let r = view(&[
        s,
        "-o",
        o,
        "--hit",
        "exact",
        "--mesh",
        other.to_str().unwrap(),
    ]);
    assert!(!r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("not the mesh the tree was baked from"));
    assert!(!out.exists());
    // A tree deeper than the f32 tracer resolves is refused, not drawn wrong.
    let deep = d.path().join("deep.svo");
    let tri = svo::Mesh::from_triangles(
        vec![
            glam::DVec3::ZERO,
            glam::DVec3::new(1e-6, 0.0, 0.0),
            glam::DVec3::new(0.0, 1e-6, 0.0),
            glam::DVec3::ONE,
        ],
        vec![[0, 1, 2], [3, 3, 3]],
    );
    let opts = svo::BakeOptions {
        depth: svo::render::MAX_TRACE_DEPTH + 1,
        ..svo::BakeOptions::default()
    };
    let (tree, _) = svo::bake_mesh(&tri, &opts).unwrap();
    svo::io::write_file(&tree, &Default::default(), &deep).unwrap();
    let r = view(&[deep.to_str().unwrap(), "-o", o]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("32-bit floats"),
        "{err}"
    );
    assert!(!out.exists());
    // Errors are one line (clap's usage errors aside).
    let r = view(&["missing.svo", "-o", o]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.starts_with("svo-view: error: ") && err.trim_end().lines().count() == 1,
        "{err}"
    );
}

fn stored_views_and_lights_are_used_unless_overridden() {
    use svo::mesh::{SceneInfo, StoredCamera, StoredLight};
    let d = tempfile::tempdir().unwrap();
    let plain = torus_svo(d.path());
    let (tree, mut build) = svo::io::read_file(&plain).unwrap();
    let view_of = |name: &str, eye: [f64; 3], fov_deg: f64| StoredCamera {
        name: name.into(),
        eye,
        target: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        fov_deg,
    };
    build.scene = SceneInfo {
        lights: vec![StoredLight {
            position: [0.0, -3.0, 1.0],
            colour: [1.0, 0.0, 0.0],
            intensity: 9.0,
        }],
        cameras: vec![
            view_of("front", [0.0, -3.0, 0.5], 50.0),
            view_of("top", [0.2, 0.0, 3.0], 30.0),
        ],
    };
    let svo = d.path().join("scene.svo");
    svo::io::write_file(&tree, &build, &svo).unwrap();
    let s = svo.to_str().unwrap();
    let png = d.path().join("v.png");
    let p = png.to_str().unwrap();
    let first = ok(&view(&[s, "-o", p, "--size", "48x36"]));
    assert!(
        first.contains("--eye 0.000000,-3.000000,0.500000") && first.contains("--fov 50"),
        "{first}"
    );
    // The stored light is red: beside a white light at the same place, the green channel
    // loses what the light gave, the red one keeps it.
    let sums = |path: &std::path::Path| {
        let img = image::open(path).unwrap().to_rgb8();
        img.pixels().fold([0u64; 2], |a, p| {
            [a[0] + u64::from(p[0]), a[1] + u64::from(p[1])]
        })
    };
    let red = sums(&png);
    let white_png = d.path().join("w.png");
    ok(&view(&[
        s,
        "--light",
        "0,-3,1:1,1,1:9",
        "-o",
        white_png.to_str().unwrap(),
        "--size",
        "48x36",
    ]));
    let white = sums(&white_png);
    assert!(
        red[1] * 100 < white[1] * 95,
        "green: red light {red:?}, white light {white:?}"
    );
    assert!(
        red[0] * 1000 > white[0] * 995,
        "red: red light {red:?}, white light {white:?}"
    );
    for name in ["top", "1"] {
        let out = ok(&view(&[s, "--view", name, "-o", p, "--size", "48x36"]));
        assert!(
            out.contains("--eye 0.200000,0.000000,3.000000") && out.contains("--fov 30"),
            "{out}"
        );
    }
    // The command line wins: its own camera and light.
    let out = ok(&view(&[
        s, "--eye", "3,0,0", "--light", "0,0,3", "-o", p, "--size", "48x36",
    ]));
    assert!(out.contains("--eye 3.000000,0.000000,0.000000"), "{out}");
    let o = view(&[s, "--view", "side", "-o", p]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("no view \"side\"; the file has front, top"),
        "{err}"
    );
    let info = ok(&view(&[s, "--info"]));
    assert!(
        info.contains("view           \"top\"") && info.contains("light          (0, -3, 1)"),
        "{info}"
    );
}

fn a_scene_file_is_a_triangle_reference() {
    // The triangles svo-bake voxelizes from a scene file are its ground truth too.
    let d = tempfile::tempdir().unwrap();
    let scene = d.path().join("s.toml");
    std::fs::write(
        &scene,
        "depth = 6\n\
         [[box]]\nmin = [-1.0, -0.2, -1.0]\nmax = [1.0, 0.0, 1.0]\n\
         [[sphere]]\ncentre = [0.0, 0.5, 0.0]\nradius = 0.5\nmaterial = \"glass\"\n\
         [[camera]]\nname = \"v\"\neye = [0.0, 1.5, 2.5]\ntarget = [0.0, 0.3, 0.0]\n",
    )
    .unwrap();
    let svo_path = d.path().join("s.svo");
    let job = svo_bake::job::BakeJob {
        input: scene.clone(),
        output: svo_path.clone(),
        options: Default::default(),
        threads: Some(1),
        given: Default::default(),
        memory: None,
        layout: Default::default(),
        values: Default::default(),
    };
    svo_bake::job::bake_file(&job).unwrap();
    let png = d.path().join("s.png");
    let out = ok(&view(&[
        svo_path.to_str().unwrap(),
        "--reference",
        scene.to_str().unwrap(),
        "--compare",
        "-o",
        png.to_str().unwrap(),
        "--size",
        "64x48",
    ]));
    // Measured 38.6 dB at this size; another scene's triangles (the pool) give 6.9 dB.
    assert!(psnr_of(&out) > 35.0, "{out}");
    // A scene file that does not parse: one line, naming the file.
    let bad = d.path().join("bad.toml");
    std::fs::write(&bad, "[[box]]\nmin = [0.0, 0.0]\n").unwrap();
    let o = view(&[
        svo_path.to_str().unwrap(),
        "--reference",
        bad.to_str().unwrap(),
        "--compare",
        "-o",
        png.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("bad.toml") && err.trim_end().lines().count() == 1,
        "{err}"
    );
}

/// `--path-bounces` reaches the tracer: the copper torus reflects, and with no bounce a path
/// no secondary ray is traced; a value out of range is a one-line error.
fn path_bounce_limit_on_the_command_line() {
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let s = svo.to_str().unwrap();
    let secondary = |extra: &[&str]| {
        let mut args = vec![s, "--bench", "1", "--size", "32x24", "--json"];
        args.extend_from_slice(extra);
        let j: serde_json::Value = serde_json::from_str(&ok(&view(&args))).unwrap();
        j["stats"]["secondary_rays"].as_u64().unwrap()
    };
    assert!(secondary(&[]) > 0);
    assert!(secondary(&["--path-bounces", "1"]) > 0);
    assert_eq!(secondary(&["--path-bounces", "0"]), 0);
    let o = view(&[s, "--bench", "1", "--path-bounces", "300"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("path-bounces"), "{err}");
}

/// The torus fixture baked at depth 7 with its inner nodes' attributes, written to `dir` as
/// `lod.svo` (version 4).
fn torus_svo_with_levels(dir: &std::path::Path) -> std::path::PathBuf {
    let mesh = svo::Mesh::load(torus_obj()).unwrap();
    let opts = svo::BakeOptions {
        depth: 7,
        node_attributes: true,
        ..svo::BakeOptions::default()
    };
    let (tree, _) = svo::bake_mesh(&mesh, &opts).unwrap();
    let lod = dir.join("lod.svo");
    svo::io::write_file(&tree, &svo::io::BuildInfo::new(), &lod).unwrap();
    lod
}

/// `--max-depth K` renders the file's top K levels: a version-4 file with its inner nodes'
/// values (the leaves of the coarser tree drawn with them), and a version-2 file cut (cubes).
fn max_depth_renders_the_top_levels() {
    let d = tempfile::tempdir().unwrap();
    let lod = torus_svo_with_levels(d.path());
    let plain = common::torus_svo_at(d.path(), 7);
    for (file, hit) in [(&lod, "contour"), (&plain, "cube")] {
        let png = d.path().join("top.png");
        let out = ok(&view(&[
            file.to_str().unwrap(),
            "--cpu",
            "--max-depth",
            "4",
            "--hit",
            hit,
            "-o",
            png.to_str().unwrap(),
            "--size",
            "64x48",
        ]));
        assert!(out.contains("64x48 depth 4"), "{out}");
        let img = image::open(&png).unwrap().to_rgb8();
        let corner = *img.get_pixel(0, 0);
        assert!((0..48).any(|y| *img.get_pixel(32, y) != corner));
    }
    // A limit past the depth reads the whole tree.
    let out = ok(&view(&[
        lod.to_str().unwrap(),
        "--cpu",
        "--max-depth",
        "20",
        "--size",
        "16x12",
    ]));
    assert!(out.contains("16x12 depth 7"), "{out}");
}

/// `--lod PIXELS` stops rays at inner nodes of a file baked with them: fewer steps per
/// primary ray, the head line says so; a file without them renders as at `--lod 0` and the
/// head line says why; a negative or non-numeric level is refused with one line.
fn lod_stops_rays_at_the_inner_nodes_of_files_that_have_them() {
    let d = tempfile::tempdir().unwrap();
    let lod = torus_svo_with_levels(d.path());
    let plain = common::torus_svo_at(d.path(), 7);
    let steps = |out: &str| -> f64 {
        let s = out.split(" steps per primary ray").next().unwrap();
        s.rsplit("; ").next().unwrap().parse().unwrap()
    };
    let run = |file: &std::path::Path, lod: &str| {
        ok(&view(&[
            file.to_str().unwrap(),
            "--lod",
            lod,
            "--size",
            "64x48",
            "--no-prepass",
        ]))
    };
    let exact = run(&lod, "0");
    let coarse = run(&lod, "4");
    assert!(coarse.contains("lod 4 px\n"), "{coarse}");
    assert!(!exact.lines().next().unwrap().contains("lod"), "{exact}");
    assert!(steps(&coarse) < steps(&exact), "{coarse}\n{exact}");
    let flat = run(&plain, "4");
    assert!(
        flat.contains("lod 4 px not applied (the tree's inner nodes carry no attributes"),
        "{flat}"
    );
    assert_eq!(steps(&flat), steps(&run(&plain, "0")));
    for bad in ["-1", "nan", "x"] {
        let o = view(&[lod.to_str().unwrap(), "--lod", bad]);
        assert!(!o.status.success(), "--lod {bad}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("lod") && err.lines().count() <= 4, "{err}");
    }
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(renders_colour_and_aovs),
        trial!(compare_writes_a_png_diff_for_every_aov),
        trial!(compare_with_the_triangle_reference_and_bench),
        trial!(bad_input_gives_one_line_and_no_output),
        trial!(stored_views_and_lights_are_used_unless_overridden),
        trial!(a_scene_file_is_a_triangle_reference),
        trial!(path_bounce_limit_on_the_command_line),
        trial!(max_depth_renders_the_top_levels),
        trial!(lod_stops_rays_at_the_inner_nodes_of_files_that_have_them),
    ]
}
