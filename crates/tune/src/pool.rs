//! A minimisation pooled over the state points of one `[[tune]]` table: the curves τ_p(t) of
//! neighbouring state points share their shape, so a state point needs two runs where a search
//! of its own needs three at least (a minimum located from its own runs alone needs a parabola).
//!
//! The model, in the log position t: τ_p(t) ≈ a_p (1 + c (t − t*_p)²), the curvature c shared
//! by the table, the level a_p and the minimum t*_p the state point's own.
//! - **The leader** ([`leader`]: the middle state point of the table's order, for a table swept
//!   over φ the middle φ, whose minimum is nearer to most siblings' than an end's) searches on
//!   its own ([`crate::minimise`]).
//! - **The prior**: c is the median relative curvature (c / vertex value) of the parabolas the
//!   siblings' own runs make (convex, vertex among their runs: the leader's first three runs
//!   usually); the expected minimum is the median of the siblings' minima (their vertex, or
//!   for a sibling with two runs, its two-run estimate below).
//! - **A follower** waits while the leader has not located a minimum, then runs a pair
//!   straddling the expected minimum, `h` either side where c h² ≤ [`TOLERANCE`] (so that where
//!   the pair straddles its minimum, the better run is within it). From two values y₁, y₂ at
//!   t₁ < t₂ and the shared c, its own minimum is
//!   t* = (t₁ + t₂)/2 − (ln y₂ − ln y₁) / (2 c (t₂ − t₁)),
//!   and the model puts its better run c (t_best − t*)² above its minimum. With t* between
//!   the two values (they straddle the minimum: |ln y₂ − ln y₁| ≤ c (t₂ − t₁)²), no further
//!   apart than a pair, and within [`TOLERANCE`]: stopped ([`Stopped::Pooled`]), the better run
//!   reported. Else t* is run next (unless it is as good as run already), and a state point
//!   with three values, or a failed run, or a prior that is gone, searches on its own from what
//!   it has. Without noise a wrong prior costs runs, not the answer (tests/pool.rs); with noise
//!   of a few per cent a pair far down a flank can pass for one straddling the minimum
//!   (MEASUREMENTS.md gives how often).
//! - Every member's own search, the leader's included, locates to [`TOLERANCE`] too (its
//!   `value_tolerance` raised to it): a table's minima are found to one tolerance.
//!
//! Stateless as the rest: a pure function of the table's evaluations (a sibling's included),
//! so a resumed or restarted search decides as before and a grid's runs count.

use crate::lattice::Range;
use crate::minimise::{self, Around, Settings, points, sorted};
use crate::noise::{self, Point};
use crate::{Conclusion, Evaluation, Objective, Proposal, Step, Stopped, in_range};

/// How far above the pooled model's minimum a follower's better run may lie when it stops: a
/// fraction of the minimum. Two per cent is less than one run's noise (2–3 %) and less than half
/// of the 5 % over which Fig. 10's minima are flat.
pub const TOLERANCE: f64 = 0.02;

/// Positions of a follower's pair lie on multiples of this (dyadic, so the pair of a repeated
/// search is the same values).
const PAIR_STEP: f64 = 1.0 / 32.0;

/// The evaluations of one search of a pool (those outside the range are ignored).
#[derive(Clone, Copy, Debug)]
pub struct Member<'a> {
    pub done: &'a [Evaluation],
    pub in_flight: &'a [Proposal],
}

/// What a follower's siblings say about its curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    /// c of τ ≈ a (1 + c (t − t*)²), t the log position.
    pub curvature: f64,
    /// Where the minimum is expected (a log position).
    pub position: f64,
}

/// Which member of a pool of `len` leads: the middle one.
pub fn leader(len: usize) -> usize {
    len / 2
}

/// The next step of search `me` of the pool (`me` indexes the pool; [`leader`] leads).
pub fn next(range: &Range, settings: &Settings, pool: &[Member], me: usize) -> Step {
    // A table's minima are located to the pooled tolerance, each member's own search's too.
    let settings = &Settings {
        value_tolerance: settings.value_tolerance.max(TOLERANCE),
        ..*settings
    };
    let own = pool[me];
    let alone = || minimise::next(range, settings, own.done, own.in_flight);
    let lead = leader(pool.len());
    if me == lead {
        return alone();
    }
    let (done, in_flight) = in_range(range, own.done, own.in_flight);
    let (points, failed) = points(range, &done);
    // A third value (the pooled guess of its minimum, or a grid's) or a failed run: the state
    // point's own curvature decides from here, as for a search of its own.
    if points.len() > 2 || !failed.is_empty() {
        return alone();
    }
    let Some(prior) = Prior::of(range, pool, me) else {
        // The leader has not located a minimum yet: a follower starts from its answer.
        let leading = minimise::next(range, settings, pool[lead].done, pool[lead].in_flight);
        return match leading {
            Step::Done(_) => alone(),
            _ if !done.is_empty() || !in_flight.is_empty() => alone(),
            _ => Step::Wait,
        };
    };
    let c = prior.curvature;
    let allowed = settings
        .max_evaluations
        .saturating_sub(done.len() + in_flight.len());
    let taken = |x: f64| done.iter().any(|e| e.x == x) || in_flight.iter().any(|p| p.x == x);
    let positions = sorted(
        points
            .iter()
            .map(|p| p.t)
            .chain(in_flight.iter().map(|p| range.position(p.x))),
    );
    if positions.len() < 2 {
        let wanted: Vec<Proposal> = pair(&prior)
            .into_iter()
            .map(|t| range.value(t))
            .filter(|&x| !taken(x))
            .take(2 - positions.len())
            .map(|x| Proposal { x, repeat: 0 })
            .collect();
        return match (wanted.is_empty(), allowed) {
            (false, 1..) => Step::Propose(wanted.into_iter().take(allowed).collect()),
            _ if !in_flight.is_empty() => Step::Wait,
            _ => alone(),
        };
    }
    if !in_flight.is_empty() {
        return Step::Wait;
    }
    let Some(t_star) = two_run_minimum(&points, c) else {
        return alone();
    };
    let best = if points[0].mean() <= points[1].mean() {
        &points[0]
    } else {
        &points[1]
    };
    // Only between the two values, and only across a gap no wider than a pair's, 2 √(tol / c)
    // (√2 more, for a prior whose curvature grew since the pair was placed): beyond them the
    // shared curvature is an extrapolation, where a tail's relative slope can pass for the
    // gentle one near a minimum; across a wider gap (two runs of a grid) the state point's own
    // curvature matters more than the shared one.
    let (t1, t2) = (points[0].t, points[1].t);
    if (t1..=t2).contains(&t_star)
        && t2 - t1 <= 2.0 * (2.0 * TOLERANCE / c).sqrt()
        && c * (best.t - t_star).powi(2) <= TOLERANCE
    {
        return Step::Done(conclusion(range, &points, best, t_star, c));
    }
    // Its guess of the minimum next (unless as good as run already): then three values, its
    // own search.
    let t = t_star.clamp(0.0, 1.0);
    let x = range.value(t);
    let run_already = points.iter().any(|p| (p.t - t).abs() < 0.5 * PAIR_STEP);
    if run_already || taken(x) || allowed == 0 {
        return alone();
    }
    Step::Propose(vec![Proposal { x, repeat: 0 }])
}

impl Prior {
    /// The shared curvature and the expected minimum, from the siblings of `me`; none while no
    /// sibling's own runs make a convex parabola with its vertex among them.
    pub fn of(range: &Range, pool: &[Member], me: usize) -> Option<Prior> {
        let siblings: Vec<Vec<Point>> = pool
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != me)
            .map(|(_, m)| {
                let (done, _) = in_range(range, m.done, m.in_flight);
                points(range, &done).0
            })
            .collect();
        let fits: Vec<(f64, f64)> = siblings.iter().filter_map(|p| own_fit(p)).collect();
        let curvature = median(fits.iter().map(|&(_, c)| c).collect())?;
        let minima = siblings
            .iter()
            .filter_map(|p| match own_fit(p) {
                Some((t, _)) => Some(t),
                None if p.len() == 2 => two_run_minimum(p, curvature),
                None => None,
            })
            .map(|t| t.clamp(0.0, 1.0))
            .collect();
        Some(Prior {
            curvature,
            position: median(minima)?,
        })
    }
}

/// The positions of a follower's pair: `h` either side of the expected minimum, the largest
/// multiple of [`PAIR_STEP`] with c h² ≤ [`TOLERANCE`] (so that where the pair straddles the
/// minimum, its better run is within the tolerance), kept inside [0, 1].
pub fn pair(prior: &Prior) -> [f64; 2] {
    let h = ((TOLERANCE / prior.curvature).sqrt() / PAIR_STEP)
        .floor()
        .clamp(1.0, 8.0)
        * PAIR_STEP;
    let centre = ((prior.position / PAIR_STEP).round() * PAIR_STEP).clamp(h, 1.0 - h);
    [centre - h, centre + h]
}

/// The vertex position and relative curvature of the parabola a state point's own runs make,
/// where it is convex, lies among them and above zero.
fn own_fit(points: &[Point]) -> Option<(f64, f64)> {
    if points.len() < 3 {
        return None;
    }
    let evaluated: Vec<f64> = points.iter().map(|p| p.t).collect();
    let (t, value, c) = Around::best(points, &evaluated).vertex(points)?;
    (value > 0.0).then_some((t, c / value))
}

/// t* of ln y = α + c (t − t*)² through two values with c given (ln(1 + x) ≈ x near a
/// minimum): t* = (t₁ + t₂)/2 − (ln y₂ − ln y₁) / (2 c (t₂ − t₁)). None unless both are
/// positive at distinct positions.
fn two_run_minimum(points: &[Point], curvature: f64) -> Option<f64> {
    let [p1, p2] = points else {
        return None;
    };
    let (y1, y2) = (p1.mean(), p2.mean());
    if !(y1 > 0.0 && y2 > 0.0) || p1.t == p2.t || curvature <= 0.0 {
        return None;
    }
    let t = 0.5 * (p1.t + p2.t) - (y2.ln() - y1.ln()) / (2.0 * curvature * (p2.t - p1.t));
    t.is_finite().then_some(t)
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    Some(if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    })
}

/// The better run reported, with the positions the model cannot tell from the minimum: t*
/// give or take its 95 % error from the two means' noise, widened by where the model stays
/// within the better run's 95 % half-width of its minimum, and holding the better run.
fn conclusion(range: &Range, points: &[Point], best: &Point, t_star: f64, c: f64) -> Conclusion {
    let (s, t95) = noise::spread(points);
    let half_width = noise::half_width(best, (s, t95));
    let runs = |p: &Point| 1.0 / p.values.len() as f64;
    let error = t95 * s * (runs(&points[0]) + runs(&points[1])).sqrt()
        / (2.0 * c * (points[1].t - points[0].t).abs());
    let reach = (half_width / best.mean() / c).sqrt();
    let lower = (t_star - error - reach).min(best.t).max(0.0);
    let upper = (t_star + error + reach).max(best.t).min(1.0);
    Conclusion {
        best: Some(best.x),
        interval: Some([range.exact(lower), range.exact(upper)]),
        objective: Some(Objective {
            x: best.x,
            mean: best.mean(),
            half_width,
            runs: best.values.len(),
        }),
        evaluations: points.iter().map(|p| p.values.len()).sum(),
        stopped: Stopped::Pooled,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pair_straddles_the_prior_closer_where_the_curve_is_sharper() {
        let flat = pair(&Prior {
            curvature: 0.5,
            position: 0.5,
        });
        let sharp = pair(&Prior {
            curvature: 8.0,
            position: 0.5,
        });
        assert_eq!(flat, [0.3125, 0.6875]);
        assert_eq!(sharp, [0.46875, 0.53125]);
        // Kept inside the range at its ends.
        let end = pair(&Prior {
            curvature: 1.0,
            position: 0.99,
        });
        assert_eq!(end, [0.75, 1.0]);
    }

    #[test]
    fn two_runs_on_a_known_curvature_give_its_minimum() {
        let (c, t_star) = (2.0, 0.4);
        let at = |t: f64| Point {
            t,
            x: t,
            values: vec![30.0 * (c * (t - t_star) * (t - t_star)).exp()],
        };
        let t = two_run_minimum(&[at(0.5), at(0.7)], c).unwrap();
        assert!((t - t_star).abs() < 1e-12, "{t}");
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![]), None);
    }
}
