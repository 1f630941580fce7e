//! Adaptive search of one knob per state point (`[[tune]]` in a plan): which values to evaluate
//! next, and when to stop, decided afresh from the evaluations done.
//!
//! **Stateless by design.** [`next`] is a pure function of the search's settings, the
//! evaluations done and the ones in flight. Nothing else is kept, so a search survives a
//! restart of whatever drives it (it reads its evaluations back as ordinary jobs), an
//! evaluation a grid already ran counts as one of the search's, and two drivers that see the
//! same jobs make the same decision.
//!
//! **A lattice of values.** The knob is searched in log space: position `t` ∈ [0, 1] stands for
//! `lo · (hi/lo)^t`, rounded to [`lattice::SIGNIFICANT_DIGITS`] digits so that the values a plan
//! would print are the values run. Proposals lie on dyadic positions (k / 2^m), so a midpoint of
//! two proposals is again one and a repeated search proposes exactly the same values (the same
//! job ids).
//!
//! Two goals ([`Goal`]): the minimum of a noisy result field ([`minimise`]), and the loosest
//! value whose runs stay safe ([`loosest_safe`]). The minimisations of one `[[tune]]` table
//! share the shape of their curves: [`next_in_pool`] spends two runs on a state point where a
//! search of its own needs three or more ([`pool`]). [`drive`] reads a plan's searches' evaluations
//! from the database.

pub mod drive;
pub mod lattice;
pub mod loosest_safe;
pub mod minimise;
mod noise;
pub mod pool;
pub mod report;

pub use lattice::Range;

use serde::Serialize;

/// What a search looks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    /// The value of the knob with the smallest mean result.
    Minimise(minimise::Settings),
    /// The loosest value whose runs are all safe.
    LoosestSafe(loosest_safe::Settings),
}

/// One finished evaluation: the knob's value, which repeat of it (an independent run, e.g.
/// another seed), and what it gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    pub x: f64,
    pub repeat: u32,
    pub outcome: Outcome,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// The result field's value (minimisation).
    Value(f64),
    /// Whether the run was safe (loosest safe).
    Safe(bool),
    /// The run failed for good: never a candidate for a minimum, unsafe for a boundary.
    Failed,
}

/// An evaluation to run: the knob's value and which repeat of it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Proposal {
    pub x: f64,
    pub repeat: u32,
}

/// What the search does next.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Run these (none of them done or in flight).
    Propose(Vec<Proposal>),
    /// Nothing to add until an evaluation in flight finishes.
    Wait,
    Done(Conclusion),
}

/// Why a search stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stopped {
    /// The interval is narrower than the settings' tolerance.
    Converged,
    /// `max_evaluations` were spent first.
    Budget,
    /// No evaluation in the range gave a usable value (every run failed).
    NothingUsable,
    /// Loosest safe: even the tightest value of the range was unsafe.
    NoSafeValue,
    /// Loosest safe: the loosest value of the range is safe.
    RangeEndSafe,
    /// Minimisation pooled over a table's state points: the curvature the siblings share puts
    /// the minimum within [`pool::TOLERANCE`] of the better of this state point's two or three
    /// values.
    Pooled,
}

impl Stopped {
    /// The name reports give it (as serialised).
    pub fn as_str(self) -> &'static str {
        match self {
            Stopped::Converged => "converged",
            Stopped::Budget => "budget",
            Stopped::NothingUsable => "nothing_usable",
            Stopped::NoSafeValue => "no_safe_value",
            Stopped::RangeEndSafe => "range_end_safe",
            Stopped::Pooled => "pooled",
        }
    }
}

/// The answer of a finished search.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conclusion {
    /// The value found: the minimum (the vertex of the parabola through the bracket where it
    /// lies inside it, else the best evaluated value), or the last safe value.
    pub best: Option<f64>,
    /// Where the answer lies: the bracket of the minimum, or [last safe, first unsafe].
    pub interval: Option<[f64; 2]>,
    /// Minimisation: the mean result at the best evaluated value, its 95 % half-width, and how
    /// many runs it pools.
    pub objective: Option<Objective>,
    /// Evaluations of the search in the range (repeats included).
    pub evaluations: usize,
    pub stopped: Stopped,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Objective {
    pub x: f64,
    pub mean: f64,
    pub half_width: f64,
    pub runs: usize,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TuneError {
    #[error(
        "the range [{lo}, {hi}] is not searchable in log space: it needs 0 < lo < hi, both finite"
    )]
    Range { lo: f64, hi: f64 },
    #[error("{what} must be at least {min} (is {value})")]
    Setting {
        what: &'static str,
        min: f64,
        value: f64,
    },
}

/// The next step of a search over `range` for `goal`, given every evaluation done (any value in
/// the range counts, the search's own or a grid's; values outside it are ignored) and the
/// proposals in flight.
pub fn next(range: &Range, goal: &Goal, done: &[Evaluation], in_flight: &[Proposal]) -> Step {
    match goal {
        Goal::Minimise(settings) => minimise::next(range, settings, done, in_flight),
        Goal::LoosestSafe(settings) => loosest_safe::next(range, settings, done, in_flight),
    }
}

/// [`next`] for search `me` of a pool: the searches of one `[[tune]]` table, which share the
/// shape of their curves ([`pool`]; [`pool::leader`] leads). A search that loosens a knob, or a pool of
/// one, decides from its own evaluations alone.
pub fn next_in_pool(range: &Range, goal: &Goal, pool: &[pool::Member], me: usize) -> Step {
    match goal {
        Goal::Minimise(settings) if pool.len() > 1 => pool::next(range, settings, pool, me),
        _ => next(range, goal, pool[me].done, pool[me].in_flight),
    }
}

/// The next repeat index of `x` not done and not in flight.
fn next_repeat(x: f64, done: &[&Evaluation], in_flight: &[&Proposal]) -> u32 {
    let done = done.iter().filter(|e| e.x == x).map(|e| e.repeat);
    let flying = in_flight.iter().filter(|p| p.x == x).map(|p| p.repeat);
    done.chain(flying).map(|r| r + 1).max().unwrap_or(0)
}

/// The evaluations done and in flight at values inside the range (a grid's runs outside it
/// belong to no search of it).
fn in_range<'a>(
    range: &Range,
    done: &'a [Evaluation],
    in_flight: &'a [Proposal],
) -> (Vec<&'a Evaluation>, Vec<&'a Proposal>) {
    (
        done.iter().filter(|e| range.contains(e.x)).collect(),
        in_flight.iter().filter(|p| range.contains(p.x)).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::Stopped;

    #[test]
    fn a_stop_is_named_as_it_is_serialised() {
        for s in [
            Stopped::Converged,
            Stopped::Budget,
            Stopped::NothingUsable,
            Stopped::NoSafeValue,
            Stopped::RangeEndSafe,
            Stopped::Pooled,
        ] {
            assert_eq!(serde_json::to_value(s).unwrap(), s.as_str());
        }
    }
}
