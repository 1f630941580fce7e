//! The estimator and the stopping rule on synthetic timings: blocks drawn from a known
//! distribution (true cost μ, Gaussian jitter), with the noise of a shared machine injected —
//! blocks that lost a time slice (slower by a random factor), whole sets slowed by a phase of
//! the machine, a machine whose speed drifts over consecutive sets, and a CPU hog that slows
//! most blocks by a varying amount. Noise that only adds leaves the fastest blocks alone, so the
//! truth the 5th percentile must find is the 5th percentile of the clean blocks,
//! μ·(1 + z₀.₀₅·jitter). What the protocol measures on real hardware is checked by the
//! experiments in the README; here the truth is known.

use overlap::estimate::{
    Goal, JACKKNIFE_GROUPS, QUANTILE, Statistic, Stop, estimate, estimate_quantile, estimate_with,
    mean_interval, median, order_interval, quantile, student_t975,
};
use overlap::rng::Rng;
use proptest::prelude::*;

/// A standard normal variate (Box–Muller).
fn normal(rng: &mut Rng) -> f64 {
    let (u1, u2) = (1.0 - rng.uniform(), rng.uniform());
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Noise injected into synthetic sets.
#[derive(Clone, Copy, Debug)]
struct Noise {
    /// Relative standard deviation of a clean block.
    jitter: f64,
    /// Fraction of blocks that lost a time slice.
    outliers: f64,
    /// A slowed block takes 1 + U(0, 1)·(factor − 1) times as long.
    factor: f64,
    /// Relative standard deviation of a whole set's cost (a set of configurations cheaper than
    /// the next: symmetric).
    set_shift: f64,
    /// Fraction of sets measured during a slow phase of the machine, each slowed by 5–50 %.
    slow_sets: f64,
}

const QUIET: Noise = Noise {
    jitter: 0.01,
    outliers: 0.0,
    factor: 1.0,
    set_shift: 0.0,
    slow_sets: 0.0,
};

/// z of the 5th percentile of a standard normal.
const Z_QUANTILE: f64 = -1.644_853_626_951_472_2;

/// The estimand under `noise`: the 5th percentile of the clean blocks (of every set, when sets
/// differ symmetrically).
fn clean_quantile(mu: f64, noise: Noise) -> f64 {
    mu * (1.0 + Z_QUANTILE * noise.jitter.hypot(noise.set_shift))
}

fn synthetic_sets(
    rng: &mut Rng,
    mu: f64,
    noise: Noise,
    repeats: usize,
    blocks: usize,
) -> Vec<Vec<f64>> {
    (0..repeats)
        .map(|_| {
            let mut shift = 1.0 + noise.set_shift * normal(rng);
            if rng.uniform() < noise.slow_sets {
                shift *= 1.05 + 0.45 * rng.uniform();
            }
            (0..blocks)
                .map(|_| {
                    let clean = mu * shift * (1.0 + noise.jitter * normal(rng));
                    if rng.uniform() < noise.outliers {
                        clean * (1.0 + rng.uniform() * (noise.factor - 1.0))
                    } else {
                        clean
                    }
                })
                .collect()
        })
        .collect()
}

#[test]
fn order_statistics_and_quantiles() {
    assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
    assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    assert!(median(&[]).is_nan());
    assert_eq!(quantile(&[0.0, 10.0], 0.25), 2.5);
    assert_eq!(quantile(&[5.0, 1.0, 3.0], 1.0), 5.0);
    assert_eq!(QUANTILE, 0.05);
    let hundred: Vec<f64> = (1..=100).map(f64::from).collect();
    // The 5th percentile of 1..=100 interpolates x_(5) and x_(6); its 95 % interval by binomial
    // ranks (B ~ Bin(100, 0.05): P(B ≤ 0) = 0.006 but P(B ≤ 1) = 0.037; P(B ≥ 11) = 0.011 but
    // P(B ≥ 10) = 0.028) is [x_(1), x_(11)].
    let e = estimate(std::slice::from_ref(&hundred)).expect("samples");
    assert!((e.value - 5.95).abs() < 1e-12, "{}", e.value);
    assert_eq!(order_interval(&hundred, QUANTILE), (1.0, 11.0));
    // The same rule at the median gives the textbook [x_(40), x_(61)].
    assert_eq!(order_interval(&hundred, 0.5), (40.0, 61.0));
    assert_eq!(
        estimate_quantile(std::slice::from_ref(&hundred), 0.5).map(|e| e.value),
        Some(50.5)
    );
    // Ten samples: even x_(1) is below the 5th percentile with probability 0.40 only, so the
    // low side is the smallest sample; the high side is x_(3) (P(B ≥ 3) = 0.012).
    let ten: Vec<f64> = (1..=10).map(f64::from).collect();
    assert_eq!(order_interval(&ten, QUANTILE), (1.0, 3.0));
    let five: Vec<f64> = (1..=5).map(f64::from).collect();
    assert_eq!(order_interval(&five, 0.5), (1.0, 5.0));
    assert!(order_interval(&[], 0.5).0.is_nan());
    // The interval of an estimate holds the order interval of all its blocks.
    let e = estimate(&[ten.clone(), ten]).expect("samples");
    assert!(e.lo <= 1.0 && e.hi >= 3.0, "{e:?}");
    assert_eq!(estimate(&[vec![], vec![]]), None);
}

/// The between-set part: identical sets add nothing to the interval (it is the order interval
/// of the blocks), and a set that holds the fastest blocks moves the estimate when its group is
/// left out, so it widens it. The mean and the median behave alike.
#[test]
fn the_jackknife_measures_what_the_sets_change() {
    let mut rng = Rng::new(8);
    let set: Vec<f64> = (0..64)
        .map(|_| 30.0 * (1.0 + 0.01 * normal(&mut rng)))
        .collect();
    let same = vec![set.clone(); JACKKNIFE_GROUPS];
    let e = estimate(&same).expect("samples");
    assert_eq!((e.lo, e.hi), order_interval(&same.concat(), QUANTILE));
    let mut mixed = same.clone();
    mixed[2] = set.iter().map(|x| x - 1.0).collect();
    for statistic in Statistic::ALL {
        let same = estimate_with(statistic, &same).expect("samples");
        let mixed = estimate_with(statistic, &mixed).expect("samples");
        assert!(
            mixed.hi - mixed.lo > 5.0 * (same.hi - same.lo).max(1e-3),
            "{statistic}: {mixed:?} vs {same:?}"
        );
        assert_eq!((mixed.samples, mixed.repeats), (64 * JACKKNIFE_GROUPS, 5));
    }
    // Identical sets: the mean's leave-a-group-out values are all equal.
    let mean = estimate_with(Statistic::Mean, &same).expect("samples");
    assert!((mean.hi - mean.lo) < 1e-9, "{mean:?}");
    assert!((mean.value - set.iter().sum::<f64>() / 64.0).abs() < 1e-9);
}

/// Fewer sets than groups: the groups are runs of consecutive blocks, so a slow stretch in the
/// middle of a single set widens the interval of the mean as a slow set would.
#[test]
fn one_set_is_cut_into_runs_of_blocks() {
    let mut rng = Rng::new(9);
    let mut set: Vec<f64> = (0..100)
        .map(|_| 30.0 * (1.0 + 0.01 * normal(&mut rng)))
        .collect();
    let steady = estimate_with(Statistic::Mean, std::slice::from_ref(&set)).expect("samples");
    assert!(steady.relative_half_width() < 0.01, "{steady:?}");
    for block in &mut set[40..60] {
        *block *= 1.3;
    }
    let slowed = estimate_with(Statistic::Mean, std::slice::from_ref(&set)).expect("samples");
    assert!(
        slowed.relative_half_width() > 3.0 * steady.relative_half_width(),
        "{slowed:?} vs {steady:?}"
    );
    assert_eq!((slowed.samples, slowed.repeats), (100, 1));
}

#[test]
fn statistics_by_name() {
    for statistic in Statistic::ALL {
        assert_eq!(statistic.name().parse::<Statistic>(), Ok(statistic));
        assert_eq!(statistic.to_string(), statistic.name());
    }
    assert_eq!(Statistic::FOR_TABLES, Statistic::Mean);
    assert_eq!(Statistic::FOR_SURFACES, Statistic::P5);
    let error = "p10".parse::<Statistic>().expect_err("not a statistic");
    assert!(
        error.contains("p10") && error.contains("mean, median or p5"),
        "{error}"
    );
    // The three on one set of 1..=100: mean 50.5, median 50.5, 5th percentile 5.95.
    let hundred: Vec<f64> = (1..=100).map(f64::from).collect();
    let value = |s| {
        estimate_with(s, std::slice::from_ref(&hundred))
            .expect("samples")
            .value
    };
    assert_eq!(value(Statistic::Mean), 50.5);
    assert_eq!(value(Statistic::Median), 50.5);
    assert!((value(Statistic::P5) - 5.95).abs() < 1e-12);
}

#[test]
fn student_quantiles() {
    assert_eq!(student_t975(1), 12.706);
    assert_eq!(student_t975(30), 2.042);
    // Tabulated values beyond the table: t(40) = 2.021, t(120) = 1.980.
    assert!((student_t975(40) - 2.021).abs() < 1e-3);
    assert!((student_t975(120) - 1.980).abs() < 1e-3);
    assert!((student_t975(1_000_000) - 1.960).abs() < 1e-3);
}

#[test]
fn the_mean_of_old_results_keeps_its_value() {
    let e = mean_interval(&[10.0, 11.0, 12.0]).expect("values");
    assert_eq!(e.value, 11.0);
    // sd = 1, t(2) = 4.303: half-width 4.303/√3.
    assert!((e.hi - 11.0 - 4.303 / 3f64.sqrt()).abs() < 1e-12);
    let one = mean_interval(&[7.0]).expect("a value");
    assert_eq!(one.value, 7.0);
    assert!(one.lo.is_nan() && one.relative_half_width().is_nan());
}

/// A CPU hog beside the measurement: 60 % of the blocks are slowed, each by 5–40 %. The median
/// of the blocks lands among the slowed ones, and where depends on how busy the hog was; the
/// 5th percentile is the clean blocks' 12.5th (0.05 / 0.4) and stays within a jitter of the
/// truth.
#[test]
fn the_low_quantile_ignores_a_hog_that_moves_the_median() {
    let mut rng = Rng::new(11);
    let mu = 30.0;
    let sets: Vec<Vec<f64>> = (0..3)
        .map(|_| {
            (0..128)
                .map(|_| {
                    let clean = mu * (1.0 + 0.01 * normal(&mut rng));
                    if rng.uniform() < 0.6 {
                        clean * (1.05 + 0.35 * rng.uniform())
                    } else {
                        clean
                    }
                })
                .collect()
        })
        .collect();
    let e = estimate(&sets).expect("samples");
    let truth = clean_quantile(mu, QUIET);
    assert!(
        (e.value - truth).abs() < 0.01 * mu,
        "estimate {} for a clean 5th percentile of {truth}",
        e.value
    );
    let all = sets.concat();
    assert!(
        median(&all) / mu - 1.0 > 0.05,
        "median {}: the injected hog was too mild to test anything",
        median(&all)
    );
    assert!(e.lo <= e.value && e.value <= e.hi);
}

/// Lost time slices: 30 % of the blocks take up to 3× as long. The mean of the blocks (what a
/// whole-pass timing measures) is off by tens of per cent; the estimate is not.
#[test]
fn the_estimate_ignores_lost_time_slices_that_move_the_mean() {
    let mut rng = Rng::new(12);
    let noise = Noise {
        outliers: 0.3,
        factor: 3.0,
        ..QUIET
    };
    let sets = synthetic_sets(&mut rng, 30.0, noise, 3, 122);
    let e = estimate(&sets).expect("samples");
    let all = sets.concat();
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    assert!(
        (e.value / clean_quantile(30.0, noise) - 1.0).abs() < 0.01,
        "estimate {}",
        e.value
    );
    assert!(mean / 30.0 - 1.0 > 0.2, "mean {mean}: outliers too mild");
}

/// One slow set of three (a phase of the machine 10 % slow) does not move the estimate: its
/// blocks are all slower than the clean sets' fastest tenth.
#[test]
fn one_slow_set_does_not_move_the_estimate() {
    let mut rng = Rng::new(21);
    let mut sets = synthetic_sets(&mut rng, 30.0, QUIET, 3, 64);
    let clean = estimate(&[sets[0].clone(), sets[2].clone()]).expect("samples");
    for block in &mut sets[1] {
        *block *= 1.10;
    }
    let e = estimate(&sets).expect("samples");
    assert!(
        (e.value / clean.value - 1.0).abs() < 0.003,
        "{} vs clean {}",
        e.value,
        clean.value
    );
    // Ten sets, one slow: the interval stays within 1 % and covers the truth.
    let mut sets = synthetic_sets(&mut rng, 30.0, QUIET, 10, 64);
    for block in &mut sets[4] {
        *block *= 1.5;
    }
    let e = estimate(&sets).expect("samples");
    assert!(
        e.relative_half_width() < 0.01,
        "±{:.2} %",
        e.relative_half_width() * 100.0
    );
    let truth = clean_quantile(30.0, QUIET);
    assert!(e.lo <= truth && truth <= e.hi, "{e:?} vs {truth}");
}

/// Coverage of the 95 % interval over 400 synthetic points of 5 sets. Where the noise is what
/// the protocol assumes — clean blocks, positive noise on single blocks (lost time slices: 2 %
/// take up to 3× as long) and on whole sets (30 % of the sets in a slow phase, 5–50 % slow),
/// configuration sets that differ by 0.5 % — at least 90 % must cover the truth: a binomial
/// 95 % process falls below that with probability under 10⁻⁴. Sets that differ
/// *symmetrically* by twice the block jitter (2 % sd) are where the jackknife of a quantile
/// over 5 sets is weakest (a simulation of this test in Python gave 76 %): asserted ≥ 70 % so
/// that a regression shows. On this project's machine the configuration mix moves a set by
/// about 0.1 %.
#[test]
fn intervals_cover_the_truth() {
    for (noise, what, blocks, at_least) in [
        (QUIET, "clean", 64, 0.9),
        (
            Noise {
                slow_sets: 0.3,
                ..QUIET
            },
            "slow phases",
            64,
            0.9,
        ),
        (
            Noise {
                outliers: 0.02,
                factor: 3.0,
                slow_sets: 0.3,
                ..QUIET
            },
            "slow phases and lost time slices",
            122,
            0.9,
        ),
        (
            Noise {
                set_shift: 0.005,
                ..QUIET
            },
            "configuration sets 0.5 % apart",
            64,
            0.9,
        ),
        (
            Noise {
                set_shift: 0.02,
                ..QUIET
            },
            "sets that differ symmetrically by 2 %",
            64,
            0.7,
        ),
    ] {
        let mut rng = Rng::new(5);
        let trials = 400;
        let truth = clean_quantile(30.0, noise);
        let mut covered = 0;
        for _ in 0..trials {
            let sets = synthetic_sets(&mut rng, 30.0, noise, 5, blocks);
            let e = estimate(&sets).expect("samples");
            assert!(e.lo <= e.value && e.value <= e.hi);
            covered += usize::from(e.lo <= truth && truth <= e.hi);
        }
        assert!(
            covered as f64 >= at_least * trials as f64,
            "{what}: {covered} of {trials} intervals cover the truth"
        );
    }
}

/// `sets` sets of `blocks` blocks on a machine whose speed drifts: block j of set k costs
/// μ·(1 + drift·a_k + jitter·e_j), e_j standard normal, a_k a standard normal AR(1) series over
/// consecutive sets with correlation `rho` (a phase of the machine lasts about
/// (1 + rho)/(1 − rho) sets). Every block is then N(μ, μ²(drift² + jitter²)) distributed.
fn drifting_sets(
    rng: &mut Rng,
    mu: f64,
    drift: f64,
    rho: f64,
    sets: usize,
    blocks: usize,
) -> Vec<Vec<f64>> {
    let jitter = 0.01;
    let mut a = normal(rng);
    (0..sets)
        .map(|_| {
            a = rho * a + (1.0 - rho * rho).sqrt() * normal(rng);
            (0..blocks)
                .map(|_| mu * (1.0 + drift * a + jitter * normal(rng)))
                .collect()
        })
        .collect()
}

/// Coverage of every statistic's 95 % interval over 300 synthetic points of 20 sets on a
/// drifting machine (sets 1 % apart, blocks 1 % jitter), against each statistic's truth (μ for
/// the mean and the median, μ(1 + z₀.₀₅·√2 %) for the 5th percentile):
/// - independent sets: at least 88 % and at most 99.5 % (a binomial 95 % process of 300 falls
///   below 88 % with probability under 10⁻⁵); measured 93–95 %. The delete-one-set jackknife
///   this interval replaced gives the 5th percentile 86 %;
/// - phases of about three sets (rho 0.5): at least 80 %; measured 85–92 %, the delete-one-set
///   jackknife 70–75 %. Longer phases cover less (rho 0.8: 70–77 %, delete-one-set 43–44 %),
///   and a phase longer than the point is invisible to any interval of it.
#[test]
fn intervals_cover_the_truth_when_the_machine_drifts_over_sets() {
    let mu = 30.0;
    let drift = 0.01;
    let spread = drift * std::f64::consts::SQRT_2;
    for (rho, at_least) in [(0.0, 0.88), (0.5, 0.8)] {
        for statistic in Statistic::ALL {
            let truth = match statistic {
                Statistic::P5 => mu * (1.0 + Z_QUANTILE * spread),
                Statistic::Mean | Statistic::Median => mu,
            };
            let mut rng = Rng::new(17);
            let trials = 300;
            let mut covered = 0;
            for _ in 0..trials {
                let sets = drifting_sets(&mut rng, mu, drift, rho, 20, 64);
                let e = estimate_with(statistic, &sets).expect("samples");
                assert!(e.lo <= e.value && e.value <= e.hi);
                covered += usize::from(e.lo <= truth && truth <= e.hi);
            }
            let rate = covered as f64 / trials as f64;
            assert!(
                (at_least..=0.995).contains(&rate),
                "{statistic}, rho {rho}: {covered} of {trials} intervals cover the truth"
            );
        }
    }
}

#[test]
fn the_goal_never_cuts_the_repeats_asked_for() {
    let goal = Goal {
        min_repeats: 3,
        ci_target: Some(0.01),
        time_cap_s: 1.0,
        max_repeats: 10,
    };
    assert_eq!(
        goal.next(1, 0.0, 100.0, 100.0),
        None,
        "below the minimum: measure, cap or not"
    );
    assert_eq!(goal.next(3, 0.005, 0.1, 0.1), Some(Stop::Precise));
    assert_eq!(
        goal.next(3, 0.02, 0.1, 0.1),
        None,
        "imprecise and time left: one more set"
    );
    assert_eq!(
        goal.next(3, 0.02, 0.8, 0.3),
        Some(Stop::TimeCap),
        "the next set would pass the cap"
    );
    assert_eq!(
        goal.next(3, f64::NAN, 0.1, 0.1),
        None,
        "no interval yet is not precise"
    );
    assert_eq!(goal.next(10, 0.02, 0.1, 0.1), Some(Stop::MaxRepeats));
    let no_target = Goal {
        ci_target: None,
        ..goal
    };
    assert_eq!(no_target.next(3, f64::NAN, 0.0, 0.0), Some(Stop::Repeats));
    assert_eq!(no_target.next(2, f64::NAN, 0.0, 0.0), None);
}

/// Drives the stopping rule with synthetic sets as the protocol does: returns the sets used,
/// why it stopped and the final estimate.
fn measure_until_done(rng: &mut Rng, goal: Goal, noise: Noise, set_s: f64) -> (u32, Stop, f64) {
    let mut sets = Vec::new();
    let mut spent = 0.0;
    loop {
        sets.extend(synthetic_sets(rng, 30.0, noise, 1, 64));
        spent += set_s;
        let e = estimate(&sets).expect("samples");
        if let Some(stop) = goal.next(sets.len() as u32, e.relative_half_width(), spent, set_s) {
            return (sets.len() as u32, stop, e.value);
        }
    }
}

#[test]
fn noisier_points_take_more_sets_and_the_cap_bounds_them() {
    let goal = Goal {
        min_repeats: 2,
        ci_target: Some(0.01),
        time_cap_s: 100.0,
        max_repeats: 1000,
    };
    let mut rng = Rng::new(3);
    let (quiet_sets, quiet_stop, quiet_value) = measure_until_done(&mut rng, goal, QUIET, 1.0);
    // Blocks three times as noisy, a fifth of them slowed up to 3×, a third of the sets in a
    // slow phase.
    let phases = Noise {
        jitter: 0.03,
        outliers: 0.2,
        factor: 3.0,
        slow_sets: 0.3,
        ..QUIET
    };
    let (noisy_sets, noisy_stop, noisy_value) = measure_until_done(&mut rng, goal, phases, 1.0);
    // Two sets are rarely enough (Student's t with one degree of freedom is 12.7); a few are.
    assert!(
        quiet_sets <= 5 && quiet_stop == Stop::Precise,
        "{quiet_sets} sets, {quiet_stop:?}"
    );
    assert!((quiet_value / clean_quantile(30.0, QUIET) - 1.0).abs() < 0.01);
    assert_eq!(noisy_stop, Stop::Precise);
    // Precise to 1 %: the estimate is within twice that of the truth despite the outliers.
    assert!(
        (noisy_value / clean_quantile(30.0, phases) - 1.0).abs() < 0.02,
        "{noisy_value} after {noisy_sets} sets"
    );
    assert!(
        noisy_sets > quiet_sets + 2,
        "slow phases took only {noisy_sets} sets, a quiet machine {quiet_sets}"
    );
    // A target no measurement reaches stops at the cap: 10 s of 1 s sets, never more.
    let impossible = Goal {
        ci_target: Some(1e-9),
        time_cap_s: 10.0,
        ..goal
    };
    let (sets, stop, _) = measure_until_done(&mut rng, impossible, QUIET, 1.0);
    assert_eq!((sets, stop), (10, Stop::TimeCap));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Whatever the true cost and jitter, with up to 30 % of blocks slowed by up to 4×, the
    /// estimate stays within 2 jitters of the clean 5th percentile (one-sided contamination p
    /// moves it to the clean 0.05/(1 − p) ≤ 0.071 quantile, 0.18 σ, and its sampling error over
    /// at least 32 blocks has a standard deviation of 0.37 σ), and the interval holds it.
    #[test]
    fn the_estimate_resists_outliers(
        seed in any::<u64>(),
        mu in 1.0f64..100.0,
        jitter in 0.001f64..0.03,
        outliers in 0.0f64..0.3,
        factor in 1.2f64..4.0,
        repeats in 1usize..5,
        blocks in 32usize..200,
    ) {
        let mut rng = Rng::new(seed);
        let noise = Noise { jitter, outliers, factor, ..QUIET };
        let sets = synthetic_sets(&mut rng, mu, noise, repeats, blocks);
        let e = estimate(&sets).expect("samples");
        let truth = clean_quantile(mu, noise);
        prop_assert!((e.value / truth - 1.0).abs() <= 2.0 * jitter, "estimate {} for {truth}", e.value);
        prop_assert!(e.lo <= e.value && e.value <= e.hi);
        prop_assert_eq!(e.samples, repeats * blocks);
        prop_assert_eq!(e.repeats, repeats);
    }

    /// The stopping rule stops, within its bounds, for any target and cap.
    #[test]
    fn the_goal_always_stops_within_its_bounds(
        seed in any::<u64>(),
        min_repeats in 1u32..5,
        target in 1e-4f64..0.05,
        cap in 1.0f64..30.0,
        set_shift in 0.0f64..0.05,
    ) {
        let mut rng = Rng::new(seed);
        let goal = Goal { min_repeats, ci_target: Some(target), time_cap_s: cap, max_repeats: 200 };
        let (sets, stop, _) = measure_until_done(&mut rng, goal, Noise { set_shift, ..QUIET }, 1.0);
        prop_assert!(sets >= min_repeats);
        prop_assert!(sets <= min_repeats.max(cap.floor() as u32).max(1), "{sets} sets under a {cap} s cap");
        prop_assert!(stop != Stop::Repeats);
    }
}
