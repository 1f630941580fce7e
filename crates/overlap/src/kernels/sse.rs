//! SSE-intr (Algorithm 4, Larsson et al.): the three axes of one configuration in the lanes of
//! one SIMD register, with explicit intrinsics as the original. SSE/SSE2 belong to the x86-64
//! baseline, so no run-time detection is needed there; other targets run the same arithmetic
//! in scalar code.

use crate::config::{ConfigurationView, Cuboid};
#[cfg(not(target_arch = "x86_64"))]
use crate::real::Real;

/// Algorithm 4 in `f32`.
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn sse_f32(cfg: &impl ConfigurationView<f32>, cuboid: &Cuboid<f32>, radius: f32) -> bool {
    // SAFETY: SSE is part of the x86-64 baseline.
    unsafe { sse_f32_intrinsics(cfg, cuboid, radius) }
}

/// Algorithm 4 in `f64`.
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn sse_f64(cfg: &impl ConfigurationView<f64>, cuboid: &Cuboid<f64>, radius: f64) -> bool {
    // SAFETY: SSE2 is part of the x86-64 baseline.
    unsafe { sse_f64_intrinsics(cfg, cuboid, radius) }
}

/// One `__m128` holds (T, L, W, 0).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse")]
fn sse_f32_intrinsics(
    cfg: &impl ConfigurationView<f32>,
    cuboid: &Cuboid<f32>,
    radius: f32,
) -> bool {
    use std::arch::x86_64::*;
    let e = |i, j| cfg.axis(i, j);
    let [r_x, r_y, r_z] = [0, 1, 2].map(|j| cfg.r_sc(j));
    let [c_t, c_l, c_w] = cuboid.half;
    // Lines 2–4: the three dot products at once, lane i = r_SC · ê_i.
    let a = _mm_add_ps(
        _mm_add_ps(
            _mm_mul_ps(_mm_set1_ps(r_x), _mm_set_ps(0.0, e(2, 0), e(1, 0), e(0, 0))),
            _mm_mul_ps(_mm_set1_ps(r_y), _mm_set_ps(0.0, e(2, 1), e(1, 1), e(0, 1))),
        ),
        _mm_mul_ps(_mm_set1_ps(r_z), _mm_set_ps(0.0, e(2, 2), e(1, 2), e(0, 2))),
    );
    // Lines 5–8: l_i = min(a_i + c_i, 0) + max(a_i − c_i, 0), squared.
    let c = _mm_set_ps(0.0, c_w, c_l, c_t);
    let zero = _mm_setzero_ps();
    let l = _mm_add_ps(
        _mm_min_ps(_mm_add_ps(a, c), zero),
        _mm_max_ps(_mm_sub_ps(a, c), zero),
    );
    let l2 = _mm_mul_ps(l, l);
    // Line 9: horizontal sum (lane 3 is zero).
    let pairs = _mm_add_ps(l2, _mm_movehl_ps(l2, l2));
    let total = _mm_add_ss(pairs, _mm_shuffle_ps::<0b01>(pairs, pairs));
    _mm_cvtss_f32(total) <= radius * radius
}

/// Two `__m128d` hold (T, L) and (W, 0).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
fn sse_f64_intrinsics(
    cfg: &impl ConfigurationView<f64>,
    cuboid: &Cuboid<f64>,
    radius: f64,
) -> bool {
    use std::arch::x86_64::*;
    let axis = |i: usize| [0, 1, 2].map(|j| cfg.axis(i, j));
    let (e_t, e_l, e_w) = (axis(0), axis(1), axis(2));
    let [r_x, r_y, r_z] = [0, 1, 2].map(|j| cfg.r_sc(j));
    let [c_t, c_l, c_w] = cuboid.half;
    let (rx, ry, rz) = (_mm_set1_pd(r_x), _mm_set1_pd(r_y), _mm_set1_pd(r_z));
    let dot = |hi: [f64; 3], lo: [f64; 3]| {
        _mm_add_pd(
            _mm_add_pd(
                _mm_mul_pd(rx, _mm_set_pd(hi[0], lo[0])),
                _mm_mul_pd(ry, _mm_set_pd(hi[1], lo[1])),
            ),
            _mm_mul_pd(rz, _mm_set_pd(hi[2], lo[2])),
        )
    };
    let zero = _mm_setzero_pd();
    let squared_excess = |a: __m128d, c: __m128d| {
        let l = _mm_add_pd(
            _mm_min_pd(_mm_add_pd(a, c), zero),
            _mm_max_pd(_mm_sub_pd(a, c), zero),
        );
        _mm_mul_pd(l, l)
    };
    let tl = squared_excess(dot(e_l, e_t), _mm_set_pd(c_l, c_t));
    let w0 = squared_excess(dot([0.0; 3], e_w), _mm_set_pd(0.0, c_w));
    let sum = _mm_add_pd(tl, w0);
    let total = _mm_add_sd(sum, _mm_unpackhi_pd(sum, sum));
    _mm_cvtsd_f64(total) <= radius * radius
}

/// Algorithm 4 without SIMD, for targets other than x86-64.
#[cfg(not(target_arch = "x86_64"))]
#[inline]
fn sse_scalar<T: Real>(cfg: &impl ConfigurationView<T>, cuboid: &Cuboid<T>, radius: T) -> bool {
    let mut d = T::ZERO;
    for i in 0..3 {
        let a = cfg.projection(i);
        let l = (a + cuboid.half[i]).negative_part() + (a - cuboid.half[i]).positive_part();
        d = d + l * l;
    }
    d <= radius * radius
}

#[cfg(not(target_arch = "x86_64"))]
pub fn sse_f32(cfg: &impl ConfigurationView<f32>, cuboid: &Cuboid<f32>, radius: f32) -> bool {
    sse_scalar(cfg, cuboid, radius)
}

#[cfg(not(target_arch = "x86_64"))]
pub fn sse_f64(cfg: &impl ConfigurationView<f64>, cuboid: &Cuboid<f64>, radius: f64) -> bool {
    sse_scalar(cfg, cuboid, radius)
}
