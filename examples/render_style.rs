//! Renders a built-in style at rest to a PNG, or benchmarks the renderer on the 16,215-strand
//! head of Zhang and Wünsche 2007, §7.2.
//!
//! `cargo run --release --example render_style -- [STYLE] [OUT.png] [WIDTH HEIGHT [X,Y,Z]]`
//! (default `long docs/render.png 640 480`, viewed along `camera::DEFAULT_VIEW`);
//! `cargo run --release --example render_style -- --bench16k [FRAMES] [OUT.png]` prints frames
//! per second at 1 and 2 threads and writes the last image.

use std::path::Path;

use wisptree::frame::Frame;
use wisptree::pipeline::FrameBuilder;
use wisptree::render::{
    bench_render, bounds, camera::DEFAULT_VIEW, write_png, zhang_16k_body, zhang_16k_strands,
    Camera, Image, RenderInput, RenderParams, Renderer,
};
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--bench16k") {
        let frames: usize = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(20);
        let strands = zhang_16k_strands();
        let body = zhang_16k_body();
        let segs: usize = (0..strands.len())
            .map(|s| strands.strand(s).len() - 1)
            .sum();
        println!("{} strands, {segs} segments, 640x480", strands.len());
        for threads in [1, 2] {
            let b = bench_render(&strands, &body, 640, 480, threads, frames)
                .map_err(anyhow::Error::msg)?;
            println!(
                "{threads} thread(s): {:.1} fps; ms per frame: shadow maps {:.2}, shading {:.2}, rasterising {:.2}, resolve {:.2}",
                b.fps, b.stage_ms[0], b.stage_ms[1], b.stage_ms[2], b.stage_ms[3]
            );
        }
        if let Some(out) = args.get(2) {
            let mut r =
                Renderer::new(RenderParams::default(), 640, 480, 2).map_err(anyhow::Error::msg)?;
            let (lo, hi) = bounds(&strands.points);
            let cam = Camera::framing(lo, hi, DEFAULT_VIEW);
            let mut img = Image::default();
            let input = RenderInput {
                strands: &strands,
                body: &body,
            };
            r.render(&input, &cam, &mut img);
            write_png(&img, Path::new(out))?;
        }
        return Ok(());
    }
    let style = args.first().map(String::as_str).unwrap_or("long");
    let out = args.get(1).map(String::as_str).unwrap_or("docs/render.png");
    let w: u32 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(640);
    let h: u32 = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(480);
    // Optional viewing direction (eye → scene) as `x,y,z`.
    let view = match args.get(4) {
        Some(v) => {
            let c: Vec<f32> = v
                .split(",")
                .map(|x| x.trim().parse())
                .collect::<Result<_, _>>()?;
            anyhow::ensure!(c.len() == 3, "a view direction is x,y,z");
            [c[0], c[1], c[2]]
        }
        None => DEFAULT_VIEW,
    };
    let scene = Scene::load(style, "still", SolverKind::Awt)?;
    let mut solver = scene.solver();
    let mut fb = FrameBuilder::new(&scene.model, usize::MAX, 2);
    let mut frame = Frame::default();
    fb.fill(solver.as_mut(), &mut frame);
    // The style's `render:` section (defaults where it has none).
    let params = scene.loaded.style.render.clone();
    let (lo, hi) = bounds(&frame.strands.points);
    let cam = Camera::from_params(&params, lo, hi, view);
    let mut r = Renderer::new(params, w, h, 2).map_err(anyhow::Error::msg)?;
    let mut img = Image::default();
    let input = RenderInput {
        strands: &frame.strands,
        body: &frame.body,
    };
    r.render(&input, &cam, &mut img);
    let t = r.stage_times();
    println!(
        "{} strands, {} points; {:.1} ms (shadow maps {:.1}, shading {:.1}, rasterising {:.1}, resolve {:.1})",
        frame.strands.len(),
        frame.strands.points.len(),
        t.total().as_secs_f64() * 1e3,
        t.shadow_maps.as_secs_f64() * 1e3,
        t.shading.as_secs_f64() * 1e3,
        t.rasterising.as_secs_f64() * 1e3,
        t.resolve.as_secs_f64() * 1e3,
    );
    write_png(&img, Path::new(out))?;
    println!("wrote {out}");
    Ok(())
}
