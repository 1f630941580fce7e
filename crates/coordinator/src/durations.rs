//! How long jobs really take, learned from the reports: per job kind (the family of a point),
//! the ratio of the time a job took from its lease to its report to the estimate its plan gave
//! it. A job is then expected to take its estimate times its kind's scale, the largest of the
//! kind's last [`SAMPLES`] ratios (pessimistic on purpose: a job started that cannot finish
//! before its allocation ends is lost). A kind not seen yet has scale 1: its estimate is trusted.
//!
//! Only jobs of at least [`MIN_OBSERVED_S`] (estimated or taken) teach anything: a short job's
//! time from lease to report is mostly the wait behind the jobs leased with it.
//!
//! Cost: O(1) per report, O(kinds) per question. Walltime-aware leasing
//! ([`crate::Coordinator::lease_within`]) and the allocator's sizing read it.

use std::collections::{HashMap, VecDeque};

use store::Ran;

/// Ratios kept per kind.
pub const SAMPLES: usize = 32;
/// The shortest job (estimated or taken, seconds) whose ratio is kept.
pub const MIN_OBSERVED_S: f64 = 1.0;

/// The observed ratios of each kind, newest last.
#[derive(Debug, Clone, Default)]
pub struct Durations {
    ratios: HashMap<String, VecDeque<f64>>,
}

impl Durations {
    /// Learns from one finished job.
    pub fn observe(&mut self, ran: &Ran) {
        let usable = ran.estimate_s > 0.0
            && ran.ran_s.is_finite()
            && ran.ran_s >= 0.0
            && ran.ran_s.max(ran.estimate_s) >= MIN_OBSERVED_S;
        if !usable {
            return;
        }
        let ratios = self.ratios.entry(ran.kind.clone()).or_default();
        if ratios.len() == SAMPLES {
            ratios.pop_front();
        }
        ratios.push_back(ran.ran_s / ran.estimate_s);
    }

    /// What a job of `kind` takes per second of its estimate: the largest recent ratio, 1 if none.
    pub fn scale(&self, kind: &str) -> f64 {
        self.ratios
            .get(kind)
            .and_then(|r| r.iter().copied().reduce(f64::max))
            .unwrap_or(1.0)
    }

    /// Every kind's scale (kinds not seen are absent: 1).
    pub fn scales(&self) -> HashMap<String, f64> {
        self.ratios
            .keys()
            .map(|kind| (kind.clone(), self.scale(kind)))
            .collect()
    }

    /// The seconds a job of `kind` estimated at `estimate_s` is expected to take.
    pub fn expected_s(&self, kind: &str, estimate_s: f64) -> f64 {
        estimate_s * self.scale(kind)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ran(kind: &str, estimate_s: f64, ran_s: f64) -> Ran {
        Ran {
            kind: kind.into(),
            estimate_s,
            ran_s,
        }
    }

    #[test]
    fn an_unseen_kind_is_trusted() {
        let d = Durations::default();
        assert_eq!(d.expected_s("edmd", 30.0), 30.0);
    }

    #[test]
    fn a_kind_slower_than_estimated_is_expected_slower() {
        let mut d = Durations::default();
        d.observe(&ran("edmd", 10.0, 25.0));
        d.observe(&ran("edmd", 10.0, 15.0));
        assert_eq!(d.scale("edmd"), 2.5, "the largest recent ratio");
        assert_eq!(d.expected_s("edmd", 4.0), 10.0);
        assert_eq!(d.scale("overlap"), 1.0, "per kind");
    }

    #[test]
    fn short_jobs_teach_nothing_and_old_ratios_are_forgotten() {
        let mut d = Durations::default();
        // 0.2 ms estimated, 50 ms from lease to report: waiting behind its batch.
        d.observe(&ran("noop", 0.0002, 0.05));
        d.observe(&ran("noop", 0.0, 3.0));
        assert_eq!(d.scale("noop"), 1.0);
        d.observe(&ran("overlap", 2.0, 8.0));
        for _ in 0..SAMPLES {
            d.observe(&ran("overlap", 2.0, 2.0));
        }
        assert_eq!(
            d.scale("overlap"),
            1.0,
            "the slow one is {SAMPLES} reports old"
        );
    }
}
