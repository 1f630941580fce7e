//! The loosest value of an accuracy knob (ε_d, nr_tol) whose runs stay safe: bisection in log
//! space between the last safe and the first unsafe value.
//!
//! A value is safe when every run at it was judged safe (the driver applies the accuracy report's
//! rule: no overlap, no solver failure, energy drift within bounds, Z within 3 combined standard
//! errors of the tightest setting, no failed run); one unsafe or failed run makes it unsafe. The
//! tightest value of the range is run first (the reference the rule compares Z with) together
//! with the loosest. The boundary is the first unsafe value above the last safe one below it, so
//! a non-monotone knob is answered conservatively. Before it stops, the last safe value is run
//! `confirmations` more times (other seeds): safety is a rare-event verdict, and one lucky run
//! must not make a value look safe.

use crate::lattice::{Range, split};
use crate::{
    Conclusion, Evaluation, Outcome, Proposal, Step, Stopped, TuneError, in_range, next_repeat,
};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pub max_evaluations: usize,
    /// The width of [last safe, first unsafe] (as a fraction of the log range) at which it stops.
    pub tolerance: f64,
    /// Runs of the last safe value beyond its first before it is reported.
    pub confirmations: usize,
    /// Whether larger values are looser (ε_d, nr_tol: larger is cheaper and less accurate).
    pub loose_is_high: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            max_evaluations: 12,
            tolerance: 0.1,
            confirmations: 1,
            loose_is_high: true,
        }
    }
}

impl Settings {
    pub fn new(
        max_evaluations: usize,
        tolerance: f64,
        confirmations: usize,
        loose_is_high: bool,
    ) -> Result<Self, TuneError> {
        if max_evaluations < 2 {
            return Err(TuneError::Setting {
                what: "max_evaluations",
                min: 2.0,
                value: max_evaluations as f64,
            });
        }
        if !(tolerance > 0.0 && tolerance < 1.0) {
            return Err(TuneError::Setting {
                what: "tolerance (a fraction of the range, below 1)",
                min: 0.0,
                value: tolerance,
            });
        }
        Ok(Settings {
            max_evaluations,
            tolerance,
            confirmations,
            loose_is_high,
        })
    }
}

/// The runs at one value: its looseness (0 the tightest end of the range, 1 the loosest).
struct Value {
    looseness: f64,
    x: f64,
    runs: usize,
    safe: bool,
}

pub fn next(
    range: &Range,
    settings: &Settings,
    done: &[Evaluation],
    in_flight: &[Proposal],
) -> Step {
    let (done, in_flight) = in_range(range, done, in_flight);
    let allowed = settings
        .max_evaluations
        .saturating_sub(done.len() + in_flight.len());
    let looseness = |x: f64| {
        let t = range.position(x);
        if settings.loose_is_high { t } else { 1.0 - t }
    };
    let at = |l: f64| range.value(if settings.loose_is_high { l } else { 1.0 - l });
    let mut values: Vec<Value> = Vec::new();
    for e in &done {
        // A minimisation's values say nothing of safety: not counted as safe.
        let safe = matches!(e.outcome, Outcome::Safe(true));
        match values.iter_mut().find(|v| v.x == e.x) {
            Some(v) => {
                v.runs += 1;
                v.safe &= safe;
            }
            None => values.push(Value {
                looseness: looseness(e.x),
                x: e.x,
                runs: 1,
                safe,
            }),
        }
    }
    let flying = |x: f64| in_flight.iter().any(|p| p.x == x);
    let first_unsafe = values
        .iter()
        .filter(|v| !v.safe)
        .min_by(|a, b| a.looseness.total_cmp(&b.looseness));
    let unsafe_at = first_unsafe.map_or(f64::INFINITY, |v| v.looseness);
    let last_safe = values
        .iter()
        .filter(|v| v.safe && v.looseness < unsafe_at)
        .max_by(|a, b| a.looseness.total_cmp(&b.looseness));

    let mut wanted = Vec::new();
    for end in [0.0, 1.0] {
        let x = at(end);
        if !values.iter().any(|v| v.x == x) && !flying(x) {
            wanted.push(Proposal { x, repeat: 0 });
        }
    }
    let tightest = values.iter().find(|v| v.x == at(0.0));
    let conclude = |stopped, safe: Option<&Value>, unsafe_: Option<&Value>| {
        Step::Done(Conclusion {
            best: safe.map(|v| v.x),
            interval: safe.map(|s| [s.x, unsafe_.map_or(s.x, |u| u.x)]),
            objective: None,
            evaluations: done.len(),
            stopped,
        })
    };
    if tightest.is_some_and(|v| !v.safe) && in_flight.is_empty() {
        return conclude(Stopped::NoSafeValue, None, first_unsafe);
    }
    if let (true, Some(safe)) = (wanted.is_empty(), last_safe) {
        let in_between = in_flight
            .iter()
            .any(|p| (safe.looseness..=unsafe_at).contains(&looseness(p.x)));
        let converged = unsafe_at - safe.looseness <= settings.tolerance;
        if !converged && !in_between {
            let x = at(split(safe.looseness, unsafe_at.min(1.0)));
            if x != safe.x && first_unsafe.is_none_or(|u| u.x != x) {
                wanted.push(Proposal { x, repeat: 0 });
            }
        }
        let unconfirmed = safe.runs < 1 + settings.confirmations;
        if (converged || wanted.is_empty() && !in_between) && unconfirmed && !flying(safe.x) {
            wanted.push(Proposal {
                x: safe.x,
                repeat: next_repeat(safe.x, &done, &in_flight),
            });
        }
    }
    if !wanted.is_empty() && allowed > 0 {
        return Step::Propose(wanted.into_iter().take(allowed).collect());
    }
    if !in_flight.is_empty() {
        return Step::Wait;
    }
    let stopped = if !wanted.is_empty() || last_safe.is_none() {
        Stopped::Budget
    } else if first_unsafe.is_none() {
        Stopped::RangeEndSafe
    } else {
        Stopped::Converged
    };
    conclude(stopped, last_safe, first_unsafe)
}
