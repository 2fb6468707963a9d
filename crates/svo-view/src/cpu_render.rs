//! `svo-view --cpu`: a render job on the CPU reference tracer. The octree's image (its leaves
//! hit as cubes, contours or, with the mesh, the mesh's triangles), the triangle reference's
//! (`--reference`), or both measured against each other (`--compare`); once, or timed over
//! frames (`--bench`); or the primary rays alone cast and timed (`--cast`). A version-3 file
//! past what one tree in memory holds is rendered chunk by chunk as one tree; a DAG file is
//! rendered on its graph, its tree never made (where the job needs no mesh and no prefix).

use crate::job::{JobError, RenderJob, diff_path, load_reference, prepare, sibling, write_output};
use crate::report::{CameraReport, CompareReport, CpuRun, FrameReport, FrameTiming};
use crate::timing::{cast_timed, render_timed};
use svo::FormatError;
use svo::io::ChunkedFile;
use svo::render::{
    Camera, ChunkTree, ChunkedSurfaces, DagSurfaces, Frame, MeshSurfaces, OctreeSurfaces,
    RenderScene, RenderStats, SetupError, Stage, Surfaces, Tracer, compare, write_png,
};
use svo::trace::HitMode;

/// Runs a render job on the CPU (see the module docs).
pub fn render_file(job: &RenderJob) -> Result<FrameReport, JobError> {
    if renders_as_graph(job)? {
        return svo::with_threads(job.threads, |threads| render_graph(job, threads))?;
    }
    svo::with_threads(job.threads, |threads| match prepare(job) {
        Err(JobError::Setup(SetupError::Format(FormatError::TooLarge { .. }))) => {
            render_chunked(job, threads)
        }
        Ok(scene) => render_scene(job, &scene, threads),
        Err(e) => Err(e),
    })?
}

/// What the frames of a job cost and found: the last frame (none for a cast), its counters
/// and each frame's seconds.
struct Timed {
    frame: Option<Frame>,
    stats: RenderStats,
    times: Vec<f64>,
}

/// Renders `tracer`'s image of `job`, or with `job.cast` casts its primary rays, timed as
/// the job asks.
fn timed<S: Surfaces>(
    job: &RenderJob,
    tracer: &Tracer<S>,
    camera: &Camera,
) -> Result<Timed, JobError> {
    if job.cast {
        let (stats, times) = cast_timed(tracer, camera, job.bench_frames)?;
        return Ok(Timed {
            frame: None,
            stats,
            times,
        });
    }
    let (frame, times) = render_timed(tracer, camera, job.bench_frames)?;
    Ok(Timed {
        stats: frame.stats,
        frame: Some(frame),
        times,
    })
}

/// The octree's frames: its leaves hit as the job's mode says, through the mesh's triangles
/// for the exact mode.
fn octree_frames(job: &RenderJob, scene: &RenderScene) -> Result<Timed, JobError> {
    let RenderScene {
        tree,
        camera,
        lights,
        sky,
        phong,
        ..
    } = scene;
    if job.trace.mode != HitMode::Exact {
        let s = OctreeSurfaces::new(tree, job.trace.mode);
        return timed(
            job,
            &Tracer::new(s, lights, sky.clone(), *phong, job.trace),
            camera,
        );
    }
    let path = job
        .mesh
        .as_ref()
        .or(job.reference.as_ref())
        .ok_or_else(|| {
            JobError::Invalid(
                "hit mode exact needs the mesh the tree was baked from: give --mesh or --reference"
                    .into(),
            )
        })?;
    let mesh = load_reference(path)?;
    let s = svo::render::exact_surfaces(tree, &mesh)?;
    timed(
        job,
        &Tracer::new(s, lights, sky.clone(), *phong, job.trace),
        camera,
    )
}

/// The triangle reference's frames.
fn reference_frames(
    job: &RenderJob,
    scene: &RenderScene,
    mesh: svo::Mesh,
) -> Result<Timed, JobError> {
    let s = MeshSurfaces::new(mesh, scene.tree.root, scene.tree.depth);
    let tracer = Tracer::new(s, &scene.lights, scene.sky.clone(), scene.phong, job.trace);
    timed(job, &tracer, &scene.camera)
}

/// The octree's and the reference's frames measured against each other; with an output, the
/// reference's image and the difference image written beside it.
fn compared(job: &RenderJob, svo: &Timed, reference: &Timed) -> Result<CompareReport, JobError> {
    let (Some(s), Some(r)) = (&svo.frame, &reference.frame) else {
        return Err(JobError::Invalid("--compare renders images".into()));
    };
    let diff =
        compare(s, r).ok_or_else(|| JobError::Invalid("the two renders differ in size".into()))?;
    let mut report = CompareReport {
        diff,
        svo_ms: FrameTiming::median(&svo.times) * 1e3,
        reference_ms: FrameTiming::median(&reference.times) * 1e3,
        reference_output: None,
        diff_output: None,
    };
    if let Some(out) = &job.output {
        let ref_out = sibling(out, "reference");
        write_output(r, job.aov, &ref_out, r.stats.max_primary_steps.max(1))?;
        let diff_out = diff_path(out);
        write_png(&diff_out, s.width, s.height, &diff_rgb8(s, r, 4.0))?;
        report.reference_output = Some(ref_out.display().to_string());
        report.diff_output = Some(diff_out.display().to_string());
    }
    Ok(report)
}

/// A difference image: the absolute difference of the colours per channel, scaled by `gain`
/// (sRGB bytes).
fn diff_rgb8(a: &Frame, b: &Frame, gain: f32) -> Vec<u8> {
    svo::render::colour_rgb8(a)
        .iter()
        .zip(svo::render::colour_rgb8(b))
        .map(|(x, y)| (f32::from(x.abs_diff(y)) * gain).min(255.0) as u8)
        .collect()
}

/// Writes the job's output from `timed`'s frame, if it asks for one: the written path and
/// the cost heat map's scale.
fn write_frame(job: &RenderJob, timed: &Timed) -> Result<(Option<String>, u32), JobError> {
    let Some(frame) = &timed.frame else {
        return Ok((None, 1));
    };
    let cost_scale = frame.stats.max_primary_steps.max(1);
    let Some(out) = &job.output else {
        return Ok((None, cost_scale));
    };
    write_output(frame, job.aov, out, cost_scale)?;
    Ok((Some(out.display().to_string()), cost_scale))
}

/// The job's triangle reference, loaded, if it asks for one (`--compare` needs it).
fn reference_mesh(job: &RenderJob) -> Result<Option<svo::Mesh>, JobError> {
    let reference = job.reference.as_deref().map(load_reference).transpose()?;
    if job.compare && reference.is_none() {
        return Err(JobError::Invalid("--compare needs --reference MESH".into()));
    }
    Ok(reference)
}

/// The frames a job shows, from the octree's and the reference's (at least one of them),
/// with their comparison where both ran.
fn shown_of(
    job: &RenderJob,
    octree: Option<Timed>,
    reference: Option<Timed>,
) -> Result<(Timed, Option<CompareReport>), JobError> {
    Ok(match (octree, reference) {
        (Some(s), Some(r)) => {
            let c = compared(job, &s, &r)?;
            (s, Some(c))
        }
        (Some(s), None) => (s, None),
        (None, Some(r)) => (r, None),
        (None, None) => unreachable!("one of the two renders always runs"),
    })
}

/// The hit mode a job's report names: the triangles when it shows the reference alone.
fn hit_name(job: &RenderJob) -> &'static str {
    if job.reference.is_some() && !job.compare {
        "triangles"
    } else {
        job.trace.mode.name()
    }
}

/// The job on a tree in memory: the octree, the reference or both.
fn render_scene(
    job: &RenderJob,
    scene: &RenderScene,
    threads: usize,
) -> Result<FrameReport, JobError> {
    let reference = reference_mesh(job)?;
    let octree = if reference.is_none() || job.compare {
        Some(octree_frames(job, scene)?)
    } else {
        None
    };
    let reference = reference
        .map(|mesh| reference_frames(job, scene, mesh))
        .transpose()?;
    let (shown, compare) = shown_of(job, octree, reference)?;
    let (output, cost_scale) = write_frame(job, &shown)?;
    let tree = &scene.tree;
    Ok(FrameReport {
        width: scene.camera.width,
        height: scene.camera.height,
        depth: tree.depth,
        leaves: u64::from(tree.leaf_count),
        hit: hit_name(job),
        timing: FrameTiming::new(&shown.times, &shown.stats),
        stats: shown.stats,
        output,
        camera: CameraReport::of(&scene.camera),
        cpu: Some(CpuRun {
            threads,
            cost_scale,
            compare,
            lod: job.trace.lod,
            lod_applied: Surfaces::level_of_detail(&OctreeSurfaces::new(tree, job.trace.mode)),
        }),
        gpu: None,
    })
}

/// The job on a version-3 file past what one tree in memory holds: every chunk read as a
/// tree of its own (all in memory at once) and traced through [`ChunkedSurfaces`]. The exact
/// hit mode (the leaves' triangles) is refused.
fn render_chunked(job: &RenderJob, threads: usize) -> Result<FrameReport, JobError> {
    if job.mesh.is_some() || job.trace.mode == HitMode::Exact {
        return Err(JobError::Invalid(
            "a tree stored in chunks past 2^31 leaves renders in the cube and contour hit \
             modes, without --mesh"
                .into(),
        ));
    }
    let (file, trees) = ChunkedFile::load(&job.input).map_err(SetupError::from)?;
    let chunks: Vec<ChunkTree> = trees
        .into_iter()
        .enumerate()
        .map(|(i, tree)| ChunkTree {
            cell: file.chunk_cell(i),
            first_leaf: file.chunk_leaves(i).1,
            tree,
        })
        .collect();
    let (lo, hi) = chunks
        .iter()
        .map(|c| c.tree.occupied_bounds())
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
        .unwrap_or((file.root().origin, file.root().origin));
    let stage = job
        .setup()?
        .stage(file.depth(), lo, hi, &file.build().scene)?;
    let s = ChunkedSurfaces::new(
        file.root(),
        file.depth(),
        file.level(),
        &chunks,
        job.trace.mode,
    )?;
    let size = (file.root(), file.depth(), file.leaf_count());
    render_staged(job, threads, &stage, s, size)
}

/// The job's frames of `surfaces` (a tree in `root` of `depth` levels and `leaves` leaves
/// not held as one tree in memory: in chunks, or as its graph) on `stage`, beside the
/// triangle reference's or in its place as the job asks, written and reported.
fn render_staged<S: Surfaces>(
    job: &RenderJob,
    threads: usize,
    stage: &Stage,
    surfaces: S,
    (root, depth, leaves): (svo::RootCube, u8, u64),
) -> Result<FrameReport, JobError> {
    let reference = reference_mesh(job)?;
    let lod_applied = surfaces.level_of_detail();
    let octree = if reference.is_none() || job.compare {
        let tracer = Tracer::new(
            surfaces,
            &stage.lights,
            stage.sky.clone(),
            stage.phong,
            job.trace,
        );
        Some(timed(job, &tracer, &stage.camera)?)
    } else {
        None
    };
    let reference = reference
        .map(|mesh| {
            let s = MeshSurfaces::new(mesh, root, depth);
            let tracer = Tracer::new(s, &stage.lights, stage.sky.clone(), stage.phong, job.trace);
            timed(job, &tracer, &stage.camera)
        })
        .transpose()?;
    let (shown, compare) = shown_of(job, octree, reference)?;
    let (output, cost_scale) = write_frame(job, &shown)?;
    Ok(FrameReport {
        width: stage.camera.width,
        height: stage.camera.height,
        depth,
        leaves,
        hit: hit_name(job),
        timing: FrameTiming::new(&shown.times, &shown.stats),
        stats: shown.stats,
        output,
        camera: CameraReport::of(&stage.camera),
        cpu: Some(CpuRun {
            threads,
            cost_scale,
            compare,
            lod: job.trace.lod,
            lod_applied,
        }),
        gpu: None,
    })
}

/// Whether the job renders a DAG file as its graph, its tree never made: a DAG file, in the
/// cube or contour hit mode, whole (beside the triangle reference or not). (Other jobs on it
/// read the tree.)
fn renders_as_graph(job: &RenderJob) -> Result<bool, JobError> {
    let plain = job.mesh.is_none() && job.max_depth.is_none() && job.trace.mode != HitMode::Exact;
    if !plain {
        return Ok(false);
    }
    job.check()?;
    Ok(svo::io::is_dag_file(&job.input).map_err(SetupError::from)?)
}

/// The job on a DAG file, traced on its graph ([`DagSurfaces`]: the tree's hits and image,
/// in the memory of the graph and the leaves' channels).
fn render_graph(job: &RenderJob, threads: usize) -> Result<FrameReport, JobError> {
    let (dag, build) = svo::io::read_dag_file(&job.input).map_err(SetupError::from)?;
    let (lo, hi) = dag.occupied_bounds();
    let stage = job.setup()?.stage(dag.depth(), lo, hi, &build.scene)?;
    let s = DagSurfaces::new(&dag, job.trace.mode);
    let size = (dag.root(), dag.depth(), dag.leaf_count());
    render_staged(job, threads, &stage, s, size)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec3, UVec3, Vec3};
    use rand::{Rng, SeedableRng};

    /// The path for files past one tree in memory (every chunk a tree of its own) writes the
    /// image that reading the same version-3 file whole writes, byte for byte, and reports the
    /// same rays, and beside the triangles the same error and images; the exact hit mode (the
    /// mesh) is refused there in one line.
    #[test]
    fn a_file_in_chunks_renders_the_image_of_the_whole_tree() {
        let dir = tempfile::tempdir().unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x7e4d);
        let root = svo::RootCube {
            origin: DVec3::new(0.0, -1.0, 2.0),
            side: 3.0,
        };
        let cells: Vec<_> = (0..2000)
            .map(|_| {
                let c = UVec3::new(
                    rng.random_range(0..64),
                    rng.random_range(0..16),
                    rng.random_range(0..64),
                );
                let t = rng.random_range(0..100) as f32 / 100.0;
                let v = svo::Voxel {
                    colour: [t, 0.4, 1.0 - t, 1.0],
                    reflectivity: if t > 0.7 { 0.6 } else { 0.0 },
                    normal: Some(Vec3::new(0.2, 1.0, t - 0.5)),
                    ..svo::Voxel::default()
                };
                (c, v)
            })
            .collect();
        let tree = svo::Octree::from_cells(root, 6, cells).unwrap();
        let input = dir.path().join("c.svo");
        let mut bytes = Vec::new();
        svo::io::write_chunked_to(&tree, &svo::io::BuildInfo::new(), 3, &mut bytes).unwrap();
        std::fs::write(&input, bytes).unwrap();
        let job = |name: &str| RenderJob {
            input: input.clone(),
            output: Some(dir.path().join(name)),
            width: 80,
            height: 60,
            threads: Some(2),
            ..RenderJob::default()
        };
        let whole = render_file(&job("whole.png")).unwrap();
        let chunked = svo::with_threads(Some(2), |threads| {
            render_chunked(&job("chunks.png"), threads)
        })
        .unwrap()
        .unwrap();
        assert!(whole.stats.primary_hits > 500, "{:?}", whole.stats);
        assert_eq!(chunked.stats.primary_hits, whole.stats.primary_hits);
        assert_eq!(chunked.leaves, whole.leaves);
        let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
        assert!(read("whole.png") == read("chunks.png"));
        // Beside a mesh's triangles (the root cube's corners), as the whole tree is.
        let corners = [
            root.origin,
            root.origin + DVec3::new(root.side, 0.0, 0.0),
            root.origin + DVec3::new(0.0, 0.4, root.side),
        ];
        let mut obj: String = corners
            .iter()
            .map(|p| format!("v {} {} {}\n", p.x, p.y, p.z))
            .collect();
        obj += "f 1 2 3\n";
        let mesh_path = dir.path().join("m.obj");
        std::fs::write(&mesh_path, obj).unwrap();
        let compared = |name: &str| RenderJob {
            reference: Some(mesh_path.clone()),
            compare: true,
            ..job(name)
        };
        let whole = render_file(&compared("wc.png")).unwrap();
        let chunked = svo::with_threads(Some(2), |threads| {
            render_chunked(&compared("cc.png"), threads)
        })
        .unwrap()
        .unwrap();
        assert_compared_alike(&whole, &chunked, dir.path(), ("wc", "cc"));
        let e = render_chunked(
            &RenderJob {
                mesh: Some(input.clone()),
                ..job("no.png")
            },
            1,
        )
        .unwrap_err();
        assert!(e.to_string().contains("without --mesh"), "{e}");
    }

    /// A DAG file renders on its graph the image its tree layout's file renders, byte for
    /// byte, with the same hits and steps (for the depth AOV too); a job that needs the tree (a
    /// prefix) reads the tree.
    #[test]
    fn a_dag_file_renders_on_its_graph_the_image_of_its_tree() {
        let dir = tempfile::tempdir().unwrap();
        let torus = svo::Mesh::load(svo_tests::repo_root().join("fixtures/torus.obj")).unwrap();
        let opts = svo::BakeOptions {
            depth: 7,
            ..Default::default()
        };
        let tree = svo::bake_mesh(&torus, &opts).unwrap().0;
        let (tree_path, dag_path) = (dir.path().join("t.svo"), dir.path().join("d.svo"));
        let build = svo::io::BuildInfo::new();
        svo::io::write_file(&tree, &build, &tree_path).unwrap();
        svo::io::write_dag_file(&tree, &build, &dag_path).unwrap();
        let job = |input: &std::path::Path, name: &str, aov: svo::render::Aov| RenderJob {
            input: input.to_path_buf(),
            output: Some(dir.path().join(name)),
            width: 96,
            height: 72,
            threads: Some(2),
            aov,
            ..RenderJob::default()
        };
        for (aov, ext) in [
            (svo::render::Aov::Colour, "png"),
            (svo::render::Aov::Depth, "pfm"),
        ] {
            let (a, b) = (format!("tree.{ext}"), format!("dag.{ext}"));
            assert!(renders_as_graph(&job(&dag_path, &b, aov)).unwrap());
            assert!(!renders_as_graph(&job(&tree_path, &a, aov)).unwrap());
            let on_tree = render_file(&job(&tree_path, &a, aov)).unwrap();
            let on_graph = render_file(&job(&dag_path, &b, aov)).unwrap();
            assert!(on_tree.stats.primary_hits > 500, "{:?}", on_tree.stats);
            assert_eq!(on_graph.stats.primary_hits, on_tree.stats.primary_hits);
            assert_eq!(on_graph.stats.shadow_rays, on_tree.stats.shadow_rays);
            assert_eq!(on_graph.leaves, on_tree.leaves);
            let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
            assert!(read(&a) == read(&b), "{aov:?}");
        }
        let prefix = RenderJob {
            max_depth: Some(5),
            ..job(&dag_path, "prefix.png", svo::render::Aov::Colour)
        };
        assert!(!renders_as_graph(&prefix).unwrap());
        assert_eq!(render_file(&prefix).unwrap().depth, 5);
        // Beside the triangles, on the graph as on the tree: the same error, the same
        // reference image; and the reference alone.
        let torus_path = svo_tests::repo_root().join("fixtures/torus.obj");
        let compared = |input: &std::path::Path, name: &str| RenderJob {
            reference: Some(torus_path.clone()),
            compare: true,
            ..job(input, name, svo::render::Aov::Colour)
        };
        assert!(renders_as_graph(&compared(&dag_path, "dc.png")).unwrap());
        let on_tree = render_file(&compared(&tree_path, "tc.png")).unwrap();
        let on_graph = render_file(&compared(&dag_path, "dc.png")).unwrap();
        assert_compared_alike(&on_tree, &on_graph, dir.path(), ("tc", "dc"));
        let alone = RenderJob {
            compare: false,
            ..compared(&dag_path, "dr.png")
        };
        let r = render_file(&alone).unwrap();
        assert_eq!(r.hit, "triangles");
        assert!(
            std::fs::read(dir.path().join("dr.png")).unwrap()
                == std::fs::read(dir.path().join("tc.reference.png")).unwrap()
        );
    }

    /// Two reports of the same job beside the triangles (written as `a.png` and `b.png`)
    /// found the same error and wrote the same images.
    fn assert_compared_alike(
        a: &FrameReport,
        b: &FrameReport,
        dir: &std::path::Path,
        (na, nb): (&str, &str),
    ) {
        let diff = |r: &FrameReport| r.cpu.as_ref().unwrap().compare.as_ref().unwrap().diff;
        let (da, db) = (diff(a), diff(b));
        assert!(da.psnr_db.is_finite(), "{da:?}");
        assert_eq!(da.psnr_db, db.psnr_db);
        assert_eq!(da.hit_mismatch, db.hit_mismatch);
        assert_eq!(a.stats.primary_hits, b.stats.primary_hits);
        let read = |name: String| std::fs::read(dir.join(name)).unwrap();
        for ext in ["png", "reference.png", "diff.png"] {
            assert!(
                read(format!("{na}.{ext}")) == read(format!("{nb}.{ext}")),
                "{ext}"
            );
        }
    }
}
