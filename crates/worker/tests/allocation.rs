//! A worker in an allocation that ends: it tells the coordinator the time it has left, stops when
//! nothing queued fits in it or at its deadline, and stops when it has had no job for its idle
//! timeout. A fake queue plays the coordinator's part of the rule (a job is leased only if it
//! fits, one after the other, in the seconds the worker says it has left).

use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use jobs::{JobSpec, NoopSpec};
use queue::{
    CompleteOutcome, Completion, FailOutcome, Granted, JobQueue, Lease, LeaseRef, QueueError,
};
use worker::{Slots, WorkerOptions};

/// Queued no-op jobs, each with the seconds the coordinator expects it to take.
struct Fitting {
    queued: Mutex<Vec<(Lease, f64)>>,
    /// `seconds_left` of every lease call.
    asked: Mutex<Vec<Option<f64>>>,
    completed: Mutex<Vec<String>>,
}

fn noop(index: u64, duration_ms: u64) -> Lease {
    let spec = JobSpec::Noop(NoopSpec {
        index,
        duration_ms,
        fail_rate: 0.0,
    });
    Lease {
        job_id: format!("job{index}"),
        kind: "noop".into(),
        params_json: serde_json::to_string(&spec).unwrap(),
        attempt: 1,
        token: index as i64,
        expires_at: f64::NAN,
        exclusive: false,
    }
}

impl Fitting {
    fn new(jobs: Vec<(Lease, f64)>) -> Arc<Fitting> {
        Arc::new(Fitting {
            queued: Mutex::new(jobs),
            asked: Mutex::default(),
            completed: Mutex::default(),
        })
    }
}

impl JobQueue for Fitting {
    async fn lease(&self, max_jobs: u32, seconds_left: Option<f64>) -> Result<Granted, QueueError> {
        self.asked.lock().unwrap().push(seconds_left);
        let mut queued = self.queued.lock().unwrap();
        let (mut granted, mut expected) = (Granted::default(), 0.0);
        let mut kept = Vec::new();
        for (lease, takes) in queued.drain(..) {
            let fits = seconds_left.is_none_or(|left| expected + takes <= left);
            if fits && granted.leases.len() < max_jobs as usize {
                expected += takes;
                granted.leases.push(lease);
            } else {
                granted.passed_over += u64::from(!fits);
                kept.push((lease, takes));
            }
        }
        *queued = kept;
        Ok(granted)
    }

    async fn heartbeat(&self, held: Vec<LeaseRef>) -> Result<Vec<LeaseRef>, QueueError> {
        Ok(held)
    }

    async fn complete(
        &self,
        completions: Vec<Completion>,
    ) -> Result<Vec<CompleteOutcome>, QueueError> {
        self.completed
            .lock()
            .unwrap()
            .extend(completions.iter().map(|c| c.job_id.clone()));
        Ok(vec![CompleteOutcome::Accepted; completions.len()])
    }

    async fn fail(&self, lease: &LeaseRef, error: String) -> Result<FailOutcome, QueueError> {
        panic!("job {} failed: {error}", lease.job_id)
    }

    async fn release(&self, _: Vec<LeaseRef>) -> Result<(), QueueError> {
        Ok(())
    }
}

fn unix_now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
}

/// Runs one slot over `queue` until the worker finishes by itself; answers why.
fn run_until_finished(
    queue: Arc<Fitting>,
    deadline: Option<f64>,
    idle_timeout: Option<Duration>,
) -> String {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let options = WorkerOptions {
        cores: vec![0],
        heartbeat_every: Duration::from_millis(50),
        idle_poll: Duration::from_millis(10),
        lease_batch: None,
        lease_for: Duration::from_secs(60),
        deadline,
        idle_timeout,
        child_exe: None,
    };
    let slots = Slots::start(queue, options, runtime.handle().clone()).unwrap();
    // The limit only keeps a broken worker from hanging the test.
    let reason = runtime
        .block_on(async { tokio::time::timeout(Duration::from_secs(60), slots.finished()).await })
        .expect("the worker finishes by itself");
    slots.join();
    reason
}

#[test]
fn a_worker_leases_only_what_fits_before_its_deadline_then_stops() {
    // Two short jobs, and one expected to take 100 s: the worker has about 30 s.
    let queue = Fitting::new(vec![
        (noop(0, 20), 0.02),
        (noop(1, 0), 100.0),
        (noop(2, 20), 0.02),
    ]);
    let reason = run_until_finished(queue.clone(), Some(unix_now() + 30.0), None);
    assert!(reason.contains("expected to take longer"), "{reason}");
    assert_eq!(*queue.completed.lock().unwrap(), ["job0", "job2"]);
    let queued = queue.queued.lock().unwrap();
    assert_eq!(
        queued.len(),
        1,
        "the long job stays queued for another worker"
    );
    assert_eq!(queued[0].0.job_id, "job1");
    let asked = queue.asked.lock().unwrap();
    assert!(
        asked
            .iter()
            .all(|left| left.is_some_and(|s| s > 0.0 && s <= 30.0)),
        "every lease says the time left: {asked:?}"
    );
}

#[test]
fn a_worker_past_its_deadline_leases_nothing() {
    let queue = Fitting::new(vec![(noop(0, 0), 0.0)]);
    let reason = run_until_finished(queue.clone(), Some(unix_now() - 1.0), None);
    assert!(reason.contains("deadline"), "{reason}");
    assert!(queue.asked.lock().unwrap().is_empty());
    assert!(queue.completed.lock().unwrap().is_empty());
}

#[test]
fn a_worker_without_work_for_its_idle_timeout_stops() {
    let queue = Fitting::new((0..3).map(|i| (noop(i, 10), 0.01)).collect());
    let reason = run_until_finished(queue.clone(), None, Some(Duration::from_millis(300)));
    assert!(reason.contains("no job for"), "{reason}");
    assert_eq!(queue.completed.lock().unwrap().len(), 3, "the work first");
    // Without a deadline the worker asks for no limit.
    assert!(queue.asked.lock().unwrap().iter().all(Option::is_none));
}
