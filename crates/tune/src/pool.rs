//! A minimisation pooled over the state points of one `[[tune]]` table: the curves τ_p(t) of
//! neighbouring state points share their shape, so a state point needs two runs where a search
//! of its own needs three at least (a minimum located from its own runs alone needs a parabola).
//!
//! The model, in the log position t: τ_p(t) ≈ a_p (1 + c (t − t*_p)²), the curvature c shared
//! by the table, the level a_p and the minimum t*_p the state point's own.
//! - **The leader** ([`leader`]: the middle state point of the table's order, for a table swept
//!   over φ the middle φ, whose minimum is nearer to most siblings' than an end's) searches on
//!   its own ([`crate::minimise`]).
//! - **The prior**: c is the leader's relative curvature (c / vertex value) of the parabola
//!   its own runs make (convex, vertex among them: its first three runs usually; while it has
//!   none, the median over the siblings that have one). The expected minimum of a **scout**
//!   (a follower whose state point differs from the leader's in one key, φ or X0) is the
//!   leader's minimum; a follower that differs in both keys waits for the two scouts with its
//!   φ and its X0 and expects the leader's minimum moved by both scouts' shifts ([`scouts`]:
//!   additive in the keys, as Δ*_NNL moves with φ much as it does whatever X0, EDMD paper
//!   Fig. 11; a measured table's minima move by 0.2–0.3 of the log range between its φ, more
//!   than a pair's half-width, so the leader's alone is no prior for the far rows).
//! - **A follower** waits while the leader has not located a minimum, then runs a pair
//!   straddling the expected minimum, `h` either side where c h² ≤ [`TOLERANCE`] (so that where
//!   the pair straddles its minimum, the better run is within it). From its values y_i at t_i
//!   and the shared c, its own minimum t* is the least-squares fit of ln y = α + c (t − t*)²
//!   (`pooled_minimum`; through two values t* = (t₁ + t₂)/2 − (ln y₂ − ln y₁) /
//!   (2 c (t₂ − t₁))), and the model puts its better run c (t_best − t*)² above its minimum.
//!   With t* between two values no further apart than a pair, and within [`TOLERANCE`]:
//!   stopped ([`Stopped::Pooled`]), t* reported (as a search of its own reports its vertex)
//!   with the better run as the objective. Else a third value is run: t*, or beyond the pair
//!   half a pair past it (the pair's near value and the third then hold the minimum between
//!   them where the curve is gentler on that side than the shared curvature says), at most two
//!   pair widths out; the three are judged as the pair was, and must agree by their own
//!   parabola too (convex, the better run within [`TOLERANCE`] of its vertex). A state point
//!   with a fourth value, or a failed run, or a prior that is gone, searches on its own from
//!   what it has. Without noise a wrong expected minimum costs runs, not the answer; a curve
//!   r× sharper than the shared curvature says puts a pooled stop up to r× [`TOLERANCE`] above
//!   its minimum, which two runs cannot tell (tests/pool.rs). With noise of a few per cent a
//!   pair far down a flank can pass for one straddling the minimum (MEASUREMENTS.md gives how
//!   often).
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
/// fraction of the minimum. Three per cent is about one run's noise (the same scene run twice
/// on a shared VM: 1.5–2 % apart) and well below the 5 % over which Fig. 10's minima are flat:
/// a tolerance below the noise buys pairs too narrow for two runs to place a minimum in (two
/// per cent cost 15.0 runs per table of the measured curves at 2 % noise, 15 % of the tables
/// over 16, for as many state points within 5 %: MEASUREMENTS.md).
pub const TOLERANCE: f64 = 0.03;

/// Positions of a follower's pair lie on multiples of this (dyadic, so the pair of a repeated
/// search is the same values).
const PAIR_STEP: f64 = 1.0 / 32.0;

/// The evaluations of one search of a pool (those outside the range are ignored), and where its
/// state point lies in the table.
#[derive(Clone, Copy, Debug)]
pub struct Member<'a> {
    pub done: &'a [Evaluation],
    pub in_flight: &'a [Proposal],
    /// The values of the keys the table sweeps (φ and X0 for EDMD): only compared for
    /// equality, to find the siblings that differ from the leader in one key ([`scouts`]).
    pub coordinates: [f64; 2],
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
    // A fourth value or a failed run: the state point's own curvature decides from here, as for
    // a search of its own.
    if points.len() > 3 || !failed.is_empty() {
        return alone();
    }
    // A follower whose state point differs from the leader's in both keys starts from its
    // scouts' minima: it waits for them as it waits for the leader.
    if done.is_empty() && in_flight.is_empty() && scouts_pending(range, settings, pool, me) {
        return Step::Wait;
    }
    let Some(prior) = Prior::of(range, settings, pool, me) else {
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
    let Some(t_star) = pooled_minimum(&points, c) else {
        return alone();
    };
    let best = points
        .iter()
        .min_by(|a, b| a.mean().total_cmp(&b.mean()))
        .expect("two values at least");
    // Only between two values, and only across a gap no wider than a pair's, 2 √(tol / c)
    // (√2 more, for a prior whose curvature grew since the pair was placed): beyond them the
    // shared curvature is an extrapolation, where a tail's relative slope can pass for the
    // gentle one near a minimum; across a wider gap (two runs of a grid) the state point's own
    // curvature matters more than the shared one.
    let bracket = points
        .windows(2)
        .find(|w| (w[0].t..=w[1].t).contains(&t_star));
    // Three values must say it themselves too: their own parabola convex with its vertex among
    // them and the better run within the tolerance of it (a curvature unlike the shared one
    // puts the shared model's minimum anywhere between three values, down one flank too).
    let convex = points.len() == 2
        || own_fit(&points).is_some_and(|(t, own)| own * (best.t - t).powi(2) <= TOLERANCE);
    if let Some(w) = bracket
        && convex
        && w[1].t - w[0].t <= 2.0 * (2.0 * TOLERANCE / c).sqrt()
        && c * (best.t - t_star).powi(2) <= TOLERANCE
    {
        return Step::Done(conclusion(range, &points, best, t_star, c));
    }
    if points.len() > 2 {
        return alone();
    }
    // Its guess of the minimum next (unless as good as run already): then three values, judged
    // as the pair was, then its own search. Beyond the pair, half a pair's width past the guess
    // (the shared curvature's guess falls short where the curve is gentler on that side, and
    // then the pair's near value and this one hold the minimum between them), and no further
    // out than two widths: there the slope of two runs says where to look, not how far (a curve
    // steeper on one side than the shared one, or the noise, would send the run far down a
    // flank).
    let (t1, t2) = (points[0].t, points[1].t);
    let width = t2 - t1;
    let past = if t_star > t2 {
        0.5 * width
    } else if t_star < t1 {
        -0.5 * width
    } else {
        0.0
    };
    let t = (t_star + past)
        .clamp(t1 - 2.0 * width, t2 + 2.0 * width)
        .clamp(0.0, 1.0);
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
    ///
    /// The expected minimum is the leader's, moved by what each key in which `me` differs from
    /// the leader moved it for that key's scout (additive in the keys: Δ* moves with φ much as
    /// it does whatever X0, EDMD paper Fig. 11); a scout's own is the leader's. Without a
    /// located leader (a grid's runs elsewhere), the median of the siblings' minima.
    pub fn of(range: &Range, settings: &Settings, pool: &[Member], me: usize) -> Option<Prior> {
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
        let lead = leader(pool.len());
        let leading = (me != lead)
            .then(|| {
                let (done, _) = in_range(range, pool[lead].done, pool[lead].in_flight);
                own_fit(&points(range, &done).0)
            })
            .flatten();
        // The leader's curvature while it has one: a sibling's third value must not change the
        // curvature a pair was placed and is judged by (a scout's own search adds to the
        // siblings' fits while the others' pairs run).
        let curvature = match leading {
            Some((_, c)) => c,
            None => median(fits.iter().map(|&(_, c)| c).collect())?,
        };
        let position = match leading {
            Some((base, _)) => {
                let shift: f64 = scouts(pool, me)
                    .into_iter()
                    .flatten()
                    .filter_map(|s| located(range, settings, pool, s))
                    .map(|t| t - base)
                    .sum();
                base + shift
            }
            None => median(
                siblings
                    .iter()
                    .filter_map(|p| match own_fit(p) {
                        Some((t, _)) => Some(t),
                        None if p.len() == 2 => pooled_minimum(p, curvature),
                        None => None,
                    })
                    .map(|t| t.clamp(0.0, 1.0))
                    .collect(),
            )?,
        };
        Some(Prior {
            curvature,
            position: position.clamp(0.0, 1.0),
        })
    }
}

/// The scout of `me` for each key in which `me` differs from the leader, where `me` differs in
/// more than one (a scout differs in one key only, and starts from the leader's minimum): the
/// sibling with `me`'s value of that key and the leader's of the other, if the table has it.
pub fn scouts(pool: &[Member], me: usize) -> Vec<Option<usize>> {
    let lead = pool[leader(pool.len())].coordinates;
    let mine = pool[me].coordinates;
    let differ: Vec<usize> = (0..mine.len()).filter(|&k| mine[k] != lead[k]).collect();
    if differ.len() < 2 {
        return Vec::new();
    }
    differ
        .into_iter()
        .map(|k| {
            let mut at = lead;
            at[k] = mine[k];
            pool.iter().position(|m| m.coordinates == at)
        })
        .collect()
}

/// Whether a scout of `me` has not finished yet.
fn scouts_pending(range: &Range, settings: &Settings, pool: &[Member], me: usize) -> bool {
    scouts(pool, me)
        .into_iter()
        .flatten()
        .any(|s| !matches!(next(range, settings, pool, s), Step::Done(_)))
}

/// Where a finished search located its minimum (the position of the value it reports); none
/// while it runs.
fn located(range: &Range, settings: &Settings, pool: &[Member], s: usize) -> Option<f64> {
    match next(range, settings, pool, s) {
        Step::Done(c) => c.best.map(|x| range.position(x)),
        _ => None,
    }
}

/// The positions of a follower's pair: `h` either side of the expected minimum, the largest
/// multiple of `PAIR_STEP` with c h² ≤ [`TOLERANCE`] (so that where the pair straddles the
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

/// t* of ln y = α + c (t − t*)² fitted to two values or more with c given (ln(1 + x) ≈ x
/// near a minimum): ln y − c t² = α + c t*² − 2 c t* t is a line in t, fitted by least squares
/// (each value weighted by its runs); through two values t* = (t₁ + t₂)/2 − (ln y₂ − ln y₁) /
/// (2 c (t₂ − t₁)). None unless every value is positive and two positions differ.
fn pooled_minimum(points: &[Point], curvature: f64) -> Option<f64> {
    let positive = points.iter().all(|p| p.mean() > 0.0);
    if points.len() < 2 || !positive || curvature <= 0.0 {
        return None;
    }
    let weight = |p: &Point| p.values.len() as f64;
    let total: f64 = points.iter().map(weight).sum();
    let centre = points.iter().map(|p| weight(p) * p.t).sum::<f64>() / total;
    let z = |p: &Point| p.mean().ln() - curvature * p.t * p.t;
    let z_mean = points.iter().map(|p| weight(p) * z(p)).sum::<f64>() / total;
    let spread = spread_of(points);
    let covariance: f64 = points
        .iter()
        .map(|p| weight(p) * (p.t - centre) * (z(p) - z_mean))
        .sum();
    let t = -covariance / spread / (2.0 * curvature);
    (spread > 0.0 && t.is_finite()).then_some(t)
}

/// Σ n_i (t_i − t̄)² over the values, t̄ weighted by their runs n_i.
fn spread_of(points: &[Point]) -> f64 {
    let weight = |p: &Point| p.values.len() as f64;
    let total: f64 = points.iter().map(weight).sum();
    let centre = points.iter().map(|p| weight(p) * p.t).sum::<f64>() / total;
    points
        .iter()
        .map(|p| weight(p) * (p.t - centre).powi(2))
        .sum()
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

/// The model's minimum t* reported (as a search of its own reports its parabola's vertex), the
/// better run as the objective, with the positions the model cannot tell from the minimum: t*
/// give or take its 95 % error from the means' noise, widened by where the model stays within
/// the better run's 95 % half-width of its minimum, and holding the better run.
fn conclusion(range: &Range, points: &[Point], best: &Point, t_star: f64, c: f64) -> Conclusion {
    let (s, t95) = noise::spread(points);
    let half_width = noise::half_width(best, (s, t95));
    // The slope of the line t* comes from has the variance s² / Σ n_i (t_i − t̄)².
    let error = t95 * s / (2.0 * c * spread_of(points).sqrt());
    let reach = (half_width / best.mean() / c).sqrt();
    let lower = (t_star - error - reach).min(best.t).max(0.0);
    let upper = (t_star + error + reach).max(best.t).min(1.0);
    Conclusion {
        best: Some(range.exact(t_star.clamp(0.0, 1.0))),
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
        assert_eq!(flat, [0.28125, 0.71875]);
        assert_eq!(sharp, [0.46875, 0.53125]);
        // Kept inside the range at its ends.
        let end = pair(&Prior {
            curvature: 1.0,
            position: 0.99,
        });
        assert_eq!(end, [0.6875, 1.0]);
    }

    #[test]
    fn two_runs_on_a_known_curvature_give_its_minimum() {
        let (c, t_star) = (2.0, 0.4);
        let at = |t: f64| Point {
            t,
            x: t,
            values: vec![30.0 * (c * (t - t_star) * (t - t_star)).exp()],
        };
        let t = pooled_minimum(&[at(0.5), at(0.7)], c).unwrap();
        assert!((t - t_star).abs() < 1e-12, "{t}");
        let t = pooled_minimum(&[at(0.2), at(0.5), at(0.7)], c).unwrap();
        assert!((t - t_star).abs() < 1e-12, "{t}");
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![]), None);
    }
}
