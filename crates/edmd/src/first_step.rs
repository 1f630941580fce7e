//! The first step of [`crate::contact::quick_bound`] for one ellipsoid against four candidates at
//! once, on AVX2: the candidates moved to the present (Eqs. 3–6), one ascent step along the kept
//! axis or the line of centres, and the safe time of its gap ([`crate::rigid::gap_safe_time`]).
//!
//! At φ = 0.5, X0 = 2 nine in ten of the candidates whose bounding spheres overlap are ruled out
//! by this first step alone (their safe time reaches the horizon). One at a time, each is a chain
//! of square roots and divisions that waits on the one before; in four lanes one instruction
//! carries four such chains. The turns of Eqs. 3–6 take their sines and cosines four at a time
//! too, to the bit those of [`crate::rigid::rotate`] (`libm::sincos`).
//!
//! The step is the scalar one worked in the lab frame instead of A's: the support point of an
//! ellipsoid of semi-axes s along the body-frame unit u is s∘s∘u / |s∘u|, and that of B along −n
//! needs R_B n, not R_A R_Bᵀ. The gap and the bound differ from the scalar ones by rounding alone,
//! and are rigorous by the same argument: any unit direction n gives a lower bound on the
//! distance, n·(r_B − r_A) − h_A(n) − h_B(−n).

use crate::geometry::V3;
use crate::rigid::Body;

/// What the first step finds for one candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstStep {
    /// A lower bound on the contact time, after the present.
    pub lower: f64,
    /// The axis (lab frame, from A towards B) the ascent would try next: the pair's next start,
    /// of about unit length (the engine normalises a kept axis where it starts from it).
    pub next_axis: V3,
}

/// [`FirstStep`] of four candidates, lane by lane, as the lanes leave them: each array is one
/// vector store, and reading one lane of it is served from that store. Returned as four
/// `FirstStep`s, eight or sixteen bytes at a time, each was then read back across two stores,
/// which waits for both to reach the cache.
#[derive(Clone, Copy, Debug)]
pub struct FirstSteps {
    lower: [f64; 4],
    next_axis: [[f64; 4]; 3],
}

impl FirstSteps {
    /// The first step of candidate `k` (0 to 3).
    #[inline]
    pub fn lane(&self, k: usize) -> FirstStep {
        FirstStep {
            lower: self.lower[k],
            next_axis: V3::new(
                self.next_axis[0][k],
                self.next_axis[1][k],
                self.next_axis[2][k],
            ),
        }
    }
}

/// One ellipsoid shape, as the lanes need it. Made only by [`EllipsoidLanes::of`], where the
/// CPU has AVX2: holding one is what makes [`first_steps`] safe.
#[derive(Clone, Copy, Debug)]
pub struct EllipsoidLanes {
    /// Semi-axes along the body axes.
    s: V3,
    /// Bounding radius L (Eq. 33).
    l: f64,
    /// Largest radius of curvature ρ_max.
    rho: f64,
    /// The smallest semi-axis ([`crate::geometry::Surface::min_support`]).
    h_min: f64,
}

impl EllipsoidLanes {
    /// The lanes of an ellipsoid of semi-axes `s`, where the CPU has AVX2.
    pub fn of(s: V3) -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            return Some(EllipsoidLanes {
                s,
                l: s.max(),
                rho: s.max().powi(2) / s.min(),
                h_min: s.min(),
            });
        }
        None
    }
}

/// One candidate as the lanes take it: its stored state, the image offset of its box and the
/// start of its ascent (the pair's kept axis, lab frame, from A towards B), if any: of about
/// unit length in single precision, as the engine keeps it, which the lanes normalise.
#[derive(Clone, Copy)]
pub struct Lane<'a> {
    pub body: &'a Body,
    pub offset: V3,
    pub start: Option<V3>,
}

/// [`FirstStep`] of body `a` (at time `now`) against each of four candidates, every one moved
/// freely from its own time to `now`, all of shape `shape` ([`EllipsoidLanes::of`] checked AVX2).
pub fn first_steps(shape: &EllipsoidLanes, a: &Body, now: f64, lanes: &[Lane; 4]) -> FirstSteps {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: an `EllipsoidLanes` exists only where the CPU has AVX2.
        unsafe { avx2::first_steps(shape, a, now, lanes) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    unreachable!("no lanes without AVX2: {shape:?}")
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{EllipsoidLanes, FirstSteps, Lane};
    use crate::geometry::V3;
    use crate::lanes::{add, lanes, mul, splat, sub};
    use crate::rigid::{Body, COS_KERNEL, KERNEL_WORDS, SIN_KERNEL};

    /// A vector of three components, four lanes each.
    type V4 = [__m256d; 3];

    #[inline]
    #[target_feature(enable = "avx2")]
    fn div(a: __m256d, b: __m256d) -> __m256d {
        _mm256_div_pd(a, b)
    }

    /// `yes` where `mask` is set, else `no`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn select(mask: __m256d, yes: __m256d, no: __m256d) -> __m256d {
        _mm256_blendv_pd(no, yes, mask)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn dot(a: &V4, b: &V4) -> __m256d {
        add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
    }

    /// 1/a, which the three components of a vector then multiply: the divider is the
    /// kernel's busiest unit, and three divisions by one norm cost three times one.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn reciprocal(a: __m256d) -> __m256d {
        div(splat(1.0), a)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn norm(a: &V4) -> __m256d {
        _mm256_sqrt_pd(dot(a, a))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn cross(a: &V4, b: &V4) -> V4 {
        [
            sub(mul(a[1], b[2]), mul(a[2], b[1])),
            sub(mul(a[2], b[0]), mul(a[0], b[2])),
            sub(mul(a[0], b[1]), mul(a[1], b[0])),
        ]
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn plus(a: &V4, b: &V4) -> V4 {
        [add(a[0], b[0]), add(a[1], b[1]), add(a[2], b[2])]
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn minus(a: &V4, b: &V4) -> V4 {
        [sub(a[0], b[0]), sub(a[1], b[1]), sub(a[2], b[2])]
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn times(a: &V4, f: __m256d) -> V4 {
        [mul(a[0], f), mul(a[1], f), mul(a[2], f)]
    }

    /// rot·v: `v` (lab frame) in the body frame of `rot` (rows = body axes).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn to_body(rot: &[V4; 3], v: &V4) -> V4 {
        [dot(&rot[0], v), dot(&rot[1], v), dot(&rot[2], v)]
    }

    /// rotᵀ·v: `v` (body frame of `rot`) in the lab frame.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn to_lab(rot: &[V4; 3], v: &V4) -> V4 {
        let column = |q: usize| [rot[0][q], rot[1][q], rot[2][q]];
        [dot(&column(0), v), dot(&column(1), v), dot(&column(2), v)]
    }

    /// The support point s∘s∘u / |s∘u| of the ellipsoid of semi-axes `s` along the body-frame
    /// direction u, of any length.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn support_point(s: &V3, u: &V4) -> V4 {
        let su = [0, 1, 2].map(|c| mul(splat(s[c]), u[c]));
        let inv_h = reciprocal(norm(&su));
        [0, 1, 2].map(|c| mul(mul(splat(s[c]), su[c]), inv_h))
    }

    /// `libm::sincos` of the lanes of `x` where `wanted` is set: where 2⁻²⁷√2 ≤ |x| ≲ π/4 (the
    /// angles of a body's turn between events, nearly all), by the kernels of fdlibm (Sun, 1993)
    /// that `libm::sincos` takes there, the same operations in the same order, so the same
    /// numbers; elsewhere by `libm::sincos`, lane by lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn sin_cos(x: __m256d, wanted: __m256d) -> (__m256d, __m256d) {
        let c = |k: usize| splat(f64::from_bits(COS_KERNEL[k]));
        let (z, sc) = (mul(x, x), |k: usize| splat(f64::from_bits(SIN_KERNEL[k])));
        let w = mul(z, z);
        // k_sin(x, 0, 0) = x + z x (S1 + z r).
        let r = add(
            add(sc(1), mul(z, add(sc(2), mul(z, sc(3))))),
            mul(mul(z, w), add(sc(4), mul(z, sc(5)))),
        );
        let sin = add(x, mul(mul(z, x), add(sc(0), mul(z, r))));
        // k_cos(x, 0) = (1 − z/2) + (((1 − (1 − z/2)) − z/2) + z r).
        let r = add(
            mul(z, add(c(0), mul(z, add(c(1), mul(z, c(2)))))),
            mul(mul(w, w), add(c(3), mul(z, add(c(4), mul(z, c(5)))))),
        );
        let half_z = mul(splat(0.5), z);
        let one_less = sub(splat(1.0), half_z);
        let cos = add(
            one_less,
            add(sub(sub(splat(1.0), one_less), half_z), mul(z, r)),
        );
        // libm::sincos takes the kernels where the high word of |x| is one of KERNEL_WORDS.
        let word = |w: u32| splat(f64::from_bits(u64::from(w) << 32));
        let abs = _mm256_andnot_pd(splat(-0.0), x);
        let kernels = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(abs, word(*KERNEL_WORDS.start())),
            _mm256_cmp_pd::<_CMP_LT_OQ>(abs, word(KERNEL_WORDS.end() + 1)),
        );
        let others = _mm256_movemask_pd(_mm256_andnot_pd(kernels, wanted));
        if others == 0 {
            return (sin, cos);
        }
        let (mut xs, mut sins, mut coss) = ([0.0; 4], [0.0; 4], [0.0; 4]);
        // SAFETY: four f64 to four f64.
        unsafe {
            _mm256_storeu_pd(xs.as_mut_ptr(), x);
            _mm256_storeu_pd(sins.as_mut_ptr(), sin);
            _mm256_storeu_pd(coss.as_mut_ptr(), cos);
        }
        for k in (0..4).filter(|k| others & (1 << k) != 0) {
            (sins[k], coss[k]) = libm::sincos(xs[k]);
        }
        (lanes(|k| sins[k]), lanes(|k| coss[k]))
    }

    /// One number of each lane's body. Generic, not over a `fn` pointer: the compiler did not
    /// always see through the pointer, and then called it for every number of every lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn of_bodies(lanes4: &[Lane; 4], f: impl Fn(&Body) -> f64) -> __m256d {
        lanes(|k| f(lanes4[k].body))
    }

    /// One vector of each lane's body, as [`of_bodies`].
    #[inline]
    #[target_feature(enable = "avx2")]
    fn vectors_of_bodies(lanes4: &[Lane; 4], f: impl Fn(&Body) -> V3) -> V4 {
        [0, 1, 2].map(|c| lanes(|k| f(lanes4[k].body)[c]))
    }

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn first_steps(
        shape: &EllipsoidLanes,
        a: &Body,
        now: f64,
        lanes4: &[Lane; 4],
    ) -> FirstSteps {
        let body = |k: usize| -> &Body { lanes4[k].body };
        // B at the present: r + v τ and R(τ) row by row (rigid::rotate), unturned where w or τ
        // is 0.
        let tau = sub(splat(now), of_bodies(lanes4, |b| b.t));
        let w_b = vectors_of_bodies(lanes4, |b| b.w);
        let w_norm_b = norm(&w_b);
        let zero = _mm256_setzero_pd();
        let turns = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_NEQ_UQ>(w_norm_b, zero),
            _mm256_cmp_pd::<_CMP_NEQ_UQ>(tau, zero),
        );
        let (sin, cos) = sin_cos(mul(w_norm_b, tau), turns);
        // sin(wτ)/w and (1 − cos wτ)/w² of Eq. (5).
        let inv_w = reciprocal(w_norm_b);
        let first = select(turns, mul(sin, inv_w), zero);
        let second = select(turns, mul(mul(sub(splat(1.0), cos), inv_w), inv_w), zero);
        let rot_b: [V4; 3] = [0, 1, 2].map(|p| {
            let u: V4 = [0, 1, 2].map(|c| lanes(|k| body(k).rot[(p, c)]));
            let wu = cross(&w_b, &u);
            let wwu = cross(&w_b, &wu);
            plus(&plus(&u, &times(&wu, first)), &times(&wwu, second))
        });
        let v_b = vectors_of_bodies(lanes4, |b| b.v);
        let offset: V4 = [0, 1, 2].map(|c| lanes(|k| lanes4[k].offset[c]));
        let r_b = plus(
            &plus(&vectors_of_bodies(lanes4, |b| b.r), &times(&v_b, tau)),
            &offset,
        );
        let r = minus(&r_b, &[0, 1, 2].map(|c| splat(a.r[c])));
        // The axis: kept, or the line of centres.
        let kept = lanes(|k| {
            f64::from_bits(if lanes4[k].start.is_some() {
                u64::MAX
            } else {
                0
            })
        });
        let start: V4 = [0, 1, 2].map(|c| lanes(|k| lanes4[k].start.map_or(0.0, |n| n[c])));
        let axis: V4 = [0, 1, 2].map(|c| select(kept, start[c], r[c]));
        let n = times(&axis, reciprocal(norm(&axis)));
        // The support points along the axis before its normalisation, which runs beside them:
        // an ellipsoid's does not depend on the direction's length.
        let rot_a: [V4; 3] = [0, 1, 2].map(|p| [0, 1, 2].map(|c| splat(a.rot[(p, c)])));
        let off_a = to_lab(&rot_a, &support_point(&shape.s, &to_body(&rot_a, &axis)));
        let minus_axis = [0, 1, 2].map(|c| sub(zero, axis[c]));
        let off_b = to_lab(
            &rot_b,
            &support_point(&shape.s, &to_body(&rot_b, &minus_axis)),
        );
        let between = minus(&plus(&r, &off_b), &off_a);
        let gap = dot(&n, &between);
        // The ascent's next axis, damped by the radii of curvature (contact::AxisAscent), left
        // unnormalised: it is kept in single precision and normalised where it is used.
        let damping = splat(1.0 / (2.0 * shape.rho));
        let next = plus(&n, &times(&minus(&between, &times(&n, gap)), damping));
        // The safe time of the gap: rigid::gap_safe_time with quadratic moduli.
        let (w_a, v_a) = (
            [0, 1, 2].map(|c| splat(a.w[c])),
            [0, 1, 2].map(|c| splat(a.v[c])),
        );
        let (l, rho) = (splat(shape.l), splat(shape.rho));
        let turn_a = norm(&cross(&w_a, &n));
        let turn_b = norm(&cross(&w_b, &n));
        let (along_a, along_b) = (dot(&w_a, &n), dot(&w_b, &n));
        let opening = dot(&n, &minus(&v_b, &v_a));
        let closing = sub(add(mul(turn_a, l), mul(turn_b, l)), opening);
        // A gap that does not close is ∞ away: 1/0.
        let closes_at_all = _mm256_cmp_pd::<_CMP_GT_OQ>(closing, zero);
        let linear = div(
            select(closes_at_all, gap, splat(1.0)),
            select(closes_at_all, closing, zero),
        );
        let rate = dot(
            &n,
            &minus(
                &plus(&v_b, &cross(&w_b, &off_b)),
                &plus(&v_a, &cross(&w_a, &off_a)),
            ),
        );
        // rigid::support_acceleration_bound: |w × n|² ρ + |w| min(|w × n| L, |w·n| L − |w| h_min),
        // not below 0, and 0 while n does not turn.
        let h_min = splat(shape.h_min);
        let accel_of = |turn: __m256d, along: __m256d, w_norm: __m256d| {
            let abs_along = _mm256_andnot_pd(splat(-0.0), along);
            let swing = _mm256_min_pd(mul(turn, l), sub(mul(abs_along, l), mul(w_norm, h_min)));
            let m = add(mul(mul(turn, turn), rho), mul(w_norm, swing));
            select(
                _mm256_cmp_pd::<_CMP_EQ_OQ>(turn, zero),
                zero,
                select(_mm256_cmp_pd::<_CMP_LT_OQ>(m, zero), zero, m),
            )
        };
        let accel = add(
            accel_of(turn_a, along_a, splat(a.w.norm())),
            accel_of(turn_b, along_b, w_norm_b),
        );
        // rigid::positive_for: 2g / (|ġ| + √(ġ² + 2Mg)) where the gap closes, (ġ + √…)/M else.
        let root_term = _mm256_sqrt_pd(add(mul(rate, rate), mul(mul(splat(2.0), accel), gap)));
        // Each lane's case picks its numerator and denominator, and one division serves all
        // four cases (1/0: ∞ where the gap opens and no acceleration can turn it).
        let closes = _mm256_cmp_pd::<_CMP_LT_OQ>(rate, zero);
        let accelerates = _mm256_cmp_pd::<_CMP_GT_OQ>(accel, zero);
        let numerator = select(
            accelerates,
            select(closes, mul(splat(2.0), gap), add(rate, root_term)),
            select(closes, gap, splat(1.0)),
        );
        let denominator = select(
            accelerates,
            select(closes, sub(root_term, rate), accel),
            select(closes, sub(zero, rate), zero),
        );
        let curved = div(numerator, denominator);
        // f64::max(linear, curved); a gap that is not positive (or NaN) proves nothing.
        let lower = select(
            _mm256_cmp_pd::<_CMP_GT_OQ>(gap, zero),
            _mm256_max_pd(curved, linear),
            zero,
        );
        let mut steps = FirstSteps {
            lower: [0.0; 4],
            next_axis: [[0.0; 4]; 3],
        };
        // SAFETY: four f64 to four f64.
        unsafe {
            _mm256_storeu_pd(steps.lower.as_mut_ptr(), lower);
            for (to, from) in steps.next_axis.iter_mut().zip(next) {
                _mm256_storeu_pd(to.as_mut_ptr(), from);
            }
        }
        steps
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::contact::quick_bound;
    use crate::distance::elongated;
    use crate::ellipsoid::Ellipsoid;
    use crate::geometry::{M3, Surface};
    use crate::pw::contact_scale;
    use crate::rigid::rotate;
    use crate::superquadric::Superquadric;

    prop_compose! {
        /// A body near the origin, its own time before `now` = 1 (so that the lanes turn it).
        fn body()(
            r in prop::array::uniform3(-1.2f64..1.2),
            v in prop::array::uniform3(-3.0f64..3.0),
            axis in prop::array::uniform3(-1.0f64..1.0),
            angle in 0.0f64..6.3,
            w in prop::array::uniform3(-8.0f64..8.0),
            still in prop::bool::weighted(0.1),
            t in prop_oneof![Just(1.0), 0.9f64..1.0],
        ) -> Body {
            let rot = rotate(&M3::identity(), &(V3::from(axis) + V3::new(1e-3, 0.0, 0.0)), angle);
            let w = if still { V3::zeros() } else { V3::from(w) };
            Body { r: V3::from(r), v: V3::from(v), t, rot, w }
        }
    }

    /// Angles about the kernels' edges (2⁻²⁷√2 and π/4), beyond them and anywhere between.
    fn angle() -> impl Strategy<Value = f64> {
        let edge = |bits: u64| {
            (-40i64..40, prop::bool::ANY).prop_map(move |(ulps, neg)| {
                let x = f64::from_bits(bits.wrapping_add_signed(ulps));
                if neg { -x } else { x }
            })
        };
        prop_oneof![
            -1.0f64..1.0,
            edge(0x3e46_a09e_0000_0000),
            edge(0x3fe9_21fc_0000_0000),
            -1e3f64..1e3,
            Just(0.0),
            Just(-0.0),
            Just(f64::NAN),
            Just(f64::INFINITY),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// The lanes' sine and cosine are `libm::sincos`'s to the bit, in every lane asked for.
        #[cfg(target_arch = "x86_64")]
        #[test]
        fn four_angles_turn_to_the_bit_as_libm_does(
            x in prop::array::uniform4(angle()),
            wanted in prop::array::uniform4(prop::bool::weighted(0.9)),
        ) {
            use std::arch::x86_64::{_mm256_set_pd, _mm256_storeu_pd};
            if !std::is_x86_feature_detected!("avx2") {
                return Ok(());
            }
            let mask = wanted.map(|w| if w { f64::from_bits(u64::MAX) } else { 0.0 });
            let (mut sin, mut cos) = ([0.0; 4], [0.0; 4]);
            // SAFETY: the CPU has AVX2 (checked above); four f64 to four f64.
            unsafe {
                let (s, c) = avx2::sin_cos(
                    _mm256_set_pd(x[3], x[2], x[1], x[0]),
                    _mm256_set_pd(mask[3], mask[2], mask[1], mask[0]),
                );
                _mm256_storeu_pd(sin.as_mut_ptr(), s);
                _mm256_storeu_pd(cos.as_mut_ptr(), c);
            }
            for k in (0..4).filter(|&k| wanted[k]) {
                let (s, c) = libm::sincos(x[k]);
                prop_assert!(
                    s.to_bits() == sin[k].to_bits() && c.to_bits() == cos[k].to_bits(),
                    "{:e}: ({:e}, {:e}) against libm's ({s:e}, {c:e})", x[k], sin[k], cos[k]
                );
            }
        }

        /// The scalar turn's sine and cosine are `libm::sincos`'s to the bit.
        #[test]
        fn one_angle_turns_to_the_bit_as_libm_does(x in angle()) {
            let ((s, c), (ls, lc)) = (crate::rigid::sin_cos(x), libm::sincos(x));
            prop_assert!(
                s.to_bits() == ls.to_bits() && c.to_bits() == lc.to_bits(),
                "{x:e}: ({s:e}, {c:e}) against libm's ({ls:e}, {lc:e})"
            );
        }

        /// Each lane is the scalar quick bound's first step (to rounding) of the candidate moved
        /// to the present, from its kept axis (single precision, normalised by the lanes) or the
        /// line of centres; where the bodies are apart nothing overlaps before the bound (by the
        /// independent Perram–Wertheim scale), and the next axis is the scalar one, unnormalised
        /// as it: the unit axis plus a step across it, so no shorter than a unit.
        #[test]
        fn each_lane_is_the_first_step_of_the_quick_bound_and_comes_before_any_contact(
            s in prop::array::uniform3(0.3f64..1.5),
            a in body(),
            bs in prop::array::uniform4(body()),
            offsets in prop::array::uniform4(prop::array::uniform3(-1i32..=1)),
            starts in prop::array::uniform4(prop::option::of(prop::array::uniform3(-1.0f64..1.0))),
        ) {
            let e = Ellipsoid::new(s[0], s[1], s[2]);
            prop_assume!(!elongated(&e));
            let Some(shape) = EllipsoidLanes::of(e.s) else { return Ok(()) };
            let now = 1.0;
            let a = a.at(now);
            let box_l = 3.0;
            // Axes as kept, in single precision; the scalar bound takes them normalised.
            let kept = starts.map(|n| {
                n.map(|n| (V3::from(n) + V3::new(0.0, 0.0, 1e-3)).normalize().map(|c| f64::from(c as f32)))
            });
            let starts = kept.map(|n| n.map(|n| n.normalize()));
            let lanes: [Lane; 4] = [0, 1, 2, 3].map(|k| Lane {
                body: &bs[k],
                offset: V3::from(offsets[k].map(f64::from)) * box_l,
                start: kept[k],
            });
            let steps = first_steps(&shape, &a, now, &lanes);
            for k in 0..4 {
                let mut b = bs[k].at(now);
                b.r += lanes[k].offset;
                let scalar = quick_bound(&e, &a, &e, &b, 0.0, starts[k].as_ref(), None);
                let lane = steps.lane(k);
                prop_assert!(lane.lower >= 0.0);
                prop_assert!(
                    lane.lower == scalar.lower
                        || (lane.lower - scalar.lower).abs() <= 1e-9 * (1.0 + scalar.lower),
                    "lane {k}: {} against the scalar {}", lane.lower, scalar.lower
                );
                // A superquadric of exponents 2 is the same ellipsoid, through its own support
                // functions.
                let q = Superquadric::new(s, [2.0; 3]).expect("a valid superquadric");
                prop_assert_eq!(q.ellipsoid_semi_axes(), Some(e.s));
                let generic = quick_bound(&q, &a, &q, &b, 0.0, starts[k].as_ref(), None);
                prop_assert!(
                    lane.lower == generic.lower
                        || (lane.lower - generic.lower).abs() <= 1e-9 * (1.0 + generic.lower),
                    "lane {k}: {} against the superquadric's {}", lane.lower, generic.lower
                );
                let axis = scalar.axis.expect("the ascent's next axis");
                prop_assert!((lane.next_axis - axis).norm() < 1e-9, "{:?} {:?}", lane.next_axis, axis);
                prop_assert!(lane.next_axis.norm() >= 1.0 - 1e-12, "{}", lane.next_axis.norm());
                let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
                let apart = contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r)) > 1.0 + 1e-9;
                if apart && lane.lower > 0.0 {
                    let end = lane.lower.min(2.0);
                    for i in 0..200 {
                        let t = end * i as f64 / 200.0;
                        let (pa, pb) = (a.pose_after(t), b.pose_after(t));
                        let mu = contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r));
                        prop_assert!(mu > 1.0 - 1e-9, "overlap {mu} at {t} before the bound {}", lane.lower);
                    }
                }
            }
        }
    }
}
