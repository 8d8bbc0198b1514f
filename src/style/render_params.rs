//! The `render:` section of a style: how the hair is shaded, shadowed and antialiased.

use serde::{Deserialize, Serialize};

/// Rendering parameters. Colours are sRGB in [0, 1]; directions need not be unit length.
/// Every field has a default, so `render: ()` (or no section at all) gives the defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderParams {
    /// Hair colour, sRGB. Default a medium brown (0.36, 0.22, 0.12).
    pub hair_color: [f32; 3],
    /// Weight of the Kajiya-Kay diffuse term, sin(T, L). Default 0.8.
    pub diffuse: f32,
    /// Weight of the Kajiya-Kay specular term. Default 0.35.
    pub specular: f32,
    /// Exponent p of the Kajiya-Kay specular term. Default 40.
    pub specular_exponent: f32,
    /// Direction from the scene towards the (directional) light. Default (0.35, 1, 0.55).
    pub light_dir: [f32; 3],
    /// Ambient light, as a fraction of the hair (and body) colour. Default 0.18.
    pub ambient: f32,
    /// κ: opacity of one strand crossing in the opacity shadow maps; the transmittance through
    /// Ω crossings is exp(−κ·Ω). Default 0.07.
    pub kappa: f32,
    /// Opacity of a strand where it fully covers a sample. Default 0.55.
    pub strand_alpha: f32,
    /// Strand width on screen, output pixels. Default 0.9.
    pub strand_width: f32,
    /// Samples per pixel along each axis (2 → 4 samples per pixel), 2 to 4. Default 2.
    pub supersampling: u32,
    /// Weight of the 3×3 postfilter blended with the resolved image, 0 (none) to 1. Default 0.5.
    pub postfilter: f32,
    /// Background colour, sRGB. Default (0.93, 0.93, 0.95).
    pub background: [f32; 3],
    /// Colour of the head and body, sRGB. Default a skin tone (0.85, 0.66, 0.56).
    pub body_color: [f32; 3],
    /// Resolution of each of the 16 opacity shadow maps, texels per side, 16 to 2048.
    /// Default 128.
    pub shadow_map_size: u32,
    /// Camera position, metres; default: framing the hair's bounding box.
    pub eye: Option<[f32; 3]>,
    /// Point the camera looks at, metres; default: the centre of the hair's bounding box.
    pub target: Option<[f32; 3]>,
    /// Vertical field of view, degrees (1 to 170); default 30.
    pub fov_y: Option<f32>,
}

impl Default for RenderParams {
    fn default() -> Self {
        RenderParams {
            hair_color: [0.36, 0.22, 0.12],
            diffuse: 0.8,
            specular: 0.35,
            specular_exponent: 40.0,
            light_dir: [0.35, 1.0, 0.55],
            ambient: 0.18,
            kappa: 0.07,
            strand_alpha: 0.55,
            strand_width: 0.9,
            supersampling: 2,
            postfilter: 0.5,
            background: [0.93, 0.93, 0.95],
            body_color: [0.85, 0.66, 0.56],
            shadow_map_size: 128,
            eye: None,
            target: None,
            fov_y: None,
        }
    }
}

/// The dotted field path (under `render.`) and the reason of the first bad value.
pub type Invalid = (String, String);

fn check(ok: bool, field: &str, msg: impl FnOnce() -> String) -> Result<(), Invalid> {
    if ok {
        Ok(())
    } else {
        Err((format!("render.{field}"), msg()))
    }
}

fn in_range(v: f32, lo: f32, hi: f32, field: &str) -> Result<(), Invalid> {
    check(v.is_finite() && v >= lo && v <= hi, field, || {
        format!("must be between {lo} and {hi}, got {v:?}")
    })
}

fn color(c: &[f32; 3], field: &str) -> Result<(), Invalid> {
    check(
        c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)),
        field,
        || format!("each sRGB component must be in [0, 1], got {c:?}"),
    )
}

impl RenderParams {
    /// Checks every value; the error names the field as `render.<name>`.
    pub fn validate(&self) -> Result<(), Invalid> {
        color(&self.hair_color, "hair_color")?;
        color(&self.background, "background")?;
        color(&self.body_color, "body_color")?;
        in_range(self.diffuse, 0.0, 10.0, "diffuse")?;
        in_range(self.specular, 0.0, 10.0, "specular")?;
        in_range(self.specular_exponent, 1.0, 10_000.0, "specular_exponent")?;
        in_range(self.ambient, 0.0, 1.0, "ambient")?;
        in_range(self.kappa, 0.0, 100.0, "kappa")?;
        in_range(self.strand_alpha, 0.0, 1.0, "strand_alpha")?;
        check(
            self.strand_width.is_finite() && self.strand_width > 0.0 && self.strand_width <= 16.0,
            "strand_width",
            || format!("must be in (0, 16] pixels, got {}", self.strand_width),
        )?;
        check(
            (2..=4).contains(&self.supersampling),
            "supersampling",
            || {
                format!(
                    "samples per pixel along each axis must be 2, 3 or 4 (at least 4 samples per pixel), got {}",
                    self.supersampling
                )
            },
        )?;
        in_range(self.postfilter, 0.0, 1.0, "postfilter")?;
        check(
            (16..=2048).contains(&self.shadow_map_size),
            "shadow_map_size",
            || format!("must be 16 to 2048 texels, got {}", self.shadow_map_size),
        )?;
        let l = self.light_dir;
        check(
            l.iter().all(|x| x.is_finite()) && l.iter().map(|x| x * x).sum::<f32>() > 1e-12,
            "light_dir",
            || format!("must be a finite non-zero direction, got {l:?}"),
        )?;
        for (v, f) in [(self.eye, "eye"), (self.target, "target")] {
            if let Some(v) = v {
                check(v.iter().all(|x| x.is_finite()), f, || {
                    format!("must be finite, got {v:?}")
                })?;
            }
        }
        if let (Some(e), Some(t)) = (self.eye, self.target) {
            let d: f32 = (0..3).map(|i| (e[i] - t[i]).powi(2)).sum();
            check(d > 1e-12, "target", || {
                "must differ from `eye` (the camera would look nowhere)".into()
            })?;
        }
        if let Some(f) = self.fov_y {
            in_range(f, 1.0, 170.0, "fov_y")?;
        }
        Ok(())
    }
}
