//! The globally convergent fallback of the distance solver: Gilbert's algorithm (Frank–Wolfe on
//! the Minkowski difference) with support functions only, not in the paper.
//!
//! Newton–Raphson on Eqs. (23) converges only locally; from a poor start (flat bodies face to face,
//! X0 = 0.1: the guess of Sec. 3.2 puts x_B = x_A + β f_x far from B and the damping of Eq. (28)
//! then crawls) it exhausts its iterations, and so does the steepest descent. Gilbert's algorithm
//! minimises |x_B − x_A| over A × B by moving towards the support points along the current
//! separation; every iterate is a pair of points of the bodies (convex combinations of support
//! points), which bounds the distance from above, and the support gap along the current direction
//! bounds it from below. The two bounds certify the answer: a positive lower bound proves the
//! bodies apart, a point inside both proves them overlapping.

use crate::geometry::{Placed, Pose, Surface, V3};

/// What the support-function iteration proved.
#[derive(Clone, Copy, Debug)]
pub enum Certified {
    /// Apart: `lower` ≤ distance ≤ `upper`; `n` (unit, from A to B) is the axis of `lower`,
    /// `xa`, `xb` the support points of A along n and of B along −n (lab frame).
    Apart {
        lower: f64,
        upper: f64,
        n: V3,
        xa: V3,
        xb: V3,
    },
    /// Overlapping: `inside` lies strictly inside both bodies; `lower` ≤ −(penetration depth)
    /// from the best axis tried (a negative bound on the signed distance).
    Overlapping { inside: V3, lower: f64 },
    /// Neither within the iterations: the bodies touch to within `upper` − `lower`; `xa`, `xb`
    /// are the support points along the best axis `n`, a start for Newton–Raphson.
    Undecided {
        lower: f64,
        upper: f64,
        n: V3,
        xa: V3,
        xb: V3,
    },
}

/// Apart, once the best separating axis so far (its gap `best.0`, axis and support points)
/// proves a positive distance within `tol` of the upper bound.
fn apart_within(best: &(f64, V3, V3, V3), upper: f64, tol: f64) -> Option<Certified> {
    let &(lower, n, xa, xb) = best;
    (lower > 0.0 && upper - lower <= tol).then_some(Certified::Apart {
        lower,
        upper,
        n,
        xa,
        xb,
    })
}

/// The support point of the placed body along the unit lab direction `n`, in the lab frame.
pub fn support_point_lab<S: Surface>(s: &S, p: &Pose, n: &V3) -> V3 {
    p.to_lab(&s.support_point(&(p.rot * n)))
}

/// How far [`certify_from`] moves a support point towards its body's centre (a fraction of the
/// way): strictly inside the body whatever the rounding of the point, and near enough its surface
/// that overlaps deeper than about 10⁻⁶ of the body's size show.
const INSIDE_BY: f64 = 1e-6;

/// Runs Gilbert's algorithm until the bounds are within `tol` of each other (absolute, in
/// lengths), a point inside both bodies is found, or `max_iter` iterations are spent.
pub fn certify<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    tol: f64,
    max_iter: u32,
) -> Certified {
    certify_from(sa, pa, sb, pb, None, tol, max_iter)
}

/// [`certify`] from the unit axis `from` (lab frame, from A to B) where the caller has a good
/// one, or else from the line of centres. The gap along `from` bounds the distance as any axis
/// does, so it is a certificate of its own; a good axis also starts the iterations near their
/// end, where the line of centres of elongated bodies starts them far from it.
pub fn certify_from<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    from: Option<&V3>,
    tol: f64,
    max_iter: u32,
) -> Certified {
    let (qa, qb) = (sa.place(pa), sb.place(pb));
    let centres = pb.r - pa.r;
    // A degenerate axis (the normal of coincident centres) is no start.
    let from = from.filter(|n| n.iter().all(|x| x.is_finite()));
    let dir = match from {
        Some(n) => *n,
        None if centres.norm() > 0.0 => centres.normalize(),
        None => V3::x(),
    };
    // Points of A and B (convex combinations of support points) whose difference is the iterate.
    let mut pa_in = support_point_lab(sa, pa, &dir);
    let mut pb_in = support_point_lab(sb, pb, &-dir);
    let mut best = (f64::NEG_INFINITY, dir, pa_in, pb_in);
    if from.is_some() {
        best.0 = dir.dot(&(pb_in - pa_in));
        if let Some(apart) = apart_within(&best, (pb_in - pa_in).norm(), tol) {
            return apart;
        }
        // Bodies that overlap along a good axis reach into each other there: a support point a
        // hair inside its own body and inside the other proves the overlap.
        for inside in [
            pa_in + (pa.r - pa_in) * INSIDE_BY,
            pb_in + (pb.r - pb_in) * INSIDE_BY,
        ] {
            if qa.f(&inside) < 0.0 && qb.f(&inside) < 0.0 {
                return Certified::Overlapping {
                    inside,
                    lower: best.0,
                };
            }
        }
    }
    for _ in 0..max_iter {
        let v = pb_in - pa_in;
        let upper = v.norm();
        let mid = 0.5 * (pa_in + pb_in);
        if best.0 <= 0.0 && qa.f(&mid) < 0.0 && qb.f(&mid) < 0.0 {
            return Certified::Overlapping {
                inside: mid,
                lower: best.0,
            };
        }
        if upper == 0.0 {
            break;
        }
        let n = v / upper;
        let a = support_point_lab(sa, pa, &n);
        let b = support_point_lab(sb, pb, &-n);
        let w = b - a;
        let lower = n.dot(&w);
        if lower > best.0 {
            best = (lower, n, a, b);
        }
        if let Some(apart) = apart_within(&best, upper, tol) {
            return apart;
        }
        // Exact line search on the segment from v to w.
        let step = w - v;
        let ss = step.norm_squared();
        if ss == 0.0 {
            break;
        }
        let lambda = (-v.dot(&step) / ss).clamp(0.0, 1.0);
        if lambda == 0.0 {
            // No progress possible along this direction: the bounds are as good as they get.
            break;
        }
        pa_in += (a - pa_in) * lambda;
        pb_in += (b - pb_in) * lambda;
    }
    let upper = (pb_in - pa_in).norm();
    if let Some(apart) = apart_within(&best, upper, tol) {
        return apart;
    }
    Certified::Undecided {
        lower: best.0,
        upper,
        n: best.1,
        xa: best.2,
        xb: best.3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ellipsoid::Ellipsoid;
    use crate::geometry::M3;
    use crate::rigid::rotate;

    #[test]
    fn spheres_apart_and_overlapping() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let pa = Pose {
            r: V3::zeros(),
            rot: M3::identity(),
        };
        let pb = Pose {
            r: V3::new(1.2, 0.3, 0.0),
            rot: rotate(&M3::identity(), &V3::new(1.0, 1.0, 0.0), 0.3),
        };
        match certify(&e, &pa, &e, &pb, 1e-12, 200) {
            Certified::Apart { lower, upper, .. } => {
                let d = pb.r.norm() - 1.0;
                assert!(
                    lower <= d + 1e-14 && d <= upper + 1e-14,
                    "{lower} {d} {upper}"
                );
                assert!(upper - lower <= 1e-12);
            }
            other => panic!("{other:?}"),
        }
        let pb = Pose {
            r: V3::new(0.9, 0.1, 0.0),
            ..pb
        };
        assert!(matches!(
            certify(&e, &pa, &e, &pb, 1e-12, 200),
            Certified::Overlapping { .. }
        ));
    }

    /// A good axis decides without a single iteration: superquadrics p = 10, X0 = 2, end to end
    /// 0.01 apart are proved apart along their common axis, and 0.01 into each other
    /// overlapping, by a point strictly inside both; along an axis across them, neither.
    #[test]
    fn a_good_axis_decides_before_any_iteration() {
        let q =
            crate::superquadric::Superquadric::with_unit_volume([2.0, 1.0, 1.0], [2.0, 2.0, 10.0])
                .unwrap();
        let place = |x: f64| {
            let pa = Pose {
                r: V3::zeros(),
                rot: M3::identity(),
            };
            let pb = Pose {
                r: V3::new(2.0 * q.s.x + x, 0.02, -0.01),
                rot: rotate(&M3::identity(), &V3::new(0.0, 0.0, 1.0), 0.01),
            };
            (pa, pb)
        };
        let (pa, pb) = place(0.01);
        // Gilbert's iterations from the line of centres bound the distance above.
        let distance = match certify(&q, &pa, &q, &pb, 1e-6, 100_000) {
            Certified::Apart { upper, .. } | Certified::Undecided { upper, .. } => upper,
            other => panic!("{other:?}"),
        };
        match certify_from(&q, &pa, &q, &pb, Some(&V3::x()), f64::INFINITY, 0) {
            Certified::Apart { lower, n, .. } => {
                assert!(lower > 0.0 && lower <= distance, "{lower} {distance}");
                assert_eq!(n, V3::x());
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            certify(&q, &pa, &q, &pb, f64::INFINITY, 0),
            Certified::Undecided { .. }
        ));
        let (pa, pb) = place(-0.01);
        match certify_from(&q, &pa, &q, &pb, Some(&V3::x()), f64::INFINITY, 0) {
            Certified::Overlapping { inside, lower } => {
                assert!(q.place(&pa).f(&inside) < 0.0 && q.place(&pb).f(&inside) < 0.0);
                assert!(lower < 0.0, "{lower}");
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            certify_from(&q, &pa, &q, &pb, Some(&V3::y()), f64::INFINITY, 0),
            Certified::Undecided { .. }
        ));
        // Not a number is no axis: the line of centres starts the iterations.
        assert!(matches!(
            certify_from(
                &q,
                &pa,
                &q,
                &pb,
                Some(&V3::repeat(f64::NAN)),
                f64::INFINITY,
                32
            ),
            Certified::Overlapping { .. }
        ));
        // A hair into each other, the axis is no certificate of a gap, and the iterations
        // from it find the overlap.
        let pb = Pose {
            r: V3::new(2.0 * q.s.x - 1e-7, 0.0, 0.0),
            rot: M3::identity(),
        };
        assert!(!matches!(
            certify_from(&q, &pa, &q, &pb, Some(&V3::x()), f64::INFINITY, 0),
            Certified::Apart { .. }
        ));
        assert!(matches!(
            certify_from(&q, &pa, &q, &pb, Some(&V3::x()), f64::INFINITY, 1000),
            Certified::Overlapping { .. }
        ));
    }

    #[test]
    fn flat_disks_face_to_face_converge() {
        // X0 = 0.1 oblate ellipsoids nearly parallel, 0.01 apart: the case that defeats NR.
        let b = 0.5 / 0.1f64.cbrt();
        let e = Ellipsoid::new(0.1 * b, b, b);
        let pa = Pose {
            r: V3::zeros(),
            rot: M3::identity(),
        };
        let pb = Pose {
            r: V3::new(2.0 * 0.1 * b + 0.01, 0.3, -0.2),
            rot: rotate(&M3::identity(), &V3::new(0.0, 1.0, 0.0), 0.01),
        };
        match certify(&e, &pa, &e, &pb, 1e-10, 100_000) {
            Certified::Apart { lower, upper, .. } => {
                assert!(lower > 0.0 && upper - lower <= 1e-10, "{lower} {upper}")
            }
            other => panic!("{other:?}"),
        }
    }
}
