//! The scalar lane type of an evaluation: `f32` (the fast path) or `f64` (the reference path).
//!
//! One generic interpreter serves both precisions, so the reference really is "the same tape in
//! double precision" and not a second implementation that could drift. Vec3 values (points and
//! colours) are always carried in `f64` lanes, whatever `Real` is: points must keep their integer
//! lattice cell exact far beyond f32's 24-bit mantissa (see ARCHITECTURE.md, "Precision").

use std::fmt::{Debug, Display};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A floating-point lane type. Every method has IEEE-754 semantics except where documented.
pub trait Real:
    Copy
    + Send
    + Sync
    + 'static
    + Default
    + PartialEq
    + PartialOrd
    + Debug
    + Display
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    const NAN: Self;
    /// Name used in reports and disassembly: `"f32"` or `"f64"`.
    const NAME: &'static str;
    /// The largest value below one (`1 - epsilon/2`), the top of `Fract`'s range.
    const ONE_BELOW: Self;
    /// Significant bits: 24 for f32, 53 for f64.
    const MANTISSA_BITS: u32;

    /// A uniform value in [0, 1) from a 64-bit hash (`words[0]` its high half): its top
    /// [`Real::MANTISSA_BITS`] bits as a binary fraction, exactly (so an f32 value is the f64
    /// value of the same hash with its low bits dropped, and never rounds up to 1).
    #[inline(always)]
    fn from_unit_bits(words: [u32; 2]) -> Self {
        let hash = (u64::from(words[0]) << 32) | u64::from(words[1]);
        let bits = Self::MANTISSA_BITS;
        // An integer below 2^53 and a power of two: both exact, and so is their product.
        let unit = f64::from_bits(u64::from(1023 - bits) << 52);
        Self::from_f64((hash >> (64 - bits)) as f64 * unit)
    }

    /// Rounds to nearest (the `as` conversion).
    fn from_f64(v: f64) -> Self;
    /// Exact widening for f32, identity for f64.
    fn to_f64(self) -> f64;

    fn floor(self) -> Self;
    fn abs(self) -> Self;
    fn sqrt(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn exp(self) -> Self;
    fn ln(self) -> Self;
    fn log2(self) -> Self;
    fn tan(self) -> Self;
    fn asin(self) -> Self;
    fn acos(self) -> Self;
    /// Rounds half away from zero.
    fn round(self) -> Self;
    fn trunc(self) -> Self;
    fn powf(self, e: Self) -> Self;
    /// `atan2(self, x)`: `self` is y.
    fn atan2(self, x: Self) -> Self;
    /// IEEE remainder with the sign of `self` (C's `fmod`; Rust's `%`). Exact.
    fn rem(self, other: Self) -> Self;
    fn is_nan(self) -> bool;
    fn is_finite(self) -> bool;

    /// Minimum that propagates NaN (unlike `f32::min`, which drops it): a NaN operand must stay
    /// visible in bake statistics rather than silently become the other operand.
    #[inline(always)]
    fn min_nan(self, other: Self) -> Self {
        if self.is_nan() || other.is_nan() {
            Self::NAN
        } else if other < self {
            other
        } else {
            self
        }
    }

    /// Maximum that propagates NaN; see [`Real::min_nan`].
    #[inline(always)]
    fn max_nan(self, other: Self) -> Self {
        if self.is_nan() || other.is_nan() {
            Self::NAN
        } else if other > self {
            other
        } else {
            self
        }
    }
}

macro_rules! impl_real {
    ($t:ty, $name:literal) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const NAN: Self = <$t>::NAN;
            const NAME: &'static str = $name;
            const ONE_BELOW: Self = 1.0 - <$t>::EPSILON / 2.0;
            const MANTISSA_BITS: u32 = <$t>::MANTISSA_DIGITS;

            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn sin(self) -> Self {
                <$t>::sin(self)
            }
            #[inline(always)]
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            #[inline(always)]
            fn exp(self) -> Self {
                <$t>::exp(self)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                <$t>::ln(self)
            }
            #[inline(always)]
            fn log2(self) -> Self {
                <$t>::log2(self)
            }
            #[inline(always)]
            fn tan(self) -> Self {
                <$t>::tan(self)
            }
            #[inline(always)]
            fn asin(self) -> Self {
                <$t>::asin(self)
            }
            #[inline(always)]
            fn acos(self) -> Self {
                <$t>::acos(self)
            }
            #[inline(always)]
            fn round(self) -> Self {
                <$t>::round(self)
            }
            #[inline(always)]
            fn trunc(self) -> Self {
                <$t>::trunc(self)
            }
            #[inline(always)]
            fn powf(self, e: Self) -> Self {
                <$t>::powf(self, e)
            }
            #[inline(always)]
            fn atan2(self, x: Self) -> Self {
                <$t>::atan2(self, x)
            }
            #[inline(always)]
            fn rem(self, other: Self) -> Self {
                self % other
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}

impl_real!(f32, "f32");
impl_real!(f64, "f64");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_max_propagate_nan() {
        assert!(f32::NAN.min_nan(1.0).is_nan());
        assert!(1.0f32.min_nan(f32::NAN).is_nan());
        assert!(f64::NAN.max_nan(1.0).is_nan());
        assert_eq!(2.0f64.min_nan(-3.0), -3.0);
        assert_eq!(2.0f32.max_nan(-3.0), 2.0);
    }
}
