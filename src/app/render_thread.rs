//! The render thread, between the simulation and the logger: renders each frame's strands
//! (the right half of the AWT paper's Figure 4) and encodes the image for the recording.
//!
//! Live, a frame that finds another one waiting behind it is passed on without an image (the
//! renderer shows the newest state it can), so a slow renderer never holds the simulation
//! back; the skipped frames are counted in `/stats/render_skipped`. Recording, every frame is
//! rendered.

use crossbeam_channel::{Receiver, Sender};

use crate::frame::Frame;
use crate::render::{camera::DEFAULT_VIEW, encode_jpeg, Camera, Image, RenderInput, Renderer};
use crate::report::{Aggregate, Stat};
use crate::scene::Scene;

/// JPEG quality of the logged images.
pub const JPEG_QUALITY: u8 = 85;
/// The default image size, pixels.
pub const DEFAULT_RENDER_SIZE: (u32, u32) = (640, 480);
/// The stat that counts frames passed on without an image.
pub const RENDER_SKIPPED: &str = "/stats/render_skipped";

/// The camera every view of `scene` starts from: the style's `render:` overrides, else one
/// framing the box the hair sweeps in the motion's first seconds.
pub fn scene_camera(scene: &Scene) -> Camera {
    let (lo, hi) = scene.hair_extent();
    Camera::from_params(&scene.loaded.style.render, lo, hi, DEFAULT_VIEW)
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
        let mut image = Image::default();
        let mut skipped = 0u64;
        while let Ok(mut frame) = self.input.recv() {
            let behind = self.live && !self.input.is_empty();
            if behind || frame.render_strands.is_empty() {
                skipped += u64::from(behind);
                frame.image = None;
            } else {
                let input = RenderInput {
                    strands: &frame.render_strands,
                    body: &frame.body,
                };
                self.renderer.render(&input, &self.camera, &mut image);
                let mut encoded = frame.image.take().unwrap_or_default();
                encoded.jpeg = encode_jpeg(&image, JPEG_QUALITY);
                encoded.width = image.width;
                encoded.height = image.height;
                frame.image = Some(encoded);
            }
            frame.stats.push(Stat {
                path: RENDER_SKIPPED,
                value: skipped as f64,
                aggregate: Aggregate::Last,
            });
            if self.output.send(frame).is_err() {
                break;
            }
        }
    }
}
