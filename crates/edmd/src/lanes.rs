//! Four `f64` lanes on AVX2: the arithmetic the lane kernels share ([`crate::first_step`]'s
//! first steps, [`crate::nnl`]'s box tests). One instruction each and no fused multiply–add, so
//! that a lane computes what the scalar code computes, to the bit.

use std::arch::x86_64::*;

#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn splat(x: f64) -> __m256d {
    _mm256_set1_pd(x)
}

/// Lane k holds `f(k)`.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn lanes(f: impl Fn(usize) -> f64) -> __m256d {
    _mm256_set_pd(f(3), f(2), f(1), f(0))
}

#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn add(a: __m256d, b: __m256d) -> __m256d {
    _mm256_add_pd(a, b)
}

#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn sub(a: __m256d, b: __m256d) -> __m256d {
    _mm256_sub_pd(a, b)
}

#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn mul(a: __m256d, b: __m256d) -> __m256d {
    _mm256_mul_pd(a, b)
}
