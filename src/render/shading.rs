//! Kajiya-Kay strand shading and sRGB conversions.
//!
//! Convention (Kajiya and Kay 1989, "Rendering Fur with Three Dimensional Textures", §2.3, as
//! used by Zhang and Wünsche 2007, §4): T is the unit tangent of the strand, L and E are unit
//! vectors from the shaded point **towards** the light and **towards** the eye. Then
//!
//! * diffuse ∝ sin(T, L) = √(1 − (T·L)²),
//! * specular ∝ max(0, sin(T, L)·sin(T, E) − (T·L)(T·E))^p = max(0, cos(θ_L + θ_E))^p,
//!
//! where θ_L, θ_E are the angles of L and E to T. The highlight is where the eye lies on the
//! cone of mirror directions around the strand: T·E = −T·L. (Texts that write "+ (T·L)(T·E)"
//! take L as the direction the light travels, the opposite of ours.)

/// The Kajiya-Kay diffuse term sin(T, L) for unit vectors T and L (L towards the light).
#[inline]
pub fn kajiya_kay_diffuse(t_dot_l: f32) -> f32 {
    (1.0 - t_dot_l * t_dot_l).max(0.0).sqrt()
}

/// The Kajiya-Kay specular term max(0, sin(T,L) sin(T,E) − (T·L)(T·E))^p, for unit T, L, E
/// with L and E pointing from the shaded point towards the light and the eye.
#[inline]
pub fn kajiya_kay_specular(t_dot_l: f32, t_dot_e: f32, p: f32) -> f32 {
    let sl = kajiya_kay_diffuse(t_dot_l);
    let se = kajiya_kay_diffuse(t_dot_e);
    let c = sl * se - t_dot_l * t_dot_e;
    if c <= 0.0 {
        0.0
    } else {
        c.powf(p)
    }
}

/// sRGB-encoded component in [0, 1] to linear light.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light in [0, 1] to an sRGB-encoded component in [0, 1].
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// An sRGB colour to linear light.
pub fn srgb3_to_linear(c: [f32; 3]) -> [f32; 3] {
    [
        srgb_to_linear(c[0]),
        srgb_to_linear(c[1]),
        srgb_to_linear(c[2]),
    ]
}

/// Entries of the linear → 8-bit sRGB table: linear values are quantised to 1/4095.
pub(crate) const LUT_SIZE: usize = 4096;

/// The linear → 8-bit sRGB table used by the resolve (a `powf` per pixel component would cost
/// more than the rest of the resolve).
pub(crate) fn srgb_lut() -> Vec<u8> {
    (0..LUT_SIZE)
        .map(|i| {
            let v = i as f32 / (LUT_SIZE - 1) as f32;
            (linear_to_srgb(v) * 255.0 + 0.5) as u8
        })
        .collect()
}

/// Shading constants of one frame, linear colours.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HairShader {
    pub color: [f32; 3],
    pub diffuse: f32,
    pub specular: f32,
    pub exponent: f32,
    pub ambient: f32,
    /// Unit, towards the light.
    pub light: [f32; 3],
}

impl HairShader {
    /// The linear colour of a strand point with unit tangent `t`, unit direction to the eye
    /// `e` and light transmittance `trans` (from the opacity shadow maps). Ambient light is not
    /// shadowed.
    #[inline]
    pub fn shade(&self, t: [f32; 3], e: [f32; 3], trans: f32) -> [f32; 3] {
        let tl = super::camera::dot(t, self.light);
        let te = super::camera::dot(t, e);
        let d = self.diffuse * kajiya_kay_diffuse(tl);
        let s = self.specular * kajiya_kay_specular(tl, te, self.exponent);
        let k = self.ambient;
        // The highlight takes half the hair's hue (a pure white one looks grey on dark hair).
        let h = |c: f32| c * (k + trans * d) + trans * s * (0.5 + 0.5 * c);
        [h(self.color[0]), h(self.color[1]), h(self.color[2])]
    }
}
