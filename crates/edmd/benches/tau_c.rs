//! τ_c, the wall time per collision (Eq. 69), as criterion sees it: one iteration = one collision.
//! Preparing and equilibrating the configuration is untimed (the engine times its measured run).
//!
//! `cargo bench -p edmd --bench tau_c` (targets: spheres ≤ 1 µs, ellipsoids X0 = 2 NNL ≤ 25 µs, and
//! spheres ≥ 10× faster than the same spheres as X0 = 1 ellipsoids).

use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use edmd::{Neighbours, Scene, ShapeKind, run};

/// `at_least`: collisions measured per sample, chosen so that every sample runs about 0.1 s or
/// more, whatever the path: a burst of load on the shared machine then moves a sample by a few
/// per cent, not the tens of per cent it costs a run of a millisecond; and the start-up transient
/// is averaged away.
fn tau_c(c: &mut Criterion, name: &str, base: Scene, at_least: u64) {
    let mut g = c.benchmark_group("tau_c");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(100))
        .measurement_time(Duration::from_secs(5));
    g.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let mut s = base.clone();
            s.collisions = iters.max(at_least);
            let r = run(&s, &mut |_| {}).expect("run");
            assert_eq!(r.overlaps, 0);
            Duration::from_secs_f64(r.tau_c_us * 1e-6 * iters as f64)
        })
    });
    g.finish();
}

fn benches(c: &mut Criterion) {
    // Spheres default to lists with Δ_NNL = 0.25 (`scene::default_delta_nnl`); cells are named.
    let mut s = Scene::new(ShapeKind::Sphere, 256, 0.45);
    s.equilibrate = 20_000;
    tau_c(c, "sphere_n256_phi0.45_nnl", s.clone(), 250_000);
    s.neighbours = Neighbours::Ll;
    tau_c(c, "sphere_n256_phi0.45_ll", s, 250_000);

    // The same hard spheres through the general rigid-body path: what the analytic path saves.
    let mut s = Scene::new(ShapeKind::Ellipsoid, 256, 0.45);
    s.x0 = 1.0;
    s.equilibrate = 2_000;
    tau_c(c, "ellipsoid_x0_1_phi0.45_n256_ll", s, 25_000);

    for nb in [Neighbours::Nnl, Neighbours::Ll] {
        let mut s = Scene::new(ShapeKind::Ellipsoid, 256, 0.5);
        s.x0 = 2.0;
        s.eps_d = 1e-5;
        // The fastest shell in a scan of 0.03-0.35 (0.06 is the paper's 0.15 smallest semi-axes).
        s.delta_nnl = 0.08;
        s.neighbours = nb;
        s.equilibrate = 2_000;
        let name = format!(
            "ellipsoid_x0_2_phi0.5_n256_{}",
            if nb == Neighbours::Nnl { "nnl" } else { "ll" }
        );
        tau_c(c, &name, s, 5_000);
    }
}

criterion_group!(group, benches);
criterion_main!(group);
