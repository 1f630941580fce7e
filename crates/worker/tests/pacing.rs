//! How many jobs the slots lease and when: a fake queue records every call, and real slots run
//! real no-op jobs (of a chosen duration) against it.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use jobs::{JobSpec, NoopSpec};
use queue::{
    CompleteOutcome, Completion, FailOutcome, Granted, JobQueue, Lease, LeaseRef, QueueError,
};
use worker::{Slots, WorkerOptions};

/// A queue of `jobs` no-op jobs of `duration_ms`; hands out what is asked, or a fixed `forced`
/// number whatever is asked (a coordinator that over-leases, or an estimate gone wrong).
struct Recorder {
    duration_ms: u64,
    forced: Option<u32>,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    next: u64,
    jobs: u64,
    /// `max_jobs` of every lease call that found jobs.
    asked: Vec<u32>,
    /// Leases handed out and neither completed nor released yet, and the most ever outstanding.
    outstanding: u64,
    peak_outstanding: u64,
    completed: Vec<String>,
    released: Vec<String>,
}

impl Recorder {
    fn new(jobs: u64, duration_ms: u64, forced: Option<u32>) -> Arc<Recorder> {
        Arc::new(Recorder {
            duration_ms,
            forced,
            state: Mutex::new(State {
                jobs,
                ..Default::default()
            }),
        })
    }

    fn settled(&self) -> u64 {
        let state = self.state.lock().unwrap();
        (state.completed.len() + state.released.len()) as u64
    }
}

impl JobQueue for Recorder {
    async fn lease(&self, max_jobs: u32, _: Option<f64>) -> Result<Granted, QueueError> {
        let mut state = self.state.lock().unwrap();
        let n = u64::from(self.forced.unwrap_or(max_jobs)).min(state.jobs - state.next);
        if n == 0 {
            return Ok(Granted::default());
        }
        state.asked.push(max_jobs);
        let leases: Vec<Lease> = (state.next..state.next + n)
            .map(|index| {
                let spec = JobSpec::Noop(NoopSpec {
                    index,
                    duration_ms: self.duration_ms,
                    fail_rate: 0.0,
                });
                Lease {
                    job_id: format!("job{index}"),
                    kind: "noop".into(),
                    params_json: serde_json::to_string(&spec).expect("a noop spec serialises"),
                    attempt: 1,
                    token: index as i64,
                    expires_at: f64::NAN,
                    exclusive: false,
                }
            })
            .collect();
        state.next += n;
        state.outstanding += n;
        state.peak_outstanding = state.peak_outstanding.max(state.outstanding);
        Ok(Granted {
            leases,
            passed_over: 0,
        })
    }

    async fn heartbeat(&self, held: Vec<LeaseRef>) -> Result<Vec<LeaseRef>, QueueError> {
        Ok(held)
    }

    async fn complete(
        &self,
        completions: Vec<Completion>,
    ) -> Result<Vec<CompleteOutcome>, QueueError> {
        let mut state = self.state.lock().unwrap();
        state.outstanding -= completions.len() as u64;
        state
            .completed
            .extend(completions.iter().map(|c| c.job_id.clone()));
        Ok(vec![CompleteOutcome::Accepted; completions.len()])
    }

    async fn fail(&self, lease: &LeaseRef, error: String) -> Result<FailOutcome, QueueError> {
        panic!("job {} failed: {error}", lease.job_id)
    }

    async fn release(&self, leases: Vec<LeaseRef>) -> Result<(), QueueError> {
        let mut state = self.state.lock().unwrap();
        state.outstanding -= leases.len() as u64;
        state.released.extend(leases.into_iter().map(|l| l.job_id));
        Ok(())
    }
}

fn run(queue: Arc<Recorder>, lease_for: Duration, until_settled: u64) {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("a runtime");
    let options = WorkerOptions {
        cores: vec![0],
        heartbeat_every: lease_for / 4,
        idle_poll: Duration::from_millis(10),
        lease_batch: None,
        lease_for,
        deadline: None,
        idle_timeout: None,
        child_exe: None,
    };
    let slots =
        Slots::start(queue.clone(), options, runtime.handle().clone()).expect("slots start");
    let started = Instant::now();
    while queue.settled() < until_settled {
        assert!(started.elapsed() < Duration::from_secs(30), "timed out");
        std::thread::sleep(Duration::from_millis(5));
    }
    slots.stop();
    slots.join();
}

/// Jobs longer than the pacing window: every lease asks for one job, and the slot never holds a
/// second lease while one runs (no prefetch, report before the next lease).
#[test]
fn long_jobs_are_leased_one_at_a_time() {
    let queue = Recorder::new(6, 150, None);
    run(queue.clone(), Duration::from_secs(60), 6);
    let state = queue.state.lock().unwrap();
    assert_eq!(state.completed.len(), 6);
    assert_eq!(state.asked, [1; 6], "lease sizes asked");
    assert_eq!(state.peak_outstanding, 1, "a slot held more than one lease");
}

/// Jobs of microseconds: after the first, leases grow to hundreds of jobs, and the next lease is
/// asked for while the current one runs.
#[test]
fn short_jobs_are_leased_by_the_hundred_and_prefetched() {
    let queue = Recorder::new(5_000, 0, None);
    run(queue.clone(), Duration::from_secs(60), 5_000);
    let state = queue.state.lock().unwrap();
    assert_eq!(state.completed.len(), 5_000);
    assert!(state.released.is_empty());
    assert_eq!(state.asked[0], 1, "a fresh slot knows nothing of its jobs");
    assert!(
        state.asked.iter().skip(1).all(|&n| n >= 100),
        "{:?}",
        state.asked
    );
    assert!(state.asked.len() < 30, "{} lease calls", state.asked.len());
    assert!(
        state.peak_outstanding > u64::from(state.asked[1]),
        "never prefetched: {:?}",
        state.asked
    );
}

/// Leases the slot cannot start within half their duration are given back, not started late
/// and not sat on: 5 jobs of 300 ms forced on one slot with 1 s leases.
#[test]
fn leases_not_started_within_half_their_duration_are_given_back() {
    let queue = Recorder::new(5, 300, Some(5));
    run(queue.clone(), Duration::from_secs(1), 5);
    let state = queue.state.lock().unwrap();
    assert_eq!(state.asked.len(), 1);
    let mut completed = state.completed.clone();
    completed.sort();
    // Started at about 0, 300 and 600 ms: the third is past 500 ms.
    assert_eq!(completed, ["job0", "job1"]);
    assert_eq!(state.released, ["job2", "job3", "job4"]);
}
