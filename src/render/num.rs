//! Small numeric helpers of the renderer's hot loops: minimum and maximum that compile to one
//! instruction, and floor and ceiling of sample positions without a libm call. The bottom of
//! `render/`: every other file may use it, it uses none of them.

/// min(a, b) for numbers (one `minss`; `f32::min` adds NaN fix-ups on x86).
#[inline(always)]
pub(crate) fn mn(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// max(a, b) for numbers (one `maxss`).
#[inline(always)]
pub(crate) fn mx(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// Largest argument [`floor_pos`] and [`ceil_pos`] tell apart (far beyond any image).
const POS_MAX: f32 = 16_777_216.0;

/// x clamped to [0, POS_MAX], NaN to 0 (one `maxss` and one `minss`: `f32::max` and
/// `f32::min` add NaN fix-ups on x86).
#[inline(always)]
fn clamp_pos(x: f32) -> f32 {
    let x = if x > 0.0 { x } else { 0.0 };
    if x < POS_MAX {
        x
    } else {
        POS_MAX
    }
}

/// ⌊x⌋ for x ≥ 0 (negative x and NaN give 0, huge x 2²⁴), without a libm call.
#[inline(always)]
pub(crate) fn floor_pos(x: f32) -> usize {
    // The clamped value is finite and in range, so the plain truncating conversion is exact
    // (the saturating `as` costs several instructions here, on the rasteriser's hottest
    // path); truncation is the floor for x ≥ 0.
    let x = clamp_pos(x);
    // SAFETY: x is in [0, 2²⁴], representable as an i32.
    unsafe { x.to_int_unchecked::<i32>() as usize }
}

/// ⌈x⌉ for x ≥ 0 (negative x and NaN give 0, huge x 2²⁴), without a libm call.
#[inline(always)]
pub(crate) fn ceil_pos(x: f32) -> usize {
    let x = clamp_pos(x);
    // SAFETY: as in `floor_pos`.
    let i = unsafe { x.to_int_unchecked::<i32>() };
    (i + ((i as f32) < x) as i32) as usize
}
