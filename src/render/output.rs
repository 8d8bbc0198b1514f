//! The rendered image, and its PNG and JPEG encodings.

use std::path::Path;

/// An 8-bit sRGB image, row-major, 3 bytes per pixel.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width × height × 3` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// The (r, g, b) of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let o = ((y * self.width + x) * 3) as usize;
        [self.rgb[o], self.rgb[o + 1], self.rgb[o + 2]]
    }
}

/// Writes `img` as an 8-bit RGB PNG.
pub fn write_png(img: &Image, path: &Path) -> std::io::Result<()> {
    image::save_buffer_with_format(
        path,
        &img.rgb,
        img.width,
        img.height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(std::io::Error::other)
}

/// Encodes `img` as a baseline JPEG of `quality` (1–100, clamped).
pub fn encode_jpeg(img: &Image, quality: u8) -> Vec<u8> {
    let mut out = Vec::new();
    encode_jpeg_into(img, quality, &mut out);
    out
}

/// [`encode_jpeg`] into `out` (cleared first), reusing its allocation.
///
/// By the `jpeg-encoder` crate (with its AVX2 colour conversion and DCT where the processor
/// has them): four times faster than the `image` crate's encoder, which took a tenth of a
/// recording's time. Quality below 90 subsamples the chroma 2×2, as the `image` encoder did.
pub fn encode_jpeg_into(img: &Image, quality: u8, out: &mut Vec<u8>) {
    out.clear();
    let enc = jpeg_encoder::Encoder::new(&mut *out, quality.clamp(1, 100));
    // Encoding fails only on a size beyond 65,535 per side or a short pixel buffer, which an
    // `Image` from the renderer (≤ 8192 per side) never has.
    let (Ok(w), Ok(h)) = (u16::try_from(img.width), u16::try_from(img.height)) else {
        return;
    };
    if enc
        .encode(&img.rgb, w, h, jpeg_encoder::ColorType::Rgb)
        .is_err()
    {
        out.clear();
    }
}
