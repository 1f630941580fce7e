//! How often each algorithm's verdict differs from the exact one ([`crate::exact`]), on a
//! checking set of its own, drawn and judged outside the timed loops so that the timed sets keep
//! the papers' distribution and the timing is untouched.
//!
//! The checking set has two halves, reported apart:
//! - *bulk*: drawn exactly as the timed sets are (the spherocuboid of the point's acceptance,
//!   uniform rotation), from an independent seed: how often a verdict is wrong in the papers'
//!   benchmark;
//! - *shell*: sphere centres at a relative gap δ from the touching position, R(1 + δ) from the
//!   cuboid along the outward normal of the nearest feature, with |δ| log-uniform over
//!   [[`SHELL_MIN_GAP`], [`SHELL_MAX_GAP`]] (one decade per bin, [`SHELL_DECADES`]) and either
//!   sign. The nearest feature comes from a point drawn in the same spherocuboid, so faces, edges
//!   and corners are hit in proportion to the volume of the spherocuboid next to them; the frame
//!   is rotated uniformly. δ is the gap asked for before rounding to the precision: an f32
//!   configuration sits up to about 10⁻⁷ R from it, and its verdict is judged exactly on the
//!   rounded values, as the kernels see them.

use std::cmp::Ordering;

use serde::{Deserialize, Serialize};

use crate::algorithm::{Algorithm, Precision};
use crate::batch::{Batch, verdict, verdict_words};
use crate::config::{Configuration, Cuboid, axes_from_quaternion};
use crate::exact::margin_sign;
use crate::kernels::Kernels;
use crate::protocol::PointSpec;
use crate::real::Real;
use crate::rng::{Rng, derive_seed};
use crate::sampler::{Spherocuboid, generate, shoemake_quaternion};

pub const SHELL_MIN_GAP: f64 = 1e-16;
pub const SHELL_MAX_GAP: f64 = 1e-3;
/// Decades of |δ| in the shell, bin k holding [`SHELL_MAX_GAP`]·10⁻ᵏ⁻¹ ≤ |δ| < [`SHELL_MAX_GAP`]·10⁻ᵏ.
pub const SHELL_DECADES: usize = 13;

/// What the checking set found at one point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VerdictCheck {
    /// Configurations judged in each half (those the exact evaluation refused are left out).
    pub bulk: u64,
    pub shell: u64,
    /// The range of the shell's relative gaps |δ| (decade k of `shell_by_decade` holds
    /// `shell_max_gap`·10⁻ᵏ⁻¹ ≤ |δ| < `shell_max_gap`·10⁻ᵏ).
    pub shell_min_gap: f64,
    pub shell_max_gap: f64,
    /// Configurations per decade of the shell, as [`AlgorithmVerdicts::shell_wrong_by_decade`].
    pub shell_by_decade: Vec<u64>,
    /// Configurations the exact evaluation refused (values out of its range): judged by nobody.
    pub undecided: u64,
    pub algorithms: Vec<AlgorithmVerdicts>,
}

/// Verdicts of one algorithm that differ from the exact one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlgorithmVerdicts {
    pub algorithm: Algorithm,
    pub bulk_wrong: u64,
    pub shell_wrong: u64,
    pub shell_wrong_by_decade: Vec<u64>,
}

/// Checks `configurations` configurations of `spec`'s point (half bulk, half shell) drawn from
/// `seed`, for every algorithm of the spec, in the spec's precision.
pub fn check_verdicts(spec: &PointSpec, configurations: u64, seed: u64) -> VerdictCheck {
    match spec.precision {
        Precision::F32 => check::<f32>(spec, configurations, seed),
        Precision::F64 => check::<f64>(spec, configurations, seed),
    }
}

/// The checking set of `spec`'s point: `configurations` configurations drawn from `seed`, half
/// bulk, half shell (see the module's doc), in `T`.
pub struct CheckingSet<T> {
    pub bulk: Vec<Configuration<T>>,
    pub shell: Vec<Configuration<T>>,
    /// The decade of each shell configuration's gap.
    pub decades: Vec<usize>,
}

impl<T: Real> CheckingSet<T> {
    pub fn draw(spec: &PointSpec, configurations: u64, seed: u64) -> Self {
        let volume = spec.spherocuboid();
        let bulk_len = (configurations / 2) as usize;
        let bulk = generate::<T>(&volume, bulk_len, derive_seed(seed, 0));
        let bulk: Vec<Configuration<T>> = (0..bulk_len).map(|i| bulk.get(i)).collect();
        let mut rng = Rng::new(derive_seed(seed, 1));
        let (shell, decades) = (bulk_len..configurations as usize)
            .map(|_| {
                let (cfg, decade) = shell_configuration(&volume, spec.r_star, &mut rng);
                (convert(&cfg), decade)
            })
            .unzip();
        Self {
            bulk,
            shell,
            decades,
        }
    }
}

fn check<T: Kernels>(spec: &PointSpec, configurations: u64, seed: u64) -> VerdictCheck {
    let cuboid = Cuboid::<T>::from_reduced(spec.l_star, spec.w_star);
    let radius = T::from_f64(spec.r_star);
    let CheckingSet {
        bulk,
        shell,
        decades,
    } = CheckingSet::<T>::draw(spec, configurations, seed);
    let mut report = VerdictCheck {
        bulk: 0,
        shell: 0,
        shell_min_gap: SHELL_MIN_GAP,
        shell_max_gap: SHELL_MAX_GAP,
        shell_by_decade: vec![0; SHELL_DECADES],
        undecided: 0,
        algorithms: spec
            .algorithms
            .iter()
            .map(|&algorithm| AlgorithmVerdicts {
                algorithm,
                bulk_wrong: 0,
                shell_wrong: 0,
                shell_wrong_by_decade: vec![0; SHELL_DECADES],
            })
            .collect(),
    };
    for wrong in wrong_verdicts(&bulk, &spec.algorithms, &cuboid, radius) {
        let Some(wrong) = wrong else {
            report.undecided += 1;
            continue;
        };
        report.bulk += 1;
        for (k, a) in report.algorithms.iter_mut().enumerate() {
            a.bulk_wrong += (wrong >> k) & 1;
        }
    }
    let shell_wrong = wrong_verdicts(&shell, &spec.algorithms, &cuboid, radius);
    for (wrong, &decade) in shell_wrong.into_iter().zip(&decades) {
        let Some(wrong) = wrong else {
            report.undecided += 1;
            continue;
        };
        report.shell += 1;
        report.shell_by_decade[decade] += 1;
        for (k, a) in report.algorithms.iter_mut().enumerate() {
            a.shell_wrong += (wrong >> k) & 1;
            a.shell_wrong_by_decade[decade] += (wrong >> k) & 1;
        }
    }
    report
}

/// For each configuration, which of `algorithms` (bit k for the k-th) gave a verdict other than
/// the exact one; `None` where the exact evaluation refused the values. The batched kernel runs
/// on all of them at once, as it is timed.
pub fn wrong_verdicts<T: Kernels>(
    cfgs: &[Configuration<T>],
    algorithms: &[Algorithm],
    cuboid: &Cuboid<T>,
    radius: T,
) -> Vec<Option<u64>> {
    assert!(algorithms.len() <= 64, "one bit per algorithm");
    let batched = algorithms.contains(&Algorithm::OcsiBatch).then(|| {
        let batch = Batch::from_configurations(cfgs);
        let mut bits = vec![0u64; verdict_words(cfgs.len())];
        T::ocsi_batch(batch.view(), cuboid, radius, &mut bits);
        bits
    });
    cfgs.iter()
        .enumerate()
        .map(|(i, cfg)| {
            let exact = margin_sign(cfg, cuboid, radius).ok()? != Ordering::Greater;
            let mut wrong = 0u64;
            for (k, &algorithm) in algorithms.iter().enumerate() {
                let got = match (&batched, algorithm) {
                    (Some(bits), Algorithm::OcsiBatch) => verdict(bits, i),
                    _ => crate::overlaps(algorithm, cfg, cuboid, radius),
                };
                wrong |= u64::from(got != exact) << k;
            }
            Some(wrong)
        })
        .collect()
}

fn convert<T: Real>(cfg: &Configuration<f64>) -> Configuration<T> {
    Configuration {
        r_sc: cfg.r_sc.map(T::from_f64),
        axes: cfg.axes.map(|e| e.map(T::from_f64)),
    }
}

/// One shell configuration (see the module's doc) and the decade of its gap.
pub fn shell_configuration(
    volume: &Spherocuboid,
    radius: f64,
    rng: &mut Rng,
) -> (Configuration<f64>, usize) {
    let (foot, normal) = loop {
        let p = volume.sample_point(rng);
        let foot: [f64; 3] = std::array::from_fn(|i| p[i].clamp(-volume.half[i], volume.half[i]));
        let out: [f64; 3] = std::array::from_fn(|i| p[i] - foot[i]);
        let norm = out.iter().map(|x| x * x).sum::<f64>().sqrt();
        // A point inside the cuboid has no nearest feature outside: draw again.
        if norm > 0.0 {
            break (foot, out.map(|x| x / norm));
        }
    };
    let (lo, hi) = (SHELL_MIN_GAP.log10(), SHELL_MAX_GAP.log10());
    let exponent = lo + (hi - lo) * rng.uniform();
    let decade = ((hi - exponent).floor() as usize).min(SHELL_DECADES - 1);
    let gap = 10f64.powf(exponent) * if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
    let p: [f64; 3] = std::array::from_fn(|i| foot[i] + normal[i] * radius * (1.0 + gap));
    let axes = axes_from_quaternion(shoemake_quaternion(rng));
    let r_sc = std::array::from_fn(|k| p[0] * axes[0][k] + p[1] * axes[1][k] + p[2] * axes[2][k]);
    (Configuration { r_sc, axes }, decade)
}

#[cfg(test)]
mod tests {
    use super::*;

    const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    /// Off an edge of the cuboid (half extents 0.5, 1, 1; R = 1): l_L = R exactly and
    /// l_T = 2⁻²⁰, so d² = 1 + 2⁻⁴⁰ > R² and the sphere is apart. In f32, 1 + 2⁻⁴⁰ rounds to
    /// 1 = R² whatever the order of the sum, so every kernel says "overlap"; f64 keeps the 2⁻⁴⁰.
    /// The frame is each of the axis permutations, so each axis plays each role.
    fn edge_cases<T: Real>() -> (Vec<Configuration<T>>, Cuboid<T>) {
        let half = [0.5, 1.0, 1.0];
        let mut cfgs = Vec::new();
        for perm in [
            [0, 1, 2],
            [1, 2, 0],
            [2, 0, 1],
            [0, 2, 1],
            [1, 0, 2],
            [2, 1, 0],
        ] {
            let axes: [[f64; 3]; 3] = std::array::from_fn(|i| IDENTITY[perm[i]]);
            for signs in [[1.0, 1.0], [-1.0, 1.0], [1.0, -1.0]] {
                let p = [signs[0] * (0.5 + 2f64.powi(-20)), signs[1] * 2.0, 0.0];
                let r_sc = std::array::from_fn(|k| (0..3).map(|i| p[i] * axes[i][k]).sum());
                cfgs.push(convert(&Configuration { r_sc, axes }));
            }
        }
        (
            cfgs,
            Cuboid {
                half: half.map(T::from_f64),
            },
        )
    }

    #[test]
    fn f32_is_wrong_and_f64_right_just_off_an_edge() {
        let (cfgs, cuboid) = edge_cases::<f32>();
        for (cfg, wrong) in cfgs
            .iter()
            .zip(wrong_verdicts(&cfgs, &Algorithm::ALL, &cuboid, 1.0))
        {
            assert_eq!(
                margin_sign(cfg, &cuboid, 1.0),
                Ok(Ordering::Greater),
                "apart"
            );
            assert_eq!(
                wrong,
                Some((1 << Algorithm::ALL.len()) - 1),
                "every f32 kernel says overlap at {cfg:?}"
            );
        }
        let (cfgs, cuboid) = edge_cases::<f64>();
        assert!(
            wrong_verdicts(&cfgs, &Algorithm::ALL, &cuboid, 1.0)
                .iter()
                .all(|w| *w == Some(0)),
            "f64 resolves 2⁻⁴⁰"
        );
    }

    #[test]
    fn a_point_check_counts_the_shell_by_decade_and_f64_beats_f32() {
        let spec = |precision| PointSpec {
            l_star: 3.0,
            w_star: 2.0,
            r_star: 0.5,
            acceptance: 0.4,
            configurations: 1000,
            repeats: 1,
            precision,
            algorithms: Algorithm::ALL.to_vec(),
            seed: 0,
            ci_target: None,
            time_cap_s: None,
            verdict_check: Some(20_000),
            visit: None,
            plugins: Vec::new(),
        };
        let f32_check = check_verdicts(&spec(Precision::F32), 20_000, 7);
        let f64_check = check_verdicts(&spec(Precision::F64), 20_000, 7);
        for check in [&f32_check, &f64_check] {
            assert_eq!(check.bulk + check.shell + check.undecided, 20_000);
            assert_eq!(check.shell_by_decade.iter().sum::<u64>(), check.shell);
            // Log-uniform over 13 decades: about 770 of 10,000 in each.
            assert!(
                check
                    .shell_by_decade
                    .iter()
                    .all(|&n| (600..950).contains(&n))
            );
            for a in &check.algorithms {
                assert_eq!(a.shell_wrong_by_decade.iter().sum::<u64>(), a.shell_wrong);
                // Gaps of 10⁻⁴ to 10⁻³ R are far beyond either precision's rounding.
                assert_eq!(a.shell_wrong_by_decade[0], 0, "{a:?}");
            }
        }
        for (a32, a64) in f32_check.algorithms.iter().zip(&f64_check.algorithms) {
            assert!(
                a32.shell_wrong > 10 * a64.shell_wrong.max(1),
                "{a32:?} {a64:?}"
            );
            // f64 is right down to gaps of 10⁻¹³ R.
            assert!(
                a64.shell_wrong_by_decade[..10].iter().all(|&n| n == 0),
                "{a64:?}"
            );
        }
    }
}
