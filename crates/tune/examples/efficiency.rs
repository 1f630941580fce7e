//! How many runs a minimisation spends and how close it lands, on noisy parabolas in log x:
//! `cargo run --release -p tune --example efficiency -- NOISE CURVATURE [SEARCHES] [POOL] [SPREAD]`.
//! τ(t) = 1 + c · (t − t*)², each run × (1 + NOISE · N(0, 1)).
//! - POOL = 1 (default): one search alone, t* uniform in [0, 1], c = CURVATURE.
//! - POOL = P > 1: SEARCHES tables of P state points searched together ([`tune::next_in_pool`]):
//!   the table's minima t*_p within SPREAD of each other (a centre uniform where they fit in
//!   [0, 1]; SPREAD = 1: anywhere, the prior often wrong) and each c_p = CURVATURE · 2^u, u
//!   uniform in [−1, 1] (the shared-curvature model off by up to 2× either way). Driven as
//!   `sweep run --cores 1` drives: every proposal queued, the oldest run finishing at each step.

use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::{Rng, SeedableRng};
use tune::{Evaluation, Goal, Outcome, Proposal, Range, Step, minimise, pool};

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
    let size = (args.get(3).copied().unwrap_or(1.0) as usize).max(1);
    let spread = args.get(4).copied().unwrap_or(0.5).clamp(0.0, 1.0);
    let range = Range::new(0.02, 1.5).expect("a valid range");
    let goal = Goal::Minimise(minimise::Settings::default());
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut uniform = move || ((rng.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let (mut runs, mut excesses, mut reported, mut pooled) =
        (Vec::new(), Vec::new(), Vec::new(), 0usize);
    for _ in 0..searches {
        let centre = spread / 2.0 + (1.0 - spread) * uniform();
        let truths: Vec<(f64, f64)> = (0..size)
            .map(|_| {
                let t_star = if size == 1 {
                    uniform()
                } else {
                    centre + spread * (uniform() - 0.5)
                };
                let c = if size == 1 {
                    curvature
                } else {
                    curvature * 2f64.powf(2.0 * uniform() - 1.0)
                };
                (t_star, c)
            })
            .collect();
        let truth = |p: usize, x: f64| {
            let (t_star, c) = truths[p];
            1.0 + c * (range.position(x) - t_star).powi(2)
        };
        let mut done: Vec<Vec<Evaluation>> = vec![Vec::new(); size];
        let mut in_flight: Vec<Vec<Proposal>> = vec![Vec::new(); size];
        // The runs queued, oldest first: (state point, proposal).
        let mut queue: Vec<(usize, Proposal)> = Vec::new();
        let conclusions = loop {
            let members: Vec<pool::Member> = (0..size)
                .map(|p| pool::Member {
                    done: &done[p],
                    in_flight: &in_flight[p],
                })
                .collect();
            let steps: Vec<Step> = (0..size)
                .map(|p| tune::next_in_pool(&range, &goal, &members, p))
                .collect();
            if steps.iter().all(|s| matches!(s, Step::Done(_))) {
                break steps;
            }
            for (p, step) in steps.into_iter().enumerate() {
                if let Step::Propose(proposals) = step {
                    in_flight[p].extend(proposals.iter().copied());
                    queue.extend(proposals.into_iter().map(|q| (p, q)));
                }
            }
            assert!(!queue.is_empty(), "the searches wait on nothing");
            let (p, q) = queue.remove(0);
            in_flight[p].retain(|f| *f != q);
            let (a, b) = (uniform(), uniform());
            let normal = (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos();
            done[p].push(Evaluation {
                x: q.x,
                repeat: q.repeat,
                outcome: Outcome::Value(truth(p, q.x) * (1.0 + noise * normal)),
            });
        };
        for (p, step) in conclusions.into_iter().enumerate() {
            let Step::Done(c) = step else { continue };
            pooled += usize::from(c.stopped == tune::Stopped::Pooled);
            runs.push(done[p].len() as f64);
            // What the search ran and reports as its minimum: the best run's value.
            let chosen = c.objective.expect("a minimum").x;
            let minimum = truth(p, range.exact(truths[p].0));
            excesses.push(truth(p, chosen) / minimum - 1.0);
            reported.push(truth(p, c.best.expect("a value")) / minimum - 1.0);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    excesses.sort_by(f64::total_cmp);
    let p95 = excesses[(0.95 * excesses.len() as f64) as usize];
    let over5 = excesses.iter().filter(|&&e| e > 0.05).count();
    println!(
        "noise {noise}, curvature {curvature}, pools of {size} (spread {spread}): {} searches, {:.2} runs on average (max {}), {pooled} stopped pooled; τ at the best run above the minimum by {:.2} % on average, {:.2} % at the 95th percentile, {:.2} % at most, over 5 % in {over5}; at the value reported (the vertex where there is one) {:.2} % on average",
        runs.len(),
        mean(&runs),
        runs.iter().copied().fold(0.0, f64::max),
        100.0 * mean(&excesses),
        100.0 * p95,
        100.0 * excesses.last().copied().unwrap_or(0.0),
        100.0 * mean(&reported)
    );
}
