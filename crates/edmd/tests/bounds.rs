//! The contact-free intervals that prune and shorten contact searches, against the independent
//! Perram–Wertheim overlap test: within a claimed interval the bodies never overlap.

use edmd::contact::{
    ContactParams, Known, predict, predict_from, quick_bound, separating_axis, separating_axis_from,
};
use edmd::distance::{SolverStats, Tolerances, distance};
use edmd::ellipsoid::Ellipsoid;
use edmd::geometry::{M3, Placed, Surface, V3};
use edmd::pw::contact_scale;
use edmd::rigid::{Body, GapSide, Inertia, collide, ddot_max, gap_safe_time, rotate};
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

/// Whether the pair is apart now, by the independent Perram–Wertheim scale.
fn apart_now(e: &Ellipsoid, a: &Body, b: &Body) -> bool {
    let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
    contact_scale(e, &pa.rot, e, &pb.rot, &(pb.r - pa.r)) > 1.0 + 1e-9
}

/// The contact search's knobs of these tests.
fn params() -> ContactParams {
    ContactParams {
        eps_d: 1e-5,
        brent_tol: 1e-12,
        tol: Tolerances::default(),
    }
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
        prop_assume!(apart_now(&e, &a, &b));
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

    /// From the line of centres, or from any axis (the contact search starts each step's ascent
    /// from the axis of the step before).
    #[test]
    fn the_separating_axis_gap_bounds_the_distance_and_stays_clear(
        (e, a, b) in pair(),
        start in prop::option::of(prop::array::uniform3(-1.0f64..1.0)),
    ) {
        let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
        prop_assume!(apart_now(&e, &a, &b));
        let gap = match start {
            Some(n) => separating_axis_from(&e, &pa, &e, &pb, Some(&(V3::from(n) + V3::new(0.0, 0.0, 1e-3)).normalize())),
            None => separating_axis(&e, &pa, &e, &pb),
        };
        if let Some(d) = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut SolverStats::default()) {
            prop_assert!(gap.gap <= d.d + 1e-12, "gap {} above the distance {}", gap.gap, d.d);
        }
        let lower = gap.safe_time(&e, &a, &e, &b);
        prop_assert!(lower >= 0.0 && gap.closing_estimate(&a, &b) >= 0.0);
        let scale = min_scale(&e, &a, &b, lower.min(3.0), 600);
        prop_assert!(scale > 1.0 - 1e-9, "overlap {scale} before the bound {lower}");
    }

    /// The whole search, with its speculative jumps and its refinement from the bracket alone:
    /// the predicted contact is a contact, approached, and nothing overlaps before it.
    #[test]
    fn the_predicted_contact_is_the_first_and_the_bodies_approach_there((e, a, b) in pair()) {
        prop_assume!(apart_now(&e, &a, &b));
        let params = params();
        let mut stats = SolverStats::default();
        let horizon = 3.0;
        let hit = predict(&e, &a, &e, &b, horizon, &params, &mut stats);
        prop_assert_eq!(stats.failures, 0);
        let end = hit.map_or(horizon, |h| h.t);
        let scale = min_scale(&e, &a, &b, end, 600);
        prop_assert!(scale > 1.0 - 1e-9, "overlap {scale} before {hit:?}");
        if let Some(h) = hit {
            let (pa, pb) = (a.pose_after(h.t), b.pose_after(h.t));
            let at = contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r));
            prop_assert!((at - 1.0).abs() < 1e-8, "contact scale {at} at the contact");
            let u = (a.v + a.w.cross(&(h.xc - pa.r))) - (b.v + b.w.cross(&(h.xc - pb.r)));
            prop_assert!(u.dot(&h.n) > 0.0, "parting at the contact");
        }
    }

    /// The engine's quick bound, from one step of the ascent (a horizon of 0) or all of them (an
    /// infinite one), from the line of centres or from any axis kept from before (here a random
    /// one): nothing overlaps before it, no contact comes before it, and a search started from
    /// the gap it hands on finds the contact a search from scratch finds (to the bit, and with as
    /// many distance calls, where the ascent starts from the line of centres as the search's
    /// own does).
    #[test]
    fn the_quick_bound_comes_before_any_contact_and_its_gap_starts_the_same_search(
        (e, a, b) in pair(),
        horizon in prop_oneof![Just(0.0), Just(f64::INFINITY), 0.0f64..0.3],
        start in prop::option::of(prop::array::uniform3(-1.0f64..1.0)),
    ) {
        let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
        prop_assume!(apart_now(&e, &a, &b));
        let start = start.map(|n| (V3::from(n) + V3::new(0.0, 0.0, 1e-3)).normalize());
        let q = quick_bound(&e, &a, &e, &b, horizon, start.as_ref(), None);
        // Given the first step's bound (the engine's four lanes take it), the whole ascent at
        // once: the same bound and the same gap, whatever the horizon.
        let first = quick_bound(&e, &a, &e, &b, 0.0, start.as_ref(), None).lower;
        let given = quick_bound(&e, &a, &e, &b, horizon, start.as_ref(), Some(first));
        let bits = |q: &edmd::contact::QuickBound| q.now.map(|(g, safe)| (g.gap.to_bits(), safe.to_bits()));
        prop_assert!(given.now.is_some());
        if q.now.is_some() {
            prop_assert_eq!(bits(&given), bits(&q));
            prop_assert_eq!(given.lower.to_bits(), q.lower.to_bits());
        }
        prop_assert!(q.lower >= 0.0 && q.estimate >= q.lower, "{} {}", q.lower, q.estimate);
        // Only a bound beyond the horizon may stop at the first step.
        prop_assert!(q.now.is_some() || q.lower >= horizon);
        if q.lower > 0.0 {
            let scale = min_scale(&e, &a, &b, q.lower.min(3.0), 300);
            prop_assert!(scale > 1.0 - 1e-9, "overlap {scale} before the bound {}", q.lower);
        }
        let params = params();
        let mut stats = SolverStats::default();
        let hit = predict(&e, &a, &e, &b, 3.0, &params, &mut stats);
        if let Some(h) = hit {
            prop_assert!(q.lower <= h.t, "bound {} after the contact {}", q.lower, h.t);
        }
        if let Some((gap, safe)) = q.now {
            if let Some(d) = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut SolverStats::default()) {
                prop_assert!(gap.gap <= d.d + 1e-12, "gap {} above the distance {}", gap.gap, d.d);
            }
            let mut again = SolverStats::default();
            let from_gap = predict_from(&e, &a, &e, &b, 3.0, Some(Known::Gap(gap, safe)), &params, &mut again);
            if start.is_none() {
                prop_assert_eq!(from_gap, hit);
                prop_assert_eq!(again.distance_calls, stats.distance_calls);
            } else {
                match (from_gap, hit) {
                    (Some(x), Some(y)) => prop_assert!((x.t - y.t).abs() <= 1e-9 * y.t.max(1e-3), "{x:?} {y:?}"),
                    (x, y) => prop_assert_eq!(x, y),
                }
            }
        }
    }
}

proptest! {
    // Half the random pairs never meet within the horizon: they are drawn again.
    #![proptest_config(ProptestConfig { cases: 128, max_global_rejects: 4096, ..ProptestConfig::default() })]

    /// After a collision, the search that starts from the contact just resolved (no distance at
    /// the contact) finds the next contact of the pair that a search from scratch finds, and
    /// nothing overlaps before it.
    #[test]
    fn a_search_from_the_resolved_contact_finds_the_next_contact((e, a, b) in pair()) {
        prop_assume!(apart_now(&e, &a, &b));
        let params = params();
        let mut stats = SolverStats::default();
        let hit = predict(&e, &a, &e, &b, 3.0, &params, &mut stats);
        prop_assume!(hit.is_some());
        let h = hit.unwrap();
        let (mut a, mut b) = (a.at(h.t), b.at(h.t));
        let unit = Inertia { inv_m: 1.0, inv_i: 1.0 / (0.4 * e.semi_axes().min().powi(2)) };
        prop_assume!(collide(&mut a, &mut b, &h.xc, &h.n, unit, unit).is_some());
        let (a, b) = (Body { t: 0.0, ..a }, Body { t: 0.0, ..b });
        let known = Known::Contact { offset_a: h.xc - a.r, offset_b: h.xc - b.r };
        let mut from_contact = SolverStats::default();
        let next = predict_from(&e, &a, &e, &b, 3.0, Some(known), &params, &mut from_contact);
        let mut scratch = SolverStats::default();
        let again = predict(&e, &a, &e, &b, 3.0, &params, &mut scratch);
        prop_assert_eq!(from_contact.failures, 0);
        // Within the search's resolution both find the same next contact, or none.
        match (next, again) {
            (Some(x), Some(y)) => prop_assert!((x.t - y.t).abs() < 1e-6, "{} against {}", x.t, y.t),
            (x, y) => prop_assert_eq!(x.is_some(), y.is_some(), "{:?} against {:?}", x, y),
        }
        let end = next.map_or(3.0, |h| h.t);
        // Parting from the contact: sampled strictly after it.
        let scale = (1..=400)
            .map(|k| {
                let t = end * k as f64 / 401.0;
                let (pa, pb) = (a.pose_after(t), b.pose_after(t));
                contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r))
            })
            .fold(f64::INFINITY, f64::min);
        prop_assert!(scale > 1.0 - 1e-9, "overlap {scale} before {next:?}");
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
