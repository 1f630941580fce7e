//! The searches driven to the end against functions whose answer is known: a noisy parabola in
//! log x for the minimum, a threshold for the loosest safe value.

mod common;

use common::{normal, uniform};
use proptest::prelude::*;
use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::{Rng, SeedableRng};
use tune::{
    Conclusion, Evaluation, Goal, Outcome, Proposal, Range, Step, Stopped, loosest_safe, minimise,
};

/// Runs a search as a driver would: at most `parallel` evaluations in flight, the oldest
/// finishing first. Checks on every step that nothing taken is proposed again and that the
/// budget is never exceeded; returns the conclusion and every evaluation.
fn drive(
    range: &Range,
    goal: &Goal,
    budget: usize,
    parallel: usize,
    mut run: impl FnMut(&Proposal) -> Outcome,
    mut done: Vec<Evaluation>,
) -> (Conclusion, Vec<Evaluation>) {
    let mut in_flight: Vec<Proposal> = Vec::new();
    let before = done.len();
    for _ in 0..1000 {
        if in_flight.len() >= parallel {
            let p = in_flight.remove(0);
            done.push(Evaluation {
                x: p.x,
                repeat: p.repeat,
                outcome: run(&p),
            });
            continue;
        }
        match tune::next(range, goal, &done, &in_flight) {
            Step::Propose(proposals) => {
                assert!(!proposals.is_empty());
                for p in proposals {
                    let taken = |x: f64, r: u32| x == p.x && r == p.repeat;
                    assert!(
                        !done.iter().any(|e| taken(e.x, e.repeat))
                            && !in_flight.iter().any(|q| taken(q.x, q.repeat)),
                        "{p:?} proposed again"
                    );
                    assert!(range.contains(p.x), "{p:?} outside the range");
                    in_flight.push(p);
                }
                assert!(
                    done.len() - before + in_flight.len() <= budget,
                    "over budget"
                );
            }
            Step::Wait => {
                assert!(!in_flight.is_empty(), "waits with nothing in flight");
                let p = in_flight.remove(0);
                done.push(Evaluation {
                    x: p.x,
                    repeat: p.repeat,
                    outcome: run(&p),
                });
            }
            Step::Done(conclusion) => {
                assert!(in_flight.is_empty(), "done with evaluations in flight");
                return (conclusion, done);
            }
        }
    }
    panic!("the search did not stop in 1000 steps");
}

/// τ_c(Δ) = 30 (1 + `curvature` (log-position − `t_star`)²) over `range`, each run's value
/// off by a relative normal error of deviation `noise` (drawn from `seed`), minimised with the
/// default settings and `parallel` runs in flight: the conclusion, every run, and how far the
/// value chosen lies above the true minimum (relative).
fn search_noisy_parabola(
    range: &Range,
    t_star: f64,
    curvature: f64,
    noise: f64,
    parallel: usize,
    seed: u64,
) -> (Conclusion, Vec<Evaluation>, f64) {
    let settings = minimise::Settings::default();
    let truth = |x: f64| 30.0 * (1.0 + curvature * (range.position(x) - t_star).powi(2));
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let (c, done) = drive(
        range,
        &Goal::Minimise(settings),
        settings.max_evaluations,
        parallel,
        |p| Outcome::Value(truth(p.x) * (1.0 + noise * normal(&mut rng))),
        Vec::new(),
    );
    let excess = truth(c.objective.unwrap().x) / truth(range.exact(t_star)) - 1.0;
    (c, done, excess)
}

/// Noisy searches (noise up to 3 % a run, the minimum anywhere, a curvature of 0.3–6, one to
/// four runs in flight), seeded so that the count is the same on every run: the value chosen
/// lies more than 5 % and four noise deviations above the minimum in about one search in ten
/// thousand (the best of a few noisy runs is sometimes a lucky one down a flank; 42 in 400,000
/// measured, the worst 6.3 deviations), and never far beyond.
#[test]
fn noisy_searches_rarely_stop_far_from_the_minimum() {
    let range = Range::new(0.02, 1.5).unwrap();
    let mut draws = Xoshiro256PlusPlus::seed_from_u64(29);
    let searches = 20_000;
    let (mut far, mut worst) = (0, 0.0f64);
    for _ in 0..searches {
        let t_star = uniform(&mut draws);
        let curvature = 0.3 + 5.7 * uniform(&mut draws);
        let noise = 0.03 * uniform(&mut draws);
        let parallel = 1 + (4.0 * uniform(&mut draws)) as usize;
        let seed = draws.next_u64();
        let (_, _, excess) =
            search_noisy_parabola(&range, t_star, curvature, noise, parallel, seed);
        if excess > 0.05 {
            worst = worst.max(excess / noise);
            far += usize::from(excess > 4.0 * noise);
        }
    }
    println!("{far} of {searches} beyond 5 % and four deviations, the worst {worst:.2} deviations");
    assert!(far <= searches / 1000, "{far} of {searches}");
    assert!(worst <= 8.0, "{worst}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// A noisy τ_c(Δ) = base · (1 + a (log-position − t*)²): the search stops within the
    /// budget with a run it made. Without noise the value chosen is within the value tolerance
    /// of the minimum (the search stops where its best mean is within the tolerance of that mean
    /// above the vertex: best − min ≤ tol · best, so best ≤ min / (1 − tol)) and the interval
    /// holds the minimum. With noise no bound holds for every seed (the best of a few noisy runs
    /// can be a lucky one far down a flank): `noisy_searches_rarely_stop_far_from_the_minimum`
    /// counts how often.
    #[test]
    fn the_minimum_of_a_noisy_parabola_is_found_within_the_budget(
        t_star in 0.0f64..1.0,
        curvature in 0.3f64..6.0,
        noise in prop_oneof![Just(0.0), 0.0f64..0.03],
        parallel in 1usize..5,
        seed in any::<u64>(),
    ) {
        let range = Range::new(0.02, 1.5).unwrap();
        let settings = minimise::Settings::default();
        let (c, done, excess) = search_noisy_parabola(&range, t_star, curvature, noise, parallel, seed);
        prop_assert!(done.len() <= settings.max_evaluations);
        prop_assert!(matches!(c.stopped, Stopped::Converged | Stopped::Budget), "{c:?}");
        let chosen = c.objective.unwrap().x;
        prop_assert!(done.iter().any(|e| e.x == chosen), "{c:?} {done:?}");
        if noise == 0.0 {
            let tolerance = settings.value_tolerance;
            prop_assert!(excess <= tolerance / (1.0 - tolerance) + 1e-12, "{excess} {c:?} {done:?}");
            let [lo, hi] = c.interval.unwrap();
            let x_star = range.exact(t_star);
            prop_assert!(lo <= x_star * (1.0 + 1e-12) && x_star <= hi * (1.0 + 1e-12), "{c:?}");
        }
    }

    /// The decision depends on what was evaluated, not on the order it arrived in.
    #[test]
    fn the_next_step_does_not_depend_on_the_order_of_the_evaluations(
        values in prop::collection::vec((0.02f64..1.5, 1.0f64..100.0), 1..10),
        rotation in 0usize..10,
    ) {
        let range = Range::new(0.02, 1.5).unwrap();
        let goal = Goal::Minimise(minimise::Settings::default());
        let done: Vec<Evaluation> = values.iter()
            .map(|&(x, v)| Evaluation { x, repeat: 0, outcome: Outcome::Value(v) })
            .collect();
        let mut turned = done.clone();
        turned.rotate_left(rotation % done.len());
        turned.reverse();
        prop_assert_eq!(tune::next(&range, &goal, &done, &[]), tune::next(&range, &goal, &turned, &[]));
    }

    /// Safe below a threshold, unsafe from it: the answer brackets the threshold within the
    /// tolerance, the value reported was run safely 1 + confirmations times, and no unsafe value
    /// is reported.
    #[test]
    fn the_loosest_safe_value_brackets_the_threshold(
        threshold in -0.2f64..1.2,
        loose_is_high in any::<bool>(),
        parallel in 1usize..4,
    ) {
        let range = Range::new(1e-12, 1e-4).unwrap();
        let settings = loosest_safe::Settings { loose_is_high, ..Default::default() };
        let looseness = |x: f64| {
            let t = range.position(x);
            if loose_is_high { t } else { 1.0 - t }
        };
        let (c, done) = drive(&range, &Goal::LoosestSafe(settings), settings.max_evaluations, parallel,
            |p| Outcome::Safe(looseness(p.x) < threshold), Vec::new());
        if threshold <= 0.0 {
            prop_assert_eq!(c.stopped, Stopped::NoSafeValue);
            prop_assert_eq!(c.best, None);
        } else if threshold > 1.0 {
            prop_assert_eq!(c.stopped, Stopped::RangeEndSafe);
            prop_assert_eq!(c.best, Some(if loose_is_high { range.hi() } else { range.lo() }));
        } else {
            prop_assert_eq!(c.stopped, Stopped::Converged, "{:?} {:?}", c, done);
            let [safe, unsafe_] = c.interval.unwrap();
            prop_assert_eq!(Some(safe), c.best);
            prop_assert!(looseness(safe) < threshold && threshold <= looseness(unsafe_));
            // Rounded values sit up to 5e-4 (relative) off their positions.
            prop_assert!(looseness(unsafe_) - looseness(safe) <= settings.tolerance + 1e-3);
            let runs = done.iter().filter(|e| e.x == safe).count();
            prop_assert_eq!(runs, 1 + settings.confirmations);
        }
    }
}

#[test]
fn a_search_whose_every_run_fails_stops_and_says_so() {
    let range = Range::new(0.02, 1.5).unwrap();
    let settings = minimise::Settings::default();
    let (c, done) = drive(
        &range,
        &Goal::Minimise(settings),
        12,
        2,
        |_| Outcome::Failed,
        Vec::new(),
    );
    assert_eq!(c.stopped, Stopped::NothingUsable);
    assert_eq!(c.best, None);
    // The quarters, the middle and both ends: nothing more is worth trying.
    assert_eq!(done.len(), 5);
}

/// Failed runs below a value (a list too short for its bodies, say) bound the bracket: the
/// minimum is found above them.
#[test]
fn failed_values_bound_the_search_as_values_worse_than_any() {
    let range = Range::new(0.02, 1.5).unwrap();
    let settings = minimise::Settings::default();
    let truth = |x: f64| 10.0 + (range.position(x) - 0.3).powi(2) * 20.0;
    let (c, done) = drive(
        &range,
        &Goal::Minimise(settings),
        12,
        1,
        |p| {
            if range.position(p.x) < 0.28 {
                Outcome::Failed
            } else {
                Outcome::Value(truth(p.x))
            }
        },
        Vec::new(),
    );
    assert_eq!(c.stopped, Stopped::Converged, "{c:?} {done:?}");
    let chosen = range.position(c.objective.unwrap().x);
    assert!((0.28..0.45).contains(&chosen), "{c:?}");
}

/// A flat objective within its noise: no value is run more than `max_repeats` times, and the
/// interval says the position is not known (wide), whatever parabola the noise drew.
#[test]
fn a_flat_objective_is_repeated_then_reported_as_a_wide_interval() {
    let range = Range::new(0.02, 1.5).unwrap();
    let settings = minimise::Settings {
        max_evaluations: 30,
        ..Default::default()
    };
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let (c, done) = drive(
        &range,
        &Goal::Minimise(settings),
        30,
        3,
        |_| Outcome::Value(20.0 * (1.0 + 0.02 * normal(&mut rng))),
        Vec::new(),
    );
    for e in &done {
        let runs = done.iter().filter(|o| o.x == e.x).count();
        assert!(runs <= settings.max_repeats, "{e:?} run {runs} times");
    }
    let [lo, hi] = c.interval.unwrap();
    assert!(range.position(hi) - range.position(lo) > 0.3, "{c:?}");
}

/// A grid already run (Fig. 10's eight values of Δ_NNL) is the search's own: none of its values
/// is run again, and a grid that already pins the minimum needs no new run.
#[test]
fn a_grid_already_run_is_reused() {
    let range = Range::new(0.01, 0.4).unwrap();
    let settings = minimise::Settings {
        max_evaluations: 16,
        ..Default::default()
    };
    let truth = |x: f64| 30.0 * (1.0 + 2.0 * (range.position(x) - 0.55).powi(2));
    let grid: Vec<Evaluation> = [0.01, 0.02, 0.035, 0.06, 0.1, 0.16, 0.25, 0.4]
        .iter()
        .map(|&x| Evaluation {
            x,
            repeat: 0,
            outcome: Outcome::Value(truth(x)),
        })
        .collect();
    let (c, done) = drive(
        &range,
        &Goal::Minimise(settings),
        16,
        2,
        |p| Outcome::Value(truth(p.x)),
        grid,
    );
    // The grid's own parabola says nothing is lower by more than the value tolerance.
    assert_eq!(done.len(), 8, "{done:?}");
    assert_eq!(c.stopped, Stopped::Converged);
    assert!(
        (range.position(c.best.unwrap()) - 0.55).abs() < 0.02,
        "{c:?}"
    );
}

#[test]
fn bad_settings_are_refused_naming_the_setting() {
    let e = minimise::Settings::new(2, 0.1, 3, 0.01).unwrap_err();
    assert!(e.to_string().contains("max_evaluations"), "{e}");
    let e = minimise::Settings::new(12, 1.5, 3, 0.01).unwrap_err();
    assert!(e.to_string().contains("tolerance"), "{e}");
    let e = Range::new(0.0, 1.0).unwrap_err();
    assert!(e.to_string().contains("0 < lo < hi"), "{e}");
}
