//! How many runs a minimisation spends and how close it lands, on noisy curves in log x:
//! `cargo run --release -p tune --example efficiency -- NOISE CURVATURE [SEARCHES] [POOL] [SPREAD]`
//! or `… -- NOISE TABLE.csv [SEARCHES]`; each run × (1 + NOISE · N(0, 1)).
//! - POOL = 1 (default): one search alone, τ(t) = 1 + c · (t − t*)², t* uniform in [0, 1],
//!   c = CURVATURE.
//! - POOL = P > 1: SEARCHES tables of P state points searched together ([`tune::next_in_pool`]),
//!   laid out as a plan sweeping φ (outer) and two X0 (inner) lists them: the table's minima
//!   t*_p within SPREAD of each other (a centre uniform where they fit in [0, 1]; SPREAD = 1:
//!   anywhere, the prior often wrong; no trend over the table: an additive prior is as wrong as
//!   a constant one) and each c_p = CURVATURE · 2^u, u uniform in [−1, 1] (the shared-curvature
//!   model off by up to 2× either way).
//! - TABLE.csv (`phi,x0,delta,tau` a line, after a header): one table of the measured curves,
//!   ln τ interpolated in t between the measured values (cubic Hermite), the range their Δ's,
//!   searched SEARCHES times with fresh noise.
//!
//! Driven as `sweep run --cores 1` drives: every proposal queued, the oldest run finishing at
//! each step.

use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::{Rng, SeedableRng};
use tune::{Evaluation, Goal, Outcome, Proposal, Range, Step, minimise, pool};

/// A state point's curve τ(t) in the log position and its minimum.
struct Curve {
    tau: Box<dyn Fn(f64) -> f64>,
    minimum: f64,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let number = |i: usize, default: f64| {
        args.get(i)
            .and_then(|a| a.parse::<f64>().ok())
            .unwrap_or(default)
    };
    let noise = number(0, 0.02);
    let table = args.get(1).filter(|a| a.ends_with(".csv")).map(|path| {
        let text = std::fs::read_to_string(path).expect("a readable table");
        measured(&text)
    });
    let curvature = number(1, 1.0);
    let searches = number(2, 1000.0) as usize;
    let size = match &table {
        Some((_, curves)) => curves.len(),
        None => (number(3, 1.0) as usize).max(1),
    };
    let spread = number(4, 0.5).clamp(0.0, 1.0);
    let range = match &table {
        Some((range, _)) => *range,
        None => Range::new(0.02, 1.5).expect("a valid range"),
    };
    let goal = Goal::Minimise(minimise::Settings::default());
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut uniform = move || ((rng.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let (mut runs, mut per_table, mut excesses, mut reported, mut pooled) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), 0usize);
    let mut by_point = vec![(0.0, 0.0_f64); size];
    for _ in 0..searches {
        let centre = spread / 2.0 + (1.0 - spread) * uniform();
        let synthetic: Vec<Curve> = (0..size)
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
                Curve {
                    tau: Box::new(move |t| 1.0 + c * (t - t_star).powi(2)),
                    minimum: 1.0,
                }
            })
            .collect();
        let curves = match &table {
            Some((_, curves)) => curves,
            None => &synthetic,
        };
        let truth = |p: usize, x: f64| (curves[p].tau)(range.position(x));
        let mut done: Vec<Vec<Evaluation>> = vec![Vec::new(); size];
        let mut in_flight: Vec<Vec<Proposal>> = vec![Vec::new(); size];
        // The runs queued, oldest first: (state point, proposal).
        let mut queue: Vec<(usize, Proposal)> = Vec::new();
        let conclusions = loop {
            let members: Vec<pool::Member> = (0..size)
                .map(|p| pool::Member {
                    done: &done[p],
                    in_flight: &in_flight[p],
                    coordinates: [(p / 2) as f64, (p % 2) as f64],
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
        per_table.push(done.iter().map(Vec::len).sum::<usize>() as f64);
        for (p, step) in conclusions.into_iter().enumerate() {
            let Step::Done(c) = step else { continue };
            pooled += usize::from(c.stopped == tune::Stopped::Pooled);
            runs.push(done[p].len() as f64);
            // What the search ran and reports as its minimum: the best run's value.
            let chosen = c.objective.expect("a minimum").x;
            let excess = truth(p, chosen) / curves[p].minimum - 1.0;
            excesses.push(excess);
            by_point[p].0 += done[p].len() as f64 / searches as f64;
            by_point[p].1 = by_point[p].1.max(excess);
            reported.push(truth(p, c.best.expect("a value")) / curves[p].minimum - 1.0);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    excesses.sort_by(f64::total_cmp);
    let p95 = excesses[(0.95 * excesses.len() as f64) as usize];
    let over5 = excesses.iter().filter(|&&e| e > 0.05).count();
    let source = match table {
        Some(_) => format!("the table {}", args[1]),
        None => format!("curvature {curvature}, pools of {size} (spread {spread})"),
    };
    println!(
        "noise {noise}, {source}: {} searches, {:.2} runs on average (max {}), {pooled} stopped pooled; τ at the best run above the minimum by {:.2} % on average, {:.2} % at the 95th percentile, {:.2} % at most, over 5 % in {over5}; at the value reported (the vertex where there is one) {:.2} % on average",
        runs.len(),
        mean(&runs),
        runs.iter().copied().fold(0.0, f64::max),
        100.0 * mean(&excesses),
        100.0 * p95,
        100.0 * excesses.last().copied().unwrap_or(0.0),
        100.0 * mean(&reported)
    );
    if size > 1 {
        per_table.sort_by(f64::total_cmp);
        let over16 = per_table.iter().filter(|&&n| n > 16.0).count();
        println!(
            "runs per table: mean {:.2}, median {}, 95th percentile {}, max {}, over 16 in {over16} of {}",
            mean(&per_table),
            per_table[per_table.len() / 2],
            per_table[(0.95 * per_table.len() as f64) as usize],
            per_table.last().copied().unwrap_or(0.0),
            per_table.len()
        );
        for (p, (n, worst)) in by_point.iter().enumerate() {
            println!(
                "  state point {p}: {n:.2} runs on average, worst excess {:.2} %",
                100.0 * worst
            );
        }
    }
}

/// The curves of a measured table (`phi,x0,delta,tau` lines after a header), in the plan's order
/// (φ, then X0), and the range of their Δ's.
fn measured(text: &str) -> (Range, Vec<Curve>) {
    let mut rows: Vec<[f64; 4]> = text
        .lines()
        .skip(1)
        .filter_map(|line| {
            let v: Vec<f64> = line.split(',').filter_map(|f| f.parse().ok()).collect();
            (v.len() == 4).then(|| [v[0], v[1], v[2], v[3]])
        })
        .collect();
    rows.sort_by(|a, b| a.partial_cmp(b).expect("finite values"));
    let lo = rows.iter().map(|r| r[2]).fold(f64::INFINITY, f64::min);
    let hi = rows.iter().map(|r| r[2]).fold(0.0, f64::max);
    let range = Range::new(lo, hi).expect("a table of positive Δ's");
    let mut curves = Vec::new();
    for point in rows.chunk_by(|a, b| a[0] == b[0] && a[1] == b[1]) {
        let nodes: Vec<(f64, f64)> = point
            .iter()
            .map(|r| (range.position(r[2]), r[3].ln()))
            .collect();
        let at = move |t: f64| hermite(&nodes, t).exp();
        let minimum = (0..=10_000)
            .map(|i| at(i as f64 / 10_000.0))
            .fold(f64::INFINITY, f64::min);
        curves.push(Curve {
            tau: Box::new(at),
            minimum,
        });
    }
    (range, curves)
}

/// The cubic Hermite interpolant through `nodes` (sorted by position), slopes by finite
/// differences: smooth, and through every measured value.
fn hermite(nodes: &[(f64, f64)], t: f64) -> f64 {
    let n = nodes.len();
    let i = nodes.windows(2).position(|w| t <= w[1].0).unwrap_or(n - 2);
    let slope = |k: usize| {
        let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
        (nodes[b].1 - nodes[a].1) / (nodes[b].0 - nodes[a].0)
    };
    let ((t0, y0), (t1, y1)) = (nodes[i], nodes[i + 1]);
    let h = t1 - t0;
    let s = ((t - t0) / h).clamp(0.0, 1.0);
    let (s2, s3) = (s * s, s * s * s);
    (2.0 * s3 - 3.0 * s2 + 1.0) * y0
        + (s3 - 2.0 * s2 + s) * h * slope(i)
        + (-2.0 * s3 + 3.0 * s2) * y1
        + (s3 - s2) * h * slope(i + 1)
}
