//! The contact scale μ of two convex bodies, for shapes without a closed-form contact function
//! (superquadrics): the factor by which both must be scaled about their centres to touch, μ < 1
//! meaning overlap. The Monte Carlo of [`crate::init`] needs it to refuse, compare and undo overlaps.
//!
//! Scaling both bodies by k is, up to the factor k, moving B to r/k: the signed distance of the
//! scaled bodies is g(k) = k·d(r/k) = max_n [n·r − k H(n)], H(n) = h_A(n) + h_B(−n) the support
//! of the Minkowski difference. As a maximum of functions affine in k, g is convex, decreasing at a
//! rate H(n*) between the sums of inscribed and of bounding radii, with its root at μ. Newton's
//! method on g (the slope from the closest points of [`distance`], Eqs. 9 and 11) therefore never
//! steps past μ from the left, and every iterate after the first is a lower bound converging to it.

use crate::distance::{Guess, SolverStats, Tolerances, distance, multipliers_guess};
use crate::geometry::{M3, Placed, Pose, Surface, V3};
use crate::support_distance::{Certified, certify_from};

/// [`contact_scale`] is exact (to the solver's tolerance) from about 0.95 up to 1 + this, and a
/// lower bound above and (by property tests, not by proof) in deep overlaps.
pub const EXACT_BELOW: f64 = 1e-6;

/// Iterations of Gilbert's algorithm [`within`] allows for a certificate before it solves for
/// the distance. The random sequential addition of superquadrics p = 10, X0 = 2 (N 512, φ 0.25)
/// asks 7,850 pairs: from a cold start their distance took 65,000 instructions each (one in
/// nine fell back to steepest descent), where 32 iterations decide all but 187 (12 left 527
/// undecided, 64 left 97 and cost as much). The whole start took 2,790 M instructions, now
/// 2,381 M, with the same decisions (MEASUREMENTS.md, "Overlaps decided by certificates").
const CERTIFY_ITERATIONS: u32 = 32;

/// Newton steps allowed; the rest is bisection inside the bracket.
const MAX_STEPS: u32 = 80;

/// μ for shapes `sa`, `sb` with orientations `rot_a`, `rot_b` (rows = body axes) and centre
/// separation `r` = r_B − r_A. Where the distance solver gives no answer, bisection keeps the
/// bracket; the result is never above μ by more than the solver's tolerance.
pub fn contact_scale<S: Surface>(sa: &S, rot_a: &M3, sb: &S, rot_b: &M3, r: &V3) -> f64 {
    // H(n) lies between these: the bodies contain balls of their smallest semi-axis (exponents
    // ≥ 2 put the ellipsoid of the same semi-axes inside a superquadric) and lie in their
    // bounding spheres.
    let big = sa.bounding_radius() + sb.bounding_radius();
    let small = sa.semi_axes().min() + sb.semi_axes().min();
    let rn = r.norm();
    let (mut lo, mut hi) = (rn / big, rn / small);
    let tol = Tolerances::default();
    let mut stats = SolverStats::default();
    let pa = Pose {
        r: V3::zeros(),
        rot: *rot_a,
    };
    let qa = sa.place(&pa);
    let mut k = 1.0f64.clamp(lo, hi);
    for step in 0..MAX_STEPS {
        let pb = Pose {
            r: r / k,
            rot: *rot_b,
        };
        let next = match distance(sa, &pa, sb, &pb, None, &tol, &mut stats) {
            Some(d) => {
                let g = k * d.d;
                if g >= 0.0 {
                    lo = lo.max(k);
                } else {
                    hi = hi.min(k);
                }
                // Apart: g falls at most at the rate `big`, so μ ≥ k + g/big; far enough above 1,
                // that bound is all a caller needs.
                if step == 0 && g > 0.0 && k + g / big > 1.0 + EXACT_BELOW {
                    return k + g / big;
                }
                let n = qa.grad(&d.xa).normalize();
                let h = n.dot(r) / k - d.d;
                let plausible =
                    h.is_finite() && h >= small * (1.0 - 1e-9) && h <= big * (1.0 + 1e-9);
                let newton = k + g / h;
                if plausible && newton >= lo && newton <= hi {
                    if (newton - k).abs() <= 1e-14 * k {
                        return newton.min(hi);
                    }
                    newton
                } else {
                    0.5 * (lo + hi)
                }
            }
            None => 0.5 * (lo + hi),
        };
        if hi - lo <= 1e-14 * hi {
            return lo;
        }
        k = next;
    }
    lo
}

/// Whether the bodies scaled by `k` about their centres touch or overlap (μ ≤ k). Most pairs are
/// decided by a certificate of Gilbert's algorithm ([`certify_from`]) within
/// `CERTIFY_ITERATIONS`: a positive gap along an axis proves them apart, a point inside both
/// proves them overlapping. Pairs at contact or nearly are left undecided, and take the sign of
/// their distance at that scale, g(k) = k·d(r/k) ≤ 0, Newton–Raphson started from the support
/// points of the certificates' best axis (at N 2048 of [2, 2, 10], X0 = 2, φ 0.256: 1,528 M
/// instructions a start from their cold start, 1,417 M so): one solve where [`contact_scale`] takes
/// several to converge μ (its bracket trusts the same sign at every scale it tries). Where the
/// solver gives no answer, [`contact_scale`] decides. The certificates start from `axis` (unit,
/// from A to B) where the caller has a good one ([`certify_from`]): any axis gives the same
/// decisions.
pub fn within<S: Surface>(
    sa: &S,
    rot_a: &M3,
    sb: &S,
    rot_b: &M3,
    r: &V3,
    k: f64,
    axis: Option<&V3>,
) -> bool {
    let pa = Pose {
        r: V3::zeros(),
        rot: *rot_a,
    };
    let pb = Pose {
        r: r / k,
        rot: *rot_b,
    };
    let guess = match certify_from(sa, &pa, sb, &pb, axis, f64::INFINITY, CERTIFY_ITERATIONS) {
        Certified::Apart { .. } => return false,
        Certified::Overlapping { .. } => return true,
        Certified::Undecided { xa, xb, .. } => {
            let (alpha, beta) = multipliers_guess(sa, &pa, sb, &pb, &xa, &xb);
            Guess {
                xa_body: pa.to_body(&xa),
                alpha,
                beta,
            }
        }
    };
    let mut stats = SolverStats::default();
    match distance(
        sa,
        &pa,
        sb,
        &pb,
        Some(&guess),
        &Tolerances::default(),
        &mut stats,
    ) {
        Some(d) => d.d <= 0.0,
        None => contact_scale(sa, rot_a, sb, rot_b, r) <= k,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ellipsoid::Ellipsoid;
    use crate::pw;
    use crate::rigid::rotate;
    use crate::superquadric::Superquadric;
    use crate::support_distance::certify;
    use proptest::prelude::*;

    /// The pair the property test once failed on, against an oracle of [`contact_scale`]: two
    /// superquadrics (p 6.42, aspect 2.86) crossed, apart at k = 1.001 by 8·10⁻⁴ (Gilbert's
    /// algorithm proves it), where the contact scale, 1 + 7.5·10⁻⁴ from its first step, is only
    /// the lower bound it promises above 1 + [`EXACT_BELOW`]. `within` answers apart; and at
    /// 1.005, past the true contact near 1.0021, within.
    #[test]
    fn within_where_the_contact_scale_is_only_a_bound() {
        let q = Superquadric::with_unit_volume(
            [2.8643868629527223, 1.0, 1.0],
            [2.0, 2.0, 6.4169849635777325],
        )
        .unwrap();
        let ra = rotate(&M3::identity(), &V3::new(0.0, 0.0, 1.3825520224181833), 1.0);
        let rb = rotate(
            &M3::identity(),
            &V3::new(-2.751463800306812, 0.0, 2.7031657516853853),
            1.0,
        );
        let r = V3::new(-0.7420528624543256, 0.0, 0.0);
        let bound = contact_scale(&q, &ra, &q, &rb, &r);
        assert!(bound > 1.0 + EXACT_BELOW && bound < 1.001, "{bound}");
        let pa = Pose {
            r: V3::zeros(),
            rot: ra,
        };
        for (k, touch) in [(1.001, false), (1.005, true)] {
            let pb = Pose { r: r / k, rot: rb };
            assert_eq!(certified_touch(&q, &pa, &pb), Some(touch), "k {k}");
            assert_eq!(within(&q, &ra, &q, &rb, &r, k, None), touch, "k {k}");
        }
    }

    /// A superquadric of aspect `x0` and exponents [2, 2, `p`], and the two orientations turned
    /// from the identity by the rotation vectors `wa` and `wb`.
    fn turned_pair(x0: f64, p: f64, wa: [f64; 3], wb: [f64; 3]) -> (Superquadric, M3, M3) {
        let q = Superquadric::with_unit_volume([x0, 1.0, 1.0], [2.0, 2.0, p]).unwrap();
        let turned = |w: [f64; 3]| rotate(&M3::identity(), &V3::from(w), 1.0);
        (q, turned(wa), turned(wb))
    }

    /// Whether Gilbert's algorithm proves the placed superquadrics overlapping (`Some(true)`) or
    /// apart (`Some(false)`); `None` where it cannot tell.
    fn certified_touch(q: &Superquadric, pa: &Pose, pb: &Pose) -> Option<bool> {
        match certify(q, pa, q, pb, 1e-13, 100_000) {
            Certified::Overlapping { .. } => Some(true),
            Certified::Apart { .. } => Some(false),
            Certified::Undecided { .. } => None,
        }
    }

    proptest! {
        /// For p = 2 the superquadric is an ellipsoid: μ matches Perram–Wertheim near contact
        /// (0.95 ≤ μ ≤ 1 + EXACT_BELOW, where the Monte Carlo compares and pushes) and stays
        /// below it elsewhere (deep overlaps, where the distance solver is not asked to be exact),
        /// for two ellipsoids of any aspect ratios and sizes (a mixture's pairs).
        #[test]
        fn matches_perram_wertheim_for_ellipsoids(
            x0 in 0.3f64..3.0,
            x0b in 0.3f64..3.0,
            size in 0.5f64..2.0,
            r in prop::array::uniform3(-1.5f64..1.5),
            wa in prop::array::uniform3(-3.0f64..3.0),
            wb in prop::array::uniform3(-3.0f64..3.0),
            scale in 0.5f64..1.0,
        ) {
            let q = Superquadric::with_unit_volume([x0, 1.0, 1.0], [2.0; 3]).unwrap();
            let unit = Superquadric::with_unit_volume([x0b, 1.0, 1.0], [2.0; 3]).unwrap();
            let qb = Superquadric::new((unit.s * size).into(), [2.0; 3]).unwrap();
            let e = Ellipsoid::new(q.s.x, q.s.y, q.s.z);
            let eb = Ellipsoid::new(qb.s.x, qb.s.y, qb.s.z);
            let (ra, rb) = (rotate(&M3::identity(), &V3::from(wa), 1.0), rotate(&M3::identity(), &V3::from(wb), 1.0));
            let r = V3::from(r);
            prop_assume!(r.norm() > 0.1);
            // Put the pair at a chosen scale near contact, where the Monte Carlo needs μ exactly.
            let r = r * (scale / pw::contact_scale(&e, &ra, &eb, &rb, &r)) * 1.1;
            let oracle = pw::contact_scale(&e, &ra, &eb, &rb, &r);
            let mu = contact_scale(&q, &ra, &qb, &rb, &r);
            if (0.95..=1.0 + EXACT_BELOW).contains(&oracle) {
                prop_assert!((mu - oracle).abs() <= 1e-8 * oracle, "{mu} vs {oracle}");
            } else {
                prop_assert!(mu <= oracle * (1.0 + 1e-9), "{mu} vs {oracle}");
            }
        }

        /// Where Gilbert's certificates decide, they decide as the distance solver does (Newton
        /// on Eqs. 23 from its own start, a different algorithm): superquadrics up to p = 10
        /// and aspect 3, placed from deep overlaps to twice their contact distance, and asked
        /// at the Monte Carlo's k. Pairs whose distance is within 10⁻⁶ of contact, or that the
        /// solver cannot answer, are left out: the tolerances differ there.
        #[test]
        fn certificates_decide_as_the_distance_solver(
            x0 in 0.33f64..3.0,
            p in prop_oneof![Just(2.0), 2.0f64..10.0, Just(10.0)],
            r in prop::array::uniform3(-1.5f64..1.5),
            wa in prop::array::uniform3(-3.0f64..3.0),
            wb in prop::array::uniform3(-3.0f64..3.0),
            at in prop_oneof![0.5f64..2.0, 0.99f64..1.01, 0.9999f64..1.0001],
        ) {
            let (q, ra, rb) = turned_pair(x0, p, wa, wb);
            let r = V3::from(r);
            prop_assume!(r.norm() > 0.1);
            let r = r * (at / contact_scale(&q, &ra, &q, &rb, &r));
            let k = 1.0 + 1e-9;
            let pa = Pose { r: V3::zeros(), rot: ra };
            let pb = Pose { r: r / k, rot: rb };
            let d = distance(&q, &pa, &q, &pb, None, &Tolerances::default(), &mut SolverStats::default());
            let Some(d) = d.filter(|d| d.d.abs() > 1e-6) else {
                return Err(TestCaseError::reject("at contact, or unanswered"));
            };
            match certify(&q, &pa, &q, &pb, f64::INFINITY, CERTIFY_ITERATIONS) {
                Certified::Apart { .. } => prop_assert!(d.d > 0.0, "apart, d {}", d.d),
                Certified::Overlapping { .. } => prop_assert!(d.d < 0.0, "overlapping, d {}", d.d),
                Certified::Undecided { .. } => {}
            }
            prop_assert_eq!(within(&q, &ra, &q, &rb, &r, k, None), d.d < 0.0);
        }

        /// `within` decides as an independent oracle does: Perram–Wertheim for ellipsoids
        /// (p = 2), and for superquadrics up to p = 10 and aspect 3 Gilbert's algorithm on their
        /// support functions ([`certify`]), which proves overlap by a point inside both and
        /// separation by an axis. Pairs are placed around contact (0.9–1.1 of it, within 10⁻⁴ and
        /// 10⁻⁶, deep overlaps and separations at 0.5 and 2) and asked at k = 1, 1 + 10⁻⁹ (the
        /// Monte Carlo's) and 1 + 10⁻³, but for pairs within 10⁻⁷ of contact at k, where the
        /// solver's tolerance decides. (An oracle of [`contact_scale`] is wrong at 1 + 10⁻³: above
        /// 1 + [`EXACT_BELOW`] it is a lower bound.)
        #[test]
        fn within_decides_as_an_independent_oracle(
            x0 in 0.33f64..3.0,
            p in prop_oneof![Just(2.0), 2.0f64..10.0, Just(10.0)],
            r in prop::array::uniform3(-1.5f64..1.5),
            wa in prop::array::uniform3(-3.0f64..3.0),
            wb in prop::array::uniform3(-3.0f64..3.0),
            at in prop_oneof![0.9f64..1.1, 0.9999f64..1.0001, 0.999999f64..1.000001, Just(0.5), Just(2.0)],
            k in prop_oneof![Just(1.0), Just(1.0 + 1e-9), Just(1.0 + 1e-3)],
            axis in prop_oneof![
                Just(None),
                prop::array::uniform3(-1.0f64..1.0).prop_map(|n| Some((V3::from(n), 0.0))),
                prop::array::uniform3(-0.3f64..0.3).prop_map(|n| Some((V3::from(n), 1.0))),
            ],
        ) {
            let (q, ra, rb) = turned_pair(x0, p, wa, wb);
            let r = V3::from(r);
            prop_assume!(r.norm() > 0.1);
            let e = Ellipsoid::new(q.s.x, q.s.y, q.s.z);
            let place = |r: &V3| if p == 2.0 { pw::contact_scale(&e, &ra, &e, &rb, r) } else { contact_scale(&q, &ra, &q, &rb, r) };
            let r = r * (at / place(&r));
            let pa = Pose { r: V3::zeros(), rot: ra };
            // Whether the pair touches at scale s, where the oracle proves it.
            let touches_at = |s: f64| -> Option<bool> {
                if p == 2.0 {
                    return Some(pw::contact_scale(&e, &ra, &e, &rb, &r) <= s);
                }
                certified_touch(&q, &pa, &Pose { r: r / s, rot: rb })
            };
            let (below, above) = (touches_at(k * (1.0 - 1e-7)), touches_at(k * (1.0 + 1e-7)));
            // Touching a little below k, or apart a little above it: decided with a margin.
            let expected = match (below, above) {
                (Some(true), _) => true,
                (_, Some(false)) => false,
                _ => return Err(TestCaseError::reject("within 1e-7 of contact")),
            };
            // Any first axis for the certificates: none (the line of centres), one at random, or
            // one near the line of centres (a good axis of bodies reaching into each other).
            let axis = axis.and_then(|(n, centres)| (n + r.normalize() * centres).try_normalize(1e-3));
            prop_assert_eq!(within(&q, &ra, &q, &rb, &r, k, axis.as_ref()), expected, "k {}, axis {:?}", k, axis);
        }
    }
}
