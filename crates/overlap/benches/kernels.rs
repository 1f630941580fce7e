//! Criterion benches of the overlap kernels over one pre-generated set (the papers' Sec. 3
//! point L* = 4, W* = 8, R* = 5 at 40 % acceptance), beside two references: the plain read of
//! the same arrays (the memory floor) and parry3d's ball–cuboid `intersection_test` (a
//! general-purpose collision library doing the same job).
//!
//! `cargo bench -p overlap --bench kernels`. The set is 200,000 configurations (9.6 MB in f32),
//! so these figures are cache-resident; `sweep bench overlap` measures the DRAM-bound protocol.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use overlap::batch::verdict_words;
use overlap::protocol::{PointSpec, count_overlaps, stream_read};
use overlap::sampler::generate;
use overlap::{Algorithm, Batch, Cuboid, Kernels, Precision};
use parry3d::math::{Matrix, Pose, Rotation, Vector};
use parry3d::query::intersection_test;
use parry3d::shape::{Ball, Cuboid as ParryCuboid};

const N: usize = 200_000;

fn point() -> PointSpec {
    PointSpec {
        l_star: 4.0,
        w_star: 8.0,
        r_star: 5.0,
        acceptance: 0.4,
        configurations: N as u64,
        repeats: 1,
        precision: Precision::F32,
        algorithms: Algorithm::ALL.to_vec(),
        seed: 1,
        ci_target: None,
        time_cap_s: None,
        verdict_check: None,
        visit: None,
        plugins: Vec::new(),
    }
}

fn bench_precision<T: Kernels>(c: &mut Criterion) {
    let spec = point();
    let batch: Batch<T> = generate(&spec.spherocuboid(), N, spec.seed);
    let cuboid = Cuboid::<T>::from_reduced(spec.l_star, spec.w_star);
    let radius = T::from_f64(spec.r_star);
    let mut verdicts = vec![0u64; verdict_words(N)];
    let mut group = c.benchmark_group(format!("overlap_{}", T::NAME));
    group.throughput(Throughput::Elements(N as u64));
    group.bench_function("stream_read", |b| {
        b.iter(|| stream_read(black_box(batch.view())))
    });
    for algorithm in Algorithm::ALL {
        group.bench_function(algorithm.name(), |b| {
            b.iter(|| {
                count_overlaps(
                    algorithm,
                    black_box(batch.view()),
                    &cuboid,
                    radius,
                    &mut verdicts,
                )
            })
        });
    }
    group.finish();
}

/// parry3d on the same configurations: the cuboid posed by its axes, the ball at r_SC.
fn bench_parry(c: &mut Criterion) {
    let spec = point();
    let batch: Batch<f32> = generate(&spec.spherocuboid(), N, spec.seed);
    let half = Cuboid::<f32>::from_reduced(spec.l_star, spec.w_star).half;
    let cuboid = ParryCuboid::new(Vector::new(half[0], half[1], half[2]));
    let ball = Ball::new(spec.r_star as f32);
    let poses: Vec<(Pose, Pose)> = (0..N)
        .map(|i| {
            let cfg = batch.get(i);
            let [t, l, w] = cfg.axes.map(|e| Vector::new(e[0], e[1], e[2]));
            let rotation = Rotation::from_mat3(&Matrix::from_cols(t, l, w));
            let [x, y, z] = cfg.r_sc;
            (
                Pose::from_rotation(rotation),
                Pose::from_translation(Vector::new(x, y, z)),
            )
        })
        .collect();
    let count = || {
        poses
            .iter()
            .filter(|(at_cuboid, at_ball)| {
                intersection_test(at_cuboid, &cuboid, at_ball, &ball)
                    .is_ok_and(|hit| hit.intersecting)
            })
            .count()
    };
    // The peer must be timed on the same geometry: its verdicts agree with OCSI's up to rounding.
    let ours = count_overlaps(
        Algorithm::Ocsi,
        batch.view(),
        &Cuboid { half },
        spec.r_star as f32,
        &mut [],
    ) as usize;
    assert!(
        count().abs_diff(ours) <= N / 10_000,
        "parry3d counts {} overlaps, OCSI {ours}",
        count()
    );
    let mut group = c.benchmark_group("overlap_f32");
    group.throughput(Throughput::Elements(N as u64));
    group.bench_function("parry3d_intersection_test", |b| b.iter(count));
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_precision::<f32>(c);
    bench_precision::<f64>(c);
    bench_parry(c);
}

criterion_group! {
    name = kernels;
    config = Criterion::default().sample_size(10).warm_up_time(std::time::Duration::from_millis(500)).measurement_time(std::time::Duration::from_secs(2));
    targets = benches
}
criterion_main!(kernels);
