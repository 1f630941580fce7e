//! The two floating-point precisions every kernel is generic over: their arithmetic. Which
//! SIMD kernel each one runs is [`crate::kernels::Kernels`].

use std::fmt::Debug;
use std::ops::{Add, Mul, Neg, Sub};

/// `f32` or `f64`. Sealed: the SIMD kernels exist for exactly these two.
pub trait Real:
    Copy
    + Default
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Neg<Output = Self>
    + Send
    + Sync
    + 'static
    + sealed::Sealed
{
    const ZERO: Self;
    /// Unit roundoff u = ε/2, the bound on the relative error of one rounded operation.
    const UNIT_ROUNDOFF: f64;
    const NAME: &'static str;
    /// The largest finite value and the smallest positive normal one, as f64.
    const MAX_F64: f64;
    const MIN_POSITIVE_F64: f64;

    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    /// XOR of the bit patterns of all values: the stream-read baseline. Unlike a float sum,
    /// which it may not reorder, the compiler vectorises this fold.
    fn xor_fold(values: &[Self]) -> u64;

    fn abs(self) -> Self;

    /// `max(x, 0)` as a compare-and-select: unlike `f32::max` it lowers to one `maxss`/`maxps`
    /// instead of the NaN-propagating `maxnum` sequence.
    #[inline(always)]
    fn positive_part(self) -> Self {
        if self > Self::ZERO { self } else { Self::ZERO }
    }

    /// `min(x, 0)`, see [`Real::positive_part`].
    #[inline(always)]
    fn negative_part(self) -> Self {
        if self < Self::ZERO { self } else { Self::ZERO }
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const UNIT_ROUNDOFF: f64 = (f32::EPSILON as f64) / 2.0;
    const NAME: &'static str = "f32";
    const MAX_F64: f64 = f32::MAX as f64;
    const MIN_POSITIVE_F64: f64 = f32::MIN_POSITIVE as f64;

    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn xor_fold(values: &[Self]) -> u64 {
        values.iter().fold(0u32, |acc, v| acc ^ v.to_bits()) as u64
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const UNIT_ROUNDOFF: f64 = f64::EPSILON / 2.0;
    const NAME: &'static str = "f64";
    const MAX_F64: f64 = f64::MAX;
    const MIN_POSITIVE_F64: f64 = f64::MIN_POSITIVE;

    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    fn xor_fold(values: &[Self]) -> u64 {
        values.iter().fold(0u64, |acc, v| acc ^ v.to_bits())
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
}

pub(crate) mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}
