//! What the rendering experiments of Zhang and Wünsche 2007 (Figs. 12–14) share: reading the
//! renderer's images back as light, and putting images side by side.

use crate::frame::StrandBuf;
use crate::render::Image;

/// Linear value of an 8-bit sRGB component.
pub fn srgb_to_linear(c: u8) -> f64 {
    let x = f64::from(c) / 255.0;
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// The linear (r, g, b) of pixel (x, y).
pub fn linear(img: &Image, x: u32, y: u32) -> [f64; 3] {
    img.pixel(x, y).map(srgb_to_linear)
}

/// Relative luminance (ITU-R BT.709 weights on linear values) of pixel (x, y), 0 to 1.
pub fn luminance(img: &Image, x: u32, y: u32) -> f64 {
    let [r, g, b] = linear(img, x, y);
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

/// `images` left to right on a white ground, `gap` pixels apart, top-aligned.
pub fn side_by_side(images: &[&Image], gap: u32) -> Image {
    let width =
        images.iter().map(|i| i.width).sum::<u32>() + gap * images.len().saturating_sub(1) as u32;
    let height = images.iter().map(|i| i.height).max().unwrap_or(0);
    let mut out = Image {
        width,
        height,
        rgb: vec![255; (width * height * 3) as usize],
    };
    let mut x0 = 0;
    for img in images {
        for y in 0..img.height {
            let src = &img.rgb[(y * img.width * 3) as usize..((y + 1) * img.width * 3) as usize];
            let o = ((y * width + x0) * 3) as usize;
            out.rgb[o..o + src.len()].copy_from_slice(src);
        }
        x0 += img.width + gap;
    }
    out
}

/// A strand buffer of `strands` (metres, f64 points).
pub fn strand_buf<'a>(strands: impl IntoIterator<Item = &'a Vec<[f64; 3]>>) -> StrandBuf {
    let mut buf = StrandBuf::default();
    buf.offsets.push(0);
    for s in strands {
        buf.points.extend(s.iter().map(|p| p.map(|x| x as f32)));
        buf.offsets.push(buf.points.len() as u32);
    }
    buf
}

/// `x` to `digits` decimals (the printed numbers, not the measures, are rounded).
pub fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

/// The `(x, y, w, h)` part of `img`, each pixel a `k × k` block.
pub fn zoom(img: &Image, (x0, y0, w, h): (u32, u32, u32, u32), k: u32) -> Image {
    let (w, h) = (w.min(img.width - x0), h.min(img.height - y0));
    let mut out = Image {
        width: w * k,
        height: h * k,
        rgb: Vec::with_capacity((w * h * k * k * 3) as usize),
    };
    for y in 0..h * k {
        for x in 0..w * k {
            out.rgb
                .extend_from_slice(&img.pixel(x0 + x / k, y0 + y / k));
        }
    }
    out
}
