//! Benchmark loops: a frame rendered, or its primary rays cast, once untimed and then a number
//! of times into the same buffers, each timed (`--bench`).

use svo::render::{
    Camera, CameraError, Frame, Hits, RenderStats, Surfaces, Tracer, cast_primary, render,
    render_into,
};

/// Renders once, or, with `frames`, once untimed and then that many timed frames into the
/// same buffers (at least one): the last frame and the time of each counted frame, seconds.
pub fn render_timed<S: Surfaces>(
    tracer: &Tracer<S>,
    camera: &Camera,
    frames: Option<u32>,
) -> Result<(Frame, Vec<f64>), CameraError> {
    let mut frame = render(tracer, camera)?;
    let mut times = Vec::new();
    match frames {
        Some(n) => {
            for _ in 0..n.max(1) {
                render_into(tracer, camera, &mut frame)?;
                times.push(frame.elapsed.as_secs_f64());
            }
        }
        None => times.push(frame.elapsed.as_secs_f64()),
    }
    Ok((frame, times))
}

/// Casts once, or, with `frames`, once untimed and then that many timed casts into the same
/// buffers: the counters of a cast as [`RenderStats`] (primary rays only) and the seconds
/// of each counted cast.
pub fn cast_timed<S: Surfaces>(
    tracer: &Tracer<S>,
    camera: &Camera,
    frames: Option<u32>,
) -> Result<(RenderStats, Vec<f64>), CameraError> {
    let mut hits = Hits::default();
    cast_primary(tracer, camera, &mut hits)?;
    let mut times = Vec::new();
    match frames {
        Some(n) => {
            for _ in 0..n.max(1) {
                cast_primary(tracer, camera, &mut hits)?;
                times.push(hits.elapsed.as_secs_f64());
            }
        }
        None => times.push(hits.elapsed.as_secs_f64()),
    }
    let stats = RenderStats {
        primary_rays: u64::from(hits.width) * u64::from(hits.height),
        primary_hits: hits.hits,
        steps: hits.steps,
        primary_steps: hits.steps,
        capped: hits.capped,
        max_primary_steps: hits.max_steps,
        ..RenderStats::default()
    };
    Ok((stats, times))
}
