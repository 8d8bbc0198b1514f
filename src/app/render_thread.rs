//! The render thread, between the simulation and the logger: renders each frame's strands
//! (the right half of the AWT paper's Figure 4) and encodes the image for the recording.
//!
//! Recording, every frame is rendered. The JPEG encoding then runs on a thread of its own, one
//! frame behind the renderer: the encoder is single-threaded, and done in line it left one of
//! the renderer's two cores idle for a tenth of every frame. Frames keep their order (one
//! encoder, first in first out), and the images go back to the renderer to be drawn into again.
//!
//! Live, the renderer draws the newest frame it can and skips the others (counted in
//! `/stats/render_skipped`), so a slow renderer never holds the simulation back (see below).
//!
//! The simulation comes first. Recording, the render thread raises its own nice value before
//! it builds the renderer, whose pool threads inherit it (on Linux a thread's nice value is its
//! own and passes to the threads it starts), and every frame waits for its image.
//!
//! Live, no frame waits for the renderer at all ([`dispatch`]): the render thread only hands
//! the newest frame's strands to a drawing thread when that one is free and passes every frame
//! on at once; a finished image rides on to the logger with the next frame, stamped with the
//! frame it shows ([`EncodedImage::shows`]). The drawing thread and its pool run in Linux's
//! `SCHED_IDLE` class: they get only a core nothing else wants, and a waking simulation thread
//! takes it from them at once. When the run stops, the render thread lets go of a half-drawn
//! image instead of waiting for it, so a starved renderer cannot hold up the end of a run.
//!
//! Why (2026-12-05): at nice 10 the renderer still finished its time slice before a woken
//! simulation thread got the core, and the collider's helper then often woke too late to share
//! a step: `bench --live`, the 20 rendering rows at 5 s alternated three times, idle class
//! against nice 10, median 1.06 (1.01–1.23) faster, AWT `long` × `shake` 0.90 → 1.10. The
//! idle class was tried first with the frames still passing through the drawing thread: with
//! two busy loops of another program on both cores, Ctrl-C on `run --web --style long --motion
//! shake` then waited 15 s for the frame being drawn (0.4 s at nice 10). With the drawing off
//! the frames' path, the stop no longer depends on it: 0.05–1.7 s the same way. Measured with
//! this design against nice 10 (`bench --live --rows "shake +render,lean +render"`, the eight
//! AWT rendering rows, alternated three times): median 1.21× (1.01–1.71), `long` × `shake`
//! 0.83–0.93 → 1.00–1.06.

use crossbeam_channel::{Receiver, Sender};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use crate::frame::{BodyBuf, EncodedImage, Frame, StrandBuf};
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

/// Live: whether the drawing thread will take the next frame's strands. The simulation
/// places every strand of the model for a frame (12,797 on Long: a fifth of the simulation
/// thread's time with rendering on, 2026-12-06) only when it [`Self::claim`]s the gate; the
/// drawing thread [`Self::open`]s it again when it has handed its image back. Without it, a
/// live run placed every strand of every frame and the drawing thread took one frame in
/// several: the rest was thrown away.
#[derive(Clone, Debug)]
pub struct DrawGate(Arc<AtomicBool>);

impl Default for DrawGate {
    fn default() -> Self {
        DrawGate(Arc::new(AtomicBool::new(true)))
    }
}

impl DrawGate {
    /// Whether to place this frame's strands for the drawing thread: true once per image
    /// (the gate closes until [`Self::open`]).
    pub fn claim(&self) -> bool {
        self.0.swap(false, Ordering::AcqRel)
    }

    /// The drawing thread is free for a frame's strands again (or a claimed frame was never
    /// sent).
    pub fn open(&self) {
        self.0.store(true, Ordering::Release);
    }
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
    /// Live: frames never wait for the renderer, which draws what it has time for (see the
    /// module doc), and the drawing thread opens this gate whenever it is free (the
    /// simulation places a frame's strands only then). `None`: every frame is rendered.
    pub live: Option<DrawGate>,
}

/// Starts the render thread at a lower priority than the caller's (live: the drawing thread,
/// see the module doc); returns once its renderer is built, or why it could not be.
pub fn start(mut setup: RenderSetup) -> Result<(), String> {
    if let Some(gate) = setup.live.take() {
        return start_live(setup, gate);
    }
    let (ready_tx, ready_rx) = crossbeam_channel::bounded::<Result<(), String>>(1);
    std::thread::Builder::new()
        .name("wisptree-render".into())
        .spawn(move || {
            lower_this_threads_priority(false);
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
            }
            .run();
        })
        .map_err(|e| format!("starting the render thread: {e}"))?;
    ready_rx
        .recv()
        .unwrap_or_else(|_| Err("the render thread stopped while starting".to_owned()))
}

/// A frame's strands and body, handed to the drawing thread (live).
struct DrawJob {
    /// The frame's index, for [`EncodedImage::shows`].
    index: u64,
    /// The frame's simulated time, s.
    sim_time: f64,
    /// Every strand, as the frame had them.
    strands: StrandBuf,
    /// The body, as posed in the frame.
    body: BodyBuf,
}

/// What the drawing thread hands back: the encoded image, and the job whose buffers the next
/// job reuses.
struct Drawn {
    /// The image, stamped with the frame it shows.
    image: EncodedImage,
    /// The job drawn.
    job: DrawJob,
}

/// Live: starts the drawing thread (idle class, with the renderer and its pool) and the render
/// thread that runs [`dispatch`] at the caller's priority.
fn start_live(setup: RenderSetup, gate: DrawGate) -> Result<(), String> {
    let (ready_tx, ready_rx) = crossbeam_channel::bounded::<Result<(), String>>(1);
    // One job at a time: the render thread gives a job only to an idle drawing thread.
    let (jobs_tx, jobs_rx) = crossbeam_channel::bounded::<DrawJob>(1);
    let (drawn_tx, drawn_rx) = crossbeam_channel::bounded::<Drawn>(1);
    let RenderSetup {
        params,
        size: (w, h),
        camera,
        input,
        output,
        live: _,
    } = setup;
    std::thread::Builder::new()
        .name("wisptree-draw".into())
        .spawn(move || {
            lower_this_threads_priority(true);
            let mut renderer = match Renderer::new(params, w, h, crate::render::default_threads()) {
                Ok(r) => r,
                Err(e) => {
                    let _ = ready_tx.send(Err(e));
                    return;
                }
            };
            let _ = ready_tx.send(Ok(()));
            let mut img = Image::default();
            while let Ok(job) = jobs_rx.recv() {
                let input = RenderInput {
                    strands: &job.strands,
                    body: &job.body,
                };
                renderer.render(&input, &camera, &mut img);
                let mut image = EncodedImage {
                    shows: Some((job.index, job.sim_time)),
                    ..EncodedImage::default()
                };
                encode_jpeg_into(&img, JPEG_QUALITY, &mut image.jpeg);
                (image.width, image.height) = (img.width, img.height);
                if drawn_tx.send(Drawn { image, job }).is_err() {
                    break;
                }
                // After the send: the frame that brings the next strands finds this image
                // (and the job's buffers) waiting for it.
                gate.open();
            }
        })
        .map_err(|e| format!("starting the drawing thread: {e}"))?;
    ready_rx
        .recv()
        .unwrap_or_else(|_| Err("the drawing thread stopped while starting".to_owned()))?;
    std::thread::Builder::new()
        .name("wisptree-render".into())
        .spawn(move || dispatch(&input, &output, &jobs_tx, &drawn_rx))
        .map_err(|e| format!("starting the render thread: {e}"))?;
    Ok(())
}

/// The live render thread: passes every frame from `input` on to `output` at once. The
/// drawing thread (`jobs` in, `drawn` out) gets the strands of a frame that arrives while it is
/// idle; a frame that arrives while it draws, or without strands (the simulation places them
/// only when the [`DrawGate`] is open), is skipped. A finished image goes on with the next
/// frame. Returns when `input` hangs up or `output` goes away, without waiting for an image
/// being drawn.
fn dispatch(
    input: &Receiver<Frame>,
    output: &Sender<Frame>,
    jobs: &Sender<DrawJob>,
    drawn: &Receiver<Drawn>,
) {
    let mut spare = Some(DrawJob {
        index: 0,
        sim_time: 0.0,
        strands: StrandBuf::default(),
        body: BodyBuf::default(),
    });
    let mut skipped = 0u64;
    while let Ok(mut frame) = input.recv() {
        frame.image = None;
        if let Ok(Drawn { image, job }) = drawn.try_recv() {
            frame.image = Some(image);
            spare = Some(job);
        }
        if frame.render_strands.is_empty() {
            // The simulation did not place the strands: the drawing thread was busy.
            skipped += 1;
        } else {
            match spare.take() {
                Some(mut job) => {
                    // The frame goes on with the job's old strands, which nothing after the
                    // renderer reads; the simulation refills them when the frame comes back.
                    std::mem::swap(&mut job.strands, &mut frame.render_strands);
                    job.body.clone_from(&frame.body);
                    (job.index, job.sim_time) = (frame.index, frame.sim_time);
                    if jobs.send(job).is_err() {
                        // No drawing thread any more: pass the frames on without images.
                        skipped += 1;
                    }
                }
                None => skipped += 1,
            }
        }
        frame
            .stats
            .push(Stat::new(RENDER_SKIPPED, skipped as f64, Aggregate::Last));
        if output.send(frame).is_err() {
            break;
        }
    }
}

/// Lowers this thread's scheduling priority (Linux: per thread, inherited by the threads it
/// starts): the `SCHED_IDLE` class when `idle` (the live drawing thread, see the module doc),
/// else, or if that is refused, a nice value [`RENDER_NICENESS`] higher. Elsewhere, nothing.
#[cfg_attr(not(target_os = "linux"), allow(unused_variables))]
fn lower_this_threads_priority(idle: bool) {
    #[cfg(target_os = "linux")]
    // SAFETY: plain system calls on this thread's own id; a failure is harmless.
    unsafe {
        let param = libc::sched_param { sched_priority: 0 };
        if idle && libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) == 0 {
            return;
        }
        let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
        let now = libc::getpriority(libc::PRIO_PROCESS, tid);
        libc::setpriority(libc::PRIO_PROCESS, tid, (now + RENDER_NICENESS).min(19));
    }
}

/// The render thread's inputs when recording (every frame rendered, in order; live runs use
/// [`dispatch`] and a drawing thread instead).
pub struct RenderThread {
    /// The renderer (its buffers are reused frame to frame).
    pub renderer: Renderer,
    /// The camera.
    pub camera: Camera,
    /// Frames from the simulation thread.
    pub input: Receiver<Frame>,
    /// Frames (with images) to the logger.
    pub output: Sender<Frame>,
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
        while let Ok(mut frame) = self.input.recv() {
            let mut image = None;
            if frame.render_strands.is_empty() {
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
            // Recording skips nothing; the stat is logged all the same, as live runs log it.
            frame
                .stats
                .push(Stat::new(RENDER_SKIPPED, 0.0, Aggregate::Last));
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
    encoded.shows = None;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crossbeam_channel::{bounded, unbounded};

    fn frame(index: u64) -> Frame {
        let mut f = Frame {
            index,
            sim_time: index as f64 * 0.04,
            ..Frame::default()
        };
        f.render_strands.points.push([index as f32, 0.0, 0.0]);
        f.render_strands.offsets.extend([0, 1]);
        f
    }

    /// The drawing thread stands still until told: frames still pass, the first finished
    /// image rides on the next frame with its own frame's stamp, and hanging up ends the
    /// render thread while an image is still being drawn.
    #[test]
    fn live_frames_never_wait_for_the_drawing_and_images_keep_their_frames_stamp() {
        let (sim_tx, input) = bounded::<Frame>(1);
        let (output, logger) = unbounded::<Frame>();
        let (jobs_tx, jobs_rx) = bounded::<DrawJob>(1);
        let (drawn_tx, drawn_rx) = bounded::<Drawn>(1);
        let render = std::thread::spawn(move || dispatch(&input, &output, &jobs_tx, &drawn_rx));
        // Frames 0..5 with the drawing thread busy on frame 0 all along.
        for i in 0..5 {
            sim_tx.send(frame(i)).unwrap();
            let f = logger.recv().expect("every frame passes on");
            assert_eq!(f.index, i);
            assert!(f.image.is_none());
        }
        let job = jobs_rx
            .try_recv()
            .expect("frame 0 went to the drawing thread");
        assert_eq!((job.index, job.strands.points[0][0]), (0, 0.0));
        assert!(jobs_rx.try_recv().is_err(), "one job at a time");
        // Drawn: the image goes on with the next frame, stamped with frame 0.
        let image = EncodedImage {
            jpeg: vec![1, 2, 3],
            shows: Some((job.index, job.sim_time)),
            ..EncodedImage::default()
        };
        drawn_tx.send(Drawn { image, job }).unwrap();
        sim_tx.send(frame(5)).unwrap();
        let f = logger.recv().unwrap();
        assert_eq!(f.index, 5);
        let img = f.image.expect("the finished image rides on frame 5");
        assert_eq!(img.shows, Some((0, 0.0)));
        let skipped = f.stats.iter().find(|s| s.name == RENDER_SKIPPED).unwrap();
        assert_eq!(skipped.value, 4.0, "frames 1-4 were not drawn");
        // Frame 5 went to the now idle drawing thread; nobody ever finishes it.
        let job = jobs_rx.try_recv().expect("frame 5 is being drawn");
        assert_eq!(job.index, 5);
        sim_tx.send(frame(6)).unwrap();
        assert_eq!(logger.recv().unwrap().index, 6);
        // The simulation stops: the render thread ends without the image of frame 5.
        drop(sim_tx);
        render.join().expect("the render thread returns");
        assert!(logger.recv().is_err(), "the logger's input closes");
        drop(jobs_rx);
    }

    /// Live with a real drawing thread: the gate lets the simulation place one frame's
    /// strands, stays closed while that frame is drawn, and opens once its image is back; a
    /// frame sent without strands passes on and counts as skipped.
    #[test]
    fn live_the_gate_lets_one_frame_in_per_image_and_frames_without_strands_are_skipped() {
        let gate = DrawGate::default();
        let (sim_tx, input) = bounded::<Frame>(1);
        let (output, logger) = unbounded::<Frame>();
        let params = crate::style::RenderParams::default();
        let camera = Camera::from_params(&params, [-1.0; 3], [1.0; 3], DEFAULT_VIEW);
        start(RenderSetup {
            params,
            size: (32, 24),
            camera,
            input,
            output,
            live: Some(gate.clone()),
        })
        .expect("the drawing thread starts");
        let skipped = |f: &Frame| {
            f.stats
                .iter()
                .find(|s| s.name == RENDER_SKIPPED)
                .unwrap()
                .value
        };
        assert!(
            gate.claim(),
            "open at the start: the drawing thread is idle"
        );
        assert!(
            !gate.claim(),
            "closed once claimed, until the image is back"
        );
        sim_tx.send(frame(0)).unwrap();
        let f = logger.recv().unwrap();
        assert_eq!((f.index, skipped(&f)), (0, 0.0));
        let t0 = std::time::Instant::now();
        while !gate.claim() {
            assert!(
                t0.elapsed() < std::time::Duration::from_secs(60),
                "the drawing thread never opened the gate again"
            );
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        // The gate was claimed for frame 1: it carries strands, and frame 0's image.
        sim_tx.send(frame(1)).unwrap();
        let f = logger.recv().unwrap();
        let img = f.image.as_ref().expect("frame 0's image rides on frame 1");
        assert_eq!((img.shows, img.width, img.height), (Some((0, 0.0)), 32, 24));
        assert_eq!(skipped(&f), 0.0);
        // Frame 2 comes without strands (the gate was closed): passed on, skipped.
        sim_tx
            .send(Frame {
                index: 2,
                ..Frame::default()
            })
            .unwrap();
        let f = logger.recv().unwrap();
        assert_eq!((f.index, skipped(&f)), (2, 1.0));
        drop(sim_tx);
        assert!(logger.iter().count() == 0, "the logger's input closes");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn live_drawing_runs_in_the_idle_class_and_recording_at_a_higher_nice_value() {
        let probe = |idle: bool| {
            std::thread::spawn(move || {
                lower_this_threads_priority(idle);
                // SAFETY: plain system calls on this thread's own id.
                unsafe {
                    let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
                    (
                        libc::sched_getscheduler(0),
                        libc::getpriority(libc::PRIO_PROCESS, tid),
                    )
                }
            })
            .join()
            .expect("the probe thread")
        };
        // SAFETY: reads this thread's own nice value.
        let base = unsafe {
            libc::getpriority(
                libc::PRIO_PROCESS,
                libc::syscall(libc::SYS_gettid) as libc::id_t,
            )
        };
        assert_eq!(
            probe(true).0,
            libc::SCHED_IDLE,
            "live drawing is idle-class"
        );
        let (policy, nice) = probe(false);
        assert_eq!(
            policy,
            libc::SCHED_OTHER,
            "recording stays in the normal class"
        );
        assert_eq!(
            nice,
            (base + RENDER_NICENESS).min(19),
            "at a higher nice value"
        );
    }
}
