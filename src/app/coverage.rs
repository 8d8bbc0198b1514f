//! `wisptree inspect --coverage STYLE`: how much of the scalp the hair at rest hides, seen from
//! above, behind, left and right. A full head of hair (the AWT paper's Figure 7 shows full
//! heads) hides nearly all of it; bald patches on the crown or at a parting show up as a lower
//! percentage in the view that sees them.
//!
//! **How it is measured.** Each view is rendered twice by the real renderer, with the style's
//! strand width, opacity and antialiasing, the scalp alone as the body, and the body drawn once
//! black and once white, unlit and unshadowed (ambient light 1: the flat key colour of a
//! coverage test). The hair is the same in both images (its shading does not depend on the
//! body's colour), so the difference of the two images, in linear light, is the fraction of the
//! scalp that comes through the hair at each pixel. The 3×3 postfilter is turned off, so that
//! it does not spread the scalp's colour onto neighbouring hair pixels. A pixel shows the scalp
//! when more than [`SHOWS_THROUGH`] of it comes through: one strand (opacity 0.55 by default)
//! lets 45 % through and does not hide the scalp; two let 20 % through and do.
//!
//! **Which pixels are scalp.** The scalp ellipsoid also stands for the face and the neck, where
//! no hair grows. A pixel is scalp when the ray through its centre hits the drawn ellipsoid at a
//! point within [`SCALP_MARGIN`] of a strand's root (measured on the full-size ellipsoid, where
//! the roots sit): the hair-bearing part of the head, gaps between wisps and partings included.

use std::path::Path;

use anyhow::Context as _;

use crate::frame::{BodyBuf, StrandBuf};
use crate::model::HairModel;
use crate::render::body::SCALP_DRAWN;
use crate::render::camera::{Camera, View};
use crate::render::{write_png, Image, RenderInput, Renderer};
use crate::style::RenderParams;

/// How far from the nearest root a point of the scalp still grows hair, m: about three root
/// spacings of the built-in styles' wisps, so that the gaps inside a region count as scalp but
/// the forehead and the face do not.
pub const SCALP_MARGIN: f32 = 0.010;

/// The fraction of the scalp's colour coming through the hair above which a pixel shows the
/// scalp.
pub const SHOWS_THROUGH: f32 = 0.25;

/// The four views: name and viewing direction (eye → head). The face looks along +z and the
/// head's left is +x (as `render`'s default three-quarter view has it).
pub const VIEWS: [(&str, [f32; 3]); 4] = [
    ("top", [0.0, -1.0, 0.0]),
    ("behind", [0.0, 0.0, 1.0]),
    ("left", [-1.0, 0.0, 0.0]),
    ("right", [1.0, 0.0, 0.0]),
];

/// The scalp as the renderer draws it (before [`SCALP_DRAWN`]).
#[derive(Debug, Clone, Copy)]
pub struct Scalp {
    /// Centre, m.
    pub center: [f32; 3],
    /// Semi-axes along x, y, z, m (the scalp is axis-aligned at rest).
    pub radii: [f32; 3],
}

/// One view's count.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ViewCoverage {
    /// `top`, `behind`, `left` or `right`.
    pub view: &'static str,
    /// Pixels of hair-bearing scalp in the view.
    pub scalp_pixels: usize,
    /// Of those, the pixels where the scalp shows through the hair.
    pub showing_pixels: usize,
    /// `1 − showing / scalp`, in percent.
    pub hidden_percent: f64,
}

/// The coverage of a model's hair at rest, every strand drawn. `images`: a folder to write each
/// view's render (with the style's colours) into, as `coverage_<view>.png`, with the scalp that
/// shows painted red and the scalp that the hair hides tinted green.
pub fn of_model(
    model: &HairModel,
    params: &RenderParams,
    size: (u32, u32),
    images: Option<&Path>,
) -> anyhow::Result<Vec<ViewCoverage>> {
    let k = model.k;
    let mut strands = StrandBuf::default();
    strands.offsets.push(0);
    let mut roots = Vec::with_capacity(model.strands.len());
    for s in 0..model.strands.len() {
        let pts = &model.strands.rest[s * k..(s + 1) * k];
        crate::pipeline::catmull_rom(pts, super::STRAND_SUBDIVISIONS, &mut strands.points);
        strands.offsets.push(strands.points.len() as u32);
        roots.push(pts[0].map(|x| x as f32).into());
    }
    let scalp = Scalp {
        center: model.scalp_center.map(|x| x as f32).into(),
        radii: model.scalp_radii.map(|x| x as f32).into(),
    };
    measure(&strands, &roots, &scalp, params, size, images)
}

/// The box each view frames: the hair's and the scalp's, as `wisptree render` frames the hair
/// (so that a strand is as wide, in millimetres, as in its pictures).
fn framed_box(strands: &StrandBuf, scalp: &Scalp) -> ([f32; 3], [f32; 3]) {
    let (mut lo, mut hi) = crate::render::camera::bounds(&strands.points);
    if strands.points.is_empty() {
        (lo, hi) = (scalp.center, scalp.center);
    }
    for a in 0..3 {
        lo[a] = lo[a].min(scalp.center[a] - scalp.radii[a]);
        hi[a] = hi[a].max(scalp.center[a] + scalp.radii[a]);
    }
    (lo, hi)
}

/// The coverage of `strands` over the part of `scalp` within [`SCALP_MARGIN`] of `roots`, from
/// the four [`VIEWS`], on `size` (width, height) images framing the hair and the scalp as
/// `wisptree render` frames the hair.
pub fn measure(
    strands: &StrandBuf,
    roots: &[[f32; 3]],
    scalp: &Scalp,
    params: &RenderParams,
    size: (u32, u32),
    images: Option<&Path>,
) -> anyhow::Result<Vec<ViewCoverage>> {
    let (width, height) = size;
    let body = BodyBuf {
        scalp_center: scalp.center,
        scalp_radii: scalp.radii,
        scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        ..BodyBuf::default()
    };
    let flat = RenderParams {
        postfilter: 0.0,
        ambient: 1.0,
        ..params.clone()
    };
    let renderer = |body_color: [f32; 3]| {
        Renderer::new(
            RenderParams {
                body_color,
                ..flat.clone()
            },
            width,
            height,
            crate::render::default_threads(),
        )
        .map_err(|e| anyhow::anyhow!("rendering: {e}"))
    };
    let (mut black, mut white) = (renderer([0.0; 3])?, renderer([1.0; 3])?);
    let mut shown = images.map(|_| renderer(params.body_color)).transpose()?;
    let near = RootGrid::new(roots, SCALP_MARGIN);
    let input = RenderInput {
        strands,
        body: &body,
    };
    let (lo, hi) = framed_box(strands, scalp);
    let (mut a, mut b) = (Image::default(), Image::default());
    let mut out = Vec::with_capacity(VIEWS.len());
    for (name, dir) in VIEWS {
        let mut camera = Camera::framing(lo, hi, dir);
        if dir[1] < 0.0 {
            // From above, the face at the top of the image.
            camera.up = [0.0, 0.0, 1.0];
        }
        black.render(&input, &camera, &mut a);
        white.render(&input, &camera, &mut b);
        let mut shot = Image::default();
        if let Some(r) = shown.as_mut() {
            r.render(&input, &camera, &mut shot);
        }
        let view = View::new(&camera, width, height);
        let (mut scalp_pixels, mut showing_pixels) = (0, 0);
        for y in 0..height {
            for x in 0..width {
                let Some(p) = scalp_hit(&view, scalp, x as f32 + 0.5, y as f32 + 0.5) else {
                    continue;
                };
                if !near.any_within(p) {
                    continue;
                }
                scalp_pixels += 1;
                let (pa, pb) = (a.pixel(x, y), b.pixel(x, y));
                let through = (0..3)
                    .map(|c| srgb_to_linear(pb[c]) - srgb_to_linear(pa[c]))
                    .fold(0.0f32, f32::max);
                let showing = through > SHOWS_THROUGH;
                showing_pixels += showing as usize;
                if !shot.rgb.is_empty() {
                    // The map of the count: the scalp that shows in red, the hidden scalp
                    // tinted green, over the render.
                    let o = ((y * width + x) * 3) as usize;
                    let px = &mut shot.rgb[o..o + 3];
                    if showing {
                        px.copy_from_slice(&[230, 30, 30]);
                    } else {
                        px[1] = px[1].saturating_add(60);
                    }
                }
            }
        }
        if let Some(dir) = images {
            let path = dir.join(format!("coverage_{name}.png"));
            write_png(&shot, &path).with_context(|| format!("{}: cannot write", path.display()))?;
        }
        let hidden_percent = if scalp_pixels == 0 {
            100.0
        } else {
            100.0 * (1.0 - showing_pixels as f64 / scalp_pixels as f64)
        };
        out.push(ViewCoverage {
            view: name,
            scalp_pixels,
            showing_pixels,
            hidden_percent,
        });
    }
    Ok(out)
}

/// Where the ray through pixel position `(x, y)` first meets the drawn scalp, mapped onto the
/// full-size ellipsoid (where the roots sit).
fn scalp_hit(view: &View, scalp: &Scalp, x: f32, y: f32) -> Option<[f32; 3]> {
    let d = view.ray(x, y);
    let r = scalp.radii.map(|r| r * SCALP_DRAWN);
    // In the frame where the drawn ellipsoid is the unit sphere: |o + t·d|² = 1.
    let o = [0, 1, 2].map(|a| (view.eye[a] - scalp.center[a]) / r[a]);
    let dl = [0, 1, 2].map(|a| d[a] / r[a]);
    let (qa, qb) = (dot(dl, dl), dot(o, dl));
    let qc = dot(o, o) - 1.0;
    let disc = qb * qb - qa * qc;
    if disc < 0.0 {
        return None;
    }
    let t = (-qb - disc.sqrt()) / qa;
    if t <= 0.0 {
        return None;
    }
    Some([0, 1, 2].map(|a| scalp.center[a] + (o[a] + t * dl[a]) * r[a] / SCALP_DRAWN))
}

/// An 8-bit sRGB value in linear light.
fn srgb_to_linear(v: u8) -> f32 {
    let c = v as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The roots in a uniform grid of cells as large as the search radius.
struct RootGrid {
    cell: f32,
    radius2: f32,
    cells: std::collections::HashMap<[i32; 3], Vec<[f32; 3]>>,
}

impl RootGrid {
    fn new(roots: &[[f32; 3]], radius: f32) -> RootGrid {
        let mut cells: std::collections::HashMap<[i32; 3], Vec<[f32; 3]>> = Default::default();
        for r in roots {
            cells.entry(Self::key(r, radius)).or_default().push(*r);
        }
        RootGrid {
            cell: radius,
            radius2: radius * radius,
            cells,
        }
    }

    fn key(p: &[f32; 3], cell: f32) -> [i32; 3] {
        p.map(|x| (x / cell).floor() as i32)
    }

    fn any_within(&self, p: [f32; 3]) -> bool {
        let c = Self::key(&p, self.cell);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    if list.iter().any(|r| {
                        let d = [r[0] - p[0], r[1] - p[1], r[2] - p[2]];
                        dot(d, d) <= self.radius2
                    }) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Roots over the whole upper half of a unit-ish head; opaque hair lying on the scalp over
    /// the half with x > 0 only (the other half's roots have no hair). Seen from above, half of
    /// the hair-bearing scalp is hidden.
    #[test]
    fn a_scalp_half_covered_from_above_is_half_hidden() {
        let scalp = Scalp {
            center: [0.0, 1.6, 0.0],
            radii: [0.1, 0.1, 0.1],
        };
        let mut roots = Vec::new();
        let mut strands = StrandBuf::default();
        strands.offsets.push(0);
        let on_scalp = |theta: f32, phi: f32, lift: f32| {
            let r = 0.1 + lift;
            [
                r * theta.sin() * phi.cos(),
                1.6 + r * theta.cos(),
                r * theta.sin() * phi.sin(),
            ]
        };
        // Roots every ~2 mm over the cap (polar angle up to 80°).
        let n = 160;
        for i in 0..=n {
            let theta = 80f32.to_radians() * i as f32 / n as f32;
            let around = ((2.0 * std::f32::consts::PI * 0.1 * theta.sin()) / 0.002).ceil() as usize;
            for j in 0..around.max(1) {
                let phi = 2.0 * std::f32::consts::PI * j as f32 / around.max(1) as f32;
                roots.push(on_scalp(theta, phi, 0.0));
            }
        }
        // The hair: arcs of constant x > 0, from the front to the back over the cap, packed
        // 1 mm apart just above the scalp, drawn wide and opaque.
        for k in 1..100 {
            let x = 0.1 * k as f32 / 100.0;
            let rr = (0.1f32 * 0.1 - x * x).sqrt() * 1.02 + 0.002;
            for m in 0..=60 {
                let a = std::f32::consts::PI * m as f32 / 60.0;
                strands.points.push([x, 1.6 + rr * a.sin(), rr * a.cos()]);
            }
            strands.offsets.push(strands.points.len() as u32);
        }
        let params = RenderParams {
            strand_alpha: 1.0,
            strand_width: 3.0,
            ..RenderParams::default()
        };
        let views = measure(&strands, &roots, &scalp, &params, (200, 200), None).unwrap();
        let top = &views[0];
        assert_eq!(top.view, "top");
        assert!(top.scalp_pixels > 3_000, "{top:?}");
        assert!(
            (top.hidden_percent - 50.0).abs() <= 2.0,
            "half the scalp covered from above: {top:?}"
        );
        // From the left (+x side) the hair covers what that view sees of the cap; from the right
        // the bare half shows.
        let (left, right) = (&views[2], &views[3]);
        assert!(left.hidden_percent > 95.0, "{left:?}");
        assert!(right.hidden_percent < 5.0, "{right:?}");
    }

    #[test]
    fn no_hair_hides_nothing_and_no_roots_means_no_scalp() {
        let scalp = Scalp {
            center: [0.0, 1.6, 0.0],
            radii: [0.1, 0.12, 0.11],
        };
        let strands = StrandBuf {
            points: Vec::new(),
            offsets: vec![0],
        };
        let roots = [[0.0, 1.72, 0.0]];
        let p = RenderParams::default();
        let v = measure(&strands, &roots, &scalp, &p, (96, 96), None).unwrap();
        assert!(v[0].scalp_pixels > 0 && v[0].showing_pixels == v[0].scalp_pixels);
        assert_eq!(v[0].hidden_percent, 0.0);
        let v = measure(&strands, &[], &scalp, &p, (96, 96), None).unwrap();
        assert!(v.iter().all(|c| c.scalp_pixels == 0));
    }
}
