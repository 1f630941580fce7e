//! How many jobs a slot leases at once, and when it asks for the next ones.
//!
//! A slot leases as many jobs as it expects to run within [`WINDOW`], from the run times it has
//! observed: one at a time for timing jobs that last longer than the window, up to [`MAX_BATCH`]
//! for jobs of microseconds, whose round trips would otherwise cost more than the jobs. It asks
//! for the next lease before the current one runs out (prefetch) only for such short jobs, when
//! what is left to run is about a round trip: long jobs are never held unstarted, so a cluster of
//! long jobs runs exactly one job per slot at a time.
//!
//! The estimate can be wrong (a plan mixing short and long points): the slot itself never starts
//! a job whose lease it has held unstarted for half the lease duration — it gives such leases back
//! ([`crate::slots`]) — so no worker hoards jobs it cannot start within their lease.

use std::time::Duration;

/// The work one lease should cover: short against any lease duration and against the time a
/// result waits for its report, long against a round trip to the coordinator.
pub const WINDOW: Duration = Duration::from_millis(100);

/// The most jobs one lease asks for (bounds one transaction and one message).
pub const MAX_BATCH: u32 = 512;

/// Weight of the newest observation in the moving averages.
const SMOOTHING: f64 = 0.25;

/// A slot's observations: how long its jobs and its lease calls take.
#[derive(Debug, Clone, Default)]
pub struct Pace {
    /// Moving average of one job's run time; `None` until one job has run.
    job_s: Option<f64>,
    /// Moving average of a lease call's round trip.
    lease_s: Option<f64>,
}

fn smooth(average: &mut Option<f64>, sample: Duration) {
    let sample = sample.as_secs_f64();
    *average = Some(match *average {
        Some(previous) => previous + SMOOTHING * (sample - previous),
        None => sample,
    });
}

impl Pace {
    pub fn observe_job(&mut self, took: Duration) {
        smooth(&mut self.job_s, took);
    }

    pub fn observe_lease(&mut self, took: Duration) {
        smooth(&mut self.lease_s, took);
    }

    /// Jobs to ask for: as many as fit in [`WINDOW`]; one before any job has been seen.
    pub fn batch(&self) -> u32 {
        match self.job_s {
            Some(job_s) if job_s > 0.0 => {
                (WINDOW.as_secs_f64() / job_s).clamp(1.0, MAX_BATCH as f64) as u32
            }
            Some(_) => MAX_BATCH,
            None => 1,
        }
    }

    /// Whether jobs have been seen to last less than the window. Only short jobs are prefetched
    /// and reported while the next ones run: for long ones a round trip costs nothing, and a slot
    /// then holds exactly one lease at a time.
    pub fn short_jobs(&self) -> bool {
        self.job_s.is_some_and(|job_s| job_s < WINDOW.as_secs_f64())
    }

    /// Whether to ask for the next lease now, with `left` jobs of the current one still to run
    /// (this one included): only for short jobs, once what is left would be done within two
    /// round trips, and at the latest when the last job starts.
    pub fn prefetch_now(&self, left: usize) -> bool {
        let Some(job_s) = self.job_s.filter(|_| self.short_jobs()) else {
            return false;
        };
        let round_trip_s = self.lease_s.unwrap_or(0.0);
        left <= 1 || left as f64 * job_s <= 2.0 * round_trip_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn after(jobs: &[Duration]) -> Pace {
        let mut pace = Pace::default();
        jobs.iter().for_each(|&took| pace.observe_job(took));
        pace
    }

    #[test]
    fn a_fresh_slot_asks_for_one_job_and_does_not_prefetch() {
        let pace = Pace::default();
        assert_eq!(pace.batch(), 1);
        assert!(!pace.prefetch_now(1));
    }

    #[test]
    fn the_batch_covers_the_window() {
        assert_eq!(after(&[Duration::from_micros(5)]).batch(), MAX_BATCH);
        assert_eq!(after(&[Duration::ZERO]).batch(), MAX_BATCH);
        assert_eq!(after(&[Duration::from_millis(1)]).batch(), 100);
        assert_eq!(after(&[Duration::from_millis(30)]).batch(), 3);
        // Timing jobs: one at a time.
        assert_eq!(after(&[Duration::from_millis(150)]).batch(), 1);
        assert_eq!(after(&[Duration::from_secs(20)]).batch(), 1);
    }

    #[test]
    fn the_batch_follows_a_change_of_job_length() {
        let mut pace = after(&[Duration::from_micros(10); 4]);
        assert_eq!(pace.batch(), MAX_BATCH);
        for _ in 0..3 {
            pace.observe_job(Duration::from_secs(2));
        }
        assert_eq!(pace.batch(), 1, "long jobs after short ones");
    }

    #[test]
    fn long_jobs_are_never_prefetched() {
        let mut pace = after(&[Duration::from_millis(500)]);
        pace.observe_lease(Duration::from_secs(1));
        for left in [0, 1, 2] {
            assert!(!pace.prefetch_now(left), "left {left}");
        }
    }

    #[test]
    fn short_jobs_prefetch_about_a_round_trip_before_the_end() {
        let mut pace = after(&[Duration::from_micros(10)]);
        pace.observe_lease(Duration::from_micros(500));
        // 2 × 500 µs of round trip covers 100 jobs of 10 µs.
        assert!(pace.prefetch_now(100));
        assert!(!pace.prefetch_now(101));
        assert!(pace.prefetch_now(1), "at the latest with the last job");
    }
}
