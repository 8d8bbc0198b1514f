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
    // Branch-free: a mispredicted branch per point costs more than this whole expression.
    // `c > 0` is false for NaN as well.
    let v = exp2(p * log2(c));
    if c > 0.0 {
        v
    } else {
        0.0
    }
}

/// log₂ x for finite x > 0 (the atanh series of Cephes' `logf`, relative error about 10⁻⁷;
/// x below the smallest normal float, and NaN, give −126). Written out so that a strand
/// point's shading has no libm call and no branch, and the same result on every platform.
#[inline(always)]
pub fn log2(x: f32) -> f32 {
    let x = if x > f32::MIN_POSITIVE {
        x
    } else {
        f32::MIN_POSITIVE
    };
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    // The mantissa in [√½, √2), so that s below stays under 0.172.
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let big = m > std::f32::consts::SQRT_2;
    let (m, e) = if big { (m * 0.5, e + 1) } else { (m, e) };
    // ln m = 2 atanh(s) = 2 (s + s³/3 + s⁵/5 + s⁷/7 + s⁹/9 + …), s = (m − 1)/(m + 1).
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let series = 1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0))));
    e as f32 + 2.0 * std::f32::consts::LOG2_E * s * series
}

/// 2ˣ (Cephes' `exp2f` polynomial on [−½, ½], relative error about 2·10⁻⁷); x below −126
/// gives 0, above 127 (and NaN) 2¹²⁷. No branch.
#[inline(always)]
pub fn exp2(x: f32) -> f32 {
    // (NaN fails `x < 127` and becomes 127.)
    let xc = if x < 127.0 { x } else { 127.0 };
    let xc = if xc > -126.0 { xc } else { -126.0 };
    // Round to the nearest integer by the 1.5·2²³ trick (no SSE4.1 `roundss` needed).
    const MAGIC: f32 = 12_582_912.0;
    let n = (xc + MAGIC) - MAGIC;
    let f = xc - n;
    let p = 1.0
        + f * (6.931_472e-1
            + f * (2.402_265e-1
                + f * (5.550_332_5e-2
                    + f * (9.618_437e-3 + f * (1.339_887_4e-3 + f * 1.535_336_2e-4)))));
    // SAFETY: n is an integer in [−126, 127] (x was clamped, NaN to 127 by the first `if`).
    let n = unsafe { n.to_int_unchecked::<i32>() };
    let v = p * f32::from_bits(((n + 127) as u32) << 23);
    if x < -126.0 {
        0.0
    } else {
        v
    }
}

/// e^x by [`exp2`].
#[inline(always)]
pub fn exp(x: f32) -> f32 {
    exp2(x * std::f32::consts::LOG2_E)
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
    /// shadowed. The scalar reference of the renderer's four-lane shading
    /// (`point_colors`), which its tests compare against.
    #[cfg_attr(not(test), allow(dead_code))]
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log2_and_exp2_match_the_standard_library_to_a_few_ulps() {
        for i in 0..2000 {
            let x = 1e-30f32 * 1.07f32.powi(i);
            let (got, want) = (log2(x), x.log2());
            assert!(
                (got - want).abs() <= 2e-6 * want.abs().max(1.0),
                "log2({x}) {got} vs {want}"
            );
        }
        for i in -1200..1200 {
            let x = i as f32 * 0.1037;
            let (got, want) = (exp2(x), x.exp2());
            assert!(
                (got - want).abs() <= 4e-7 * want,
                "exp2({x}) {got} vs {want}"
            );
            // e^x rounds x·log₂e first: its relative error grows as |x|·2⁻²⁴ (transmittances
            // use x = −κΩ, a few units at most).
            let y = x * 0.2;
            let (got, want) = (exp(y), y.exp());
            assert!(
                (got - want).abs() <= (4e-7 + y.abs() * 1.2e-7) * want,
                "exp({y}) {got} vs {want}"
            );
        }
        assert_eq!(exp2(-200.0), 0.0);
        assert_eq!(log2(0.0), -126.0);
        assert_eq!(log2(-1.0), -126.0);
        assert!(exp2(f32::NAN).is_finite());
    }

    #[test]
    fn the_fast_specular_power_matches_powf() {
        for &p in &[1.0f32, 2.0, 40.0, 300.0] {
            for i in 1..100 {
                let c = i as f32 / 100.0;
                let (got, want) = (exp2(p * log2(c)), c.powf(p));
                assert!(
                    (got - want).abs() <= 1e-5 * want + 1e-30,
                    "{c}^{p}: {got} vs {want}"
                );
            }
        }
    }
}
