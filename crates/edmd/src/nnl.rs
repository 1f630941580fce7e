//! Nearest-neighbour lists from oriented bounding parallelepipeds (Sec. 3.3): the box of Eq. (52),
//! the 15-axis separation test (Eqs. 62–64), and the escape time of a body from its box (Eqs. 59–61).

use crate::geometry::{M3, Surface, V3};
use crate::lists::{Region, SingleCentre};
use crate::rigid::{Body, Flight, positive_for, support_acceleration_bound};

/// Oriented bounding parallelepiped, immobile between two rebuilds.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Obp {
    pub c: V3,
    /// Rows = the body axes at build time.
    pub rot: M3,
    /// Half-extents s_k + Δ_NNL (Eq. 52).
    pub half: V3,
}

impl Obp {
    pub fn around<S: Surface>(s: &S, body: &Body, delta: f64) -> Self {
        Obp {
            c: body.r,
            rot: body.rot,
            half: s.semi_axes().add_scalar(delta),
        }
    }

    /// Radius of the sphere circumscribing the box.
    pub fn radius(&self) -> f64 {
        self.half.norm()
    }
}

impl Region for Obp {
    type Body = Body;
    fn around<S: Surface>(s: &S, body: &Body, delta: f64) -> Self {
        Obp::around(s, body, delta)
    }

    fn reach<S: Surface>(s: &S, delta: f64) -> f64 {
        2.0 * s.semi_axes().add_scalar(delta).norm()
    }

    fn centre(&self) -> &V3 {
        &self.c
    }

    type Centre = SingleCentre;

    fn overlaps(&self, other: &Self, shift: &V3, reach: f64) -> bool {
        // The other box inside its circumsphere against this box's three slabs: most candidates
        // end here, before the 15-axis test builds its rotation.
        let local = self.rot * (other.c + shift - self.c);
        let radius = 0.5 * reach;
        (0..3).all(|k| local[k].abs() <= self.half[k] + radius) && overlap(self, other, shift)
    }

    const IN_FOURS: bool = true;

    fn overlaps4(&self, others: [&Self; 4], shifts: &[V3; 4], reach: f64) -> [bool; 4] {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { avx2::overlaps4(self, others, shifts, 0.5 * reach) };
        }
        [0, 1, 2, 3].map(|k| self.overlaps(others[k], &shifts[k], reach))
    }

    fn escape_time<S: Surface>(&self, s: &S, body: &Body, eps_nnl: f64, horizon: f64) -> f64 {
        escape_time(s, body, self, eps_nnl, horizon)
    }
}

/// Whether two boxes overlap; `shift` is added to the centre of `b` (periodic image).
///
/// The projections of Eqs. (62)–(64) onto the 3 + 3 face normals and the 9 edge cross products,
/// written as the separating-axis test: the boxes are disjoint iff one of the 15 axes separates them.
pub fn overlap(a: &Obp, b: &Obp, shift: &V3) -> bool {
    // Parallel edges make a cross-product axis vanish; the epsilon keeps that test conservative.
    const EPS: f64 = 1e-12;
    let r = a.rot * b.rot.transpose(); // r[(i,j)] = u_i^A · u_j^B
    let ar = r.abs().add_scalar(EPS);
    let t = a.rot * (b.c + shift - a.c);
    let (ea, eb) = (a.half, b.half);
    for i in 0..3 {
        let rb = eb[0] * ar[(i, 0)] + eb[1] * ar[(i, 1)] + eb[2] * ar[(i, 2)];
        if t[i].abs() > ea[i] + rb {
            return false;
        }
    }
    for j in 0..3 {
        let ra = ea[0] * ar[(0, j)] + ea[1] * ar[(1, j)] + ea[2] * ar[(2, j)];
        let tj = t[0] * r[(0, j)] + t[1] * r[(1, j)] + t[2] * r[(2, j)];
        if tj.abs() > ra + eb[j] {
            return false;
        }
    }
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let ra = ea[i1] * ar[(i2, j)] + ea[i2] * ar[(i1, j)];
            let rb = eb[j1] * ar[(i, j2)] + eb[j2] * ar[(i, j1)];
            let tt = (t[i2] * r[(i1, j)] - t[i1] * r[(i2, j)]).abs();
            if tt > ra + rb {
                return false;
            }
        }
    }
    true
}

/// [`Region::overlaps`] of four boxes against one, on AVX2: the slabs and the 15 axes of
/// [`overlap`] in four lanes, every lane through every axis, each value computed as the scalar
/// test computes it (the same products and sums in the same order, nalgebra's products of a
/// matrix included), so that the lanes decide as it does to the bit.
///
/// A rebuild tests its box against every box whose circumsphere meets its own (37 at X0 = 2,
/// φ = 0.5, Δ_NNL 0.05, of which 14 overlap and take all 15 axes): one at a time, each test
/// built its rotation and ran its branches alone (MEASUREMENTS.md, "Boxes tested four at a
/// time").
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::Obp;
    use crate::geometry::V3;
    use crate::lanes::{add, lanes, mul, splat, sub};

    #[inline]
    #[target_feature(enable = "avx2")]
    fn abs(a: __m256d) -> __m256d {
        _mm256_andnot_pd(_mm256_set1_pd(-0.0), a)
    }

    /// (x₀ y₀ + x₁ y₁) + x₂ y₂, nalgebra's order for a row of a product.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn dot3(x: [__m256d; 3], y: [__m256d; 3]) -> __m256d {
        add(add(mul(x[0], y[0]), mul(x[1], y[1])), mul(x[2], y[2]))
    }

    /// Lanes where `a > b` (false with a NaN, as the scalar comparison).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn above(a: __m256d, b: __m256d) -> __m256d {
        _mm256_cmp_pd::<_CMP_GT_OQ>(a, b)
    }

    /// [`Region::overlaps`](crate::lists::Region::overlaps) of `b[k]` (centre shifted by
    /// `shift[k]`) against `a`, with `radius` the half reach.
    #[target_feature(enable = "avx2")]
    pub(super) fn overlaps4(a: &Obp, b: [&Obp; 4], shift: &[V3; 4], radius: f64) -> [bool; 4] {
        const EPS: f64 = 1e-12;
        let d = [0, 1, 2].map(|k| sub(lanes(|l| b[l].c[k] + shift[l][k]), splat(a.c[k])));
        // Rows of A (broadcast) and of each B (one lane each).
        let ra = [0, 1, 2].map(|i| [0, 1, 2].map(|k| splat(a.rot[(i, k)])));
        let rb = [0, 1, 2].map(|j| [0, 1, 2].map(|k| lanes(|l| b[l].rot[(j, k)])));
        let t = [0, 1, 2].map(|i| dot3(ra[i], d));
        // r[i][j] = u_i^A · u_j^B, as `a.rot * b.rot.transpose()`.
        let r = [0, 1, 2].map(|i| [0, 1, 2].map(|j| dot3(ra[i], rb[j])));
        let ar = r.map(|row| row.map(|x| add(abs(x), splat(EPS))));
        let ea = [0, 1, 2].map(|k| splat(a.half[k]));
        let eb = [0, 1, 2].map(|k| lanes(|l| b[l].half[k]));
        // Outside a slab of A widened by the other's circumsphere, or separated by an axis.
        let mut apart = _mm256_setzero_pd();
        let mut out = |mask: __m256d| apart = _mm256_or_pd(apart, mask);
        for i in 0..3 {
            // Not within the slab, NaN included, as the scalar `<=` decides.
            let within = add(ea[i], splat(radius));
            out(_mm256_cmp_pd::<_CMP_NLE_UQ>(abs(t[i]), within));
        }
        for i in 0..3 {
            out(above(abs(t[i]), add(ea[i], dot3(eb, ar[i]))));
        }
        for j in 0..3 {
            let ra_j = dot3(ea, [ar[0][j], ar[1][j], ar[2][j]]);
            let tj = dot3(t, [r[0][j], r[1][j], r[2][j]]);
            out(above(abs(tj), add(ra_j, eb[j])));
        }
        for i in 0..3 {
            let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
            for j in 0..3 {
                let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
                let ra_ij = add(mul(ea[i1], ar[i2][j]), mul(ea[i2], ar[i1][j]));
                let rb_ij = add(mul(eb[j1], ar[i][j2]), mul(eb[j2], ar[i][j1]));
                let tt = abs(sub(mul(t[i2], r[i1][j]), mul(t[i1], r[i2][j])));
                out(above(tt, add(ra_ij, rb_ij)));
            }
        }
        let bits = _mm256_movemask_pd(apart);
        [0, 1, 2, 3].map(|k| bits & (1 << k) == 0)
    }
}

/// Time after `body.t` when the body may first touch its box.
///
/// The distance of the body from face ±k is d = e_k ∓ (r − c)·u_k − h_k, with h_k the body's support
/// along u_k (exact for an ellipsoid, so no Newton–Raphson is needed for the planes of Eq. 59).
/// A body that does not rotate moves linearly and its escape time is exact. A rotating body advances
/// by steps that no face gap can close within (a sharper bound than ḋ_k ≤ |v·u_k| + L‖w‖ of
/// Eq. 60, see below), and the escape time is taken as soon as a gap falls below ε_d^nnl (Eq. 61):
/// a lower bound, so a rebuild comes early, never late. Each axis is looked at again only when
/// the safe time of its own two faces runs out. The steps stop at the first past `horizon`, whose
/// time is a lower bound too.
pub fn escape_time<S: Surface>(s: &S, body: &Body, obp: &Obp, eps_nnl: f64, horizon: f64) -> f64 {
    let axes = [
        obp.rot.row(0).transpose(),
        obp.rot.row(1).transpose(),
        obp.rot.row(2).transpose(),
    ];
    if body.w == V3::zeros() {
        let mut best = f64::INFINITY;
        for (k, u) in axes.iter().enumerate() {
            let h = s.support(&(body.rot * u));
            let o = (body.r - obp.c).dot(u);
            let vu = body.v.dot(u);
            let gap = if vu > 0.0 {
                obp.half[k] - o - h
            } else {
                obp.half[k] + o - h
            };
            if vu != 0.0 {
                best = best.min(gap.max(0.0) / vu.abs());
            }
        }
        return best;
    }
    // Each face gap g = e_k ∓ o − h changes at the exact rate ġ = ∓v·u_k − ḣ (ḣ = u_k·(w × p), p
    // the support point) with |g̈| ≤ M from `support_acceleration_bound`: g stays positive for the
    // root of g + ġτ − ½Mτ² (the contact search's bound, applied to the six planes).
    let (l, rho_max, h_min) = (
        s.bounding_radius(),
        s.max_curvature_radius(),
        s.min_support(),
    );
    let accel = axes.map(|u| support_acceleration_bound(&body.w, &u, l, rho_max, h_min));
    // Each axis's two faces are safe until `until[k]`: only the axes whose time has come are
    // looked at again. A superquadric's support point is a root to find: p = 10, X0 = 2, N 512,
    // 1,000 collisions took 787 M instructions, 746 M so (ellipsoids, whose support points are
    // cheap beside the turn of the pose, as many as before).
    let (mut tau, flight) = (0.0, Flight::of(body));
    let mut until = [0.0f64; 3];
    for _ in 0..100_000 {
        let p = flight.pose_after(tau);
        for (k, u) in axes.iter().enumerate() {
            if until[k] > tau {
                continue;
            }
            let support = p.rot.transpose() * s.support_point(&(p.rot * u));
            let h = support.dot(u);
            let h_rate = u.dot(&body.w.cross(&support));
            let o = (p.r - obp.c).dot(u);
            let vu = body.v.dot(u);
            let (low, high) = (obp.half[k] - o - h, obp.half[k] + o - h);
            if low < eps_nnl || high < eps_nnl {
                return tau;
            }
            let (rate_low, rate_high) = (-vu - h_rate, vu - h_rate);
            let dt = if accel[k].is_infinite() {
                // A flat face has no curvature bound (Surface::max_curvature_radius = +∞): the
                // gap changes at most at |v·u| + L|w × u| (Eq. 60 along one axis), the same for
                // both faces.
                low.min(high) / (vu.abs() + l * body.w.cross(u).norm())
            } else if high >= low && rate_high >= rate_low {
                // `positive_for` rises with the gap and with its rate: the face the body is
                // nearer and moves towards holds out the shorter time, and the other needs no
                // root of its own.
                positive_for(low, rate_low, accel[k])
            } else if low >= high && rate_low >= rate_high {
                positive_for(high, rate_high, accel[k])
            } else {
                positive_for(low, rate_low, accel[k]).min(positive_for(high, rate_high, accel[k]))
            };
            until[k] = tau + dt;
        }
        tau = until.into_iter().fold(f64::INFINITY, f64::min);
        if tau >= horizon {
            return tau;
        }
    }
    tau
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ellipsoid::Ellipsoid;
    use crate::lists::Region;
    use crate::rigid::rotate;

    fn obp(c: V3, rot: M3, half: V3) -> Obp {
        Obp { c, rot, half }
    }

    #[test]
    fn axis_aligned_boxes() {
        let id = M3::identity();
        let a = obp(V3::zeros(), id, V3::new(1.0, 0.5, 0.5));
        let b = obp(V3::new(2.1, 0.0, 0.0), id, V3::new(1.0, 0.5, 0.5));
        assert!(!overlap(&a, &b, &V3::zeros()));
        assert!(overlap(&a, &b, &V3::new(-0.2, 0.0, 0.0)));
    }

    #[test]
    fn edge_edge_separation_needs_cross_axes() {
        // Two long thin boxes, crossed at 90° and slightly apart along z: only a cross axis separates
        // them once they are rotated 45° about z; the face axes alone would report overlap.
        let ra = rotate(
            &M3::identity(),
            &V3::new(0.0, 0.0, 1.0),
            std::f64::consts::FRAC_PI_4,
        );
        let rb = rotate(
            &M3::identity(),
            &V3::new(0.0, 0.0, 1.0),
            -std::f64::consts::FRAC_PI_4,
        );
        let half = V3::new(2.0, 0.1, 0.1);
        let a = obp(V3::zeros(), ra, half);
        let b = obp(V3::new(0.0, 0.0, 0.21), rb, half);
        assert!(!overlap(&a, &b, &V3::zeros()));
        let b = obp(V3::new(0.0, 0.0, 0.19), rb, half);
        assert!(overlap(&a, &b, &V3::zeros()));
    }

    proptest::proptest! {
        /// Four boxes at once decide as one at a time, to the bit: boxes of any proportions and
        /// orientations (parallel edges included, where a cross axis vanishes), at distances
        /// from deep overlap to beyond the slabs, and on either side of the last point, along a
        /// line from A's centre, where one at a time finds them overlapping (found by bisection
        /// to adjacent floats: a sum taken in another order moves it).
        #[test]
        fn four_boxes_at_once_decide_as_one_at_a_time(
            boxes in proptest::collection::vec(
                (
                    proptest::array::uniform3(0.01f64..3.0),
                    proptest::array::uniform3(-3.0f64..3.0),
                    proptest::array::uniform3(-4.0f64..4.0),
                    0..3usize,
                ),
                5,
            ),
            shift in proptest::array::uniform3(-1i32..=1),
        ) {
            let make = |(half, turn, c, kind): &([f64; 3], [f64; 3], [f64; 3], usize)| Obp {
                c: V3::from(*c),
                // Turned anyhow, not at all (edges parallel to the first box's), or about z.
                rot: match kind {
                    0 => *nalgebra::Rotation3::new(V3::from(*turn)).matrix(),
                    1 => M3::identity(),
                    _ => rotate(&M3::identity(), &V3::z(), turn[0]),
                },
                half: V3::from(*half),
            };
            let a = make(&boxes[0]);
            let mut others: Vec<Obp> = boxes[1..].iter().map(make).collect();
            let l = 5.0;
            let shifts = [0, 1, 2, 3].map(|k| {
                V3::new(shift[0] as f64, shift[1] as f64, shift[2] as f64) * (l * (k % 2) as f64)
            });
            let reach = 2.0 * boxes.iter().map(|b| V3::from(b.0).norm()).fold(0.0, f64::max);
            let same = |others: &[Obp]| {
                let one = [0, 1, 2, 3].map(|k| a.overlaps(&others[k], &shifts[k], reach));
                let four = a.overlaps4([0, 1, 2, 3].map(|k| &others[k]), &shifts, reach);
                (one, four)
            };
            let (one, four) = same(&others);
            proptest::prop_assert_eq!(one, four);
            // Box 2 (no shift) along the line from A's centre through its own: overlapping at
            // 0, apart at 2 reach.
            let dir = (others[2].c - a.c + V3::new(1e-3, 0.0, 0.0)).normalize();
            let at = |x: f64| a.c + dir * x;
            let (mut lo, mut hi) = (0.0f64, 2.0 * reach);
            let mut probe = others[2];
            while hi > lo && f64::from_bits(lo.to_bits() + 1) < hi {
                let mid = 0.5 * (lo + hi);
                probe.c = at(mid);
                if a.overlaps(&probe, &shifts[2], reach) { lo = mid } else { hi = mid }
            }
            for x in [lo, hi] {
                others[2].c = at(x);
                let (one, four) = same(&others);
                proptest::prop_assert_eq!(one, four, "at {:e} along the line", x);
            }
        }
    }

    #[test]
    fn escape_time_is_exact_without_rotation_and_early_with_rotation() {
        let e = Ellipsoid::new(1.0, 0.5, 0.5);
        let mut body = Body {
            r: V3::zeros(),
            v: V3::new(0.5, 0.0, 0.0),
            rot: M3::identity(),
            w: V3::zeros(),
            t: 0.0,
        };
        let o = Obp::around(&e, &body, 0.2);
        assert!((escape_time(&e, &body, &o, 1e-3, f64::INFINITY) - 0.4).abs() < 1e-14);
        body.w = V3::new(0.0, 0.0, 1.0);
        let te = escape_time(&e, &body, &o, 1e-3, f64::INFINITY);
        // At the escape time every gap is still non-negative and the smallest is below ε_d^nnl.
        let p = body.pose_after(te);
        let mut min_gap = f64::INFINITY;
        for k in 0..3 {
            let u = o.rot.row(k).transpose();
            let h = e.support(&(p.rot * u));
            let off = (p.r - o.c).dot(&u).abs();
            min_gap = min_gap.min(o.half[k] - off - h);
        }
        assert!((0.0..1e-3).contains(&min_gap), "gap {min_gap} at {te}");
    }

    /// The smallest of the six face gaps of `body` (shape `s`) in box `o`, `tau` after `body.t`,
    /// from the support function itself.
    fn min_face_gap<S: Surface>(s: &S, body: &Body, o: &Obp, tau: f64) -> f64 {
        let p = body.pose_after(tau);
        (0..3)
            .map(|k| {
                let u = o.rot.row(k).transpose();
                o.half[k] - (p.r - o.c).dot(&u).abs() - s.support(&(p.rot * u))
            })
            .fold(f64::INFINITY, f64::min)
    }

    proptest::proptest! {
        /// A turning body never leaves its box before its escape time, and is within ε_d^nnl of
        /// a face at it (looking only to a horizon, before it or at a step past the horizon):
        /// ellipsoids and superquadrics with flat faces (p up to 10), whose axes are
        /// looked at again only when their own safe times run out. The gaps are checked on 400
        /// points of the way, from the support function.
        #[test]
        fn no_face_is_crossed_before_the_escape_time(
            x0 in 0.2f64..5.0,
            p in proptest::prop_oneof![proptest::strategy::Just(2.0), 2.0f64..10.0],
            v in proptest::array::uniform3(-2.0f64..2.0),
            w in proptest::array::uniform3(-6.0f64..6.0),
            turn in proptest::array::uniform3(-3.0f64..3.0),
            delta in 0.02f64..0.3,
            look in 0.0f64..1.2,
        ) {
            let q = crate::superquadric::Superquadric::with_unit_volume([x0, 1.0, 1.0], [2.0, 2.0, p])
                .unwrap();
            let body = Body {
                r: V3::new(0.3, -0.2, 0.1),
                v: V3::from(v),
                rot: rotate(&M3::identity(), &V3::from(turn), 1.0),
                w: V3::from(w),
                t: 0.0,
            };
            let eps = 5e-3;
            let o = Obp::around(&q, &body, delta);
            let te = escape_time(&q, &body, &o, eps, f64::INFINITY);
            proptest::prop_assert!(te.is_finite() && te >= 0.0, "{te}");
            for k in 0..=400 {
                let tau = te * f64::from(k) / 400.0;
                let gap = min_face_gap(&q, &body, &o, tau);
                proptest::prop_assert!(gap >= -1e-12, "gap {gap} at {tau} of {te}");
            }
            let at_escape = min_face_gap(&q, &body, &o, te);
            proptest::prop_assert!(at_escape < eps, "gap {at_escape} at the escape {te}");
            // Looking no further than a horizon gives the same escape, or the time of a step
            // past the horizon and before it: still a lower bound, never a stop short of it.
            let horizon = te * look;
            let early = escape_time(&q, &body, &o, eps, horizon);
            proptest::prop_assert!(
                early == te || (horizon..te).contains(&early),
                "{early} with the horizon {horizon}, escape {te}"
            );
        }
    }
}
