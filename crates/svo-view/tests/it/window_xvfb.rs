//! The window under Xvfb with lavapipe: `svo-view FILE` opens a window, renders a few frames
//! (trace, blit, overlay), captures the window and exits; a DAG file's graph shows the frame
//! of its tree. Without Xvfb or an adapter the
//! harness reports the test ignored, except under CI (`CI` set), where both are installed by
//! `.ci/run` and their absence fails it.
#![cfg(feature = "window")]

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use svo_tests::harness::{Need, Test};
use svo_tests::trial;

use crate::common;
use common::torus_svo;

fn skip_or_fail(why: &str) {
    svo_tests::missing(&format!("what the window test needs ({why})"));
}

/// An X server on a free display, killed on drop.
struct Xvfb(Child, u32);

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start_xvfb() -> Option<Xvfb> {
    let n = (90..190).find(|n| !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists())?;
    let child = Command::new("Xvfb")
        .args([
            &format!(":{n}"),
            "-screen",
            "0",
            "640x480x24",
            "-nolisten",
            "tcp",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let x = Xvfb(child, n);
    let t = Instant::now();
    while !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists() {
        // Generous: a loaded machine may take a while to start a server.
        if t.elapsed() > Duration::from_secs(60) {
            return None;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Some(x)
}

fn window_opens_renders_and_captures() {
    let Some(x) = start_xvfb() else {
        skip_or_fail("Xvfb is not installed or did not start (apt-get install xvfb)");
        return;
    };
    let d = tempfile::tempdir().unwrap();
    let svo = torus_svo(d.path());
    let shot = d.path().join("shot.png");
    let Some(out) = open_window(&x, &svo, &shot) else {
        return;
    };
    assert!(out.contains("frames, first after"), "{out}");
    let img = image::open(&shot).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (480, 360), "the window's size");
    // The torus is in the middle of the window, below the overlay (the top left, about
    // 340x190 pixels): some pixel there differs from the bottom corner's sky.
    let corner = *img.get_pixel(479, 359);
    assert!(
        (140..340).any(|x| *img.get_pixel(x, 230) != corner),
        "no torus in the capture"
    );
    // The same tree as a DAG file, shown on its graph: the same capture below the overlay,
    // whose frame-rate line and fade-in differ from run to run (on a loaded machine its
    // fade-in changes most of its pixels; a wrong walk moves the torus's thousands).
    let (tree, build) = svo::io::read_file(&svo).unwrap();
    let dag_file = d.path().join("dag.svo");
    svo::io::write_dag_file(&tree, &build, &dag_file).unwrap();
    let dag_shot = d.path().join("dag.png");
    open_window(&x, &dag_file, &dag_shot).unwrap();
    let on_graph = image::open(&dag_shot).unwrap().to_rgb8();
    let off = |a: &image::Rgb<u8>, b: &image::Rgb<u8>| (0..3).map(|k| a[k].abs_diff(b[k])).max();
    let below = |i: &image::RgbImage| i.rows().skip(200).flatten().copied().collect::<Vec<_>>();
    let (a, b) = (below(&img), below(&on_graph));
    let far = a
        .iter()
        .zip(&b)
        .filter(|(a, b)| off(a, b).is_some_and(|d| d > 24))
        .count();
    assert!(
        far * 50 < a.len(),
        "{far} of {} pixels below the overlay differ by more than 24 levels",
        a.len()
    );
}

/// Opens `svo` in a 480x360 window on `x`, quits after three frames, the last saved to
/// `shot`: what the run printed, `None` (reported) without an adapter.
fn open_window(x: &Xvfb, svo: &Path, shot: &Path) -> Option<String> {
    let runtime = shot.with_extension("xdg");
    std::fs::create_dir_all(&runtime).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_svo-view"))
        .args([
            svo.to_str().unwrap(),
            "--size",
            "480x360",
            "--quit-after",
            "3",
            "-o",
            shot.to_str().unwrap(),
        ])
        .env("DISPLAY", format!(":{}", x.1))
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    if !o.status.success() && err.contains("no GPU adapter found") {
        skip_or_fail(&err);
        return None;
    }
    assert!(o.status.success(), "{err}");
    Some(String::from_utf8_lossy(&o.stdout).into_owned())
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![trial!(
        window_opens_renders_and_captures,
        Need::tool("Xvfb", "apt-get install xvfb"),
        common::gpu_need()
    )]
}
