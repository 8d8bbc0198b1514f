//! `wisptree render`: simulates a style under a motion and writes the rendered hair of every
//! frame as a PNG (`frame_00000.png`, …). A file in the way that an earlier `render` did not
//! write is kept as `NAME.bak` (see `out_dir.rs`).

use std::io::IsTerminal as _;
use std::path::PathBuf;

use super::out_dir::OutDir;
use crate::error::BadInput;
use crate::frame::Frame;
use crate::pipeline::{self, FrameBuilder};
use crate::render::{write_png, Image, RenderInput, Renderer};
use crate::scene::Scene;
use crate::solver::SolverKind;

/// What `wisptree render` is asked to do.
#[derive(Debug, Clone)]
pub struct RenderCommand {
    /// A built-in style name or a style file.
    pub style: String,
    /// A motion preset or file.
    pub motion: String,
    /// The hair model.
    pub model: SolverKind,
    /// Simulated seconds.
    pub seconds: f64,
    /// The folder the PNGs go to (created if needed).
    pub out: PathBuf,
    /// Image size, pixels.
    pub size: (u32, u32),
}

/// `wisptree render`. Returns the number of images written.
pub fn run(cmd: &RenderCommand) -> anyhow::Result<u64> {
    let scene = Scene::load(&cmd.style, &cmd.motion, cmd.model)?;
    let mut out = OutDir::open(&cmd.out, "render")?;
    let frames = scene.frames_for(cmd.seconds);
    out.check_names((0..frames).map(frame_name))?;
    let mut renderer = Renderer::new(
        scene.loaded.style.render.clone(),
        cmd.size.0,
        cmd.size.1,
        crate::render::default_threads(),
    )
    .map_err(|e| BadInput(format!("rendering: {e}")))?;
    let camera = super::render_thread::scene_camera(&scene);
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(frames);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40.cyan/blue} {pos}/{len} frames  {elapsed} elapsed, ~{eta} left",
            )
            .expect("a valid progress template"),
        );
        b
    });
    let mut solver = scene.solver();
    let mut report = solver.new_report();
    let mut builder = FrameBuilder::new(&scene.model, usize::MAX, super::STRAND_SUBDIVISIONS);
    let mut frame = Frame::default();
    let mut image = Image::default();
    for index in 0..frames {
        pipeline::step_frame(&mut *solver, &mut report, &mut frame);
        builder.fill(&mut *solver, &mut frame);
        let input = RenderInput {
            strands: &frame.strands,
            body: &frame.body,
        };
        renderer.render(&input, &camera, &mut image);
        let name = frame_name(index);
        let path = out.make_way(&name)?;
        write_png(&image, &path)
            .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
        out.written(&name)?;
        if let Some(b) = &bar {
            b.inc(1);
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    out.finish()?;
    out.report_moved_aside();
    println!(
        "wrote {frames} images of {}x{} to {}",
        cmd.size.0,
        cmd.size.1,
        cmd.out.display()
    );
    Ok(frames)
}

/// The image of frame `index`.
fn frame_name(index: u64) -> String {
    format!("frame_{index:05}.png")
}
