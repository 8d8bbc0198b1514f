//! The render thread, between the simulation and the logger: renders each frame's strands
//! (the right half of the AWT paper's Figure 4) and encodes the image for the recording.
//!
//! Live, a frame that finds another one waiting behind it is passed on without an image (the
//! renderer shows the newest state it can), so a slow renderer never holds the simulation
//! back; the skipped frames are counted in `/stats/render_skipped`. Recording, every frame is
//! rendered.
//!
//! The JPEG encoding runs on a thread of its own, one frame behind the renderer: the encoder
//! is single-threaded, and done in line it left one of the renderer's two cores idle for a
//! tenth of every frame. Frames keep their order (one encoder, first in first out), and the
//! images go back to the renderer to be drawn into again.
//!
//! The simulation comes first: the render thread lowers its own scheduling priority before it
//! builds the renderer, whose pool threads inherit it (on Linux a thread's nice value is its
//! own and passes to the threads it starts). On a 2-core machine the simulation's two threads
//! then get the cores when they need them, and the renderer takes what is left: a live run
//! skips images, not simulation frames.
//!
//! Lower was tried (2026-12-05). Live in Linux's `SCHED_IDLE` class the renderer gave the
//! simulation more: `bench --live`, the 20 rendering rows at 5 s, alternated three times with
//! this nice-10 build, median 1.06 (1.01–1.23) faster, AWT `long` × `shake` 0.90 → 1.10. But
//! an idle-class (or nice-19) thread barely runs while other programs hold the cores, and a
//! live run waits for the frame the renderer is drawing when it stops: with two busy loops
//! of another program on both cores, Ctrl-C on `run --web --style long --motion shake` took
//! 15 s to exit idle-class and 4 s at nice 19, against 0.4 s at nice 10. A quick stop was
//! kept; lowering it further needs a renderer that can drop a frame half drawn.

use crossbeam_channel::{Receiver, Sender};
use std::thread::JoinHandle;

use crate::frame::Frame;
use crate::render::{camera::DEFAULT_VIEW, encode_jpeg_into, Camera, Image, RenderInput, Renderer};
use crate::report::{Aggregate, Stat};
use crate::scene::Scene;

/// JPEG quality of the logged images.
pub const JPEG_QUALITY: u8 = 85;
/// The default image size, pixels.
pub const DEFAULT_RENDER_SIZE: (u32, u32) = (640, 480);
/// The stat that counts frames passed on without an image.
pub const RENDER_SKIPPED: &str = "render_skipped";

/// The camera every view of `scene` starts from: the style's `render:` overrides, else one
/// framing the box the hair sweeps in the motion's first seconds.
pub fn scene_camera(scene: &Scene) -> Camera {
    let (lo, hi) = scene.hair_extent();
    Camera::from_params(&scene.loaded.style.render, lo, hi, DEFAULT_VIEW)
}

/// How much lower than the simulation the render threads run (nice value, 0–19).
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
const RENDER_NICENESS: i32 = 10;

/// What the render thread is started with; it builds its renderer itself (see the module doc).
pub struct RenderSetup {
    /// The style's render settings.
    pub params: crate::style::RenderParams,
    /// Width and height, pixels.
    pub size: (u32, u32),
    /// The camera.
    pub camera: Camera,
    /// Frames from the simulation.
    pub input: Receiver<Frame>,
    /// Frames on to the logger.
    pub output: Sender<Frame>,
    /// Skip an image when frames wait behind it.
    pub live: bool,
}

/// Starts the render thread at a lower priority than the caller's; returns once its renderer
/// is built, or why it could not be.
pub fn start(setup: RenderSetup) -> Result<(), String> {
    let (ready_tx, ready_rx) = crossbeam_channel::bounded::<Result<(), String>>(1);
    std::thread::Builder::new()
        .name("wisptree-render".into())
        .spawn(move || {
            lower_this_threads_priority();
            let (w, h) = setup.size;
            let renderer = match Renderer::new(setup.params, w, h, crate::render::default_threads())
            {
                Ok(r) => r,
                Err(e) => {
                    let _ = ready_tx.send(Err(e));
                    return;
                }
            };
            let _ = ready_tx.send(Ok(()));
            RenderThread {
                renderer,
                camera: setup.camera,
                input: setup.input,
                output: setup.output,
                live: setup.live,
            }
            .run();
        })
        .map_err(|e| format!("starting the render thread: {e}"))?;
    ready_rx
        .recv()
        .unwrap_or_else(|_| Err("the render thread stopped while starting".to_owned()))
}

/// Raises this thread's nice value (Linux: per thread); elsewhere, or if refused, nothing.
fn lower_this_threads_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: plain system calls on this thread's own id; a failure is harmless.
    unsafe {
        let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
        let now = libc::getpriority(libc::PRIO_PROCESS, tid);
        libc::setpriority(libc::PRIO_PROCESS, tid, (now + RENDER_NICENESS).min(19));
    }
}

/// The render thread's inputs.
pub struct RenderThread {
    /// The renderer (its buffers are reused frame to frame).
    pub renderer: Renderer,
    /// The camera.
    pub camera: Camera,
    /// Frames from the simulation thread.
    pub input: Receiver<Frame>,
    /// Frames (with images) to the logger.
    pub output: Sender<Frame>,
    /// Skip frames when behind (live); else render every one.
    pub live: bool,
}

impl RenderThread {
    /// Renders until the simulation thread hangs up or the logger goes away.
    pub fn run(mut self) {
        let (to_encoder, encoder_in) = crossbeam_channel::bounded::<Job>(1);
        let (images_back, images) = crossbeam_channel::unbounded::<Image>();
        let encoder = {
            let output = self.output.clone();
            std::thread::Builder::new()
                .name("wisptree-jpeg".into())
                .spawn(move || encode_loop(&encoder_in, &output, &images_back))
        };
        // Without an encoder thread (the system refused one), encode in line.
        let mut inline = Image::default();
        let encoder: Option<JoinHandle<()>> = encoder.ok();
        let mut skipped = 0u64;
        while let Ok(mut frame) = self.input.recv() {
            let behind = self.live && !self.input.is_empty();
            let mut image = None;
            if behind || frame.render_strands.is_empty() {
                skipped += u64::from(behind);
                frame.image = None;
            } else {
                let input = RenderInput {
                    strands: &frame.render_strands,
                    body: &frame.body,
                };
                let mut img = if encoder.is_some() {
                    images.try_recv().unwrap_or_default()
                } else {
                    std::mem::take(&mut inline)
                };
                self.renderer.render(&input, &self.camera, &mut img);
                image = Some(img);
            }
            frame
                .stats
                .push(Stat::new(RENDER_SKIPPED, skipped as f64, Aggregate::Last));
            let sent = if encoder.is_some() {
                to_encoder.send(Job { frame, image }).is_ok()
            } else {
                if let Some(img) = &image {
                    encode(&mut frame, img);
                }
                inline = image.unwrap_or_default();
                self.output.send(frame).is_ok()
            };
            if !sent {
                break;
            }
        }
        drop(to_encoder);
        if let Some(e) = encoder {
            let _ = e.join();
        }
    }
}

/// A frame on its way to the encoder, with its rendered image (none if it was skipped).
struct Job {
    frame: Frame,
    image: Option<Image>,
}

/// Puts `img` into `frame` as a JPEG, reusing the frame's previous JPEG buffer.
fn encode(frame: &mut Frame, img: &Image) {
    let mut encoded = frame.image.take().unwrap_or_default();
    encode_jpeg_into(img, JPEG_QUALITY, &mut encoded.jpeg);
    encoded.width = img.width;
    encoded.height = img.height;
    frame.image = Some(encoded);
}

/// The encoder thread: encodes each job's image, passes the frame on, returns the image.
fn encode_loop(jobs: &Receiver<Job>, output: &Sender<Frame>, images: &Sender<Image>) {
    while let Ok(Job { mut frame, image }) = jobs.recv() {
        if let Some(img) = image {
            encode(&mut frame, &img);
            // The renderer may be gone already; the image is then simply dropped.
            let _ = images.send(img);
        }
        if output.send(frame).is_err() {
            break;
        }
    }
}
