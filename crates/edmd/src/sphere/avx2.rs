//! [`super::first_contact`] four neighbours at a time. The same operations in the same order as
//! [`super::contact_time_with`] (no fused multiply-adds; `max` with the operand order that returns
//! 0 for NaN, as `f64::max(x, 0.0)` does), so that every lane equals the scalar result to the bit.

use std::arch::x86_64::*;

use super::{Probe, Trajectory};

/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn first_contact<const MIXED: bool>(
    neighbours: &[Trajectory],
    probe: &Probe,
    horizon: f64,
) -> Option<(usize, f64)> {
    let splat = _mm256_set1_pd;
    let (rx, ry, rz) = (splat(probe.r.x), splat(probe.r.y), splat(probe.r.z));
    let (vx, vy, vz) = (splat(probe.v.x), splat(probe.v.y), splat(probe.v.z));
    let (now, sigma2, radius, zero, inf) = (
        splat(probe.now),
        splat(probe.sigma2),
        splat(probe.radius),
        _mm256_setzero_pd(),
        splat(f64::INFINITY),
    );
    // Per lane: the earliest time so far and its index (the bits of a u64, u64::MAX for none).
    let mut best_t = splat(horizon);
    let mut best_i = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    // Chunks of four from the start, and one more ending at the end when the length is not a
    // multiple of four: its neighbours seen twice give the same time at the same index, which
    // changes neither the earliest time nor the first index. Fewer than four go through a copy
    // padded with NaN trajectories, which never meet (b < 0 fails).
    let padded;
    let neighbours = if neighbours.len() >= 4 {
        neighbours
    } else {
        padded = nan_padded(neighbours);
        &padded[..]
    };
    let starts = (0..neighbours.len() - 3)
        .step_by(4)
        .chain((neighbours.len() % 4 != 0).then(|| neighbours.len() - 4));
    for start in starts {
        let idx = _mm256_add_epi64(
            _mm256_set1_epi64x(start as i64),
            _mm256_set_epi64x(3, 2, 1, 0),
        );
        let c = &neighbours[start..start + 4];
        // Two loads per neighbour, [r, t0] and [v, radius], transposed into one register per field.
        // SAFETY: a `Trajectory` is 8 consecutive f64 (repr(C)); each load stays inside one.
        let (lo, hi) = unsafe {
            let p = |k: usize| c[k].r.as_ptr();
            (
                [0, 1, 2, 3].map(|k| _mm256_loadu_pd(p(k))),
                [0, 1, 2, 3].map(|k| _mm256_loadu_pd(p(k).add(4))),
            )
        };
        let [x, y, z, t0] = transpose(lo);
        let [wx, wy, wz, rj] = transpose(hi);
        let dt = _mm256_sub_pd(now, t0);
        let dx = _mm256_sub_pd(_mm256_add_pd(x, _mm256_mul_pd(wx, dt)), rx);
        let dy = _mm256_sub_pd(_mm256_add_pd(y, _mm256_mul_pd(wy, dt)), ry);
        let dz = _mm256_sub_pd(_mm256_add_pd(z, _mm256_mul_pd(wz, dt)), rz);
        let (ux, uy, uz) = (
            _mm256_sub_pd(wx, vx),
            _mm256_sub_pd(wy, vy),
            _mm256_sub_pd(wz, vz),
        );
        let dot = |a: [__m256d; 3], b: [__m256d; 3]| {
            _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(a[0], b[0]), _mm256_mul_pd(a[1], b[1])),
                _mm256_mul_pd(a[2], b[2]),
            )
        };
        let b = dot([dx, dy, dz], [ux, uy, uz]);
        let sigma2 = if MIXED {
            let s = _mm256_add_pd(radius, rj);
            _mm256_mul_pd(s, s)
        } else {
            sigma2
        };
        let cc = _mm256_sub_pd(dot([dx, dy, dz], [dx, dy, dz]), sigma2);
        let vv = dot([ux, uy, uz], [ux, uy, uz]);
        let disc = _mm256_sub_pd(_mm256_mul_pd(b, b), _mm256_mul_pd(vv, cc));
        let root = _mm256_sqrt_pd(_mm256_max_pd(disc, zero));
        let neg_b = _mm256_xor_pd(b, splat(-0.0));
        let t = _mm256_max_pd(_mm256_div_pd(cc, _mm256_add_pd(neg_b, root)), zero);
        let meets = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_LT_OQ>(b, zero),
            _mm256_cmp_pd::<_CMP_GE_OQ>(disc, zero),
        );
        let tau = _mm256_blendv_pd(inf, t, meets);
        let earlier = _mm256_cmp_pd::<_CMP_LT_OQ>(tau, best_t);
        best_t = _mm256_blendv_pd(best_t, tau, earlier);
        best_i = _mm256_blendv_pd(best_i, _mm256_castsi256_pd(idx), earlier);
    }
    let mut ts = [0.0; 4];
    let mut is = [0u64; 4];
    // SAFETY: 4 f64 / u64 fit the arrays.
    unsafe {
        _mm256_storeu_pd(ts.as_mut_ptr(), best_t);
        _mm256_storeu_si256(is.as_mut_ptr().cast(), _mm256_castpd_si256(best_i));
    }
    // The earliest over the lanes, and among equal times the first index, as the scalar loop
    // keeps; lanes that never found one hold u64::MAX. Selects, not branches.
    let t = ts.iter().fold(horizon, |m, &t| m.min(t));
    let first = ts.iter().zip(&is).fold(u64::MAX, |f, (&lt, &li)| {
        f.min(if lt == t { li } else { u64::MAX })
    });
    (first != u64::MAX).then_some((first as usize, t))
}

/// Up to four trajectories, the rest NaN.
#[cold]
fn nan_padded(neighbours: &[Trajectory]) -> [Trajectory; 4] {
    let mut padded = [Trajectory {
        r: [f64::NAN; 3],
        ..Trajectory::default()
    }; 4];
    padded[..neighbours.len()].copy_from_slice(neighbours);
    padded
}

/// Rows to columns: lane k of output f is lane f of input k.
#[inline]
#[target_feature(enable = "avx2")]
fn transpose(m: [__m256d; 4]) -> [__m256d; 4] {
    // [a0 b0 a2 b2], [a1 b1 a3 b3], [c0 d0 c2 d2], [c1 d1 c3 d3] (a, b, c, d = inputs 0-3).
    let ab_even = _mm256_unpacklo_pd(m[0], m[1]);
    let ab_odd = _mm256_unpackhi_pd(m[0], m[1]);
    let cd_even = _mm256_unpacklo_pd(m[2], m[3]);
    let cd_odd = _mm256_unpackhi_pd(m[2], m[3]);
    [
        _mm256_permute2f128_pd::<0x20>(ab_even, cd_even),
        _mm256_permute2f128_pd::<0x20>(ab_odd, cd_odd),
        _mm256_permute2f128_pd::<0x31>(ab_even, cd_even),
        _mm256_permute2f128_pd::<0x31>(ab_odd, cd_odd),
    ]
}
