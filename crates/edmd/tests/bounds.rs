//! The contact-free intervals that prune and shorten contact searches, against the independent
//! Perram–Wertheim overlap test: within a claimed interval the bodies never overlap.

use edmd::contact::separating_axis;
use edmd::distance::{SolverStats, Tolerances, distance};
use edmd::ellipsoid::Ellipsoid;
use edmd::geometry::{M3, Placed, Surface, V3};
use edmd::pw::contact_scale;
use edmd::rigid::{Body, GapSide, Towards, ddot_max, gap_safe_time, gap_safe_time_towards, rotate};
use edmd::superquadric::Superquadric;
use edmd::support_distance::{Certified, certify, support_point_lab};
use proptest::prelude::*;

/// The smallest Perram–Wertheim scale factor over `samples` times in [0, t_end): below 1 is an overlap.
fn min_scale(e: &Ellipsoid, a: &Body, b: &Body, t_end: f64, samples: usize) -> f64 {
    (0..samples)
        .map(|k| {
            let t = t_end * k as f64 / samples as f64;
            let (pa, pb) = (a.pose_after(t), b.pose_after(t));
            contact_scale(e, &pa.rot, e, &pb.rot, &(pb.r - pa.r))
        })
        .fold(f64::INFINITY, f64::min)
}

prop_compose! {
    /// Two moving ellipsoids (semi-axes 0.15–1.5, so aspect ratios up to 10) that do not overlap now.
    fn pair()(
        s in prop::array::uniform3(0.15f64..1.5),
        axis_a in prop::array::uniform3(-1.0f64..1.0),
        axis_b in prop::array::uniform3(-1.0f64..1.0),
        angles in prop::array::uniform2(0.0f64..6.3),
        dir in prop::array::uniform3(-1.0f64..1.0),
        gap in 0.0f64..1.0,
        v in prop::array::uniform3(-3.0f64..3.0),
        w in prop::array::uniform3(-8.0f64..8.0),
        wb in prop::array::uniform3(-8.0f64..8.0),
    ) -> (Ellipsoid, Body, Body) {
        let e = Ellipsoid::new(s[0], s[1], s[2]);
        let rot = |axis: [f64; 3], angle| rotate(&M3::identity(), &(V3::from(axis) + V3::new(1e-3, 0.0, 0.0)), angle);
        let dir = (V3::from(dir) + V3::new(0.0, 1e-3, 0.0)).normalize();
        // Centres between touching and one bounding diameter apart along `dir`.
        let reach = 2.0 * e.bounding_radius();
        let a = Body { r: V3::zeros(), v: V3::zeros(), rot: rot(axis_a, angles[0]), w: V3::from(w), t: 0.0 };
        let b = Body { r: dir * reach * (0.3 + gap), v: V3::from(v), rot: rot(axis_b, angles[1]), w: V3::from(wb), t: 0.0 };
        (e, a, b)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn no_overlap_within_the_safe_time_from_the_closest_points((e, a, b) in pair()) {
        let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
        prop_assume!(contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r)) > 1.0 + 1e-9);
        let d = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut SolverStats::default());
        prop_assume!(matches!(d, Some(d) if d.d > 0.0));
        let d = d.unwrap();
        let n = e.place(&pa).grad(&d.xa).normalize();
        let safe = gap_safe_time(&GapSide::new(&e, &a, &pa.rot, d.xa - pa.r, &n), &GapSide::new(&e, &b, &pb.rot, d.xb - pb.r, &-n), &n, d.d);
        // Never shorter than the step of Eq. (39), d/ḋ_max.
        prop_assert!(safe >= d.d / ddot_max(&a, &b, e.bounding_radius(), e.bounding_radius()) * (1.0 - 1e-9));
        let scale = min_scale(&e, &a, &b, safe.min(3.0), 600);
        prop_assert!(scale > 1.0 - 1e-9, "overlap {scale} within the safe time {safe} (d = {})", d.d);
    }

    #[test]
    fn the_separating_axis_gap_bounds_the_distance_and_stays_clear((e, a, b) in pair()) {
        let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
        prop_assume!(contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r)) > 1.0 + 1e-9);
        let gap = separating_axis(&e, &pa, &e, &pb);
        if let Some(d) = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut SolverStats::default()) {
            prop_assert!(gap.gap <= d.d + 1e-12, "gap {} above the distance {}", gap.gap, d.d);
        }
        let lower = gap.safe_time(&e, &a, &e, &b);
        prop_assert!(lower >= 0.0 && gap.closing_estimate(&a, &b) >= 0.0);
        let scale = min_scale(&e, &a, &b, lower.min(3.0), 600);
        prop_assert!(scale > 1.0 - 1e-9, "overlap {scale} before the bound {lower}");
    }
}

#[test]
fn a_few_ascent_steps_find_most_of_the_distance() {
    // The elongation of the benchmark (X0 = 2), random orientations, gaps up to 0.4 σ.
    let e = Ellipsoid::new(0.794, 0.397, 0.397);
    let mut rng = edmd::rng::Rng::new(5);
    let mut ratios = Vec::new();
    while ratios.len() < 500 {
        let mut axis = || {
            V3::new(
                rng.uniform() - 0.5,
                rng.uniform() - 0.5,
                rng.uniform() - 0.5,
            )
        };
        let (ra, rb) = (
            rotate(&M3::identity(), &axis(), 3.0),
            rotate(&M3::identity(), &axis(), 3.0),
        );
        let r = axis().normalize() * (0.8 + 1.0 * rng.uniform());
        let pa = edmd::geometry::Pose {
            r: V3::zeros(),
            rot: ra,
        };
        let pb = edmd::geometry::Pose { r, rot: rb };
        if let Some(d) = distance(
            &e,
            &pa,
            &e,
            &pb,
            None,
            &Tolerances::default(),
            &mut SolverStats::default(),
        ) && (0.01..0.4).contains(&d.d)
        {
            ratios.push(separating_axis(&e, &pa, &e, &pb).gap / d.d);
        }
    }
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    assert!(ratios[ratios.len() - 1] <= 1.0 + 1e-9);
    assert!(median > 0.9, "median gap / distance {median}");
}

#[test]
fn touching_bodies_that_separate_are_safe_for_a_while_and_then_not() {
    // Just after a collision: d = 0, separating at unit speed, both spinning fast. Eq. (39) would step
    // ε_d/ḋ_max at a time; the quadratic bound clears a finite interval at once.
    let e = Ellipsoid::new(1.0, 0.4, 0.4);
    let a = Body {
        r: V3::zeros(),
        v: V3::new(-0.5, 0.0, 0.0),
        rot: M3::identity(),
        w: V3::new(0.0, 0.0, 6.0),
        t: 0.0,
    };
    let b = Body {
        r: V3::new(2.0, 0.0, 0.0),
        v: V3::new(0.5, 0.0, 0.0),
        rot: M3::identity(),
        w: V3::new(0.0, 0.0, -6.0),
        t: 0.0,
    };
    let n = V3::new(1.0, 0.0, 0.0);
    let safe = gap_safe_time(
        &GapSide::new(&e, &a, &a.rot, n, &n),
        &GapSide::new(&e, &b, &b.rot, -n, &-n),
        &n,
        0.0,
    );
    assert!(safe > 0.005 && safe.is_finite(), "{safe}");
    assert!(min_scale(&e, &a, &b, safe, 2000) > 1.0 - 1e-12);
    // Spinning tips swing back within a quarter turn: the bound must stop before they could.
    let first_overlap = (1..4000).map(|k| k as f64 * 1e-4).find(|&t| {
        let (pa, pb) = (a.pose_after(t), b.pose_after(t));
        contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r)) < 1.0
    });
    if let Some(t) = first_overlap {
        assert!(safe < t, "safe {safe} past the overlap at {t}");
    }
}

/// The superquadric of the scenes: a : b : c = X0 : 1 : 1, exponents [2, 2, p], volume π/6.
fn superquadric(x0: f64, p: f64) -> Superquadric {
    Superquadric::with_unit_volume([x0, 1.0, 1.0], [2.0, 2.0, p]).unwrap()
}

/// The support gap of A and B along the fixed lab direction `n` at time t (negative t: the
/// past), from the support points: a lower bound on their distance, 0 at contact.
fn support_gap(q: &Superquadric, a: &Body, b: &Body, n: &V3, t: f64) -> f64 {
    let (pa, pb) = (a.pose_after(t), b.pose_after(t));
    n.dot(&(support_point_lab(q, &pb, &-n) - support_point_lab(q, &pa, n)))
}

/// Whether Gilbert's algorithm (support functions only, no Newton–Raphson) proves A and B
/// overlapping at time t: a point strictly inside both.
fn gilbert_overlap(q: &Superquadric, a: &Body, b: &Body, t: f64) -> bool {
    matches!(
        certify(
            q,
            &a.pose_after(t),
            q,
            &b.pose_after(t),
            f64::INFINITY,
            2_000
        ),
        Certified::Overlapping { .. }
    )
}

prop_compose! {
    /// Two spinning superquadrics (p from 2 to 20, X0 0.5 or 2) a small gap apart: half of them
    /// flat face over flat face, nearly parallel (where a flat face's support point runs fastest
    /// as it turns), the rest in random orientations along a random line of centres.
    fn sq_pair()(
        x0 in prop::sample::select(vec![0.5, 2.0]),
        p in prop_oneof![Just(2.0), 2.0f64..20.0],
        face_to_face in any::<bool>(),
        axes in prop::array::uniform3(-1.0f64..1.0),
        dir in prop::array::uniform3(-1.0f64..1.0),
        angles in prop::array::uniform2(0.0f64..3.2),
        tilt in -3.0f64..0.0,
        gap in -4.0f64..-0.5,
        v in prop::array::uniform3(-2.0f64..2.0),
        wa in prop::array::uniform3(-8.0f64..8.0),
        wb in prop::array::uniform3(-8.0f64..8.0),
    ) -> (Superquadric, Body, Body) {
        let q = superquadric(x0, p);
        let axis = V3::from(axes) + V3::new(1e-3, 0.0, 0.0);
        let gap = 10f64.powf(gap);
        let (rot_a, rot_b, r) = if face_to_face {
            // B on A's flat face (the p axis), turned by up to 1e-3 rad, shifted sideways a little.
            let c = q.semi_axes().z;
            let side = V3::from(dir) * 0.3 * q.semi_axes().x.min(q.semi_axes().y);
            (M3::identity(), rotate(&M3::identity(), &axis, 10f64.powf(tilt)),
             V3::new(side.x, side.y, 2.0 * c + gap))
        } else {
            let u = (V3::from(dir) + V3::new(0.0, 1e-3, 0.0)).normalize();
            (rotate(&M3::identity(), &axis, angles[0]), rotate(&M3::identity(), &u, angles[1]),
             u * (2.0 * q.bounding_radius() * (0.3 + gap)))
        };
        let a = Body { r: V3::zeros(), v: V3::zeros(), rot: rot_a, w: V3::from(wa), t: 0.0 };
        let b = Body { r, v: V3::from(v), rot: rot_b, w: V3::from(wb), t: 0.0 };
        (q, a, b)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Within the contact-free interval claimed from the closest points, forwards and backwards in
    /// time, the support gap along the fixed normal never closes (the bound's own claim) and
    /// Gilbert's algorithm never finds the bodies overlapping (the distance is never negative).
    #[test]
    fn superquadrics_stay_apart_within_the_safe_time((q, a, b) in sq_pair()) {
        let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
        prop_assume!(!gilbert_overlap(&q, &a, &b, 0.0));
        let d = distance(&q, &pa, &q, &pb, None, &Tolerances::default(), &mut SolverStats::default());
        prop_assume!(matches!(d, Some(d) if d.d > 0.0));
        let d = d.unwrap();
        let n = q.place(&pa).grad(&d.xa).normalize();
        let side_a = GapSide::new(&q, &a, &pa.rot, d.xa - pa.r, &n);
        let side_b = GapSide::new(&q, &b, &pb.rot, d.xb - pb.r, &-n);
        // The support gap along n is the distance at t = 0, to the solver's tolerance.
        let slack = 1e-9;
        prop_assert!((support_gap(&q, &a, &b, &n, 0.0) - d.d).abs() < slack);
        for (towards, sign) in [(Towards::Future, 1.0), (Towards::Past, -1.0)] {
            let safe = gap_safe_time_towards(&side_a, &side_b, &n, d.d, towards);
            prop_assert!(safe >= 0.0);
            let (la, lb) = (q.bounding_radius(), q.bounding_radius());
            // Never shorter than the linear bound d/ḋ_max of Eq. (39).
            prop_assert!(safe >= d.d / ddot_max(&a, &b, la, lb) * (1.0 - 1e-9));
            let end = safe.min(2.0);
            for k in 0..=400 {
                // Denser near the end of the interval, where a wrong bound would first fail.
                let t = sign * end * (1.0 - (1.0 - k as f64 / 400.0).powi(3));
                let g = support_gap(&q, &a, &b, &n, t);
                prop_assert!(g > -slack, "{towards:?}: gap {g} at {t} within the safe time {safe} (d = {})", d.d);
                if k % 20 == 0 {
                    prop_assert!(!gilbert_overlap(&q, &a, &b, t), "{towards:?}: overlap at {t} within {safe}");
                }
            }
        }
    }
}
