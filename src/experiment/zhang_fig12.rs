//! Zhang and Wünsche 2007, Fig. 12 (§4, §7.1): a hair volume without and with shadows. The
//! paper's point is that the opacity shadow maps give the volume depth: hair inside it, under
//! other hair as seen from the light, is darker than hair on its outside.
//!
//! The Long style at rest (as generated, before any step), rendered with the style's own
//! settings (`shadows`) and with the opacity shadow maps off (`no_shadows`: κ = 0, so every
//! transmittance is 1). Measured on the hair pixels of the lower half of the hair's extent in
//! the image:
//!
//! - `lower_luminance`: their mean relative luminance;
//! - `layer_contrast`: (L_outer − L_inner) / (L_outer + L_inner), the Michelson contrast of the
//!   mean luminance of the outer layer's pixels and of the inner layer's.
//!
//! How the layers are told apart: in 3D, by strand. Around the vertical axis through the scalp
//! centre, in 12 sectors of azimuth, the strands of each sector are ranked by their mean
//! distance from the axis over their points in the lower half of the hair volume; the
//! farthest third of a sector is the outer layer, the nearest third the inner one. Then in the
//! image: a third render (flat colour, no light: outer strands red, inner blue, the rest green)
//! says which layer each pixel shows: a pixel belongs to a layer if at least half of it is hair
//! and at least 60% of that hair is the layer's.

use serde_json::{json, Map};

use super::zhang_images::{linear, luminance, round, side_by_side, zoom};
use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::frame::{Frame, StrandBuf};
use crate::pipeline::FrameBuilder;
use crate::render::camera::DEFAULT_VIEW;
use crate::render::{Camera, Image, RenderInput, RenderParams, Renderer};
use crate::scene::Scene;
use crate::solver::SolverKind;

/// Image size, pixels.
const SIZE: (u32, u32) = (480, 480);
/// Sectors of azimuth the layers are ranked in.
const SECTORS: usize = 12;

/// `zhang-fig12`.
pub static ZHANG_FIG12: ExperimentDef = ExperimentDef {
    name: "zhang-fig12",
    description: "Zhang & Wünsche 2007, Fig. 12: the Long style at rest rendered without and \
                  with opacity shadow maps",
    expectation: "layer_contrast (outer vs inner layer of the lower half) larger with shadows",
    run: run_fig12,
};

/// Which layer each strand of `strands` is in: 0 outer, 1 between (or not in the lower half),
/// 2 inner; `axis` is the (x, z) of the vertical axis.
pub fn layers(strands: &StrandBuf, axis: [f32; 2]) -> Vec<u8> {
    let (lo, hi) = crate::render::bounds(&strands.points);
    let mid = 0.5 * (lo[1] + hi[1]);
    let mut sectors: Vec<Vec<(f32, usize)>> = vec![Vec::new(); SECTORS];
    for s in 0..strands.len() {
        let (mut n, mut r, mut dx, mut dz) = (0usize, 0.0f32, 0.0f32, 0.0f32);
        for p in strands.strand(s).iter().filter(|p| p[1] < mid) {
            let (x, z) = (p[0] - axis[0], p[2] - axis[1]);
            n += 1;
            r += (x * x + z * z).sqrt();
            (dx, dz) = (dx + x, dz + z);
        }
        if n > 0 {
            let az = dz.atan2(dx) + std::f32::consts::PI;
            let k = ((az / std::f32::consts::TAU * SECTORS as f32) as usize).min(SECTORS - 1);
            sectors[k].push((r / n as f32, s));
        }
    }
    let mut out = vec![1u8; strands.len()];
    for sec in &mut sectors {
        sec.sort_by(|a, b| a.0.total_cmp(&b.0));
        let third = sec.len() / 3;
        for &(_, s) in &sec[..third] {
            out[s] = 2;
        }
        for &(_, s) in &sec[sec.len() - third..] {
            out[s] = 0;
        }
    }
    out
}

/// Per pixel of the flat-colour render `ids`: `Some(0)` outer, `Some(2)` inner, `Some(1)` hair
/// of neither, `None` not hair.
fn pixel_layers(ids: &Image) -> Vec<Option<u8>> {
    let mut out = Vec::with_capacity((ids.width * ids.height) as usize);
    for y in 0..ids.height {
        for x in 0..ids.width {
            let [r, g, b] = linear(ids, x, y);
            let sum = r + g + b;
            out.push(if sum < 0.5 {
                None
            } else if r >= 0.6 * sum {
                Some(0)
            } else if b >= 0.6 * sum {
                Some(2)
            } else {
                Some(1)
            });
        }
    }
    out
}

/// (lower_luminance, outer, inner, outer pixels, inner pixels) of `img` over the lower half of
/// the hair pixels' rows.
fn measure(img: &Image, px: &[Option<u8>]) -> (f64, f64, f64, usize, usize) {
    let w = img.width as usize;
    let rows: Vec<usize> = px
        .iter()
        .enumerate()
        .filter(|(_, l)| l.is_some())
        .map(|(i, _)| i / w)
        .collect();
    let (top, bottom) = (
        rows.iter().copied().min().unwrap_or(0),
        rows.iter().copied().max().unwrap_or(0),
    );
    let half = (top + bottom) / 2;
    let mut sums = [(0.0, 0usize); 4];
    for (i, l) in px.iter().enumerate() {
        let Some(l) = l else { continue };
        if i / w < half {
            continue;
        }
        let y = luminance(img, (i % w) as u32, (i / w) as u32);
        for k in [3, *l as usize] {
            sums[k].0 += y;
            sums[k].1 += 1;
        }
    }
    let mean = |k: usize| sums[k].0 / sums[k].1.max(1) as f64;
    (mean(3), mean(0), mean(2), sums[0].1, sums[2].1)
}

/// The box `(x, y, w, h)` of the hair pixels of `px` (rows of `width`), grown by `margin`.
fn hair_box(px: &[Option<u8>], width: u32, margin: u32) -> (u32, u32, u32, u32) {
    let (mut lo, mut hi) = ([u32::MAX; 2], [0u32; 2]);
    for (i, l) in px.iter().enumerate() {
        if l.is_some() {
            let p = [i as u32 % width, i as u32 / width];
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    if lo[0] > hi[0] {
        return (0, 0, width, px.len() as u32 / width.max(1));
    }
    let (x0, y0) = (lo[0].saturating_sub(margin), lo[1].saturating_sub(margin));
    (x0, y0, hi[0] + margin + 1 - x0, hi[1] + margin + 1 - y0)
}

fn run_fig12(
    _opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let scene = Scene::load("long", "still", SolverKind::Awt)?;
    let mut solver = scene.solver();
    let mut frame = Frame::default();
    FrameBuilder::new(&scene.model, usize::MAX, 2).fill(solver.as_mut(), &mut frame);
    let style = scene.loaded.style.render.clone();
    let (lo, hi) = scene.hair_extent();
    let camera = Camera::from_params(&style, lo, hi, DEFAULT_VIEW);
    let c = scene.model.scalp_center;
    let layer = layers(&frame.strands, [c[0] as f32, c[2] as f32]);
    let input = RenderInput {
        strands: &frame.strands,
        body: &frame.body,
    };
    let threads = crate::render::default_threads();
    let new = |p: RenderParams| {
        Renderer::new(p, SIZE.0, SIZE.1, threads).map_err(|e| anyhow::anyhow!("rendering: {e}"))
    };
    // The layers' flat colours: full ambient light, nothing else, black around.
    let mut ids = new(RenderParams {
        ambient: 1.0,
        diffuse: 0.0,
        specular: 0.0,
        kappa: 0.0,
        postfilter: 0.0,
        background: [0.0; 3],
        body_color: [0.0; 3],
        ..style.clone()
    })?;
    let palette = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let colors: Vec<[f32; 3]> = layer.iter().map(|&l| palette[l as usize]).collect();
    ids.set_strand_colors(&colors);
    let mut id_img = Image::default();
    ids.render(&input, &camera, &mut id_img);
    let px = pixel_layers(&id_img);

    let mut runs = Vec::new();
    let mut images = Vec::new();
    for (label, kappa) in [("no_shadows", 0.0), ("shadows", style.kappa)] {
        let mut r = new(RenderParams {
            kappa,
            ..style.clone()
        })?;
        let mut img = Image::default();
        r.render(&input, &camera, &mut img);
        sink.rendered(label, 0, &frame.strands, &img)?;
        let (lower, outer, inner, n_outer, n_inner) = measure(&img, &px);
        let mut m = Map::new();
        m.insert("kappa".into(), json!(round(f64::from(kappa), 4)));
        m.insert("lower_luminance".into(), json!(round(lower, 4)));
        m.insert("outer_luminance".into(), json!(round(outer, 4)));
        m.insert("inner_luminance".into(), json!(round(inner, 4)));
        m.insert(
            "layer_contrast".into(),
            json!(round((outer - inner) / (outer + inner).max(1e-12), 4)),
        );
        m.insert("outer_px".into(), json!(n_outer));
        m.insert("inner_px".into(), json!(n_inner));
        runs.push(ExperimentRun {
            label: label.into(),
            metrics: m,
        });
        images.push(img);
    }
    // The pictures: the hair's part of each image, with a margin.
    let part = hair_box(&px, SIZE.0, 12);
    let crops: Vec<Image> = images.iter().map(|i| zoom(i, part, 1)).collect();
    sink.picture("zhang_fig12", &side_by_side(&[&crops[0], &crops[1]], 8))?;
    sink.picture("zhang_fig12_layers", &zoom(&id_img, part, 1))?;
    Ok(runs)
}
