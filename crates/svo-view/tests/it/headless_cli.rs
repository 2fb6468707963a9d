//! `svo-view --headless` end to end: the colour image and the depth AOV written by the GPU,
//! the benchmark line with the adapter's name, `--vs-cpu`, a DAG file on its graph, and one-line errors (before any
//! adapter is needed) for what the GPU path does not do, or when no mode is given.
//! Without an adapter the harness reports the rendering test ignored (under CI: failed).

use std::process::Command;
use svo_tests::harness::Test;
use svo_tests::trial;

use crate::common;
use common::{torus_svo, torus_svo_at};

fn view(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_svo-view"))
        .args(args)
        .output()
        .expect("run svo-view")
}

/// The one-line error of a failed run.
fn error_line(o: &std::process::Output) -> String {
    assert!(!o.status.success(), "expected failure");
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(e.starts_with("svo-view: error:"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    e
}

fn headless_renders_on_the_gpu() {
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let s = svo.to_str().unwrap();
    let png = d.path().join("t.png");
    let o = view(&[
        s,
        "--headless",
        "-o",
        png.to_str().unwrap(),
        "--size",
        "48x36",
        "--bench",
        "2",
        "--vs-cpu",
    ]);
    if !o.status.success() {
        let e = String::from_utf8_lossy(&o.stderr);
        if e.contains("no GPU adapter found") {
            svo_tests::missing(&format!("a GPU adapter for the headless test: {e}"));
            return;
        }
        panic!("{e}");
    }
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("adapter: "), "{out}");
    assert!(
        out.contains("2 frame(s): median") && out.contains("Mrays/s"),
        "{out}"
    );
    assert!(
        out.contains("hit/miss differs on 0.0000% of pixels"),
        "{out}"
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (48, 36));
    let corner = *img.get_pixel(0, 0);
    assert!((0..36).any(|y| *img.get_pixel(24, y) != corner));

    // The depth AOV: +inf on a miss, positive distances on the torus.
    let pfm = d.path().join("d.pfm");
    let o = view(&[
        s,
        "--headless",
        "--aov",
        "depth",
        "-o",
        pfm.to_str().unwrap(),
        "--size",
        "40x30",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (w, h, v) = svo::render::read_pfm(&std::fs::read(&pfm).unwrap()).unwrap();
    assert_eq!((w, h), (40, 30));
    assert!(v[0].is_infinite());
    assert!(v.iter().filter(|x| x.is_finite()).count() > 30);

    // `--wide-view` on a tree of depth 6: the report says so, and the image is the
    // octree walk's, byte for byte.
    let e = tempfile::tempdir().unwrap();
    let even = torus_svo_at(e.path(), 6);
    let render = |wide: bool| {
        let png = e.path().join(format!("w{wide}.png"));
        let mut args = vec![
            even.to_str().unwrap(),
            "--headless",
            "--size",
            "48x36",
            "-o",
        ];
        args.push(png.to_str().unwrap());
        if wide {
            args.push("--wide-view");
        }
        let o = view(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        assert_eq!(out.contains("walks the 64-ary view"), wide, "{out}");
        std::fs::read(&png).unwrap()
    };
    let octree_walk = render(false);
    assert_eq!(octree_walk, render(true));

    // The same tree as a DAG file: rendered on its graph (the report says so), the image
    // byte for byte the tree's, and the CPU's walk of the graph agreeing with it.
    let (tree, build) = svo::io::read_file(&even).unwrap();
    let dag_file = e.path().join("dag.svo");
    svo::io::write_dag_file(&tree, &build, &dag_file).unwrap();
    let png = e.path().join("dag.png");
    let o = view(&[
        dag_file.to_str().unwrap(),
        "--headless",
        "--size",
        "48x36",
        "--vs-cpu",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("walks the graph"), "{out}");
    assert!(
        out.contains("hit/miss differs on 0.0000% of pixels"),
        "{out}"
    );
    assert_eq!(std::fs::read(&png).unwrap(), octree_walk);
}

fn what_the_gpu_does_not_do_is_a_clear_error() {
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let s = svo.to_str().unwrap();
    let out = d.path().join("x.png");
    let o = out.to_str().unwrap();
    let e = error_line(&view(&[s, "--headless", "--hit", "exact", "-o", o]));
    assert!(e.contains("CPU only"), "{e}");
    let e = error_line(&view(&[s, "--headless", "--sky", "/nonexistent", "-o", o]));
    assert!(e.contains("cube-map sky"), "{e}");
    let e = error_line(&view(&[s, "-o", o]));
    assert!(e.contains("--headless") && e.contains("--cpu"), "{e}");
    let e = error_line(&view(&["/nonexistent.svo", "--headless", "-o", o]));
    assert!(e.contains("nonexistent"), "{e}");
    assert!(!out.exists(), "no output after an error");
    // --vs-cpu without --headless is refused by the parser.
    assert!(!view(&[s, "--cpu", "--vs-cpu"]).status.success());
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![
        trial!(headless_renders_on_the_gpu, common::gpu_need()),
        trial!(what_the_gpu_does_not_do_is_a_clear_error),
    ]
}
