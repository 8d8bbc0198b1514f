//! `wisptree gallery --out DIR`: one picture of every built-in style and of every experiment,
//! and a page (`index.html`) that shows each experiment's pictures with the numbers it printed
//! and the paper's claim beside them.
//!
//! The experiments come from the registry ([`crate::experiment::all`]): an experiment added
//! there is in the next gallery without a change here. Each runs as `wisptree experiment`
//! runs it, into a sink that keeps every run's last frame, its key frame (the state the
//! run's number is measured on), and the pictures the experiment makes of itself (awt-fig7's
//! contact sheet, zhang-fig12/13/14's crops) through [`FrameSink::picture`], as
//! `wisptree experiment --out` writes them. A rendering experiment's run (no solver) is shown
//! by the last image it rendered. `--quick` shortens every run (the numbers then need not show the paper's
//! point, and the page says so).

use std::io::IsTerminal as _;
use std::path::PathBuf;

use super::gallery_page::{self, ExperimentEntry, Page, Shot, StyleEntry};
use super::out_dir::OutDir;
use crate::experiment::{self, ExperimentOptions, FrameSink};
use crate::frame::{BodyBuf, Frame, StrandBuf};
use crate::pipeline::{self, FrameBuilder};
use crate::render::{camera::DEFAULT_VIEW, Camera, Image, RenderInput, RenderParams, Renderer};
use crate::report::AdaptEvent;
use crate::scene::Scene;
use crate::solver::{Solver, SolverKind};
use crate::style::builtin::BUILTIN_STYLES;

/// Fewer strands than this are drawn thick (see [`KeyFrame::render`]).
const SPARSE_STRANDS: usize = 1000;

/// The fraction of every run's length `--quick` runs.
pub const QUICK_SCALE: f64 = 0.1;

/// What `wisptree gallery` is asked to do.
#[derive(Debug, Clone)]
pub struct GalleryCommand {
    /// The folder the pictures and the page go to.
    pub out: PathBuf,
    /// Shortened runs and smaller pictures (a test, a first look).
    pub quick: bool,
    /// Show a progress bar on stderr (when it is a terminal).
    pub progress: bool,
}

/// What the gallery wrote.
#[derive(Debug, Clone)]
pub struct GalleryOutcome {
    /// The page.
    pub index: PathBuf,
    /// Every picture, in the page's order.
    pub pictures: Vec<PathBuf>,
    /// Experiments that failed, with why.
    pub failed: Vec<(String, String)>,
}

/// `wisptree gallery`.
pub fn run(cmd: &GalleryCommand) -> anyhow::Result<GalleryOutcome> {
    let mut out = OutDir::open(&cmd.out, "gallery")?;
    let size = if cmd.quick { (320, 240) } else { (480, 360) };
    let experiments = experiment::all();
    let bar = progress_bar(
        cmd.progress,
        (BUILTIN_STYLES.len() + experiments.len()) as u64,
    );
    let mut page = Page {
        quick: cmd.quick.then_some(QUICK_SCALE),
        styles: Vec::new(),
        experiments: Vec::new(),
    };
    let mut pictures = Vec::new();
    for b in &BUILTIN_STYLES {
        bar.set_message(format!("style {}", b.name));
        let image = style_picture(b.name, size)?;
        let file = format!("style_{}.png", b.name);
        pictures.push(out.write(&file, &png(&image)?)?);
        page.styles.push(StyleEntry {
            name: b.name.to_owned(),
            description: b.description.to_owned(),
            file,
        });
        bar.inc(1);
    }

    let opts = ExperimentOptions {
        duration_scale: if cmd.quick { QUICK_SCALE } else { 1.0 },
    };
    let mut failed = Vec::new();
    for def in &experiments {
        bar.set_message(format!("experiment {}", def.name));
        let mut sink = GallerySink::default();
        let mut entry = ExperimentEntry {
            name: def.name.to_owned(),
            description: def.description.to_owned(),
            expectation: def.expectation.to_owned(),
            pictures: Vec::new(),
            runs: Vec::new(),
            error: None,
        };
        match (def.run)(&opts, &mut sink) {
            Ok(runs) => {
                for (name, image) in &sink.pictures {
                    let file = format!("exp_{}_{name}.png", def.name);
                    pictures.push(out.write(&file, &png(image)?)?);
                    entry.pictures.push(file);
                }
                for r in runs {
                    let image = match sink.runs.iter().find(|s| s.label == r.label) {
                        Some(shot) => Some(shot.render(size)?),
                        None => sink
                            .rendered
                            .iter()
                            .find(|(l, _)| *l == r.label)
                            .map(|(_, img)| img.clone()),
                    };
                    let mut file = None;
                    if let Some(image) = image {
                        let name = format!("exp_{}_{}.png", def.name, r.label);
                        pictures.push(out.write(&name, &png(&image)?)?);
                        file = Some(name);
                    }
                    entry.runs.push(Shot {
                        label: r.label.clone(),
                        file,
                        metrics: r.metrics.clone(),
                    });
                }
            }
            Err(e) => {
                failed.push((def.name.to_owned(), format!("{e:#}")));
                entry.error = Some(format!("{e:#}"));
            }
        }
        page.experiments.push(entry);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let index = out.write("index.html", gallery_page::html(&page).as_bytes())?;
    out.finish()?;
    out.report_moved_aside();
    Ok(GalleryOutcome {
        index,
        pictures,
        failed,
    })
}

/// A bar over the styles and experiments, naming the one under way; hidden when asked or when
/// stderr is not a terminal.
fn progress_bar(show: bool, total: u64) -> indicatif::ProgressBar {
    if !show || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(total);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{elapsed_precise} [{bar:30}] {pos}/{len} {msg} ({eta} left)",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    // An experiment takes up to ten seconds with no step of its own to report: keep the
    // clock moving.
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

/// A built-in style at rest after its settling, rendered as `wisptree render` renders it
/// (the style's own colours and light, the camera framing its hair).
fn style_picture(name: &str, size: (u32, u32)) -> anyhow::Result<Image> {
    let scene = Scene::load(name, "still", SolverKind::Awt)?;
    let mut renderer = Renderer::new(
        scene.loaded.style.render.clone(),
        size.0,
        size.1,
        crate::render::default_threads(),
    )
    .map_err(|e| anyhow::anyhow!("rendering {name}: {e}"))?;
    let camera = super::render_thread::scene_camera(&scene);
    let mut solver = scene.solver();
    let mut report = solver.new_report();
    let mut frame = Frame::default();
    let mut builder = FrameBuilder::new(&scene.model, usize::MAX, super::STRAND_SUBDIVISIONS);
    pipeline::step_frame(&mut *solver, &mut report, &mut frame);
    builder.fill(&mut *solver, &mut frame);
    let mut image = Image::default();
    renderer.render(
        &RenderInput {
            strands: &frame.strands,
            body: &frame.body,
        },
        &camera,
        &mut image,
    );
    Ok(image)
}

/// `img` as PNG bytes.
fn png(img: &Image) -> anyhow::Result<Vec<u8>> {
    use image::ImageEncoder as _;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(
            &img.rgb,
            img.width,
            img.height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| anyhow::anyhow!("encoding a PNG: {e}"))?;
    Ok(bytes)
}

/// Keeps each run's last frame (strands and body; a rendering experiment's run: its last
/// image) and the experiment's own pictures.
#[derive(Default)]
struct GallerySink {
    runs: Vec<KeyFrame>,
    /// The last image of each run of a rendering experiment (zhang-fig12/13/14), by label.
    rendered: Vec<(String, Image)>,
    pictures: Vec<(String, Image)>,
}

/// A run's latest frame, ready to render.
struct KeyFrame {
    label: String,
    builder: FrameBuilder,
    strands: StrandBuf,
    body: BodyBuf,
}

impl KeyFrame {
    /// Rendered with the renderer's own look, the camera framing the frame's hair: an
    /// experiment's scene is not a head, and the run's key moment is where its hair is then.
    /// A scene of a few strands (two wisps, a brush of guides) gets thick opaque lines, or its
    /// hair would be a few faint hairlines on the background.
    fn render(&self, size: (u32, u32)) -> anyhow::Result<Image> {
        let mut params = RenderParams::default();
        if self.strands.len() < SPARSE_STRANDS {
            params.strand_width = 2.5;
            params.strand_alpha = 0.95;
        }
        let mut renderer = Renderer::new(params, size.0, size.1, crate::render::default_threads())
            .map_err(|e| anyhow::anyhow!("rendering: {e}"))?;
        let (lo, hi) = crate::render::bounds(&self.strands.points);
        let camera = Camera::framing(lo, hi, DEFAULT_VIEW);
        let mut image = Image::default();
        renderer.render(
            &RenderInput {
                strands: &self.strands,
                body: &self.body,
            },
            &camera,
            &mut image,
        );
        Ok(image)
    }
}

impl FrameSink for GallerySink {
    fn frame(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        _: &[AdaptEvent],
    ) -> anyhow::Result<()> {
        let i = match self.runs.iter().position(|r| r.label == label) {
            Some(i) => i,
            None => {
                self.runs.push(KeyFrame {
                    label: label.to_owned(),
                    builder: FrameBuilder::new(
                        solver.model(),
                        usize::MAX,
                        super::STRAND_SUBDIVISIONS,
                    ),
                    strands: StrandBuf::default(),
                    body: BodyBuf::default(),
                });
                self.runs.len() - 1
            }
        };
        let k = &mut self.runs[i];
        solver.sync_display();
        k.builder.fill_strands(&*solver, &mut k.strands);
        pipeline::fill_body(solver.model(), solver.pose(), &mut k.body);
        // A moving obstacle (chang-fig7's sphere) is drawn as a body sphere: the run's picture
        // shows what the hair lies on.
        let mut obstacles = Vec::new();
        solver.obstacle_spheres(&mut obstacles);
        for (c, r) in obstacles {
            k.body
                .sphere_centers
                .push([c.x as f32, c.y as f32, c.z as f32]);
            k.body.sphere_radii.push(r as f32);
        }
        Ok(())
    }

    fn rendered(
        &mut self,
        label: &str,
        _index: u64,
        _strands: &StrandBuf,
        image: &Image,
    ) -> anyhow::Result<()> {
        // The run's picture is the image its experiment rendered, as it measured it.
        match self.rendered.iter_mut().find(|(l, _)| l == label) {
            Some((_, last)) => last.clone_from(image),
            None => self.rendered.push((label.to_owned(), image.clone())),
        }
        Ok(())
    }

    fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        self.pictures.push((name.to_owned(), image.clone()));
        Ok(())
    }
}
