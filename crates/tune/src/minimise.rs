//! The minimum of a noisy result field over the range by successive parabolic interpolation in
//! log x, told where the noise hides the answer.
//!
//! The first values ([`INITIAL`]) are judged once all of them are done. Each step reads the
//! evaluations as points (every run at one value pooled; a value with a
//! failed run is never the minimum, and bounds the search as a value worse than any). Around the
//! best mean it fits the least-squares parabola through the best point and up to two evaluated
//! neighbours on either side (as the EDMD paper locates Δ*_NNL, Fig. 10):
//! - the best at the edge of what was evaluated: the search extends towards that end of the
//!   range;
//! - the parabola convex with its vertex among the points: if it puts the minimum lower than
//!   the best mean by more than `value_tolerance` (relative), the vertex is evaluated next;
//!   if not, the search has converged;
//! - the vertex within half the tolerance of a value already run, or no convex parabola (noise
//!   bigger than the curvature): the gaps on either side of the best wider than `tolerance` are
//!   split; once none is left, the best and its neighbours are run again, up to `max_repeats`
//!   each, where their 95 % intervals overlap (`crate::noise`): a repeat tells close values
//!   apart, where a guess would report a worse one;
//! - nothing left to do: converged. Before it would exceed `max_evaluations` it stops (budget;
//!   the runs of a grid that fall in the range count, as they cost the same).
//!
//! The value reported is the parabola's vertex, with the interval where the parabola stays within
//! the best mean's 95 % half-width of its minimum (the positions the runs cannot tell from the
//! minimum: wide on a flat minimum, narrow on a sharp one); without a convex parabola, the best
//! evaluated value between its evaluated neighbours.

use crate::lattice::{Range, split};
use crate::noise::{self, Point};
use crate::{
    Conclusion, Evaluation, Objective, Outcome, Proposal, Step, Stopped, TuneError, in_range,
    next_repeat,
};

/// The first values evaluated, as positions in the range: the middle and the quarters. The ends
/// are evaluated only if the minimum leads there.
pub const INITIAL: [f64; 3] = [0.25, 0.5, 0.75];

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Runs the search may spend on one state point, repeats included.
    pub max_evaluations: usize,
    /// The width of bracket (as a fraction of the log range) below which it stops.
    pub tolerance: f64,
    /// Runs of one value at most when it must be told apart from its neighbours.
    pub max_repeats: usize,
    /// How much lower (relative) than the best mean the parabola through the bracket may still
    /// put the minimum when the search stops without narrowing the bracket to `tolerance`.
    pub value_tolerance: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            max_evaluations: 12,
            tolerance: 0.1,
            max_repeats: 3,
            value_tolerance: 0.01,
        }
    }
}

impl Settings {
    pub fn new(
        max_evaluations: usize,
        tolerance: f64,
        max_repeats: usize,
        value_tolerance: f64,
    ) -> Result<Self, TuneError> {
        let setting = |what, min: f64, value: f64| Err(TuneError::Setting { what, min, value });
        if max_evaluations < INITIAL.len() {
            return setting(
                "max_evaluations",
                INITIAL.len() as f64,
                max_evaluations as f64,
            );
        }
        if !(tolerance > 0.0 && tolerance < 1.0) {
            return setting(
                "tolerance (a fraction of the range, below 1)",
                0.0,
                tolerance,
            );
        }
        if max_repeats < 1 {
            return setting("max_repeats", 1.0, max_repeats as f64);
        }
        if value_tolerance.is_nan() || value_tolerance < 0.0 {
            return setting("value_tolerance", 0.0, value_tolerance);
        }
        Ok(Settings {
            max_evaluations,
            tolerance,
            max_repeats,
            value_tolerance,
        })
    }
}

pub fn next(
    range: &Range,
    settings: &Settings,
    done: &[Evaluation],
    in_flight: &[Proposal],
) -> Step {
    let (done, in_flight) = in_range(range, done, in_flight);
    let taken: Vec<f64> = done
        .iter()
        .map(|e| e.x)
        .chain(in_flight.iter().map(|p| p.x))
        .collect();
    let allowed = settings
        .max_evaluations
        .saturating_sub(done.len() + in_flight.len());
    let (points, failed) = points(range, &done);
    let evaluated: Vec<f64> = sorted(points.iter().map(|p| p.t).chain(failed.iter().copied()));
    let fresh = |t: f64| {
        let x = range.value(t);
        (!taken.contains(&x)).then_some(Proposal { x, repeat: 0 })
    };

    let wanted: Vec<Proposal> = if points.is_empty() {
        INITIAL
            .iter()
            .chain(&[0.0, 1.0])
            .filter_map(|&t| fresh(t))
            .take(INITIAL.len())
            .collect()
    } else if evaluated.len() < INITIAL.len() && !in_flight.is_empty() {
        // The first values are judged together: the first one done is at an open end of what
        // is known whatever the curve, and extending from it would spend a run the others
        // make needless.
        Vec::new()
    } else {
        let around = Around::best(&points, &evaluated);
        let flying = |a: f64, b: f64| {
            in_flight
                .iter()
                .any(|p| (a..=b).contains(&range.position(p.x)))
        };
        if let Some(end) = around.open_end() {
            // Towards the end: the end itself once within the tolerance, else a split of the way.
            let edge = points[around.best].t;
            let t = if (edge - end).abs() <= settings.tolerance {
                end
            } else {
                split(edge.min(end), edge.max(end))
            };
            if flying(t.min(edge), t.max(edge)) {
                Vec::new()
            } else {
                fresh(t).into_iter().collect()
            }
        } else {
            match around.vertex(&points) {
                Some((_, value, _))
                    if points[around.best].mean() - value
                        <= settings.value_tolerance * points[around.best].mean().abs() =>
                {
                    Vec::new()
                }
                Some((t, _, _))
                    if evaluated
                        .iter()
                        .all(|&e| (e - t).abs() > 0.5 * settings.tolerance)
                        && !flying(around.lower, around.upper) =>
                {
                    fresh(t).into_iter().collect()
                }
                _ if flying(around.lower, around.upper) => Vec::new(),
                _ => {
                    let splits: Vec<Proposal> = [
                        (around.lower, points[around.best].t),
                        (points[around.best].t, around.upper),
                    ]
                    .into_iter()
                    .filter(|(a, b)| b - a > settings.tolerance)
                    .filter_map(|(a, b)| fresh(split(a, b)))
                    .collect();
                    if splits.is_empty() {
                        repeats(&points, &around, settings, &done, &in_flight)
                    } else {
                        splits
                    }
                }
            }
        }
    };
    if !wanted.is_empty() && allowed > 0 {
        return Step::Propose(wanted.into_iter().take(allowed).collect());
    }
    if !in_flight.is_empty() {
        return Step::Wait;
    }
    let stopped = if points.is_empty() {
        Stopped::NothingUsable
    } else if wanted.is_empty() {
        Stopped::Converged
    } else {
        Stopped::Budget
    };
    Step::Done(conclusion(range, &points, &evaluated, done.len(), stopped))
}

/// The runs grouped by value, sorted by position, and the positions of values with a failed run.
pub(crate) fn points(range: &Range, done: &[&Evaluation]) -> (Vec<Point>, Vec<f64>) {
    let mut points: Vec<Point> = Vec::new();
    let mut failed = Vec::new();
    for e in done {
        let t = range.position(e.x);
        match e.outcome {
            Outcome::Value(v) if v.is_finite() => match points.iter_mut().find(|p| p.x == e.x) {
                Some(p) => p.values.push(v),
                None => points.push(Point {
                    t,
                    x: e.x,
                    values: vec![v],
                }),
            },
            _ => failed.push(e.x),
        }
    }
    points.retain(|p| !failed.contains(&p.x));
    points.sort_by(|a, b| a.t.total_cmp(&b.t));
    let failed = sorted(failed.into_iter().map(|x| range.position(x)));
    (points, failed)
}

pub(crate) fn sorted(positions: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = positions.collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// The best point (index into the points) and the evaluated positions on either side of it.
pub(crate) struct Around {
    pub(crate) best: usize,
    /// The nearest evaluated position below the best, or the best's own where nothing is.
    lower: f64,
    upper: f64,
    below: bool,
    above: bool,
}

impl Around {
    pub(crate) fn best(points: &[Point], evaluated: &[f64]) -> Self {
        let best = (0..points.len())
            .min_by(|&a, &b| points[a].mean().total_cmp(&points[b].mean()))
            .unwrap_or(0);
        let t = points[best].t;
        let lower = evaluated.iter().rev().find(|&&e| e < t).copied();
        let upper = evaluated.iter().find(|&&e| e > t).copied();
        Around {
            best,
            lower: lower.unwrap_or(t),
            upper: upper.unwrap_or(t),
            below: lower.is_some(),
            above: upper.is_some(),
        }
    }

    /// The end of the range towards which nothing bounds the best, if any.
    fn open_end(&self) -> Option<f64> {
        if !self.below && self.lower > 0.0 {
            Some(0.0)
        } else if !self.above && self.upper < 1.0 {
            Some(1.0)
        } else {
            None
        }
    }

    /// The vertex (position, value) of the parabola through the best point and up to two of its
    /// usable neighbours on either side, where it is convex and lies among them.
    pub(crate) fn vertex(&self, points: &[Point]) -> Option<(f64, f64, f64)> {
        let near: Vec<&Point> = points
            [self.best.saturating_sub(2)..(self.best + 3).min(points.len())]
            .iter()
            .collect();
        let (first, last) = (near[0].t, near[near.len() - 1].t);
        parabola_vertex(&near).filter(|&(t, _, _)| first <= t && t <= last)
    }
}

/// Another run of the best point and of its neighbours whose intervals overlap its interval,
/// those with the fewest runs first, while they have fewer than `max_repeats`.
fn repeats(
    points: &[Point],
    around: &Around,
    settings: &Settings,
    done: &[&Evaluation],
    in_flight: &[&Proposal],
) -> Vec<Proposal> {
    let spread = noise::spread(points);
    let best = &points[around.best];
    let close: Vec<&Point> = points
        .iter()
        .filter(|p| (around.lower..=around.upper).contains(&p.t))
        .filter(|p| {
            let interval = noise::half_width(p, spread).hypot(noise::half_width(best, spread));
            p.mean() - best.mean() <= interval
        })
        .collect();
    let fewest = close.iter().map(|p| p.values.len()).min().unwrap_or(0);
    if close.len() < 2 || fewest >= settings.max_repeats {
        return Vec::new();
    }
    close
        .into_iter()
        .filter(|p| p.values.len() == fewest)
        .map(|p| Proposal {
            x: p.x,
            repeat: next_repeat(p.x, done, in_flight),
        })
        .collect()
}

fn conclusion(
    range: &Range,
    points: &[Point],
    evaluated: &[f64],
    evaluations: usize,
    stopped: Stopped,
) -> Conclusion {
    if points.is_empty() {
        return Conclusion {
            best: None,
            interval: None,
            objective: None,
            evaluations,
            stopped,
        };
    }
    let around = Around::best(points, evaluated);
    let best = &points[around.best];
    let half_width = noise::half_width(best, noise::spread(points));
    // Where the parabola stays within the best mean's noise of its vertex: the positions the
    // runs cannot tell from the minimum. Without one, between the best's evaluated neighbours.
    let (vertex, lower, upper) = match around.vertex(points) {
        Some((t, _, c)) => {
            let reach = (half_width / c).sqrt();
            (Some(t), (t - reach).max(0.0), (t + reach).min(1.0))
        }
        None => (
            None,
            if around.below { around.lower } else { 0.0 },
            if around.above { around.upper } else { 1.0 },
        ),
    };
    Conclusion {
        best: Some(vertex.map_or(best.x, |t| range.exact(t))),
        interval: Some([range.exact(lower), range.exact(upper)]),
        objective: Some(Objective {
            x: best.x,
            mean: best.mean(),
            half_width,
            runs: best.values.len(),
        }),
        evaluations,
        stopped,
    }
}

/// The vertex (position, value) and curvature c of y = a + b t + c t², fitted by least squares to the points' means (weighted by
/// their runs), where at least three values make it and it opens upwards.
fn parabola_vertex(points: &[&Point]) -> Option<(f64, f64, f64)> {
    if points.len() < 3 {
        return None;
    }
    // Centred on the points' mean position, so the normal equations stay well conditioned.
    let centre = points.iter().map(|p| p.t).sum::<f64>() / points.len() as f64;
    let mut m = [[0.0; 3]; 3];
    let mut r = [0.0; 3];
    for p in points {
        let (w, t, y) = (p.values.len() as f64, p.t - centre, p.mean());
        let basis = [1.0, t, t * t];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += w * basis[i] * basis[j];
            }
            r[i] += w * basis[i] * y;
        }
    }
    let [a, b, c] = solve3(m, r)?;
    (c > 0.0).then(|| (centre - b / (2.0 * c), a - b * b / (4.0 * c), c))
}

/// Cramer's rule for a 3 × 3 system; None when it is singular.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    let scale = m.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
    if !d.is_finite() || d.abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for i in 0..3 {
            mk[i][k] = r[i];
        }
        *o = det(&mk) / d;
    }
    Some(out)
}
