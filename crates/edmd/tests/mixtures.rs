//! Sphere mixtures: the Boublík–Mansoori–Carnahan–Starling–Leland equation of state, the
//! independent overlap audit, conservation with unequal masses, and the bookkeeping per pair.

use edmd::scene::Species;
use edmd::{Neighbours, RunReport, Scene, ShapeKind, run};

/// Z of an additive hard-sphere mixture, Mansoori et al., J. Chem. Phys. 54, 1523 (1971), from
/// the moments ξ_k = Σ x_i σ_i^k of the diameters and the packing fraction η:
/// Z = 1/(1−η) + 3 ξ1 ξ2 η / (ξ3 (1−η)²) + ξ2³ η² (3−η) / (ξ3² (1−η)³).
fn bmcsl(eta: f64, xi: [f64; 4]) -> f64 {
    let [_, x1, x2, x3] = xi;
    let e = 1.0 - eta;
    1.0 / e
        + 3.0 * x1 * x2 * eta / (x3 * e * e)
        + x2.powi(3) * eta * eta * (3.0 - eta) / (x3 * x3 * e.powi(3))
}

/// ξ_k of a binary mixture with fractions `x` and diameters `d`.
fn moments(x: [f64; 2], d: [f64; 2]) -> [f64; 4] {
    [0, 1, 2, 3].map(|k| x[0] * d[0].powi(k) + x[1] * d[1].powi(k))
}

/// Carnahan–Starling, the one-species limit.
fn carnahan_starling(eta: f64) -> f64 {
    (1.0 + eta + eta * eta - eta.powi(3)) / (1.0 - eta).powi(3)
}

#[test]
fn bmcsl_reduces_to_carnahan_starling_for_one_size() {
    // Z_CS(0.3) = 1.363 / 0.343.
    assert!((carnahan_starling(0.3) - 3.973_761).abs() < 1e-6);
    for eta in [0.1, 0.3, 0.45] {
        for (x, d) in [([1.0, 0.0], [1.0, 2.0]), ([0.5, 0.5], [1.3, 1.3])] {
            let z = bmcsl(eta, moments(x, d));
            assert!(
                (z - carnahan_starling(eta)).abs() < 1e-12,
                "{eta} {x:?} {d:?}: {z}"
            );
        }
    }
    // Unequal sizes at the same η: less pressure than one size (more room per volume).
    assert!(bmcsl(0.4, moments([0.5, 0.5], [1.0, 2.0])) < carnahan_starling(0.4));
}

fn binary(n: usize, phi: f64, ratio: f64, nb: Neighbours, collisions: u64) -> Scene {
    let sp = |d: f64| Species {
        shape: ShapeKind::Sphere,
        diameter: d,
        fraction: 0.5,
        polydispersity: 0.0,
        ..Default::default()
    };
    let mut s = Scene::new(ShapeKind::Sphere, n, phi);
    s.neighbours = nb;
    if nb == Neighbours::Ll {
        s.delta_nnl = edmd::default_delta_nnl(ShapeKind::Sphere, nb);
    }
    s.species = Some(vec![sp(1.0), sp(ratio)]);
    s.collisions = collisions;
    s.equilibrate = collisions / 5;
    s.validate().expect("valid");
    s
}

fn go(s: &Scene) -> RunReport {
    let r = run(s, &mut |_| {}).expect("run");
    assert_eq!(r.overlaps, 0, "overlaps: {r:?}");
    assert!(r.energy_drift_rel <= 1e-9, "drift {}", r.energy_drift_rel);
    assert!(r.momentum_drift < 1e-9, "momentum {}", r.momentum_drift);
    r
}

/// Z within the statistical error of BMCSL (4 standard errors of the 10 blocks, plus 0.6 % for
/// the equation itself, which like its one-size limit Carnahan–Starling falls short of the
/// simulated Z by up to 0.5 % at φ = 0.45: CS 9.354 against Kolafa's 9.403) at N = 500 over
/// 1.5·10⁵ collisions, on both neighbour methods;
/// the parts of Z per pair sum to Z − 1, the pair counts to the collisions.
#[test]
fn binary_mixtures_follow_bmcsl() {
    for (ratio, phi, nb) in [
        (1.4, 0.4, Neighbours::Nnl),
        (2.0, 0.3, Neighbours::Ll),
        (2.0, 0.45, Neighbours::Nnl),
    ] {
        let r = go(&binary(500, phi, ratio, nb, 150_000));
        let z = bmcsl(phi, moments([0.5, 0.5], [1.0, ratio]));
        eprintln!(
            "ratio {ratio} phi {phi} {nb:?}: Z {:.4} ± {:.4} BMCSL {z:.4} tau_c {:.3} us drift {:.1e} {:?}",
            r.pressure_z, r.pressure_z_err, r.tau_c_us, r.energy_drift_rel, r.species
        );
        let err = 4.0 * r.pressure_z_err + 0.006 * z;
        assert!(
            (r.pressure_z - z).abs() < err,
            "ratio {ratio} phi {phi} {nb:?}: Z {} ± {} vs BMCSL {z}",
            r.pressure_z,
            r.pressure_z_err
        );
        let sp = r.species.as_ref().expect("a mixture reports its species");
        assert_eq!(sp.count, vec![250, 250]);
        assert!(sp.pairs.iter().all(|p| p.distance_calls.is_none()));
        assert!((sp.mean_diameter[1] - ratio).abs() < 1e-12);
        assert_eq!(sp.pairs.len(), 3);
        assert_eq!(
            sp.pairs.iter().map(|p| p.collisions).sum::<u64>(),
            r.collisions
        );
        let parts: f64 = sp.pairs.iter().map(|p| p.pressure_z_part).sum();
        assert!(
            (parts - (r.pressure_z - 1.0)).abs() < 1e-9 * r.pressure_z,
            "{parts} vs {}",
            r.pressure_z
        );
        // Big spheres collide more often than small ones.
        assert!(sp.pairs[2].collisions > sp.pairs[0].collisions, "{sp:?}");
        assert!((r.temperature - 1.0).abs() < 0.02, "T {}", r.temperature);
    }
}

/// Spheres of one size run the one-species path bit for bit as before species existed: the
/// collision sequence's fingerprint (its last blocks), Z and the energy drift, pinned on the
/// code before this change (commit c6de570), for a scene without species and for one whose only
/// species has one size (which is the same scene, another id). Pinned again when the spheres'
/// initial state changed (issue 29: random sequential addition instead of a melted lattice, five
/// relaxing collisions per particle instead of ten), which changes every sphere trajectory from
/// its first collision; the store of the bodies and the lists' room did not change them. Pinned
/// again when that compression lost its Monte Carlo sweeps (steps of 10 % and pushes alone): Z
/// 9.341 / 9.394 → 9.457 / 9.554 here (LL / NNL, N = 256, 2·10⁴ collisions; Kolafa 9.403). And
/// again when the compression's last (partial) step pushed pairs past contact by what it took,
/// not by a full step, and pushes stopped on stalling instead of after 50 passes: 9.426 / 9.345.
/// And again when the Monte Carlo's queries took a candidate's separation from its cell's image
/// shift instead of rounding a nearest image (its last bits): 9.327 / 9.345. And again when the
/// start's kinetic energy became 3(N − 1)/2 and Z's temperature that of 3N − 3 degrees of freedom
/// (velocities scaled by √(1 − 1/N), which changes their bits): 9.417 / 9.340. And again when the
/// added spheres were numbered along a Z-order curve before the compression (its pushes go in
/// that order): 9.476 / 9.364. And again when the first step of that compression became 20 %
/// (two steps from φ 0.25 to 0.45 instead of three): 9.379 / 9.468. And again when its pushes
/// went 1.25 steps past contact and the relaxation took 3 collisions per particle, not 5 (fewer
/// blocks in the sequence): 9.491 / 9.542.
#[test]
fn one_size_spheres_run_the_pinned_one_species_path() {
    for (nb, tail, z_bits, drift_bits, len) in [
        (
            Neighbours::Ll,
            "a86b9193e6e5c62c7c780c323e1884a4db0a257c6042a713e9c782ac7d93d4b3a9601357b7f6af1065b3a61ddbdf26c9",
            0x4022fb27b2cde3cfu64,
            0x3d123ce7923ce781u64,
            2840,
        ),
        (
            Neighbours::Nnl,
            "8e97caa6c9b8e63f47228ce5c23a6100f7c31cc8d154c429cba5e3b0a50af8cedc3e1c10b5df8ed7df41d9c73ffe1097",
            0x402315b4cf1f4512u64,
            0x3d10bb6610bb6603u64,
            2840,
        ),
    ] {
        let mut s = Scene::new(ShapeKind::Sphere, 256, 0.45);
        s.neighbours = nb;
        s.delta_nnl = edmd::default_delta_nnl(ShapeKind::Sphere, nb);
        s.collisions = 20_000;
        s.equilibrate = 2_000;
        let one = Species {
            shape: ShapeKind::Sphere,
            diameter: 1.0,
            fraction: 1.0,
            polydispersity: 0.0,
            ..Default::default()
        };
        let with_species = Scene {
            species: Some(vec![one]),
            ..s.clone()
        };
        for scene in [s, with_species] {
            let r = run(&scene, &mut |_| {}).expect("run");
            let hex = r.sequence.to_hex();
            assert_eq!(hex.len(), len, "{nb:?}");
            assert!(
                hex.ends_with(tail),
                "{nb:?}: the collision sequence changed"
            );
            assert_eq!(r.pressure_z.to_bits(), z_bits, "{nb:?}");
            assert_eq!(r.energy_drift_rel.to_bits(), drift_bits, "{nb:?}");
            assert!(r.species.is_none());
        }
    }
}

/// Size-polydisperse spheres (one species, δ = 12 %): Z within the errors of BMCSL evaluated on
/// the moments of the diameters the run drew (`mixture_sizes`, the same draw from the same
/// seed), 0 overlaps, the drift bound, and the initial state at the requested φ = Σ π σ³/6 / V.
#[test]
fn polydisperse_spheres_follow_bmcsl_on_their_own_moments() {
    let mut s = Scene::new(ShapeKind::Sphere, 500, 0.4);
    s.species = Some(vec![Species {
        shape: ShapeKind::Sphere,
        diameter: 1.0,
        fraction: 1.0,
        polydispersity: 0.12,
        ..Default::default()
    }]);
    s.collisions = 150_000;
    s.equilibrate = 30_000;
    assert!(s.is_mixture());
    let (sizes, species) = edmd::run::mixture_sizes(&s, &mut edmd::rng::Rng::new(s.seed));
    assert!(species.iter().all(|&k| k == 0));
    let n = sizes.len() as f64;
    let xi = [0, 1, 2, 3].map(|k| sizes.iter().map(|d| d.powi(k)).sum::<f64>() / n);
    // The spread drawn: 12 % truncated at 3σ (0.986 of it), within sampling error at N = 500.
    let spread = (xi[2] - xi[1] * xi[1]).sqrt() / xi[1];
    assert!((spread - 0.986 * 0.12).abs() < 0.01, "spread {spread}");
    assert!(sizes.iter().all(|&d| (d - 1.0).abs() <= 3.0 * 0.12 + 1e-12));
    let r = go(&s);
    let volume: f64 = sizes
        .iter()
        .map(|d| std::f64::consts::PI / 6.0 * d.powi(3))
        .sum();
    assert!(
        (volume / r.box_length.powi(3) - 0.4).abs() < 1e-12,
        "φ of the box"
    );
    let z = bmcsl(0.4, xi);
    eprintln!(
        "polydisperse 12 %: Z {:.4} ± {:.4} BMCSL {z:.4}",
        r.pressure_z, r.pressure_z_err
    );
    assert!(
        (r.pressure_z - z).abs() < 4.0 * r.pressure_z_err + 0.006 * z,
        "Z {} vs {z}",
        r.pressure_z
    );
    let sp = r.species.expect("species");
    assert_eq!(sp.pairs.len(), 1);
    assert_eq!(sp.pairs[0].collisions, r.collisions);
}

/// A scene of the given species (NNL, Δ_NNL 0.15, `collisions` after a fifth of them).
fn mixture(n: usize, phi: f64, species: Vec<Species>, collisions: u64) -> Scene {
    let shape = species.iter().map(|s| s.shape).max().expect("species");
    let mut s = Scene::new(shape, n, phi);
    s.exponents = None;
    s.neighbours = Neighbours::Nnl;
    s.delta_nnl = 0.15;
    s.species = Some(species);
    s.collisions = collisions;
    s.equilibrate = collisions / 5;
    s.validate().expect("valid");
    s
}

fn ellipsoid(x0: f64, diameter: f64, fraction: f64) -> Species {
    Species {
        shape: ShapeKind::Ellipsoid,
        x0,
        diameter,
        fraction,
        ..Default::default()
    }
}

/// Spheres simulated as rigid bodies, σ2/σ1 = 1.4, x = 0.5: ellipsoid species of X0 = 1 (the
/// rigid mixture's model — a shape, a mass and an inertia per body, Eq. 41 with unequal masses
/// — with the analytic contact time of two spheres) and of X0 = 1.001 (the general contact
/// search between two shapes of different sizes) give the BMCSL equation of state, with the
/// bounds of [`binary_mixtures_follow_bmcsl`].
#[test]
fn spheres_as_rigid_bodies_follow_bmcsl() {
    let z = bmcsl(0.4, moments([0.5, 0.5], [1.0, 1.4]));
    for x0 in [1.0, 1.001] {
        let s = mixture(
            256,
            0.4,
            vec![ellipsoid(x0, 1.0, 0.5), ellipsoid(x0, 1.4, 0.5)],
            60_000,
        );
        let r = go(&s);
        eprintln!(
            "rigid spheres 1.4, X0 {x0}: Z {:.4} ± {:.4} BMCSL {z:.4} tau_c {:.2} us calls {:.2}",
            r.pressure_z, r.pressure_z_err, r.tau_c_us, r.distance_calls_per_collision
        );
        assert_eq!(r.solver_failures, 0);
        assert!(
            (r.pressure_z - z).abs() < 4.0 * r.pressure_z_err + 0.006 * z,
            "X0 {x0}: Z {} ± {} vs BMCSL {z}",
            r.pressure_z,
            r.pressure_z_err
        );
        // Spheres take no solver; the others do.
        assert_eq!(r.distance_calls_per_collision == 0.0, x0 == 1.0);
        let sp = r.species.expect("species");
        assert!((sp.mean_diameter[1] - 1.4).abs() < 1e-12);
        assert!(sp.pairs[2].collisions > sp.pairs[0].collisions, "{sp:?}");
    }
}

/// Two species of one ellipsoid are the one-species scene under another name: the mixture path
/// gives its Z within the combined errors (4 of them).
#[test]
fn two_species_of_one_ellipsoid_give_the_pure_systems_z() {
    let mixed = mixture(
        256,
        0.4,
        vec![ellipsoid(2.0, 1.0, 0.5), ellipsoid(2.0, 1.0, 0.5)],
        40_000,
    );
    let pure = Scene {
        species: None,
        x0: 2.0,
        ..mixed.clone()
    };
    let (m, p) = (go(&mixed), go(&pure));
    let err = (m.pressure_z_err.powi(2) + p.pressure_z_err.powi(2)).sqrt();
    eprintln!(
        "X0 2 as two species: Z {:.4} ± {:.4}, pure {:.4} ± {:.4}",
        m.pressure_z, m.pressure_z_err, p.pressure_z, p.pressure_z_err
    );
    assert!((m.pressure_z - p.pressure_z).abs() < 4.0 * err);
    assert!(p.species.is_none() && m.species.is_some());
}

/// Rigid mixtures — prolate with oblate ellipsoids (X0 = 2 and 0.5), spheres with ellipsoids,
/// spheres with superquadrics, size-polydisperse ellipsoids — run without an overlap in the independent audit, without a solver
/// failure, with energy and momentum conserved; every body keeps its species' shape and size,
/// and the parts of Z per pair sum to Z − 1.
#[test]
fn rigid_mixtures_conserve_and_never_overlap() {
    let sphere = |diameter: f64| Species {
        diameter,
        fraction: 0.5,
        ..Default::default()
    };
    let cube = Species {
        shape: ShapeKind::Superquadric,
        x0: 2.0,
        exponents: Some([2.0, 2.0, 4.0]),
        fraction: 0.5,
        ..Default::default()
    };
    for (species, n, collisions) in [
        (
            vec![ellipsoid(0.5, 1.0, 0.5), ellipsoid(2.0, 1.0, 0.5)],
            256,
            20_000,
        ),
        (vec![sphere(1.0), ellipsoid(2.0, 1.3, 0.5)], 256, 20_000),
        (vec![sphere(1.2), cube], 128, 4_000),
        (
            vec![Species {
                polydispersity: 0.1,
                ..ellipsoid(2.0, 1.0, 1.0)
            }],
            128,
            5_000,
        ),
    ] {
        let s = mixture(n, 0.4, species.clone(), collisions);
        let (r, state) = edmd::run_with_state(&s, &mut |_| {}).expect("run");
        eprintln!(
            "{:?}: Z {:.4} ± {:.4} tau_c {:.2} us drift {:.1e} calls {:.2}",
            species.iter().map(|s| (s.shape, s.x0)).collect::<Vec<_>>(),
            r.pressure_z,
            r.pressure_z_err,
            r.tau_c_us,
            r.energy_drift_rel,
            r.distance_calls_per_collision
        );
        assert_eq!(r.overlaps, 0);
        assert_eq!(r.solver_failures, 0);
        assert!(r.energy_drift_rel <= 1e-9, "drift {}", r.energy_drift_rel);
        assert!(r.momentum_drift < 1e-9, "momentum {}", r.momentum_drift);
        let sp = r.species.as_ref().expect("species");
        let kinds = species.len();
        assert_eq!(sp.count, vec![n / kinds; kinds]);
        assert_eq!(
            sp.pairs.iter().map(|p| p.collisions).sum::<u64>(),
            r.collisions
        );
        let parts: f64 = sp.pairs.iter().map(|p| p.pressure_z_part).sum();
        assert!((parts - (r.pressure_z - 1.0)).abs() < 1e-9 * r.pressure_z);
        // Every distance evaluation of the measured run is some pair's.
        let calls: u64 = sp.pairs.iter().filter_map(|p| p.distance_calls).sum();
        let total = r.distance_calls_per_collision * r.collisions as f64;
        assert!((calls as f64 - total).abs() < 0.5, "{calls} vs {total}");
        // Two spheres meet without a solver: their pair alone takes no distance.
        let spheres = species
            .iter()
            .filter(|s| s.shape == ShapeKind::Sphere)
            .count();
        assert_eq!(
            sp.pairs
                .iter()
                .filter(|p| p.distance_calls == Some(0))
                .count(),
            spheres,
            "{sp:?}"
        );
        // Each body is its species' shape at its size: the volumes add up to φ V.
        let volume: f64 = state
            .particles
            .iter()
            .map(|p| {
                let abc: f64 = p.semi_axes.iter().product();
                match p.shape {
                    "superquadric" => {
                        let q = edmd::superquadric::Superquadric::new(p.semi_axes, p.exponents)
                            .expect("superquadric");
                        q.volume()
                    }
                    _ => 4.0 / 3.0 * std::f64::consts::PI * abc,
                }
            })
            .sum();
        assert!(
            (volume / r.box_length.powi(3) - 0.4).abs() < 1e-9,
            "φ {}",
            volume / r.box_length.powi(3)
        );
    }
}
