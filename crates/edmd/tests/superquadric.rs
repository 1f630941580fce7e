//! Superquadrics through the whole engine: with every exponent 2 a superquadric is an ellipsoid,
//! and the run must say so (same physics within its errors) although every geometric quantity
//! goes through the general code of Eq. (77), its support function and the Gilbert audit.

use edmd::{Neighbours, Scene, ShapeKind};

fn scene(shape: ShapeKind, neighbours: Neighbours) -> Scene {
    let mut s = Scene::new(shape, 128, 0.3);
    s.x0 = 2.0;
    s.neighbours = neighbours;
    // Both runs start alike and part by rounding within a few hundred collisions: the two means
    // are then independent samples. Over 4,000 collisions their mean free times once differed
    // by 6.7 % by chance (LL); over 20,000, by 2.2 %.
    s.collisions = 20_000;
    s.equilibrate = 1_000;
    s
}

#[test]
fn superquadric_with_exponents_two_reproduces_the_ellipsoid() {
    for nb in [Neighbours::Ll, Neighbours::Nnl] {
        let e = edmd::run(&scene(ShapeKind::Ellipsoid, nb), &mut |_| {}).unwrap();
        let mut sq = scene(ShapeKind::Superquadric, nb);
        sq.exponents = Some([2.0; 3]);
        let q = edmd::run(&sq, &mut |_| {}).unwrap();
        assert_eq!((q.overlaps, q.solver_failures), (0, 0), "{nb:?}");
        assert!(q.energy_drift_rel < 1e-10, "{nb:?}: {}", q.energy_drift_rel);
        // Same seed, same shape: Z within 4 combined standard errors, and the mean free time
        // (collisions per unit time) within 5 %.
        let sigma = (e.pressure_z_err.powi(2) + q.pressure_z_err.powi(2)).sqrt();
        assert!(
            (e.pressure_z - q.pressure_z).abs() < 4.0 * sigma,
            "{nb:?}: Z {} ± {} vs {} ± {}",
            e.pressure_z,
            e.pressure_z_err,
            q.pressure_z,
            q.pressure_z_err
        );
        assert!(
            (e.mean_free_time / q.mean_free_time - 1.0).abs() < 0.05,
            "{nb:?}: mean free time {} vs {}",
            e.mean_free_time,
            q.mean_free_time
        );
        eprintln!(
            "{nb:?}: Z ellipsoid {:.3} ± {:.3}, superquadric {:.3} ± {:.3}; tau_c {:.1} vs {:.1} us",
            e.pressure_z, e.pressure_z_err, q.pressure_z, q.pressure_z_err, e.tau_c_us, q.tau_c_us
        );
    }
}
