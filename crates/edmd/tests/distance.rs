//! Newton–Raphson distance against independent oracles: the Perram–Wertheim contact function for
//! the sign (ellipsoids), |r| − σ for spheres; on both sides of contact, for 0.2 ≤ X0 ≤ 5.

use edmd::distance::{SolverStats, Tolerances, distance};
use edmd::ellipsoid::Ellipsoid;
use edmd::geometry::{M3, Pose, V3};
use edmd::pw::contact_scale;
use edmd::rigid::rotate;
use proptest::prelude::*;

fn uniaxial(x0: f64) -> Ellipsoid {
    let b = 0.5 / x0.cbrt();
    Ellipsoid::new(x0 * b, b, b)
}

fn orientation(axis: [f64; 3], angle: f64) -> M3 {
    rotate(
        &M3::identity(),
        &V3::from(axis),
        angle / V3::from(axis).norm().max(1e-9),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// The centre separation is scaled so that the PW contact scale μ is 1 ± δ: the bodies are
    /// apart (μ > 1) or overlap (μ < 1) by a known small margin, and the NR distance must agree.
    #[test]
    fn sign_matches_perram_wertheim(
        x0 in prop_oneof![0.2f64..1.0, 1.0f64..5.0],
        dir in prop::array::uniform3(-1.0f64..1.0),
        axa in prop::array::uniform3(-1.0f64..1.0), anga in 0.0f64..6.3,
        axb in prop::array::uniform3(-1.0f64..1.0), angb in 0.0f64..6.3,
        log_delta in -9.0f64..-1.3,
        outside in any::<bool>(),
    ) {
        let dir = V3::from(dir);
        prop_assume!(dir.norm() > 0.1);
        let e = uniaxial(x0);
        let (ra, rb) = (orientation(axa, anga), orientation(axb, angb));
        let mu0 = contact_scale(&e, &ra, &e, &rb, &dir);
        let delta = 10f64.powf(log_delta);
        let target = if outside { 1.0 + delta } else { 1.0 - delta };
        let r = dir * (target / mu0);
        let pa = Pose { r: V3::zeros(), rot: ra };
        let pb = Pose { r, rot: rb };
        let mut st = SolverStats::default();
        let d = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut st);
        prop_assert!(d.is_some(), "solver failed: x0 {x0} mu {target}");
        let d = d.unwrap();
        prop_assert_eq!(d.d > 0.0, outside, "x0 {} mu {} distance {}", x0, target, d.d);
        // A translation by |d| along the normal brings them into contact: check with PW.
        let n = (d.xb - d.xa).normalize() * d.d.signum();
        let touching = contact_scale(&e, &ra, &e, &rb, &(r - n * d.d));
        prop_assert!((touching - 1.0).abs() < 1e-7, "after moving by d: mu = {}", touching);
    }

    /// Spheres: the distance is exactly |r| − σ, whatever the orientations.
    #[test]
    fn spheres_exact(
        dir in prop::array::uniform3(-1.0f64..1.0),
        gap in -0.3f64..2.0,
        axa in prop::array::uniform3(-1.0f64..1.0), anga in 0.0f64..6.3,
    ) {
        let dir = V3::from(dir);
        prop_assume!(dir.norm() > 0.1);
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let r = dir.normalize() * (1.0 + gap);
        let pa = Pose { r: V3::new(0.1, -0.2, 0.3), rot: orientation(axa, anga) };
        let pb = Pose { r: pa.r + r, rot: M3::identity() };
        let mut st = SolverStats::default();
        let d = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut st).unwrap();
        prop_assert!((d.d - gap).abs() < 1e-12, "{} vs {}", d.d, gap);
    }
}
