//! Run-time choice between a function's AVX2 build and its portable build.
//!
//! [`multiversion!`] defines a function compiled twice: once for the baseline processor and
//! once inside `#[target_feature(enable = "avx2,popcnt,bmi1,bmi2,lzcnt")]` (see
//! [`avx2_present`]), chosen per call by a [`Level`] argument (the caller passes
//! [`crate::simd::level`], or a test's explicit level). Plain scalar and
//! `[f32; 4]` code built for AVX2 uses the three-operand VEX encoding and wider vectors (the
//! renderer's tile pass runs about 15 % faster, the guide strands' strips and articulated-body
//! runs 1–5 %); fused multiply-add is never enabled, so both builds compute every value bit
//! for bit alike. What the body calls is compiled for AVX2 only where it is inlined, so hot
//! callees must be `#[inline(always)]`.
//!
//! A body may also be generic over the instruction set, `fn f<I: Bound>(..)`: the AVX2 build
//! is instantiated with [`Avx2`] and the portable one with [`Portable`], the marker types on
//! which the operations of [`super::blend`] and [`super::cull`] are implemented (each with its
//! intrinsics and its portable twin), so a choice of [`Level`] picks both the build and the
//! operations.

use super::Level;

/// An instruction set the operations of this module are written for.
pub trait Isa: Copy + 'static {
    /// Its level.
    const LEVEL: Level;
}

/// Plain Rust, compiled for every processor.
#[derive(Debug, Clone, Copy)]
pub struct Portable;

/// x86-64 with AVX2 (its operations use SSE/AVX intrinsics; on other processors they fall
/// back to the portable twins, though [`Level::Avx2`] is never chosen there).
#[derive(Debug, Clone, Copy)]
pub struct Avx2;

impl Isa for Portable {
    const LEVEL: Level = Level::Portable;
}

impl Isa for Avx2 {
    const LEVEL: Level = Level::Avx2;
}

/// Whether the processor has what the AVX2 builds are compiled for: AVX2 and the
/// bit-manipulation instructions every AVX2 processor also has (POPCNT, BMI1, BMI2, LZCNT:
/// the loops over lane masks count and find bits with one instruction each instead of a
/// dozen, which changes no value). Each check is one cached load.
#[inline(always)]
pub fn avx2_present() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("lzcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the AVX2 build may run: `level` asks for it and the processor has it (checked
/// here too, so that an explicit [`Level::Avx2`] on a processor without it runs the portable
/// build rather than faulting).
#[inline(always)]
pub fn avx2_allowed(level: Level) -> bool {
    level == Level::Avx2 && avx2_present()
}

/// Defines `fn name(level: Level, args..) -> ret`, its body compiled for the baseline and for
/// AVX2 and chosen by `level` (see the module docs). With a type parameter `<I: Bound>`, the
/// body is instantiated with [`Avx2`] and [`Portable`] respectively.
macro_rules! multiversion {
    (
        $(#[$m:meta])*
        $vis:vis fn $name:ident<$I:ident: $bound:path>($($arg:ident: $ty:ty),* $(,)?)
        $(-> $ret:ty)? $body:block
    ) => {
        $(#[$m])*
        $vis fn $name(level: $crate::simd::Level, $($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn body<$I: $bound>($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,popcnt,bmi1,bmi2,lzcnt")]
                unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
                    body::<$crate::simd::dispatch::Avx2>($($arg),*)
                }
                if $crate::simd::dispatch::avx2_allowed(level) {
                    // SAFETY: the processor has AVX2, checked just above.
                    return unsafe { avx2($($arg),*) };
                }
            }
            let _ = level;
            body::<$crate::simd::dispatch::Portable>($($arg),*)
        }
    };
    (
        $(#[$m:meta])*
        $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block
    ) => {
        $(#[$m])*
        $vis fn $name(level: $crate::simd::Level, $($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn body($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,popcnt,bmi1,bmi2,lzcnt")]
                unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
                    body($($arg),*)
                }
                if $crate::simd::dispatch::avx2_allowed(level) {
                    // SAFETY: the processor has AVX2, checked just above.
                    return unsafe { avx2($($arg),*) };
                }
            }
            let _ = level;
            body($($arg),*)
        }
    };
}
pub(crate) use multiversion;

#[cfg(test)]
mod tests {
    use super::*;

    crate::simd::dispatch::multiversion! {
        fn which<I: Isa>(x: u32) -> (Level, u32) {
            (I::LEVEL, x + 1)
        }
    }

    #[test]
    fn the_portable_level_runs_the_portable_build_and_avx2_the_best_there_is() {
        assert_eq!(which(Level::Portable, 1), (Level::Portable, 2));
        assert_eq!(
            which(Level::Avx2, 1),
            (super::super::best_available(), 2),
            "AVX2 asked for runs AVX2 where the processor has it, else the portable build"
        );
    }
}
