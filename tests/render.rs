//! The hair renderer (issue 10): Kajiya-Kay terms, opacity shadow maps, antialiasing, depth
//! order, determinism, the body, and refusing bad parameters.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;

use wisptree::frame::{BodyBuf, StrandBuf};
use wisptree::render::{
    bounds, eq1_opacity, kajiya_kay_diffuse, kajiya_kay_specular, shading::srgb_to_linear,
    zhang_16k_body, zhang_16k_strands, Camera, Image, RenderInput, RenderParams, Renderer,
    ShadowMaps, MAPS,
};

/// Counts the allocations of threads that set `COUNTING` (see `rendering_allocates_nothing_once_warm`).
struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    if COUNTING.try_with(|c| c.get()) == Ok(true) {
        let _ = ALLOCS.try_with(|a| a.set(a.get() + 1));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

const W: u32 = 160;
const H: u32 = 120;

fn strands(lines: &[Vec<[f32; 3]>]) -> StrandBuf {
    let mut s = StrandBuf {
        points: Vec::new(),
        offsets: vec![0],
    };
    for l in lines {
        s.points.extend_from_slice(l);
        s.offsets.push(s.points.len() as u32);
    }
    s
}

/// A polyline from `a` to `b` in `n` segments.
fn line(a: [f32; 3], b: [f32; 3], n: usize) -> Vec<[f32; 3]> {
    (0..=n)
        .map(|k| {
            let t = k as f32 / n as f32;
            [
                a[0] + (b[0] - a[0]) * t,
                a[1] + (b[1] - a[1]) * t,
                a[2] + (b[2] - a[2]) * t,
            ]
        })
        .collect()
}

/// The camera of the flat tests: at (0, 0, 1) looking down −z, 30° vertical field of view.
fn front_camera() -> Camera {
    Camera {
        eye: [0.0, 0.0, 1.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 30.0,
    }
}

/// World size of one pixel at z = 0 for [`front_camera`].
fn pixel_size() -> f32 {
    2.0 * (15f32.to_radians()).tan() / H as f32
}

/// Pixel (column, row) of world point p seen by [`front_camera`].
fn pixel_of(p: [f32; 3]) -> (u32, u32) {
    let f = (H as f32 * 0.5) / 15f32.to_radians().tan();
    let d = 1.0 - p[2];
    (
        (W as f32 * 0.5 + p[0] / d * f) as u32,
        (H as f32 * 0.5 - p[1] / d * f) as u32,
    )
}

/// Flat white hair (ambient 1, no diffuse or specular) on black, fully opaque strands.
fn flat_params() -> RenderParams {
    RenderParams {
        hair_color: [1.0; 3],
        ambient: 1.0,
        diffuse: 0.0,
        specular: 0.0,
        background: [0.0; 3],
        strand_alpha: 1.0,
        ..RenderParams::default()
    }
}

fn render(params: RenderParams, s: &StrandBuf, body: &BodyBuf, cam: &Camera) -> Image {
    let mut r = Renderer::new(params, W, H, 1).expect("valid renderer");
    let mut img = Image::default();
    r.render(&RenderInput { strands: s, body }, cam, &mut img);
    img
}

fn luminance(p: [u8; 3]) -> f32 {
    p.iter()
        .map(|&c| srgb_to_linear(c as f32 / 255.0))
        .sum::<f32>()
        / 3.0
}

fn total_linear(img: &Image) -> f64 {
    img.rgb
        .iter()
        .map(|&c| srgb_to_linear(c as f32 / 255.0) as f64)
        .sum()
}

#[test]
fn kajiya_kay_terms_match_hand_computed_values() {
    // T along x; L at 60° from T: T·L = cos 60° = 0.5, sin(T, L) = √3/2.
    let tl = 0.5f32;
    assert!((kajiya_kay_diffuse(tl) - 0.75f32.sqrt()).abs() < 1e-6);
    assert!(
        (kajiya_kay_diffuse(1.0)).abs() < 1e-6,
        "no diffuse along the strand"
    );
    assert!((kajiya_kay_diffuse(0.0) - 1.0).abs() < 1e-6);
    // The highlight: E on the mirror cone, T·E = −T·L: sin·sin − cos·cos = 0.75 + 0.25 = 1.
    assert!((kajiya_kay_specular(tl, -tl, 40.0) - 1.0).abs() < 1e-5);
    // Not at T·E = +T·L: 0.75 − 0.25 = 0.5, so 0.5^p.
    let p = 8.0;
    assert!((kajiya_kay_specular(tl, tl, p) - 0.5f32.powf(p)).abs() < 1e-6);
    assert!(kajiya_kay_specular(tl, -tl, p) > 100.0 * kajiya_kay_specular(tl, tl, p));
    // T·L = 0.6, T·E = 0: 0.8 · 1 − 0 = 0.8, squared 0.64.
    assert!((kajiya_kay_specular(0.6, 0.0, 2.0) - 0.64).abs() < 1e-6);
    // Negative base clamps to zero: both along T, sin = 0, −(1)(1) < 0.
    assert_eq!(kajiya_kay_specular(1.0, 1.0, 3.0), 0.0);
}

#[test]
fn the_highlight_shows_where_t_dot_e_is_minus_t_dot_l() {
    // A strand along x lit from (−1, 1, 0)/√2 (T·L = −0.707); seen from (+1, 0, 1)/√2 the eye
    // is on the mirror cone (T·E = +0.707 = −T·L); seen from (−1, 0, 1)/√2, T·E = T·L.
    let s = strands(&[line([-0.05, 0.0, 0.0], [0.05, 0.0, 0.0], 10)]);
    let body = BodyBuf::default();
    let params = RenderParams {
        hair_color: [0.2, 0.2, 0.2],
        diffuse: 0.0,
        ambient: 0.0,
        specular: 1.0,
        specular_exponent: 20.0,
        light_dir: [-1.0, 1.0, 0.0],
        background: [0.0; 3],
        strand_alpha: 1.0,
        strand_width: 2.0,
        ..RenderParams::default()
    };
    let look = |dir: [f32; 3]| {
        let cam = Camera {
            eye: [dir[0] * 0.5, dir[1] * 0.5, dir[2] * 0.5],
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 30.0,
        };
        total_linear(&render(params.clone(), &s, &body, &cam))
    };
    let mirror = look([1.0, 0.0, 1.0]);
    let same = look([-1.0, 0.0, 1.0]);
    assert!(
        mirror > 20.0 * same.max(1e-3),
        "mirror {mirror}, same side {same}"
    );
}

#[test]
fn eq1_is_the_two_nearest_maps_interpolated() {
    let omega: Vec<f32> = (0..MAPS).map(|i| (i * i) as f32 * 0.5).collect();
    let (z0, dz) = (0.2, 0.01);
    // On a map: that map's value.
    assert!((eq1_opacity(&omega, z0 + 3.0 * dz, z0, dz) - omega[3]).abs() < 1e-4);
    // A quarter of the way from map 5 to map 6.
    let z = z0 + 5.25 * dz;
    let want = 0.75 * omega[5] + 0.25 * omega[6];
    assert!((eq1_opacity(&omega, z, z0, dz) - want).abs() < 1e-4);
}

#[test]
fn shadow_maps_follow_eq1_and_accumulate_front_to_back() {
    // A sheet of strands at y = 0 lit from above: behind it (lower y) the opacity is that of
    // the sheet; the maps in front of it hold nothing.
    let mut lines = Vec::new();
    for k in 0..40 {
        let z = -0.1 + k as f32 * 0.005;
        lines.push(line([-0.1, 0.0, z], [0.1, 0.0, z], 20));
    }
    // A strand far below, so the maps span depth, and one above but off to the side, so that
    // the first maps lie in front of the sheet.
    lines.push(line([-0.1, -0.3, 0.0], [0.1, -0.3, 0.0], 20));
    lines.push(line([0.3, 0.2, 0.0], [0.4, 0.2, 0.0], 5));
    let s = strands(&lines);
    let mut maps = ShadowMaps::new(64);
    maps.build(&s.points, &s.offsets, [0.0, 1.0, 0.0]);
    let q = maps.light_space([0.0, 0.0, 0.0]);
    let (tx, ty) = (q[0].floor() as usize, q[1].floor() as usize);
    let texel = maps.texel(tx, ty).to_vec();
    assert_eq!(
        texel[..4],
        [0.0; 4],
        "nothing lies in front of the sheet: {texel:?}"
    );
    assert!(
        texel[MAPS - 1] > 1.0,
        "the sheet is opaque behind: {texel:?}"
    );
    for w in texel.windows(2) {
        assert!(w[1] >= w[0], "opacity only grows away from the light");
    }
    // The lookup at a texel centre between two maps is eq. 1 on that texel.
    let (z0, dz) = (maps.first_depth(), maps.spacing());
    let z = z0 + 7.4 * dz;
    let centre = [tx as f32 + 0.5, ty as f32 + 0.5, z];
    let want = eq1_opacity(&texel, z, z0, dz);
    assert!((maps.opacity(centre, 0.0) - want).abs() < 1e-4 * want.max(1.0));
    // The bias looks one map nearer the light.
    let biased = eq1_opacity(&texel, z - dz, z0, dz);
    assert!((maps.opacity(centre, 1.0) - biased).abs() < 1e-4 * biased.max(1.0));
}

/// A test strand along x at y = 0 and, optionally, a dense wisp above it (towards the light).
fn shadow_scene(wisp: bool) -> StrandBuf {
    let mut lines = vec![line([-0.05, 0.0, 0.0], [0.05, 0.0, 0.0], 10)];
    if wisp {
        for k in 0..30 {
            let z = -0.03 + k as f32 * 0.002;
            for m in 0..5 {
                let y = 0.05 + m as f32 * 0.004;
                lines.push(line([-0.06, y, z], [0.06, y, z], 12));
            }
        }
    }
    strands(&lines)
}

#[test]
fn a_strand_behind_a_dense_wisp_is_darker() {
    let body = BodyBuf::default();
    let params = RenderParams {
        light_dir: [0.0, 1.0, 0.0],
        kappa: 0.5,
        background: [0.0; 3],
        strand_alpha: 1.0,
        strand_width: 2.0,
        ..RenderParams::default()
    };
    let cam = front_camera();
    let lit = render(params.clone(), &shadow_scene(false), &body, &cam);
    let shadowed = render(params, &shadow_scene(true), &body, &cam);
    // The strand's pixels (the wisp is above it on screen, from the front).
    let (x0, y) = pixel_of([-0.03, 0.0, 0.0]);
    let (x1, _) = pixel_of([0.03, 0.0, 0.0]);
    let mean =
        |img: &Image| (x0..x1).map(|x| luminance(img.pixel(x, y))).sum::<f32>() / (x1 - x0) as f32;
    let (a, b) = (mean(&lit), mean(&shadowed));
    assert!(a > 0.01, "the lone strand is visible: {a}");
    assert!(b < 0.8 * a, "shadowed {b} vs lit {a}");
}

#[test]
fn a_strand_with_nothing_in_front_is_not_darkened() {
    // With the one-map bias a strand never shadows itself: κ makes no difference at all.
    let body = BodyBuf::default();
    let s = shadow_scene(false);
    let cam = front_camera();
    let base = RenderParams {
        light_dir: [0.3, 1.0, 0.2],
        background: [0.0; 3],
        strand_width: 2.0,
        ..RenderParams::default()
    };
    let with = render(base.clone(), &s, &body, &cam);
    let without = render(RenderParams { kappa: 0.0, ..base }, &s, &body, &cam);
    assert!(total_linear(&with) > 1.0);
    assert_eq!(with.rgb, without.rgb);
}

#[test]
fn a_thin_line_gives_intermediate_pixels_and_keeps_its_intensity_when_moved() {
    let body = BodyBuf::default();
    let cam = front_camera();
    let px = pixel_size();
    let params = RenderParams {
        strand_width: 0.5,
        ..flat_params()
    };
    let mut totals = Vec::new();
    for k in 0..4 {
        // A short slanted line (about 12 × 3 pixels), moved by quarter pixels in x and y.
        let d = k as f32 * 0.25 * px;
        let s = strands(&[line(
            [-6.0 * px + d, -1.5 * px + d, 0.0],
            [6.0 * px + d, 1.5 * px + d, 0.0],
            3,
        )]);
        let img = render(params.clone(), &s, &body, &cam);
        let values: Vec<u8> = img.rgb.chunks(3).map(|p| p[0]).collect();
        let partial = values.iter().filter(|&&v| v > 0 && v < 250).count();
        assert!(partial >= 8, "antialiased pixels: {partial}");
        assert!(
            values.iter().all(|&v| v < 250),
            "a half-pixel line never saturates"
        );
        totals.push(total_linear(&img));
    }
    let max = totals.iter().cloned().fold(f64::MIN, f64::max);
    let min = totals.iter().cloned().fold(f64::MAX, f64::min);
    assert!(min > 0.0);
    assert!(
        (max - min) / max < 0.03,
        "total intensity varies by more than 3%: {totals:?}"
    );
}

#[test]
fn the_front_strand_shows_where_two_cross_from_either_drawing_order() {
    let body = BodyBuf::default();
    let cam = front_camera();
    let red = line([-0.05, -0.05, 0.1], [0.05, 0.05, 0.1], 8);
    let blue = line([-0.05, 0.05, 0.0], [0.05, -0.05, 0.0], 8);
    let params = RenderParams {
        strand_width: 3.0,
        ..flat_params()
    };
    let (cx, cy) = pixel_of([0.0, 0.0, 0.1]);
    for front_first in [true, false] {
        let (s, colors) = if front_first {
            (
                strands(&[red.clone(), blue.clone()]),
                [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            )
        } else {
            (
                strands(&[blue.clone(), red.clone()]),
                [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
            )
        };
        let mut r = Renderer::new(params.clone(), W, H, 1).unwrap();
        r.set_strand_colors(&colors);
        let mut img = Image::default();
        r.render(
            &RenderInput {
                strands: &s,
                body: &body,
            },
            &cam,
            &mut img,
        );
        let p = img.pixel(cx, cy);
        assert!(
            p[0] > 200 && p[0] > 3 * p[2],
            "crossing pixel {p:?} (red drawn first: {front_first})"
        );
    }
}

#[test]
fn one_and_two_threads_give_identical_images() {
    let s = zhang_16k_strands();
    let body = zhang_16k_body();
    let (lo, hi) = bounds(&s.points);
    let cam = Camera::framing(lo, hi, wisptree::render::camera::DEFAULT_VIEW);
    let input = RenderInput {
        strands: &s,
        body: &body,
    };
    let mut imgs = Vec::new();
    for threads in [1, 2] {
        let mut r = Renderer::new(RenderParams::default(), 200, 150, threads).unwrap();
        let mut img = Image::default();
        r.render(&input, &cam, &mut img);
        // A second frame through the same (warm) buffers is the same again.
        let first = img.clone();
        r.render(&input, &cam, &mut img);
        assert_eq!(first, img);
        imgs.push(img);
    }
    assert_eq!(imgs[0].rgb, imgs[1].rgb);
    let bg = imgs[0].pixel(0, 0);
    let drawn = imgs[0].rgb.chunks(3).filter(|p| *p != bg).count();
    assert!(drawn > 200 * 150 / 10, "the head covers the image: {drawn}");
}

fn style_with_render(render: &str) -> Result<(), String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("styles/short.ron");
    let text = std::fs::read_to_string(&path).unwrap();
    let text = text.replacen("Style(\n", &format!("Style(\n    render: {render},\n"), 1);
    wisptree::style::parse(&path, &text)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

#[test]
fn bad_render_parameters_in_a_style_are_refused_naming_the_field() {
    assert_eq!(style_with_render("(kappa: 0.1, supersampling: 3)"), Ok(()));
    for (section, field) in [
        ("(specular_exponent: -1.0)", "render.specular_exponent"),
        ("(supersampling: 1)", "render.supersampling"),
        ("(hair_color: (1.5, 0.2, 0.1))", "render.hair_color"),
        ("(light_dir: (0.0, 0.0, 0.0))", "render.light_dir"),
        ("(strand_alpha: 2.0)", "render.strand_alpha"),
        ("(fov_y: Some(0.0))", "render.fov_y"),
    ] {
        let e = style_with_render(section).expect_err(section);
        assert!(e.contains(field), "{section}: {e}");
        assert!(e.contains("short.ron"), "{e}");
    }
    let e = style_with_render("(specular_exponant: 3.0)").expect_err("typo");
    assert!(e.contains("specular_exponant"), "{e}");
}

#[test]
fn renderer_refuses_zero_or_absurd_sizes() {
    let p = RenderParams::default();
    for (w, h) in [(0, 100), (100, 0), (9000, 100), (100, 8193)] {
        let e = Renderer::new(p.clone(), w, h, 1).err().expect("refused");
        assert!(e.contains("width") || e.contains("height"), "{e}");
    }
    assert!(Renderer::new(p.clone(), 64, 48, 0).is_err());
    let bad = RenderParams {
        strand_width: 0.0,
        ..p
    };
    let e = Renderer::new(bad, 64, 48, 1).err().expect("refused");
    assert!(e.contains("render.strand_width"), "{e}");
}

#[test]
fn the_body_is_opaque_and_receives_the_hair_shadow() {
    let body = BodyBuf {
        sphere_centers: vec![[0.0, 0.0, 0.0]],
        sphere_radii: vec![0.1],
        scalp_center: [0.0; 3],
        scalp_radii: [0.0; 3],
        scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    };
    // A dense wisp above the left half of the sphere (x < 0), lit from above; a strand behind
    // the sphere.
    let mut lines = Vec::new();
    for k in 0..40 {
        let x = -0.12 + k as f32 * 0.003;
        for m in 0..3 {
            lines.push(line([x, 0.2 + 0.004 * m as f32, -0.15], [x, 0.2, 0.15], 10));
        }
    }
    let behind = line([-0.2, 0.0, -0.3], [0.2, 0.0, -0.3], 20);
    let params = RenderParams {
        light_dir: [0.0, 1.0, 0.0],
        kappa: 0.3,
        ..RenderParams::default()
    };
    let cam = front_camera();
    let with_behind = {
        let mut l = lines.clone();
        l.push(behind);
        strands(&l)
    };
    let img = render(params.clone(), &with_behind, &body, &cam);
    let no_behind = render(params, &strands(&lines), &body, &cam);
    // Points on the front of the sphere facing up-ish: N·L = 0.6 on both sides.
    let y = 0.06;
    let z = (0.01f32 - y * y - 0.03 * 0.03).sqrt();
    let under = pixel_of([-0.03, y, z]);
    let open = pixel_of([0.03, y, z]);
    let (a, b) = (
        luminance(img.pixel(under.0, under.1)),
        luminance(img.pixel(open.0, open.1)),
    );
    assert!(a < 0.85 * b, "under the hair {a}, in the open {b}");
    // The strand behind the sphere does not show through it.
    let centre = pixel_of([0.0, 0.0, 0.1]);
    assert_eq!(
        img.pixel(centre.0, centre.1),
        no_behind.pixel(centre.0, centre.1)
    );
    // …but does beside it.
    let side = pixel_of([0.17, 0.0, -0.3]);
    assert_ne!(img.pixel(side.0, side.1), no_behind.pixel(side.0, side.1));
}

#[test]
fn png_and_jpeg_encode() {
    let img = Image {
        width: 4,
        height: 2,
        rgb: (0..24).map(|i| (i * 10) as u8).collect(),
    };
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.png");
    wisptree::render::write_png(&img, &p).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    let j = wisptree::render::encode_jpeg(&img, 80);
    assert_eq!(&j[..2], &[0xff, 0xd8]);
}

#[test]
fn a_jpeg_decodes_to_the_image_it_encodes() {
    // A smooth 64×48 picture (a tile-sized render would do as well): the decoded JPEG has the
    // size and, within a few levels, the pixels of the original.
    let (w, h) = (64u32, 48u32);
    let rgb: Vec<u8> = (0..h)
        .flat_map(|y| {
            (0..w).flat_map(move |x| [(x * 4) as u8, (y * 5) as u8, (128 + x / 2 + y) as u8])
        })
        .collect();
    let img = Image {
        width: w,
        height: h,
        rgb,
    };
    let j = wisptree::render::encode_jpeg(&img, 85);
    let back = image::load_from_memory(&j).unwrap().to_rgb8();
    assert_eq!((back.width(), back.height()), (w, h));
    let err = back
        .as_raw()
        .iter()
        .zip(&img.rgb)
        .map(|(a, b)| (*a as f64 - *b as f64).abs())
        .sum::<f64>()
        / img.rgb.len() as f64;
    assert!(err < 3.0, "mean error {err} levels");
    // A higher quality is closer, and bigger.
    let fine = wisptree::render::encode_jpeg(&img, 98);
    assert!(fine.len() > j.len());
}

#[test]
fn rendering_allocates_nothing_once_warm() {
    // One thread: all the work is on this (counted) thread.
    let s = zhang_16k_strands();
    let body = zhang_16k_body();
    let (lo, hi) = bounds(&s.points);
    let cam = Camera::framing(lo, hi, wisptree::render::camera::DEFAULT_VIEW);
    let input = RenderInput {
        strands: &s,
        body: &body,
    };
    let mut r = Renderer::new(RenderParams::default(), 160, 120, 1).unwrap();
    let mut img = Image::default();
    for _ in 0..2 {
        r.render(&input, &cam, &mut img);
    }
    ALLOCS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    for _ in 0..3 {
        r.render(&input, &cam, &mut img);
    }
    COUNTING.with(|c| c.set(false));
    assert_eq!(
        ALLOCS.with(|a| a.get()),
        0,
        "allocations while rendering warm frames"
    );
}

#[test]
fn no_strands_draws_the_body_on_the_background() {
    let body = zhang_16k_body();
    let cam = Camera::framing([-0.2, 1.1, -0.2], [0.2, 1.75, 0.2], [0.0, 0.0, -1.0]);
    let params = RenderParams::default();
    let bg = params.background.map(|c| (c * 255.0).round() as u8);
    for s in [StrandBuf::default(), strands(&[])] {
        let img = render(params.clone(), &s, &body, &cam);
        assert_eq!(img.rgb.len(), (W * H * 3) as usize);
        let corner = img.pixel(0, 0);
        assert!(
            corner.iter().zip(bg).all(|(a, b)| a.abs_diff(b) <= 1),
            "{corner:?}"
        );
        let centre = img.pixel(W / 2, H / 2);
        assert!(
            centre.iter().zip(bg).any(|(a, b)| a.abs_diff(b) > 20),
            "body at the centre: {centre:?}"
        );
    }
}

/// An icosphere of radius `r` centred at the origin, subdivided `levels` times.
fn icosphere(r: f64, levels: usize) -> wisptree::style::obj::TriangleMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let unit = |p: [f64; 3]| {
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        [p[0] / n, p[1] / n, p[2] / n]
    };
    let mut v: Vec<[f64; 3]> = [
        [-1., t, 0.],
        [1., t, 0.],
        [-1., -t, 0.],
        [1., -t, 0.],
        [0., -1., t],
        [0., 1., t],
        [0., -1., -t],
        [0., 1., -t],
        [t, 0., -1.],
        [t, 0., 1.],
        [-t, 0., -1.],
        [-t, 0., 1.],
    ]
    .map(unit)
    .to_vec();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut nf = Vec::new();
        for tri in &f {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (p, q) = (v[a as usize], v[b as usize]);
                    v.push(unit([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                    (v.len() - 1) as u32
                });
            }
            nf.extend([
                [tri[0], m[0], m[2]],
                [tri[1], m[1], m[0]],
                [tri[2], m[2], m[1]],
                m,
            ]);
        }
        f = nf;
    }
    wisptree::style::obj::TriangleMesh {
        vertices: v.iter().map(|p| p.map(|c| c * r)).collect(),
        triangles: f,
        boundary_edges: 0,
    }
}

/// Mean absolute difference of two images' pixels within `radius` pixels of (cx, cy), in
/// 8-bit levels.
fn mean_diff_in_disk(a: &Image, b: &Image, (cx, cy): (u32, u32), radius: f32) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 0..H {
        for x in 0..W {
            let (dx, dy) = (x as f32 - cx as f32, y as f32 - cy as f32);
            if dx * dx + dy * dy <= radius * radius {
                let (p, q) = (a.pixel(x, y), b.pixel(x, y));
                sum += p
                    .iter()
                    .zip(q)
                    .map(|(u, v)| (*u as f64 - v as f64).abs())
                    .sum::<f64>()
                    / 3.0;
                n += 1;
            }
        }
    }
    sum / n as f64
}

#[test]
fn a_mesh_body_is_drawn_shaded_and_receives_the_hair_shadow() {
    // A sphere of radius 0.1 given as a triangle mesh (1280 triangles), placed by the pose (a
    // turn about y and a shift along x), against the analytic sphere where the pose puts it:
    // the same picture but for the facets' silhouette, which the test's tolerances allow.
    let shift = 0.02f32;
    let (s, c) = (0.3f32.sin(), 0.3f32.cos());
    let mesh_body = BodyBuf {
        meshes: vec![std::sync::Arc::new(icosphere(0.1, 3))],
        pose_translation: [shift, 0.0, 0.0],
        pose_rotation: [0.0, s, 0.0, c],
        scalp_radii: [0.0; 3],
        scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    };
    let sphere_body = BodyBuf {
        sphere_centers: vec![[shift, 0.0, 0.0]],
        sphere_radii: vec![0.1],
        scalp_radii: [0.0; 3],
        scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    };
    let no_body = BodyBuf {
        scalp_radii: [0.0; 3],
        scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    };
    // A dense wisp above the left half of the body, lit from above; a strand behind it.
    let mut lines = Vec::new();
    for k in 0..40 {
        let x = shift - 0.12 + k as f32 * 0.003;
        for m in 0..3 {
            lines.push(line([x, 0.2 + 0.004 * m as f32, -0.15], [x, 0.2, 0.15], 10));
        }
    }
    lines.push(line([-0.2, 0.0, -0.3], [0.2, 0.0, -0.3], 20));
    let hair = strands(&lines);
    let params = RenderParams {
        light_dir: [0.0, 1.0, 0.0],
        kappa: 0.3,
        ..RenderParams::default()
    };
    let cam = front_camera();
    let img = render(params.clone(), &hair, &mesh_body, &cam);
    let sphere = render(params.clone(), &hair, &sphere_body, &cam);
    let bare = render(params.clone(), &hair, &no_body, &cam);

    // Where the sphere is, the mesh is drawn: body colour, not the background and the strand
    // behind.
    let centre = pixel_of([shift, 0.0, 0.1]);
    let disk = 0.1 / pixel_size() * 0.9;
    let vs_sphere = mean_diff_in_disk(&img, &sphere, centre, disk);
    let vs_bare = mean_diff_in_disk(&img, &bare, centre, disk);
    assert!(
        vs_sphere < 2.0 && vs_bare > 20.0,
        "mean difference over the body's disk: {vs_sphere:.2} levels from the sphere, \
         {vs_bare:.2} from no body"
    );
    let body_colour = params.body_color.map(srgb_to_linear);
    let p = img
        .pixel(centre.0, centre.1)
        .map(|c| srgb_to_linear(c as f32 / 255.0));
    // Lit from above, the centre facing the camera gets the ambient term only: a darker
    // version of the body colour (in linear light), the same hue.
    let ratio = [
        p[0] / body_colour[0],
        p[1] / body_colour[1],
        p[2] / body_colour[2],
    ];
    assert!(
        ratio.iter().all(|r| (r - ratio[0]).abs() < 0.25 * ratio[0]),
        "centre {p:?} against body colour {body_colour:?}"
    );

    // The hair's shadow: darker under the wisp than in the open, as on the sphere.
    let y = 0.06;
    let z = (0.01f32 - y * y - 0.03 * 0.03).sqrt();
    let under = pixel_of([shift - 0.03, y, z]);
    let open = pixel_of([shift + 0.03, y, z]);
    let (a, b) = (
        luminance(img.pixel(under.0, under.1)),
        luminance(img.pixel(open.0, open.1)),
    );
    assert!(a < 0.85 * b, "under the hair {a}, in the open {b}");
    let (sa, sb) = (
        luminance(sphere.pixel(under.0, under.1)),
        luminance(sphere.pixel(open.0, open.1)),
    );
    assert!(
        (a - sa).abs() < 0.05 * sa && (b - sb).abs() < 0.05 * sb,
        "mesh {a}, {b}; sphere {sa}, {sb}"
    );

    // Hair lying on the skin shows though it dips a millimetre under it (the renderer's
    // slack for chords of a curved surface); hair a centimetre under the skin does not.
    for (depth, shows) in [(0.001f32, true), (0.01, false)] {
        let z = 0.1 - depth;
        let mut l = lines.clone();
        for k in 0..5 {
            let y = -0.01 - 0.002 * k as f32;
            l.push(line([shift - 0.008, y, z], [shift + 0.008, y, z], 4));
        }
        let with = render(params.clone(), &strands(&l), &mesh_body, &cam);
        let at = pixel_of([shift, -0.014, z]);
        let changed = with.pixel(at.0, at.1) != img.pixel(at.0, at.1);
        assert_eq!(changed, shows, "hair {depth} m under the skin");
    }

    // One and two threads give the same image.
    let mut r2 = Renderer::new(params, W, H, 2).expect("valid renderer");
    let mut two = Image::default();
    r2.render(
        &RenderInput {
            strands: &hair,
            body: &mesh_body,
        },
        &cam,
        &mut two,
    );
    assert_eq!(two.rgb, img.rgb);
}
