//! The one home of processor-specific code: every operation written with `std::arch` intrinsics
//! has a portable twin in plain Rust, and [`level`] chooses between them once per process.
//!
//! The model is tiny-skia's `src/wide/`: a small lane type per instruction set with the same
//! methods ([`lanes::F32x8`] and its portable twin [`lanes::F32x8Portable`]), and each operation
//! (for now the narrow phase of the hair–hair collisions, [`pairs`]) written ONCE, generically
//! over the lane type, so both twins do the same arithmetic in the same order: IEEE additions,
//! multiplications, divisions and square roots are exactly rounded in scalar and vector units
//! alike, and neither twin contracts a multiplication and an addition into an FMA (the `fma`
//! feature is never enabled), so the two give the same bits. Comparisons are the ordered, quiet
//! ones of Rust's `<`, `>`, `<=` (false on NaN), and every minimum, maximum and clamp is an
//! explicit compare-and-select, so even signed zeros agree. Tests compare the twins bit for bit
//! on every machine (the portable twin is always compiled and run).
//!
//! The switch: the environment variable `WISPTREE_SIMD=off`, read once (the first time any
//! operation asks), forces the portable twins; otherwise AVX2 is used when the processor has
//! it (detected at run time, so one binary serves every x86-64 machine).
//!
//! This module uses nothing of wisptree's: solvers and renderers call it, with plain arrays.

pub mod blend;
pub mod boxes;
pub mod cull;
pub mod dispatch;
pub mod lanes;
pub mod pairs;

use std::sync::OnceLock;

/// The instruction set the operations of this module run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// Plain Rust (what the compiler makes of it for the build's target).
    Portable,
    /// x86-64 AVX2 (eight f32 lanes), detected at run time.
    Avx2,
}

impl Level {
    /// Its name in logs and benchmarks.
    pub fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::Avx2 => "avx2",
        }
    }
}

/// The level every operation of this module uses in this process: [`Level::Avx2`] when the
/// processor has it, unless `WISPTREE_SIMD=off`. Decided once.
pub fn level() -> Level {
    static LEVEL: OnceLock<Level> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let off = std::env::var("WISPTREE_SIMD")
            .map(|v| v.trim().eq_ignore_ascii_case("off"))
            .unwrap_or(false);
        if off {
            Level::Portable
        } else {
            best_available()
        }
    })
}

/// The best level this processor supports, whatever `WISPTREE_SIMD` says (for tests that
/// compare the twins).
pub fn best_available() -> Level {
    if dispatch::avx2_present() {
        Level::Avx2
    } else {
        Level::Portable
    }
}
