//! The sRGB transfer curve (IEC 61966-2-1), the one implementation every Rust crate uses:
//! in f64 for the renderer's display values, in f32 for the runner's pixel paths, and as
//! 8-bit codes. The WGSL twin is `crates/gpu/shaders/srgb.wgsl`.
//!
//! Both widths share one generic body, so the f32 and f64 curves cannot drift apart; each
//! constant is the decimal of the standard rounded once to the width it is used at.

use std::ops::{Add, Div, Mul, Sub};

/// The arithmetic the curve needs, implemented for `f32` and `f64`.
pub trait TransferFloat:
    Copy + PartialOrd + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    /// Linear values at or below this are encoded by the linear toe.
    const ENCODE_KNEE: Self;
    /// Encoded values at or below this are decoded by the linear toe.
    const DECODE_KNEE: Self;
    /// Slope of the toe.
    const TOE_SLOPE: Self;
    /// The curve's offset `a` (0.055).
    const OFFSET: Self;
    /// `1 + a`.
    const ONE_PLUS_OFFSET: Self;
    /// The exponent (2.4).
    const GAMMA: Self;
    /// `1 / 2.4`.
    const INV_GAMMA: Self;
    /// `self ^ e`.
    fn pow(self, e: Self) -> Self;
}

macro_rules! transfer_float {
    ($t:ty) => {
        impl TransferFloat for $t {
            const ENCODE_KNEE: $t = 0.003_130_8;
            const DECODE_KNEE: $t = 0.04045;
            const TOE_SLOPE: $t = 12.92;
            const OFFSET: $t = 0.055;
            const ONE_PLUS_OFFSET: $t = 1.055;
            const GAMMA: $t = 2.4;
            const INV_GAMMA: $t = 1.0 / 2.4;
            fn pow(self, e: $t) -> $t {
                self.powf(e)
            }
        }
    };
}
transfer_float!(f32);
transfer_float!(f64);

/// Linear light in [0, 1] to the encoded value in [0, 1] (no clamping: callers clamp).
#[inline]
pub fn srgb_encode<T: TransferFloat>(linear: T) -> T {
    if linear <= T::ENCODE_KNEE {
        linear * T::TOE_SLOPE
    } else {
        T::ONE_PLUS_OFFSET * linear.pow(T::INV_GAMMA) - T::OFFSET
    }
}

/// An encoded value in [0, 1] to linear light in [0, 1].
#[inline]
pub fn srgb_decode<T: TransferFloat>(encoded: T) -> T {
    if encoded <= T::DECODE_KNEE {
        encoded / T::TOE_SLOPE
    } else {
        ((encoded + T::OFFSET) / T::ONE_PLUS_OFFSET).pow(T::GAMMA)
    }
}

/// An 8-bit sRGB code to linear light (computed in f32).
#[inline]
pub fn srgb8_to_linear(code: u8) -> f32 {
    srgb_decode(f32::from(code) / 255.0)
}

/// Linear light to the nearest 8-bit sRGB code (clamped to [0, 1]; NaN gives 0).
#[inline]
pub fn linear_to_srgb8(linear: f32) -> u8 {
    let l = if linear.is_finite() { linear.clamp(0.0, 1.0) } else { 0.0 };
    (srgb_encode(l) * 255.0 + 0.5) as u8
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// The curve from its definition, in f64 with the constants written out.
    fn encode_reference(l: f64) -> f64 {
        if l <= 0.0031308 { 12.92 * l } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 }
    }

    #[test]
    fn known_values_and_the_continuity_of_the_toe() {
        assert_eq!(srgb_encode(0.0f64), 0.0);
        assert!((srgb_encode(1.0f64) - 1.0).abs() < 1e-15);
        assert!((srgb_decode(1.0f64) - 1.0).abs() < 1e-15);
        assert!((srgb8_to_linear(128) - 0.215_860_5).abs() < 1e-6);
        // The two pieces meet at the knee to within the standard's rounding of its constants.
        let k = 0.003_130_8f64;
        assert!((k * 12.92 - (1.055 * k.powf(1.0 / 2.4) - 0.055)).abs() < 1e-7);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        assert_eq!(linear_to_srgb8(-1.0), 0);
        assert_eq!(linear_to_srgb8(2.0), 255);
        assert_eq!(linear_to_srgb8(f32::INFINITY), 0);
    }

    #[test]
    fn every_code_round_trips() {
        for v in 0..=255u8 {
            assert_eq!(linear_to_srgb8(srgb8_to_linear(v)), v, "code {v}");
        }
    }

    proptest! {
        #[test]
        fn f64_and_f32_curves_match_the_definition(l in 0.0f64..=1.0) {
            prop_assert!((srgb_encode(l) - encode_reference(l)).abs() <= 4.0 * f64::EPSILON);
            prop_assert!((srgb_decode(srgb_encode(l)) - l).abs() <= 1e-14);
            let e32 = f64::from(srgb_encode(l as f32));
            prop_assert!((e32 - encode_reference(f64::from(l as f32))).abs() <= 4.0 * f64::from(f32::EPSILON));
        }

        #[test]
        fn the_8_bit_code_is_the_nearest(l in 0.0f32..=1.0) {
            let exact = 255.0 * encode_reference(f64::from(l));
            let code = f64::from(linear_to_srgb8(l));
            // Nearest to within the f32 evaluation's error (a few 1e-5 codes).
            prop_assert!((code - exact).abs() <= 0.5 + 1e-4, "{l}: {code} vs {exact}");
        }
    }
}
