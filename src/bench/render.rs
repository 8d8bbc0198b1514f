//! `wisptree bench --render`: the renderer at 640×480 on Long, Long curly (every strand, at
//! rest) and a head at the scale of Zhang and Wünsche 2007's results (16,215 strands, 357k
//! segments), on 1 and 2 threads.

use crate::frame::Frame;
use crate::pipeline::FrameBuilder;
use crate::render::{bench_render, zhang_16k_body, zhang_16k_strands};
use crate::scene::Scene;
use crate::solver::SolverKind;

/// Width and height of the timed images.
pub const RENDER_SIZE: (u32, u32) = (640, 480);

/// One scene's numbers, as written under `"render"`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[allow(missing_docs)] // the JSON keys, each named for what it holds
pub struct RenderRow {
    pub scene: String,
    pub strands: usize,
    pub segments: usize,
    pub width: u32,
    pub height: u32,
    /// Frames per second at the median frame time (see [`crate::render::RenderBench::fps`]).
    pub fps_1_thread: f64,
    pub fps_2_threads: f64,
    /// Frames per second over all the timed frames (a shared machine's bursts included).
    pub fps_1_thread_mean: f64,
    pub fps_2_threads_mean: f64,
    /// Milliseconds per frame on 1 thread: shadow maps, shading (projecting every strand
    /// point, and shading those that binned segments use), rasterising, resolve.
    pub stage_ms_1_thread: [f64; 4],
}

/// Times the renderer on the three scenes, `frames` frames each per thread count.
pub fn bench_render_scenes(frames: usize) -> anyhow::Result<Vec<RenderRow>> {
    let mut rows = Vec::new();
    for style in ["long", "long_curly"] {
        let scene = Scene::load(style, "still", SolverKind::Awt)?;
        let mut solver = scene.solver();
        let mut builder =
            FrameBuilder::new(&scene.model, usize::MAX, crate::app::STRAND_SUBDIVISIONS);
        let mut frame = Frame::default();
        builder.fill(&mut *solver, &mut frame);
        rows.push(row(style, &frame.strands, &frame.body, frames)?);
    }
    rows.push(row(
        "zhang_16k",
        &zhang_16k_strands(),
        &zhang_16k_body(),
        frames,
    )?);
    Ok(rows)
}

fn row(
    scene: &str,
    strands: &crate::frame::StrandBuf,
    body: &crate::frame::BodyBuf,
    frames: usize,
) -> anyhow::Result<RenderRow> {
    let (w, h) = RENDER_SIZE;
    let one = bench_render(strands, body, w, h, 1, frames).map_err(anyhow::Error::msg)?;
    let two = bench_render(strands, body, w, h, 2, frames).map_err(anyhow::Error::msg)?;
    let segments = (0..strands.len())
        .map(|s| strands.strand(s).len().saturating_sub(1))
        .sum();
    Ok(RenderRow {
        scene: scene.to_owned(),
        strands: strands.len(),
        segments,
        width: w,
        height: h,
        fps_1_thread: one.fps,
        fps_2_threads: two.fps,
        fps_1_thread_mean: one.fps_mean,
        fps_2_threads_mean: two.fps_mean,
        stage_ms_1_thread: one.stage_ms,
    })
}

/// Prints the rows.
pub fn print_render(rows: &[RenderRow]) {
    println!();
    println!("renderer at 640x480 (fps at the median frame time, over all frames in brackets; stages in ms per frame on 1 thread: shadow maps, projection and shading, rasterising, resolve):");
    for r in rows {
        println!(
            "{:<12} {:>6} strands {:>7} segments  {:>6.1} ({:.1}) fps 1 thread  {:>6.1} ({:.1}) fps 2 threads  [{:.1}, {:.1}, {:.1}, {:.1}]",
            r.scene,
            r.strands,
            r.segments,
            r.fps_1_thread,
            r.fps_1_thread_mean,
            r.fps_2_threads,
            r.fps_2_threads_mean,
            r.stage_ms_1_thread[0],
            r.stage_ms_1_thread[1],
            r.stage_ms_1_thread[2],
            r.stage_ms_1_thread[3]
        );
    }
}
