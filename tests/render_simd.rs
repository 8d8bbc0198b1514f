//! The renderer's processor-specific paths (issue 26 §2): the 16k-strand head renders to the
//! same image, bit for bit, with the AVX2 build and with the portable twins, and to the image
//! recorded before the renderer's intrinsics moved to `src/simd`.

use wisptree::render::{
    bounds, camera::DEFAULT_VIEW, zhang_16k_body, zhang_16k_strands, Camera, Image, RenderInput,
    RenderParams, Renderer,
};
use wisptree::simd::Level;

/// FNV-1a, 64 bits: a hash written out here so that it never changes with a library.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The 16k head as `wisptree bench --render` frames it, 640 × 480, on `threads` threads.
fn head_16k(r: &mut Renderer) -> Image {
    let (s, body) = (zhang_16k_strands(), zhang_16k_body());
    let (lo, hi) = bounds(&s.points);
    let cam = Camera::framing(lo, hi, DEFAULT_VIEW);
    let input = RenderInput {
        strands: &s,
        body: &body,
    };
    let mut img = Image::default();
    r.render(&input, &cam, &mut img);
    img
}

#[test]
fn the_16k_head_renders_to_the_image_recorded_before_the_move() {
    let mut r = Renderer::new(RenderParams::default(), 640, 480, 2).unwrap();
    let img = head_16k(&mut r);
    let h = fnv1a(&img.rgb);
    // Recorded from the build before the move (commit 27487a9), 2 threads.
    assert_eq!(h, 0xac7c_2ca1_4c35_bde6, "16k head image hash {h:016x}");
}

#[test]
fn the_16k_head_is_the_same_image_bit_for_bit_with_avx2_and_with_the_portable_twins() {
    let best = wisptree::simd::best_available();
    let mut images = Vec::new();
    for level in [best, Level::Portable] {
        let mut r = Renderer::new(RenderParams::default(), 640, 480, 2)
            .unwrap()
            .with_simd_level(level);
        assert_eq!(r.simd_level(), level);
        images.push(head_16k(&mut r));
    }
    let note = if best == Level::Avx2 {
        "AVX2 build against the portable build"
    } else {
        "this processor has no AVX2: the portable build against itself only"
    };
    assert_eq!(images[0].rgb.len(), 640 * 480 * 3, "{note}");
    let differ = images[0]
        .rgb
        .iter()
        .zip(&images[1].rgb)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "{note}: {differ} bytes differ");
    assert_eq!(
        fnv1a(&images[1].rgb),
        0xac7c_2ca1_4c35_bde6,
        "{note}: the portable image is the recorded one"
    );
}
