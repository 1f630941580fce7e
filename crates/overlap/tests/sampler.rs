//! The sampler delivers the acceptance it promises, reproducibly.

use overlap::batch::verdict_words;
use overlap::config::ConfigurationView;
use overlap::protocol::count_overlaps;
use overlap::sampler::{Spherocuboid, generate, sampling_radius, steiner_volume};
use overlap::{Algorithm, Cuboid};

/// Acceptance measured by OCSI over 10^6 configurations: its standard error is
/// √(p(1−p)/N) ≤ 5·10⁻⁴, so ±0.003 is a 6σ bound that a biased sampler still fails.
#[test]
fn measured_acceptance_matches_the_target() {
    let n = 1_000_000;
    for &(l, w, r) in &[
        (1.0, 1.0, 0.05),
        (4.0, 8.0, 5.0),
        (20.0, 1.0, 0.5),
        (20.0, 20.0, 5.0),
        (1.0, 20.0, 0.05),
    ] {
        for &target in &[0.1, 0.4, 0.9] {
            let half = [0.5, l / 2.0, w / 2.0];
            let volume = Spherocuboid::for_acceptance(half, r, target);
            let batch = generate::<f64>(&volume, n, 7);
            let mut bits = vec![0u64; verdict_words(n)];
            let overlaps = count_overlaps(
                Algorithm::OcsiBatch,
                batch.view(),
                &Cuboid { half },
                r,
                &mut bits,
            );
            let measured = 1.0 - overlaps as f64 / n as f64;
            assert!(
                (measured - target).abs() <= 0.003,
                "L*={l} W*={w} R*={r}: acceptance {measured} for target {target}"
            );
        }
    }
}

#[test]
fn sampling_radius_solves_the_steiner_equation() {
    for &(edges, r, acc) in &[
        ([1.0, 4.0, 8.0], 5.0, 0.4),
        ([1.0, 20.0, 20.0], 0.05, 0.9),
        ([1.0, 1.0, 1.0], 0.5, 0.1),
    ] {
        let rho = sampling_radius(edges, r, acc);
        assert!(rho > r);
        let achieved = 1.0 - steiner_volume(edges, r) / steiner_volume(edges, rho);
        assert!(
            (achieved - acc).abs() < 1e-12,
            "{edges:?} R={r}: {achieved} vs {acc}"
        );
    }
    // The Steiner formula against the ball (edges → 0) and the box (x = 0).
    assert!((steiner_volume([0.0; 3], 2.0) - 4.0 / 3.0 * std::f64::consts::PI * 8.0).abs() < 1e-12);
    assert_eq!(steiner_volume([2.0, 3.0, 4.0], 0.0), 24.0);
}

#[test]
fn generation_is_reproducible_and_independent_of_thread_count() {
    let volume = Spherocuboid::for_acceptance([0.5, 2.0, 4.0], 5.0, 0.4);
    let n = 100_003;
    let in_pool = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| generate::<f32>(&volume, n, 42))
    };
    let (one, two) = (in_pool(1), in_pool(2));
    assert_eq!(one.values(), two.values());
    assert_ne!(
        one.values(),
        generate::<f32>(&volume, n, 43).values(),
        "another seed, the same set"
    );
    let mut reused = generate::<f32>(&volume, n, 43);
    overlap::sampler::regenerate(&mut reused, &volume, 42);
    assert_eq!(
        reused.values(),
        one.values(),
        "regenerating in place differs from a fresh set"
    );
}

/// Every generated point lies in the spherocuboid and the rotation is orthonormal.
#[test]
fn configurations_lie_in_the_sampling_volume() {
    let half = [0.5, 1.5, 10.0];
    let volume = Spherocuboid::for_acceptance(half, 0.5, 0.4);
    let batch = generate::<f64>(&volume, 10_000, 1);
    for i in 0..batch.len() {
        let c = batch.get(i);
        for (a, ea) in c.axes.iter().enumerate() {
            for (b, eb) in c.axes.iter().enumerate() {
                let dot: f64 = (0..3).map(|k| ea[k] * eb[k]).sum();
                assert!((dot - if a == b { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        let d2: f64 = (0..3)
            .map(|k| (c.projection(k).abs() - half[k]).max(0.0).powi(2))
            .sum();
        assert!(d2.sqrt() <= volume.rho * (1.0 + 1e-12));
    }
}
