//! Zhang and Wünsche 2007, Fig. 14 (§5, §6.2, §7.3): individual hairs on skin under several
//! antialiasing schemes. The paper's box and Gaussian postfilters "partially solve the aliasing
//! problem"; 2× supersampling with and without the Gaussian filter gave the best results.
//!
//! The scene: one dark straight hair 2 mm in front of a skin-coloured sphere, turning slowly
//! (2° to 26° from the image rows, one frame per 3°). The runs:
//!
//! - `none`: one point sample per pixel: a pixel takes the hair fully or not at all, as OpenGL
//!   draws lines without antialiasing (the paper's "(1) Aliasing");
//! - `filter`: the same, then wisptree's 3×3 postfilter at full weight. The postfilter's kernel
//!   is [1 2 1]ᵀ[1 2 1] / 16, binomial weights: a 3×3 Gaussian (σ ≈ 0.7 px), the paper's (3);
//! - `supersampling`: 2×2 point samples per pixel, box-filtered (4 samples: the paper's
//!   hardware "2×" is 2 samples per pixel; ours is the renderer's smallest supersampling);
//! - `supersampling_filter`: both (the paper's (5));
//! - `wisptree`: the renderer as styles use it: 2×2 samples each taking the hair's exact
//!   coverage of its cell (box prefiltering), postfilter at weight 0.5.
//!
//! The measure, `jaggedness_px`: the staircase of the drawn hair. In each pixel column the
//! hair's drawn centre is the darkness-weighted mean row (darkness: the luminance of the skin
//! rendered alone minus that of the image, within 4 px of the hair); the measure is the RMS
//! distance, pixels, from it to the true projected centre line, over the hair's columns
//! (8 px in from either end) and the frames. A point-sampled line snaps to whole rows (a
//! sawtooth of up to half a pixel: RMS ≈ 0.29 px); 2×2 samples snap it to half rows; a
//! filter spreads each step over three columns.

use serde_json::{json, Map};

use super::zhang_images::{luminance, round, side_by_side, zoom};
use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::frame::{BodyBuf, StrandBuf};
use crate::render::camera::View;
use crate::render::{Camera, Image, RenderInput, RenderParams, Renderer, Sampling};

/// Image size, pixels.
const SIZE: (u32, u32) = (320, 200);
/// Frames of the full run (the hair turns 3° a frame from 2°).
const FRAMES: usize = 9;
/// Length of the hair, m (about 240 px on screen).
const LENGTH: f32 = 0.19;
/// Columns left out at either end of the hair, pixels.
const END_MARGIN: f32 = 8.0;
/// Rows either side of the true centre line that count as the hair's, pixels.
const BAND: f32 = 4.0;

/// `zhang-fig14`.
pub static ZHANG_FIG14: ExperimentDef = ExperimentDef {
    name: "zhang-fig14",
    description: "Zhang & Wünsche 2007, Fig. 14: a slowly turning hair on skin, no \
                  antialiasing, 3x3 Gaussian postfilter ([1 2 1]^T[1 2 1]/16), 2x2 \
                  supersampling, both; and wisptree's own (coverage, 2x2, filter 0.5)",
    expectation: "jaggedness_px: filter below none; supersampling and supersampling_filter \
                  at or below filter",
    run: run_fig14,
};

/// One antialiasing scheme: label, sampling, postfilter weight.
pub fn schemes() -> [(&'static str, Sampling, f32); 5] {
    let point = |per_axis| Sampling {
        per_axis,
        point: true,
    };
    [
        ("none", point(1), 0.0),
        ("filter", point(1), 1.0),
        ("supersampling", point(2), 0.0),
        ("supersampling_filter", point(2), 1.0),
        ("wisptree", Sampling::boxed(2), 0.5),
    ]
}

/// The camera: 0.3 m in front of the skin, looking straight at it.
fn camera() -> Camera {
    Camera {
        eye: [0.0, 0.0, 0.3],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 30.0,
    }
}

/// The skin: a sphere of 0.5 m whose front is at z = 0.
fn skin() -> BodyBuf {
    BodyBuf {
        sphere_centers: vec![[0.0, 0.0, -0.5]],
        sphere_radii: vec![0.5],
        ..BodyBuf::default()
    }
}

/// The hair at `deg` degrees from the image rows, through the image centre.
fn hair(deg: f32) -> StrandBuf {
    let (s, c) = deg.to_radians().sin_cos();
    let points: Vec<[f32; 3]> = (0..9)
        .map(|k| {
            let u = LENGTH * (k as f32 / 8.0 - 0.5);
            [u * c, u * s, 0.002]
        })
        .collect();
    StrandBuf {
        offsets: vec![0, points.len() as u32],
        points,
    }
}

/// Adds frame `hair`'s squared centre errors to `sum` and their number to `n`: `img` is the
/// frame, `skin` the skin rendered alone with the same scheme.
fn jag_errors(img: &Image, skin: &Image, hair: &StrandBuf, sum: &mut f64, n: &mut usize) {
    let view = View::new(&camera(), img.width, img.height);
    let a = view.project(hair.points[0]);
    let b = view.project(*hair.points.last().expect("a hair has points"));
    let (x0, x1) = (a[0].min(b[0]) + END_MARGIN, a[0].max(b[0]) - END_MARGIN);
    let slope = (b[1] - a[1]) / (b[0] - a[0]);
    for x in 0..img.width {
        let xc = x as f32 + 0.5;
        if xc < x0 || xc > x1 {
            continue;
        }
        let yt = a[1] + slope * (xc - a[0]);
        let (mut w, mut wy) = (0.0, 0.0);
        let lo = (yt - BAND).floor().max(0.0) as u32;
        let hi = ((yt + BAND).ceil() as u32).min(img.height - 1);
        for y in lo..=hi {
            let d = (luminance(skin, x, y) - luminance(img, x, y)).max(0.0);
            w += d;
            wy += d * (f64::from(y) + 0.5);
        }
        if w > 1e-6 {
            let e = wy / w - f64::from(yt);
            *sum += e * e;
            *n += 1;
        }
    }
}

/// Frames of a run shortened by `scale` (at least 3 angles).
pub fn frames(scale: f64) -> usize {
    ((FRAMES as f64 * scale).round() as usize).clamp(3, FRAMES)
}

fn run_fig14(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let params = RenderParams {
        hair_color: [0.10, 0.06, 0.04],
        strand_alpha: 1.0,
        strand_width: 1.0,
        // No shadows: the hair's shadow on the skin would shift its drawn centre.
        kappa: 0.0,
        ..RenderParams::default()
    };
    let frames = frames(opts.duration_scale);
    let (body, cam) = (skin(), camera());
    let no_hair = StrandBuf {
        points: Vec::new(),
        offsets: vec![0],
    };
    let mut runs = Vec::new();
    let mut crops = Vec::new();
    for (label, sampling, postfilter) in schemes() {
        let p = RenderParams {
            postfilter,
            ..params.clone()
        };
        let threads = crate::render::default_threads();
        let mut r = Renderer::sampled(p, SIZE.0, SIZE.1, threads, sampling)
            .map_err(|e| anyhow::anyhow!("rendering: {e}"))?;
        let mut base = Image::default();
        r.render(
            &RenderInput {
                strands: &no_hair,
                body: &body,
            },
            &cam,
            &mut base,
        );
        let (mut sum, mut n) = (0.0, 0usize);
        let mut img = Image::default();
        for k in 0..frames {
            let h = hair(2.0 + 3.0 * k as f32);
            r.render(
                &RenderInput {
                    strands: &h,
                    body: &body,
                },
                &cam,
                &mut img,
            );
            jag_errors(&img, &base, &h, &mut sum, &mut n);
            sink.rendered(label, k as u64, &h, &img)?;
            if k == 2 {
                crops.push(zoom(&img, (120, 84, 80, 40), 4));
            }
        }
        let mut m = Map::new();
        m.insert(
            "jaggedness_px".into(),
            json!(round((sum / n.max(1) as f64).sqrt(), 3)),
        );
        m.insert(
            "samples_per_pixel".into(),
            json!(sampling.per_axis * sampling.per_axis),
        );
        m.insert("postfilter".into(), json!(postfilter));
        runs.push(ExperimentRun {
            label: label.into(),
            metrics: m,
        });
    }
    let refs: Vec<&Image> = crops.iter().collect();
    sink.picture("zhang_fig14", &side_by_side(&refs, 6))?;
    Ok(runs)
}
