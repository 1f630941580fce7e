//! How many runs a minimisation spends and how close it lands, on noisy parabolas in log x:
//! `cargo run --release -p tune --example efficiency -- NOISE CURVATURE [SEARCHES]`.
//! τ(t) = 1 + curvature · (t − t*)², t* uniform in [0, 1], each run × (1 + NOISE · N(0, 1)).

use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::{Rng, SeedableRng};
use tune::{Evaluation, Goal, Outcome, Proposal, Range, Step, minimise};

fn main() {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (noise, curvature) = (
        args.first().copied().unwrap_or(0.02),
        args.get(1).copied().unwrap_or(1.0),
    );
    let searches = args.get(2).copied().unwrap_or(1000.0) as usize;
    let range = Range::new(0.02, 1.5).expect("a valid range");
    let settings = minimise::Settings::default();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut uniform = move || ((rng.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let (mut runs, mut excesses) = (Vec::new(), Vec::new());
    for _ in 0..searches {
        let t_star = uniform();
        let truth = |x: f64| 1.0 + curvature * (range.position(x) - t_star).powi(2);
        let (mut done, mut in_flight): (Vec<Evaluation>, Vec<Proposal>) = (Vec::new(), Vec::new());
        // The oldest evaluation in flight finishes, with its noise.
        let mut finish = |done: &mut Vec<Evaluation>, in_flight: &mut Vec<Proposal>| {
            let p = in_flight.remove(0);
            let (a, b) = (uniform(), uniform());
            let normal = (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos();
            done.push(Evaluation {
                x: p.x,
                repeat: p.repeat,
                outcome: Outcome::Value(truth(p.x) * (1.0 + noise * normal)),
            });
        };
        let conclusion = loop {
            match tune::next(&range, &Goal::Minimise(settings), &done, &in_flight) {
                Step::Propose(p) => in_flight.extend(p),
                Step::Wait => finish(&mut done, &mut in_flight),
                Step::Done(c) => break c,
            }
            // Two slots per state point, as a campaign with other state points would give it.
            if in_flight.len() > 2 {
                finish(&mut done, &mut in_flight);
            }
        };
        runs.push(done.len() as f64);
        let chosen = conclusion.best.expect("a minimum");
        excesses.push(truth(chosen) / truth(range.exact(t_star)) - 1.0);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    excesses.sort_by(f64::total_cmp);
    let p95 = excesses[(0.95 * excesses.len() as f64) as usize];
    println!(
        "noise {noise}, curvature {curvature}: {searches} searches, {:.1} runs on average (max {}), τ at the answer above the minimum by {:.2} % on average, {:.2} % at the 95th percentile, {:.2} % at most",
        mean(&runs),
        runs.iter().copied().fold(0.0, f64::max),
        100.0 * mean(&excesses),
        100.0 * p95,
        100.0 * excesses.last().copied().unwrap_or(0.0)
    );
}
