//! How the slots deliver reports to a coordinator that fails them: a fake queue stands in for the
//! coordinator, and real slots run real (no-op) jobs against it.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use jobs::{JobSpec, NoopSpec};
use queue::{CompleteOutcome, Completion, FailOutcome, Granted, Lease, LeaseRef, QueueError};
use worker::{JobQueue, Slots, WorkerOptions};

/// What the fake coordinator does with a call.
#[derive(Default)]
struct Script {
    /// Completions of this job are rejected (the batch with them, as the store does).
    reject_job: Option<String>,
    /// The next `unreachable` calls to `complete` fail as if the coordinator were away.
    unreachable: u32,
    /// Every lease call is refused (credentials revoked).
    refuse_leases: bool,
}

#[derive(Default)]
struct Fake {
    script: Mutex<Script>,
    queued: Mutex<VecDeque<Lease>>,
    completed: Mutex<Vec<String>>,
    failed: Mutex<Vec<(String, String)>>,
    complete_calls: Mutex<u32>,
}

impl Fake {
    fn with_jobs(n: usize, script: Script) -> Arc<Fake> {
        let queued = (0..n)
            .map(|index| {
                let spec = JobSpec::Noop(NoopSpec {
                    index: index as u64,
                    duration_ms: 0,
                    fail_rate: 0.0,
                });
                Lease {
                    job_id: format!("job{index}"),
                    kind: "noop".into(),
                    params_json: serde_json::to_string(&spec).expect("a noop spec serialises"),
                    attempt: 1,
                    token: index as i64 + 100,
                    expires_at: f64::NAN,
                    exclusive: false,
                }
            })
            .collect();
        Arc::new(Fake {
            script: Mutex::new(script),
            queued: Mutex::new(queued),
            ..Default::default()
        })
    }

    fn settled(&self) -> usize {
        self.completed.lock().unwrap().len() + self.failed.lock().unwrap().len()
    }
}

impl JobQueue for Fake {
    async fn lease(&self, max_jobs: u32, _: Option<f64>) -> Result<Granted, QueueError> {
        if self.script.lock().unwrap().refuse_leases {
            return Err(QueueError::Refused("token revoked".into()));
        }
        let mut queued = self.queued.lock().unwrap();
        let n = (max_jobs as usize).min(queued.len());
        Ok(Granted {
            leases: queued.drain(..n).collect(),
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
        *self.complete_calls.lock().unwrap() += 1;
        let mut script = self.script.lock().unwrap();
        if script.unreachable > 0 {
            script.unreachable -= 1;
            return Err(QueueError::Transport(
                "Unavailable: connection refused".into(),
            ));
        }
        if let Some(bad) = &script.reject_job
            && completions.iter().any(|c| &c.job_id == bad)
        {
            return Err(QueueError::Rejected(format!(
                "job {bad:?}: result record 0 is not a JSON object"
            )));
        }
        self.completed
            .lock()
            .unwrap()
            .extend(completions.iter().map(|c| c.job_id.clone()));
        Ok(vec![CompleteOutcome::Accepted; completions.len()])
    }

    async fn fail(&self, lease: &LeaseRef, error: String) -> Result<FailOutcome, QueueError> {
        self.failed
            .lock()
            .unwrap()
            .push((lease.job_id.clone(), error));
        Ok(FailOutcome::Failed)
    }

    async fn release(&self, _: Vec<LeaseRef>) -> Result<(), QueueError> {
        Ok(())
    }
}

fn options(lease_batch: u32) -> WorkerOptions {
    WorkerOptions {
        cores: vec![0],
        heartbeat_every: Duration::from_millis(50),
        idle_poll: Duration::from_millis(10),
        lease_batch: Some(lease_batch),
        lease_for: Duration::from_secs(60),
        deadline: None,
        idle_timeout: None,
        child_exe: None,
    }
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("a runtime")
}

/// Waits (up to 20 s) until `done` holds.
fn wait_until(done: impl Fn() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < Duration::from_secs(20), "timed out");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn a_rejected_result_fails_its_job_and_costs_the_rest_of_its_batch_nothing() {
    let rt = runtime();
    let fake = Fake::with_jobs(
        3,
        Script {
            reject_job: Some("job1".into()),
            ..Default::default()
        },
    );
    let slots = Slots::start(fake.clone(), options(3), rt.handle().clone()).expect("slots start");
    wait_until(|| fake.settled() == 3);
    slots.stop();
    slots.join();
    let mut completed = fake.completed.lock().unwrap().clone();
    completed.sort();
    assert_eq!(completed, ["job0", "job2"]);
    let failed = fake.failed.lock().unwrap();
    assert_eq!(failed.len(), 1);
    assert_eq!(failed[0].0, "job1");
    assert!(
        failed[0].1.contains("rejected the result"),
        "{}",
        failed[0].1
    );
    assert!(failed[0].1.contains("not a JSON object"), "{}", failed[0].1);
    // The batch once, then each job alone; the rejected one is not retried.
    assert_eq!(*fake.complete_calls.lock().unwrap(), 4);
}

#[test]
fn results_wait_out_an_unreachable_coordinator() {
    let rt = runtime();
    let fake = Fake::with_jobs(
        2,
        Script {
            unreachable: 2,
            ..Default::default()
        },
    );
    let slots = Slots::start(fake.clone(), options(2), rt.handle().clone()).expect("slots start");
    wait_until(|| fake.settled() == 2);
    slots.stop();
    slots.join();
    assert_eq!(fake.completed.lock().unwrap().len(), 2);
    assert!(fake.failed.lock().unwrap().is_empty());
    assert_eq!(*fake.complete_calls.lock().unwrap(), 3);
}

#[test]
fn refused_credentials_halt_the_worker_with_the_reason() {
    let rt = runtime();
    let fake = Fake::with_jobs(
        1,
        Script {
            refuse_leases: true,
            ..Default::default()
        },
    );
    let slots = Slots::start(fake.clone(), options(1), rt.handle().clone()).expect("slots start");
    let reason = rt.block_on(async {
        tokio::time::timeout(Duration::from_secs(20), slots.halted())
            .await
            .expect("the worker halts")
    });
    assert!(
        reason.contains("refused") && reason.contains("token revoked"),
        "{reason}"
    );
    // Halting stops the slots by itself: join returns without `stop`.
    slots.join();
    assert_eq!(fake.settled(), 0);
}
