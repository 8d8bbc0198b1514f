//! The benchmark scene at the scale of Zhang and Wünsche 2007, §7.2 (16,215 strands, 357,267
//! line segments, 13–20 frames per second on their GPU), and the render benchmark.

use std::time::{Duration, Instant};

use super::camera::{bounds, Camera, DEFAULT_VIEW};
use super::{Image, RenderInput, RenderParams, Renderer};
use crate::frame::{BodyBuf, StrandBuf};

/// Strands of the benchmark head (Zhang and Wünsche 2007, §7.2).
pub const STRANDS_16K: usize = 16_215;
/// Segments per strand: 16,215 × 22 = 356,730 ≈ the paper's 357,267.
pub const SEGMENTS_PER_STRAND: usize = 22;

const SCALP_C: [f32; 3] = [0.0, 1.6, 0.0];
const SCALP_R: [f32; 3] = [0.075, 0.095, 0.09];

/// A deterministic hash of `i` to [0, 1).
fn hash01(mut i: u32) -> f32 {
    i ^= i >> 16;
    i = i.wrapping_mul(0x7feb_352d);
    i ^= i >> 15;
    i = i.wrapping_mul(0x846c_a68b);
    i ^= i >> 16;
    (i >> 8) as f32 / (1u32 << 24) as f32
}

/// A synthetic but hair-like head of [`STRANDS_16K`] strands of [`SEGMENTS_PER_STRAND`]
/// segments: roots spread evenly (a Fibonacci spiral) over the scalp ellipsoid of the default
/// style except the face, each strand leaving the scalp along its normal and bending down under
/// a gravity-like pull, kept just outside the scalp, 25–40 cm long with a slight wave.
/// The same strands on every call.
pub fn zhang_16k_strands() -> StrandBuf {
    let mut out = StrandBuf {
        points: Vec::with_capacity(STRANDS_16K * (SEGMENTS_PER_STRAND + 1)),
        offsets: vec![0],
    };
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let mut placed = 0usize;
    let mut k = 0u32;
    // Candidate directions on the unit sphere, upper part first; skip the face.
    let candidates = 40_000u32;
    while placed < STRANDS_16K {
        let i = k % candidates;
        k += 1;
        let y = 1.0 - 1.45 * (i as f32 + 0.5) / candidates as f32; // down to elevation ≈ −27°
        let r = (1.0 - y * y).max(0.0).sqrt();
        let phi = golden * i as f32;
        let n = [r * phi.cos(), y, r * phi.sin()];
        let face = n[2] > 0.3 && n[1] < 0.55;
        if face {
            continue;
        }
        // Keep 16,215 of the candidates, evenly by a stride test.
        if hash01(i.wrapping_mul(2_654_435_761)) > 0.62 {
            continue;
        }
        strand(placed as u32, n, &mut out.points);
        out.offsets.push(out.points.len() as u32);
        placed += 1;
    }
    out
}

fn strand(id: u32, n: [f32; 3], out: &mut Vec<[f32; 3]>) {
    let on_scalp = |d: [f32; 3], s: f32| {
        [
            SCALP_C[0] + d[0] * SCALP_R[0] * s,
            SCALP_C[1] + d[1] * SCALP_R[1] * s,
            SCALP_C[2] + d[2] * SCALP_R[2] * s,
        ]
    };
    let mut p = on_scalp(n, 1.0);
    let len = 0.25 + 0.15 * hash01(id);
    let step = len / SEGMENTS_PER_STRAND as f32;
    let mut dir = super::camera::scale(n, 0.6);
    let phase = std::f32::consts::TAU * hash01(id ^ 0x5bd1_e995);
    out.push(p);
    for s in 1..=SEGMENTS_PER_STRAND {
        // Gravity pulls the direction down; a small wave across it.
        let wave = 0.25 * (phase + s as f32 * 0.9).sin();
        // Hair from the front of the scalp is combed back, off the face.
        let back = (n[2] + 0.3).max(0.0);
        dir = super::camera::normalize([
            dir[0] + wave * 0.3 * -n[2],
            dir[1] - 0.8,
            dir[2] + wave * 0.3 * n[0] - back,
        ]);
        p = super::camera::add(p, super::camera::scale(dir, step));
        // Stay outside the scalp grown by 6% (hair lies on the head, not in it).
        let l = [
            (p[0] - SCALP_C[0]) / SCALP_R[0],
            (p[1] - SCALP_C[1]) / SCALP_R[1],
            (p[2] - SCALP_C[2]) / SCALP_R[2],
        ];
        let m = super::camera::dot(l, l).sqrt();
        let shell = 1.06 + 0.05 * hash01(id.wrapping_add(77));
        if m < shell {
            p = on_scalp(super::camera::scale(l, 1.0 / m.max(1e-6)), shell);
        }
        out.push(p);
    }
}

/// The head and body of the default style, unposed.
pub fn zhang_16k_body() -> BodyBuf {
    BodyBuf {
        sphere_centers: vec![
            [0.0, 1.6, 0.0],
            [0.0, 1.47, -0.01],
            [0.0, 1.25, -0.02],
            [0.12, 1.36, -0.02],
            [-0.12, 1.36, -0.02],
        ],
        sphere_radii: vec![0.072, 0.05, 0.15, 0.07, 0.07],
        scalp_center: SCALP_C,
        scalp_radii: SCALP_R,
        scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    }
}

/// Frames per second and mean stage times of [`bench_render`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderBench {
    /// Frames per second at the median frame time: the renderer's own speed, which a
    /// shared machine's bursts of other work (they slow a few frames a lot) barely move.
    pub fps: f64,
    /// Frames rendered per second of wall-clock time over all the timed frames.
    pub fps_mean: f64,
    /// Mean milliseconds per frame: shadow maps, shading, rasterising, resolve.
    pub stage_ms: [f64; 4],
    /// Frames timed.
    pub frames: usize,
}

/// Renders `frames` frames of `strands` and `body` (after 2 untimed warm-up frames) with the
/// default parameters, the camera framing the strands from [`DEFAULT_VIEW`].
pub fn bench_render(
    strands: &StrandBuf,
    body: &BodyBuf,
    width: u32,
    height: u32,
    threads: usize,
    frames: usize,
) -> Result<RenderBench, String> {
    let mut r = Renderer::new(RenderParams::default(), width, height, threads)?;
    let (lo, hi) = bounds(&strands.points);
    let cam = Camera::framing(lo, hi, DEFAULT_VIEW);
    let input = RenderInput { strands, body };
    let mut img = Image::default();
    for _ in 0..2 {
        r.render(&input, &cam, &mut img);
    }
    let frames = frames.max(1);
    let mut stages = [Duration::ZERO; 4];
    let mut times = Vec::with_capacity(frames);
    for _ in 0..frames {
        let t0 = Instant::now();
        r.render(&input, &cam, &mut img);
        times.push(t0.elapsed().as_secs_f64());
        let t = r.stage_times();
        for (s, d) in stages
            .iter_mut()
            .zip([t.shadow_maps, t.shading, t.rasterising, t.resolve])
        {
            *s += d;
        }
    }
    let total: f64 = times.iter().sum();
    Ok(RenderBench {
        fps: 1.0 / median(&mut times),
        fps_mean: frames as f64 / total,
        stage_ms: stages.map(|d| d.as_secs_f64() * 1e3 / frames as f64),
        frames,
    })
}

/// The median of `v` (the mean of the middle two for an even count); sorts `v`.
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod median_tests {
    #[test]
    fn the_median_is_the_middle_value_whatever_the_order() {
        assert_eq!(super::median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(super::median(&mut [40.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(super::median(&mut [5.0]), 5.0);
    }
}
