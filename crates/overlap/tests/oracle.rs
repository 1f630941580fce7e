//! Every algorithm, in both precisions, against an exact oracle: Eq. 2 evaluated in rational
//! arithmetic on the very values the kernel sees (floats are dyadic rationals, so the oracle's
//! only approximation is none). A kernel may disagree with the oracle only inside the rounding
//! band of [`rounding_band`] (`overlap::exact`), and that is asserted, not assumed. The library's
//! own exact evaluation (`overlap::exact`, floating-point expansions) is checked against this
//! oracle on the same cases.

mod common;

use common::exact_margin;
use num_traits::{Signed, ToPrimitive};
use overlap::batch::{Batch, verdict, verdict_words};
use overlap::config::axes_from_quaternion;
use overlap::exact::{ExactError, overlaps_exactly, rounding_band};
use overlap::kernels::batch::Isa;
use overlap::{Algorithm, Configuration, Cuboid, Kernels, Real, min_distance, overlaps};
use proptest::prelude::*;

/// The verdicts of every algorithm for `cfgs`, the batched kernel on all of them at once.
fn check_all<T: Kernels>(
    cfgs: &[Configuration<T>],
    cuboid: &Cuboid<T>,
    radius: T,
) -> Result<(), TestCaseError> {
    let batch = Batch::from_configurations(cfgs);
    let isas = Isa::available();
    let mut bits = vec![vec![0u64; verdict_words(cfgs.len())]; isas.len()];
    for (isa, bits) in isas.iter().zip(&mut bits) {
        T::ocsi_batch_on(*isa, batch.view(), cuboid, radius, bits);
    }
    for (i, cfg) in cfgs.iter().enumerate() {
        let margin = exact_margin(cfg, cuboid, radius);
        let truth = !margin.is_positive();
        let band = rounding_band(cfg, cuboid, radius);
        let margin_f = margin.to_f64().unwrap_or(f64::INFINITY);
        match overlaps_exactly(cfg, cuboid, radius) {
            Ok(verdict) => prop_assert_eq!(
                verdict,
                truth,
                "overlap::exact at d²−R² = {:e}; {:?}",
                margin_f,
                cfg
            ),
            Err(ExactError::OutOfRange { value }) => {
                prop_assert!(
                    value.abs() < 2f64.powi(-100) || value.abs() > 2f64.powi(100),
                    "refused {value:e}"
                )
            }
        }
        let per_pair = Algorithm::ALL
            .into_iter()
            .filter(|&a| a != Algorithm::OcsiBatch)
            .map(|a| (a.name(), overlaps(a, cfg, cuboid, radius)));
        let batched = isas
            .iter()
            .zip(&bits)
            .map(|(isa, bits)| (isa.name(), verdict(bits, i)));
        for (name, got) in per_pair.chain(batched) {
            prop_assert!(
                got == truth || margin_f.abs() <= band,
                "{name} {}: verdict {got}, exact d²−R² = {margin_f:e} outside the rounding band {band:e}; {cfg:?} {cuboid:?} R={radius:?}",
                T::NAME
            );
        }
        // |√a − √b| ≤ √|a − b|: the band of d² (taken at R = 0) bounds d, plus the final rounding.
        let d = min_distance(cfg, cuboid).to_f64();
        let d_exact = exact_margin(cfg, cuboid, T::ZERO)
            .to_f64()
            .unwrap_or(f64::INFINITY)
            .sqrt();
        let tolerance =
            rounding_band(cfg, cuboid, T::ZERO).sqrt() + 2.0 * T::UNIT_ROUNDOFF * d_exact;
        prop_assert!(
            (d - d_exact).abs() <= tolerance,
            "min_distance {d} vs exact {d_exact} (tolerance {tolerance:e})"
        );
    }
    Ok(())
}

#[derive(Clone, Copy, Debug)]
enum Feature {
    Face,
    Edge,
    Corner,
    Inside,
    Anywhere,
}

/// A sphere centre in the cuboid frame at distance `scale`·R from the chosen feature.
fn place(
    feature: Feature,
    half: [f64; 3],
    radius: f64,
    scale: f64,
    dir: [f64; 3],
    signs: [f64; 3],
) -> [f64; 3] {
    let n = |v: [f64; 3]| {
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-300);
        v.map(|x| x / len)
    };
    let d = scale * radius;
    match feature {
        // Off the face +T (or −T): the foot point anywhere on that face.
        Feature::Face => [signs[0] * (half[0] + d), dir[1] * half[1], dir[2] * half[2]],
        // Off the edge along W: the outward normal in the T–L plane.
        Feature::Edge => {
            let m = n([dir[0].abs() + 1e-3, dir[1].abs() + 1e-3, 0.0]);
            [
                signs[0] * (half[0] + d * m[0]),
                signs[1] * (half[1] + d * m[1]),
                dir[2] * half[2],
            ]
        }
        Feature::Corner => {
            let m = n(dir.map(|x| x.abs() + 1e-3));
            std::array::from_fn(|i| signs[i] * (half[i] + d * m[i]))
        }
        Feature::Inside => std::array::from_fn(|i| dir[i] * half[i]),
        Feature::Anywhere => std::array::from_fn(|i| dir[i] * (half[i] + 2.0 * radius)),
    }
}

fn configuration<T: Real>(p: [f64; 3], axes: [[f64; 3]; 3]) -> Configuration<T> {
    let r_sc = std::array::from_fn(|k| p[0] * axes[0][k] + p[1] * axes[1][k] + p[2] * axes[2][k]);
    Configuration {
        r_sc: r_sc.map(T::from_f64),
        axes: axes.map(|e| e.map(T::from_f64)),
    }
}

fn feature() -> impl Strategy<Value = Feature> {
    prop_oneof![
        Just(Feature::Face),
        Just(Feature::Edge),
        Just(Feature::Corner),
        Just(Feature::Inside),
        Just(Feature::Anywhere)
    ]
}

/// Distance scale relative to R: exactly touching, 1 ± 1e-12, or far from the boundary.
fn scale() -> impl Strategy<Value = f64> {
    prop_oneof![Just(1.0), Just(1.0 - 1e-12), Just(1.0 + 1e-12), 0.0..3.0f64]
}

fn orientation() -> impl Strategy<Value = [[f64; 3]; 3]> {
    let aligned = Just([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let random = (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
        .prop_filter("non-degenerate quaternion", |q| {
            q.0 * q.0 + q.1 * q.1 + q.2 * q.2 + q.3 * q.3 > 1e-3
        })
        .prop_map(|(w, x, y, z)| {
            let n = (w * w + x * x + y * y + z * z).sqrt();
            axes_from_quaternion([w / n, x / n, y / n, z / n])
        });
    prop_oneof![aligned, random]
}

fn unit_cube() -> impl Strategy<Value = [f64; 3]> {
    [-1.0..=1.0f64, -1.0..=1.0f64, -1.0..=1.0f64]
}

fn signs() -> impl Strategy<Value = [f64; 3]> {
    [
        prop_oneof![Just(-1.0), Just(1.0)],
        prop_oneof![Just(-1.0), Just(1.0)],
        prop_oneof![Just(-1.0), Just(1.0)],
    ]
}

/// (half extents, R): T = 1 as in the papers (L*, W* up to 100, R* from 0.01 to 100), and also
/// thin plates and needles where c_T is not the smallest.
fn shape() -> impl Strategy<Value = ([f64; 3], f64)> {
    let log_uniform = |lo: f64, hi: f64| (lo.ln()..hi.ln()).prop_map(f64::exp);
    let reduced = (
        log_uniform(1.0, 100.0),
        log_uniform(1.0, 100.0),
        log_uniform(0.01, 100.0),
    )
        .prop_map(|(l, w, r)| ([0.5, l / 2.0, w / 2.0], r));
    let general = (
        log_uniform(1e-3, 100.0),
        log_uniform(1e-3, 100.0),
        log_uniform(1e-3, 100.0),
        log_uniform(0.01, 100.0),
    )
        .prop_map(|(t, l, w, r)| ([t, l, w], r));
    prop_oneof![reduced, general]
}

fn run_case<T: Kernels>(
    cases: &[(Feature, f64, [f64; 3], [f64; 3])],
    half: [f64; 3],
    radius: f64,
    axes: [[f64; 3]; 3],
) -> Result<(), TestCaseError> {
    let cfgs: Vec<Configuration<T>> = cases
        .iter()
        .map(|&(feature, scale, dir, signs)| {
            configuration::<T>(place(feature, half, radius, scale, dir, signs), axes)
        })
        .collect();
    check_all(
        &cfgs,
        &Cuboid {
            half: half.map(T::from_f64),
        },
        T::from_f64(radius),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Up to 40 configurations of one shape and orientation per case, so the batched kernel also
    /// sees full blocks, partial blocks and more than one verdict word.
    #[test]
    fn every_algorithm_agrees_with_the_exact_oracle(
        (half, radius) in shape(),
        axes in orientation(),
        cases in prop::collection::vec((feature(), scale(), unit_cube(), signs()), 1..40),
    ) {
        run_case::<f32>(&cases, half, radius, axes)?;
        run_case::<f64>(&cases, half, radius, axes)?;
    }
}

/// In f64 a margin of 1e-12·R² lies far outside the rounding band for these shapes: there the
/// band is not an excuse and every algorithm must give the exact verdict.
#[test]
fn f64_resolves_a_relative_gap_of_1e_12() {
    let axes = axes_from_quaternion([0.8, 0.2, -0.4, 0.4]);
    let (half, radius) = ([0.5, 2.0, 4.0], 5.0);
    for feature in [Feature::Face, Feature::Edge, Feature::Corner] {
        for (scale, expected) in [(1.0 - 1e-12, true), (1.0 + 1e-12, false)] {
            let cfg = configuration::<f64>(
                place(
                    feature,
                    half,
                    radius,
                    scale,
                    [0.3, -0.2, 0.7],
                    [1.0, -1.0, 1.0],
                ),
                axes,
            );
            let cuboid = Cuboid { half };
            let margin = exact_margin(&cfg, &cuboid, radius);
            assert_eq!(
                !margin.is_positive(),
                expected,
                "{feature:?} {scale}: the oracle itself"
            );
            assert!(
                margin.to_f64().unwrap().abs() > rounding_band(&cfg, &cuboid, radius),
                "{feature:?}: inside the band"
            );
            for algorithm in Algorithm::ALL {
                assert_eq!(
                    overlaps(algorithm, &cfg, &cuboid, radius),
                    expected,
                    "{algorithm} at {feature:?} × {scale}"
                );
            }
        }
    }
}

/// The band is a bound, not a blanket: in f32 it must still be a small fraction of R².
#[test]
fn the_rounding_band_is_tight() {
    let axes = axes_from_quaternion([0.8, 0.2, -0.4, 0.4]);
    let cfg = configuration::<f32>(
        place(
            Feature::Corner,
            [0.5, 2.0, 4.0],
            5.0,
            1.0,
            [0.3, 0.2, 0.7],
            [1.0; 3],
        ),
        axes,
    );
    let band = rounding_band(
        &cfg,
        &Cuboid {
            half: [0.5f32, 2.0, 4.0],
        },
        5.0f32,
    );
    assert!(
        band < 1e-4 * 25.0,
        "band {band} is not small against R² = 25"
    );
}
