//! A point measured in several visits ([`pool_visits`]) on synthetic timings whose machine
//! changes between visits: each visit sees a state of the machine that scales every block by
//! 1 + σ·N(0, 1) for the whole visit (a run-level shift, or a phase longer than a visit, as
//! measured on this project's VM), and within a visit the blocks only jitter. The truth is the
//! point's cost averaged over the machine's states; one visit's interval cannot see the shift,
//! the pooled one must.

use overlap::estimate::{Estimate, Statistic, estimate_with, pool_visits};
use overlap::rng::Rng;

/// A standard normal variate (Box–Muller).
fn normal(rng: &mut Rng) -> f64 {
    let (u1, u2) = (1.0 - rng.uniform(), rng.uniform());
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

const MU: f64 = 20.0;
const JITTER: f64 = 0.01;
const SETS: usize = 10;
const BLOCKS: usize = 40;
/// z of the 5th percentile of a standard normal.
const Z_QUANTILE: f64 = -1.644_853_626_951_472_2;

/// What each statistic estimates when the machine's state averages out: the statistic of the
/// blocks of an average visit.
fn truth(statistic: Statistic) -> f64 {
    match statistic {
        Statistic::Mean | Statistic::Median => MU,
        Statistic::P5 => MU * (1.0 + Z_QUANTILE * JITTER),
    }
}

/// One visit's estimate: `SETS` sets of `BLOCKS` blocks, all scaled by this visit's state.
fn visit(rng: &mut Rng, statistic: Statistic, shift: f64) -> Estimate {
    let state = 1.0 + shift * normal(rng);
    let sets: Vec<Vec<f64>> = (0..SETS)
        .map(|_| {
            (0..BLOCKS)
                .map(|_| MU * state * (1.0 + JITTER * normal(rng)))
                .collect()
        })
        .collect();
    estimate_with(statistic, &sets).expect("blocks")
}

struct Coverage {
    pooled: f64,
    one_visit: f64,
    /// Median relative half-width of the pooled intervals.
    pooled_width: f64,
}

fn coverage(statistic: Statistic, visits: usize, shift: f64, points: usize, seed: u64) -> Coverage {
    let mut rng = Rng::new(seed);
    let truth = truth(statistic);
    let holds = |e: &Estimate| e.lo <= truth && truth <= e.hi;
    let (mut pooled, mut one_visit) = (0usize, 0usize);
    let mut widths = Vec::with_capacity(points);
    for _ in 0..points {
        let estimates: Vec<Estimate> = (0..visits)
            .map(|_| visit(&mut rng, statistic, shift))
            .collect();
        one_visit += usize::from(holds(&estimates[0]));
        let pooled_estimate = pool_visits(&estimates).expect("visits");
        pooled += usize::from(holds(&pooled_estimate));
        widths.push(pooled_estimate.relative_half_width());
    }
    widths.sort_by(f64::total_cmp);
    Coverage {
        pooled: pooled as f64 / points as f64,
        one_visit: one_visit as f64 / points as f64,
        pooled_width: widths[points / 2],
    }
}

/// A machine whose state moves by 3 % from visit to visit (the quiet VM's run-to-run drift is
/// of that order): one visit's interval, a fraction of a percent wide, holds the truth at a
/// small fraction of the points; three visits' pooled interval at the nominal 95 %, for every
/// statistic (the t interval is exact for Gaussian states; 400 points give ±2.2 % of noise on
/// the rate, hence the band).
#[test]
fn pooled_interval_covers_a_run_level_shift_at_the_nominal_rate() {
    for (seed, statistic) in [
        (1, Statistic::Mean),
        (2, Statistic::Median),
        (3, Statistic::P5),
    ] {
        let c = coverage(statistic, 3, 0.03, 400, seed);
        eprintln!(
            "{statistic:?}, 3 % shift: pooled covers {:.3} (half-width {:.3}), one visit {:.3}",
            c.pooled, c.pooled_width, c.one_visit
        );
        assert!(
            (0.90..=0.99).contains(&c.pooled),
            "{statistic:?}: pooled coverage {:.3}",
            c.pooled
        );
        assert!(
            c.one_visit < 0.4,
            "{statistic:?}: one visit covered {:.3}, expected far below 95 %",
            c.one_visit
        );
        // Honest, not useless: t(2)·σ/√3 ≈ 7.5 % for a 3 % shift.
        assert!(
            c.pooled_width < 0.12,
            "{statistic:?}: {:.3}",
            c.pooled_width
        );
    }
    // More visits: narrower, still at the nominal rate.
    let five = coverage(Statistic::P5, 5, 0.03, 400, 4);
    assert!((0.90..=0.99).contains(&five.pooled), "{:.3}", five.pooled);
    assert!(five.pooled_width < coverage(Statistic::P5, 3, 0.03, 400, 4).pooled_width);
}

/// Without a shift the within-visit term still holds: the pooled interval covers at least at
/// the nominal rate (it is conservative then, by the max of the two terms).
#[test]
fn pooled_interval_without_a_shift_is_at_least_nominal() {
    for (seed, statistic) in [(5, Statistic::Mean), (6, Statistic::P5)] {
        let c = coverage(statistic, 3, 0.0, 300, seed);
        eprintln!(
            "{statistic:?}, no shift: pooled {:.3}, one visit {:.3}",
            c.pooled, c.one_visit
        );
        assert!(c.pooled >= 0.93, "{statistic:?}: {:.3}", c.pooled);
        assert!(c.one_visit >= 0.85, "{statistic:?}: {:.3}", c.one_visit);
    }
}

#[test]
fn pooling_rules() {
    let e = |value: f64, half: f64| Estimate {
        value,
        lo: value - half,
        hi: value + half,
        samples: 100,
        repeats: 4,
    };
    assert_eq!(pool_visits(&[]), None);
    // One visit: today's interval, unchanged.
    assert_eq!(pool_visits(&[e(10.0, 0.3)]), Some(e(10.0, 0.3)));
    // Visits that agree exactly: the within-visit term, √(Σ h²)/n.
    let same = pool_visits(&[e(10.0, 0.3), e(10.0, 0.3), e(10.0, 0.3)]).expect("visits");
    assert_eq!(same.value, 10.0);
    assert!((same.hi - same.lo - 2.0 * 0.3 / 3f64.sqrt()).abs() < 1e-12);
    assert_eq!((same.samples, same.repeats), (300, 12));
    // Visits apart: the mean, and t(2) · s / √3 between them (s = 1 for 9, 10, 11).
    let apart = pool_visits(&[e(9.0, 0.1), e(10.0, 0.1), e(11.0, 0.1)]).expect("visits");
    assert!((apart.value - 10.0).abs() < 1e-12);
    assert!(
        (apart.hi - 10.0 - 4.303 / 3f64.sqrt()).abs() < 1e-9,
        "{apart:?}"
    );
    // A visit without an interval adds nothing to the within term, and poisons nothing.
    let blind = Estimate {
        lo: f64::NAN,
        hi: f64::NAN,
        ..e(10.0, 0.0)
    };
    let mixed = pool_visits(&[blind, e(10.0, 0.6)]).expect("visits");
    assert!((mixed.hi - 10.3).abs() < 1e-12, "{mixed:?}");
}
