//! Physics of whole runs: conservation laws, the overlap audit, the hard-sphere equation of state
//! (Kolafa), X0 = 1 ellipsoids = spheres, and linked cells vs neighbour lists.

use edmd::ellipsoid::Ellipsoid;
use edmd::geometry::min_image;
use edmd::pw::contact_scale;
use edmd::{FrameEvery, Hooks, Neighbours, RunReport, Scene, ShapeKind, run, run_with_hooks};

fn scene(
    shape: ShapeKind,
    n: usize,
    phi: f64,
    x0: f64,
    nb: Neighbours,
    collisions: u64,
    equilibrate: u64,
) -> Scene {
    let mut s = Scene::new(shape, n, phi);
    s.x0 = x0;
    s.neighbours = nb;
    s.collisions = collisions;
    s.equilibrate = equilibrate;
    s
}

fn go(s: &Scene) -> RunReport {
    let r = run(s, &mut |_| {}).expect("run");
    assert_eq!(r.overlaps, 0, "overlaps in {s:?}: {r:?}");
    r
}

/// Kolafa's fit of the hard-sphere compressibility factor.
fn kolafa(eta: f64) -> f64 {
    (1.0 + eta + eta * eta - 2.0 / 3.0 * eta.powi(3) * (1.0 + eta)) / (1.0 - eta).powi(3)
}

#[test]
fn kolafa_reference_values() {
    for (eta, z) in [(0.30, 3.9843), (0.40, 6.9457), (0.45, 9.4029)] {
        assert!((kolafa(eta) - z).abs() < 1e-4);
    }
}

#[test]
fn spheres_conserve_energy_and_momentum_over_1e5_collisions() {
    for nb in [Neighbours::Ll, Neighbours::Nnl] {
        let r = go(&scene(
            ShapeKind::Sphere,
            256,
            0.45,
            1.0,
            nb,
            100_000,
            1_000,
        ));
        assert!(r.energy_drift_rel < 1e-10, "{nb:?}: {}", r.energy_drift_rel);
        assert!(r.momentum_drift < 1e-12, "{nb:?}: {}", r.momentum_drift);
        assert_eq!(r.solver_failures, 0);
        assert_eq!(r.nnl_rebuilds > 0, nb == Neighbours::Nnl, "{r:?}");
    }
}

#[test]
fn ellipsoids_conserve_energy_and_momentum() {
    // 10^4 collisions: what the CI time budget allows on the Newton–Raphson path.
    let r = go(&scene(
        ShapeKind::Ellipsoid,
        128,
        0.4,
        2.0,
        Neighbours::Nnl,
        10_000,
        1_000,
    ));
    assert!(r.energy_drift_rel < 1e-10, "{}", r.energy_drift_rel);
    assert!(r.momentum_drift < 1e-12, "{}", r.momentum_drift);
    assert_eq!(r.solver_failures, 0);
}

#[test]
fn no_overlaps_for_elongated_and_flat_ellipsoids_up_to_phi_half() {
    for x0 in [0.5, 2.0] {
        for phi in [0.3, 0.5] {
            let r = go(&scene(
                ShapeKind::Ellipsoid,
                128,
                phi,
                x0,
                Neighbours::Nnl,
                1_500,
                500,
            ));
            assert_eq!(r.solver_failures, 0, "x0 {x0} phi {phi}");
            assert!(r.pressure_z > 1.0, "x0 {x0} phi {phi}: Z {}", r.pressure_z);
        }
    }
    // X0 = 5 needs N = 256 for the box to exceed twice the bounding diameter; φ = 0.5 takes
    // half a minute to prepare, so CI runs φ = 0.3 and `validation_x0_5_phi_half` does 0.5.
    let r = go(&scene(
        ShapeKind::Ellipsoid,
        256,
        0.3,
        5.0,
        Neighbours::Nnl,
        1_500,
        500,
    ));
    assert_eq!(r.solver_failures, 0);
    // The fluid, not the FCC crystal a compressed lattice stays in above freezing (Z ≈ 9.5 there).
    let r = go(&scene(
        ShapeKind::Sphere,
        256,
        0.5,
        1.0,
        Neighbours::Ll,
        // 1,000 collisions of equilibration left seed 1 at Z = 13.39 ± 0.16: not yet forgotten
        // the compression.
        50_000,
        5_000,
    ));
    let fluid = kolafa(0.5);
    assert!(
        (r.pressure_z - fluid).abs() < 0.03 * fluid,
        "phi 0.5: Z {} vs the fluid's {fluid}",
        r.pressure_z
    );
}

/// Run with `--ignored`: X0 = 5 at φ = 0.5.
#[test]
#[ignore]
fn validation_x0_5_phi_half() {
    let r = go(&scene(
        ShapeKind::Ellipsoid,
        256,
        0.5,
        5.0,
        Neighbours::Nnl,
        5_000,
        1_000,
    ));
    println!(
        "X0 = 5, phi = 0.5: Z = {:.3} ± {:.3}, overlaps {}, solver failures {}, tau_c = {:.1} us",
        r.pressure_z, r.pressure_z_err, r.overlaps, r.solver_failures, r.tau_c_us
    );
    assert_eq!(r.solver_failures, 0);
}

#[test]
fn hard_spheres_match_kolafa_within_two_percent() {
    for (phi, z) in [(0.30, 3.9843), (0.40, 6.9457), (0.45, 9.4029)] {
        let r = go(&scene(
            ShapeKind::Sphere,
            256,
            phi,
            1.0,
            Neighbours::Ll,
            100_000,
            20_000,
        ));
        assert!(
            (r.pressure_z / z - 1.0).abs() < 0.02,
            "phi {phi}: Z {} ± {} vs Kolafa {z}",
            r.pressure_z,
            r.pressure_z_err
        );
        assert!(
            (r.temperature - 1.0).abs() < 1e-9,
            "spheres keep kT = 1: {}",
            r.temperature
        );
        // Second check: the Enskog mean free time t = 1/[4ρσ²g(σ)√(πkT/m)], g(σ) = (Z−1)/(4η).
        let rho = phi / (std::f64::consts::PI / 6.0);
        let g = (z - 1.0) / (4.0 * phi);
        let t_mft = 1.0 / (4.0 * rho * g * std::f64::consts::PI.sqrt());
        assert!(
            (r.mean_free_time / t_mft - 1.0).abs() < 0.03,
            "phi {phi}: mean free time {} vs {t_mft}",
            r.mean_free_time
        );
    }
}

/// Two measurements agree if they differ by less than 4 combined standard errors.
fn agree(a: &RunReport, b: &RunReport) -> bool {
    (a.pressure_z - b.pressure_z).abs()
        < 4.0 * (a.pressure_z_err.powi(2) + b.pressure_z_err.powi(2)).sqrt()
}

#[test]
fn ellipsoid_with_unit_aspect_ratio_is_a_sphere() {
    let s = go(&scene(
        ShapeKind::Sphere,
        256,
        0.40,
        1.0,
        Neighbours::Ll,
        60_000,
        5_000,
    ));
    let e = go(&scene(
        ShapeKind::Ellipsoid,
        256,
        0.40,
        1.0,
        Neighbours::Ll,
        30_000,
        3_000,
    ));
    assert!(
        agree(&s, &e),
        "sphere Z {} ± {}, X0 = 1 ellipsoid Z {} ± {}",
        s.pressure_z,
        s.pressure_z_err,
        e.pressure_z,
        e.pressure_z_err
    );
    assert!(
        (e.pressure_z / kolafa(0.40) - 1.0).abs() < 0.03,
        "X0 = 1: Z {}",
        e.pressure_z
    );
    assert_eq!(e.solver_failures, 0);
}

/// A dilute start of rigid bodies ends with Monte Carlo sweeps at the target, not relaxing
/// collisions (`edmd::init::DILUTE_SWEEPS`), and is in equilibrium from its first collision:
/// X0 = 1 ellipsoids at φ = 0.25 measured from the start, with no equilibration, give Kolafa's
/// Z.
#[test]
fn a_dilute_start_of_rigid_bodies_is_in_equilibrium_from_its_first_collision() {
    let phi = 0.25;
    assert!(phi <= edmd::init::DILUTE_PHI);
    let r = go(&scene(
        ShapeKind::Ellipsoid,
        1000,
        phi,
        1.0,
        Neighbours::Nnl,
        100_000,
        0,
    ));
    let dev = r.pressure_z / kolafa(phi) - 1.0;
    assert!(
        dev.abs() < 0.01 && dev.abs() < 4.0 * r.pressure_z_err / r.pressure_z,
        "Z {} ± {} against Kolafa's {}",
        r.pressure_z,
        r.pressure_z_err,
        kolafa(phi)
    );
    assert_eq!(r.solver_failures, 0);
}

#[test]
fn linked_cells_and_neighbour_lists_give_the_same_pressure() {
    let ll = go(&scene(
        ShapeKind::Sphere,
        256,
        0.40,
        1.0,
        Neighbours::Ll,
        60_000,
        5_000,
    ));
    let nnl = go(&scene(
        ShapeKind::Sphere,
        256,
        0.40,
        1.0,
        Neighbours::Nnl,
        60_000,
        5_000,
    ));
    assert!(
        agree(&ll, &nnl),
        "spheres: LL {} ± {}, NNL {} ± {}",
        ll.pressure_z,
        ll.pressure_z_err,
        nnl.pressure_z,
        nnl.pressure_z_err
    );
    let ll = go(&scene(
        ShapeKind::Ellipsoid,
        256,
        0.30,
        2.0,
        Neighbours::Ll,
        6_000,
        1_000,
    ));
    let nnl = go(&scene(
        ShapeKind::Ellipsoid,
        256,
        0.30,
        2.0,
        Neighbours::Nnl,
        6_000,
        1_000,
    ));
    assert!(
        agree(&ll, &nnl),
        "X0 = 2: LL {} ± {}, NNL {} ± {}",
        ll.pressure_z,
        ll.pressure_z_err,
        nnl.pressure_z,
        nnl.pressure_z_err
    );
}

/// A rigid body's search for a partner ends at the partner's own next event (on NNL, never after
/// it leaves its box), which leaves the contact to whichever of the two is predicted last: a
/// contact both left to the other would let the bodies pass into each other. Every pair of a
/// dense run is checked by the independent Perram–Wertheim scale every 250 collisions, on both
/// neighbour methods.
#[test]
fn no_pair_ever_overlaps_in_a_dense_ellipsoid_run() {
    for nb in [Neighbours::Nnl, Neighbours::Ll] {
        let s = scene(ShapeKind::Ellipsoid, 128, 0.5, 2.0, nb, 20_000, 0);
        let [a, b, c] = s.semi_axes();
        let e = Ellipsoid::new(a, b, c);
        let (mut frames, mut closest) = (0, f64::INFINITY);
        let mut on_frame = |f: &edmd::Frame| {
            frames += 1;
            for (i, p) in f.bodies.iter().enumerate() {
                for q in &f.bodies[i + 1..] {
                    let r = min_image(q.r - p.r, f.box_length);
                    closest = closest.min(contact_scale(&e, &p.rot, &e, &q.rot, &r));
                }
            }
            Ok(())
        };
        let hooks = Hooks {
            frame_every: FrameEvery::Collisions(250),
            on_frame: Some(&mut on_frame),
            ..Hooks::default()
        };
        let (r, _) = run_with_hooks(&s, &mut |_| {}, hooks).expect("run");
        assert_eq!((r.overlaps, r.solver_failures), (0, 0), "{nb:?}");
        assert_eq!(frames, 81, "{nb:?}");
        assert!(
            closest > 1.0 - 1e-9,
            "{nb:?}: contact scale {closest} at a frame"
        );
    }
}

#[test]
fn same_seed_same_trajectory() {
    let s = scene(
        ShapeKind::Ellipsoid,
        64,
        0.3,
        2.0,
        Neighbours::Nnl,
        500,
        100,
    );
    let (a, b) = (go(&s), go(&s));
    assert_eq!((a.pressure_z, a.sim_time), (b.pressure_z, b.sim_time));
}

/// The validation figures (N = 500, 10^6 collisions, seeds 0–7): run with
/// `cargo test --release -p edmd --test physics -- --ignored --nocapture`.
///
/// One run scatters by about 0.15 % (the standard deviation of eight seeds at φ 0.45), so the
/// mean of eight is held to 0.15 %, nearly three standard errors. The mean of four was held to
/// it, two standard errors, until seeds 0–3 of the spheres' start numbered along the Z curve
/// read −0.166 % with LL at φ 0.3, where 28 seeds read −0.076 ± 0.021 % (the start before it:
/// −0.033 ± 0.016 %, the same 28). With Z's temperature over 3N degrees of freedom, not the
/// 3N − 3 that the zero net momentum leaves, the means of eight seeds sat 0.08–0.20 % above
/// Kolafa's, 0.18–0.20 % in two of the six cases (MEASUREMENTS.md, "Z with the measured
/// temperature of 3N − 3 degrees of freedom").
#[test]
#[ignore]
fn validation_kolafa_large() {
    for nb in [Neighbours::Ll, Neighbours::Nnl] {
        for (phi, z) in [(0.30, 3.9843), (0.40, 6.9457), (0.45, 9.4029)] {
            let mut devs = Vec::new();
            for seed in 0..8 {
                // Lists with the spheres' default Δ_NNL (0.25), the one users get.
                let mut s = scene(ShapeKind::Sphere, 500, phi, 1.0, nb, 1_000_000, 100_000);
                s.seed = seed;
                let r = go(&s);
                let dev = r.pressure_z / z - 1.0;
                println!(
                    "{nb:?} phi {phi} seed {seed}: Z = {:.4} ± {:.4} (Kolafa {z}), deviation {:+.3} %, tau_c = {:.3} us",
                    r.pressure_z,
                    r.pressure_z_err,
                    dev * 100.0,
                    r.tau_c_us
                );
                assert!(dev.abs() < 0.005);
                devs.push(dev);
            }
            let mean = devs.iter().sum::<f64>() / devs.len() as f64;
            println!("{nb:?} phi {phi}: mean deviation {:+.3} %", mean * 100.0);
            assert!(
                mean.abs() < 0.0015,
                "{nb:?} phi {phi}: mean deviation {mean:e}"
            );
        }
    }
}

/// Few spheres read the temperature they start at, k_B T = 1, over the 3N − 3 degrees of freedom
/// their zero net momentum leaves, and their Z sits a little below the equation of state of the
/// infinite system (seeds 0–7, 10⁵ collisions: N 16 −0.3 to −0.9 %, N 64 −0.2 to −0.8 %). Over 3N
/// degrees of freedom the temperature read 1 − 1/N and Z − 1 was a factor N/(N − 1) high: Z was
/// 4.14–4.16 at N 16 and 4.00–4.03 at N 64 (0.3–4.4 % above Kolafa’s 3.984).
#[test]
fn few_spheres_keep_their_temperature_and_sit_just_below_the_equation_of_state() {
    let fluid = kolafa(0.3);
    for n in [16, 64] {
        let mut zs = Vec::new();
        for seed in 0..3 {
            let mut s = scene(
                ShapeKind::Sphere,
                n,
                0.3,
                1.0,
                Neighbours::Ll,
                100_000,
                10_000,
            );
            s.seed = seed;
            let r = go(&s);
            assert!(
                (r.temperature - 1.0).abs() < 1e-9,
                "N {n}: kT {} over 3N − 3 degrees of freedom",
                r.temperature
            );
            zs.push(r.pressure_z);
        }
        let mean = zs.iter().sum::<f64>() / zs.len() as f64;
        assert!(
            mean < fluid && mean > 0.985 * fluid,
            "N {n}: Z {mean} ({zs:?}) against Kolafa's {fluid}"
        );
    }
}
