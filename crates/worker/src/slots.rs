//! The slots: one OS thread per core, pinned before it runs anything, each looping lease → run →
//! report. A heartbeat task extends every lease held. Stopping lets each slot finish the job in
//! hand (a timing cannot be interrupted without being lost) and lease nothing more.
//!
//! Calls that fail for a reason that may pass (the coordinator away or busy) are retried; a report
//! is never dropped for that. A call the coordinator rejects is not retried: a rejected result is
//! reported as a failure of its job instead, and refused credentials halt the worker
//! ([`Slots::halted`]).

use std::collections::HashMap;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use std::future::Future;

use queue::{CompleteOutcome, Completion, JobQueue, Lease, LeaseRef, QueueError};
use jobs::JobSpec;
use tokio::runtime::Handle;
use tokio::sync::watch;

use crate::WorkerError;

#[derive(Clone, Debug)]
pub struct WorkerOptions {
    /// Core ids (as `core_affinity` numbers them); one slot each.
    pub cores: Vec<usize>,
    pub heartbeat_every: Duration,
    /// Wait between lease attempts when the queue is empty.
    pub idle_poll: Duration,
    /// Jobs leased per call: larger batches amortise the round trip of short jobs.
    pub lease_batch: u32,
}

/// Leases currently held by this worker, by job id.
type Held = Arc<Mutex<HashMap<String, LeaseRef>>>;

/// Shared by the slots, the heartbeat and the owner of [`Slots`]: the stop flag, and why the worker
/// halted by itself, if it did.
struct Control {
    stop: AtomicBool,
    halted: watch::Sender<Option<String>>,
}

impl Control {
    fn stopping(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Stops every slot because of an error no retry can fix; the first reason is kept.
    fn halt(&self, reason: String) {
        tracing::error!(%reason, "the worker stops");
        self.halted.send_if_modified(|halted| {
            let first = halted.is_none();
            if first {
                *halted = Some(reason);
            }
            first
        });
        self.stop.store(true, Ordering::SeqCst);
    }
}

pub struct Slots {
    control: Arc<Control>,
    threads: Vec<JoinHandle<()>>,
    heartbeat: tokio::task::JoinHandle<()>,
}

impl Slots {
    /// Pins one thread per core in `options.cores` and starts leasing from `queue`. Must be called
    /// from outside the runtime's worker threads (slots block on `runtime`).
    pub fn start<Q: JobQueue>(queue: Arc<Q>, options: WorkerOptions, runtime: Handle) -> Result<Slots, WorkerError> {
        let available = core_affinity::get_core_ids().ok_or(WorkerError::NoCores)?;
        let mut cores = Vec::with_capacity(options.cores.len());
        for &core in &options.cores {
            cores.push(*available.iter().find(|c| c.id == core).ok_or(WorkerError::NoSuchCore(core))?);
        }
        let control = Arc::new(Control { stop: AtomicBool::new(false), halted: watch::Sender::new(None) });
        let held: Held = Arc::default();
        let threads = cores
            .into_iter()
            .map(|core| {
                let slot = Slot {
                    queue: queue.clone(),
                    core,
                    control: control.clone(),
                    held: held.clone(),
                    runtime: runtime.clone(),
                    options: options.clone(),
                };
                std::thread::Builder::new()
                    .name(format!("slot-core{}", core.id))
                    .spawn(move || slot.run())
                    .map_err(WorkerError::Thread)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let heartbeat = runtime.spawn(heartbeat_loop(queue, held, options.heartbeat_every, control.clone()));
        Ok(Slots { control, threads, heartbeat })
    }

    /// Asks every slot to finish its current job and lease nothing more.
    pub fn stop(&self) {
        self.control.stop.store(true, Ordering::SeqCst);
    }

    /// Resolves, with the reason, once the worker has stopped by itself: its credentials were
    /// refused, or the coordinator rejected its requests for work. Never resolves otherwise.
    pub async fn halted(&self) -> String {
        let mut halted = self.control.halted.subscribe();
        match halted.wait_for(Option::is_some).await {
            Ok(reason) => reason.clone().unwrap_or_default(),
            // The sender lives in `self.control`: it cannot be dropped while `self` is borrowed.
            Err(_) => std::future::pending().await,
        }
    }

    /// Waits for every slot to exit (after [`Slots::stop`], or once [`Slots::halted`]).
    pub fn join(self) {
        for thread in self.threads {
            if thread.join().is_err() {
                tracing::error!("a slot thread panicked");
            }
        }
        self.heartbeat.abort();
    }
}

async fn heartbeat_loop<Q: JobQueue>(queue: Arc<Q>, held: Held, every: Duration, control: Arc<Control>) {
    let mut interval = tokio::time::interval(every);
    loop {
        interval.tick().await;
        let leases: Vec<LeaseRef> = held.lock().map(|h| h.values().cloned().collect()).unwrap_or_default();
        if leases.is_empty() {
            continue;
        }
        match queue.heartbeat(leases.clone()).await {
            Ok(valid) => {
                for lost in leases.iter().filter(|l| !valid.contains(l)) {
                    tracing::warn!(job = %lost.job_id, "lease lost: the result will be recorded as late");
                }
            }
            Err(error @ QueueError::Refused(_)) => control.halt(error.to_string()),
            Err(error) => tracing::warn!(%error, "heartbeat failed; retrying at the next beat"),
        }
    }
}

struct Slot<Q> {
    queue: Arc<Q>,
    core: core_affinity::CoreId,
    control: Arc<Control>,
    held: Held,
    runtime: Handle,
    options: WorkerOptions,
}

/// Bounded exponential backoff while the coordinator is away.
const BACKOFF: [u64; 6] = [100, 200, 500, 1000, 2000, 5000];

impl<Q: JobQueue> Slot<Q> {
    fn run(self) {
        if !core_affinity::set_for_current(self.core) {
            tracing::error!(core = self.core.id, "cannot pin the slot: it will not run jobs");
            return;
        }
        // Configuration generation of a job runs on this slot's core only, so it never disturbs
        // a timing on another core.
        let core = self.core;
        let pool = match rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .start_handler(move |_| {
                core_affinity::set_for_current(core);
            })
            .build()
        {
            Ok(pool) => pool,
            Err(error) => {
                tracing::error!(%error, "cannot start the slot's thread pool");
                return;
            }
        };
        let mut failures = 0usize;
        while !self.control.stopping() {
            match self.runtime.block_on(self.queue.lease(self.options.lease_batch)) {
                Ok(leases) if leases.is_empty() => self.sleep(self.options.idle_poll),
                Ok(leases) => {
                    failures = 0;
                    self.run_batch(leases, &pool);
                }
                Err(error) if !error.is_transient() => self.control.halt(format!("cannot lease jobs: {error}")),
                Err(error) => {
                    tracing::warn!(%error, "lease failed; backing off");
                    self.sleep(Duration::from_millis(BACKOFF[failures.min(BACKOFF.len() - 1)]));
                    failures += 1;
                }
            }
        }
    }

    /// Sleeps up to `duration`, waking early when asked to stop.
    fn sleep(&self, duration: Duration) {
        let step = Duration::from_millis(20);
        let mut left = duration;
        while !left.is_zero() && !self.control.stopping() {
            let nap = left.min(step);
            std::thread::sleep(nap);
            left -= nap;
        }
    }

    fn hold(&self, lease: &Lease) {
        if let Ok(mut held) = self.held.lock() {
            held.insert(lease.job_id.clone(), LeaseRef { job_id: lease.job_id.clone(), token: lease.token });
        }
    }

    fn forget(&self, job_id: &str) {
        if let Ok(mut held) = self.held.lock() {
            held.remove(job_id);
        }
    }

    /// Runs the leased jobs in order and reports their results together (one transaction for the
    /// batch); a lease stays held, hence heartbeaten, until its report has landed. Stopping
    /// returns the unstarted leases.
    fn run_batch(&self, leases: Vec<Lease>, pool: &rayon::ThreadPool) {
        let mut completions = Vec::with_capacity(leases.len());
        let mut leases = leases.into_iter();
        for lease in leases.by_ref() {
            self.hold(&lease);
            match run_job(&lease, pool) {
                Ok(records) => completions.push(Completion {
                    job_id: lease.job_id,
                    token: lease.token,
                    core_id: Some(self.core.id as u32),
                    records,
                }),
                Err(error) => {
                    tracing::warn!(job = %lease.job_id, %error, "job failed");
                    self.report_failure(&LeaseRef { job_id: lease.job_id, token: lease.token }, error);
                }
            }
            if self.control.stopping() {
                break;
            }
        }
        let unstarted: Vec<LeaseRef> = leases.map(|l| LeaseRef { job_id: l.job_id, token: l.token }).collect();
        if !unstarted.is_empty() {
            if let Err(error) = self.runtime.block_on(self.queue.release(unstarted)) {
                tracing::warn!(%error, "could not return unstarted leases; they will expire");
            }
        }
        self.report(completions);
    }

    /// Reports finished jobs in one call. The coordinator takes a batch whole or not at all, so
    /// when it rejects one, each job is reported on its own: one malformed result must not cost
    /// the others theirs.
    fn report(&self, completions: Vec<Completion>) {
        if completions.is_empty() {
            return;
        }
        match self.deliver(|| self.queue.complete(completions.clone())) {
            Ok(outcomes) => {
                for (completion, outcome) in completions.iter().zip(outcomes) {
                    if outcome != CompleteOutcome::Accepted {
                        tracing::warn!(job = %completion.job_id, ?outcome, "result not counted");
                    }
                    self.forget(&completion.job_id);
                }
            }
            Err(error @ QueueError::Refused(_)) => {
                // The leases expire and the jobs run again elsewhere.
                self.control.halt(error.to_string());
                completions.iter().for_each(|c| self.forget(&c.job_id));
            }
            Err(_) if completions.len() > 1 => completions.into_iter().for_each(|c| self.report(vec![c])),
            Err(error) => {
                let lease = LeaseRef { job_id: completions[0].job_id.clone(), token: completions[0].token };
                tracing::error!(job = %lease.job_id, %error, "result rejected; reporting the job as failed");
                self.report_failure(&lease, format!("the coordinator rejected the result: {error}"));
            }
        }
    }

    /// Reports that a job failed (the coordinator retries it or marks it failed), then lets its
    /// lease go.
    fn report_failure(&self, lease: &LeaseRef, error: String) {
        match self.deliver(|| self.queue.fail(lease, error.clone())) {
            Ok(_) => {}
            Err(refused @ QueueError::Refused(_)) => self.control.halt(refused.to_string()),
            Err(rejected) => {
                tracing::error!(job = %lease.job_id, error = %rejected, "failure report rejected; the lease will expire")
            }
        }
        self.forget(&lease.job_id);
    }

    /// Makes a call, retrying while the coordinator is unreachable or busy: a report is only lost
    /// if the worker itself dies, and then the lease expires and the job runs again. An error that
    /// would recur is returned at once.
    fn deliver<T, F: Future<Output = Result<T, QueueError>>>(&self, call: impl Fn() -> F) -> Result<T, QueueError> {
        let mut attempt = 0;
        loop {
            match self.runtime.block_on(call()) {
                Ok(value) => return Ok(value),
                Err(error) if error.is_transient() => {
                    tracing::warn!(%error, "report failed; retrying");
                    std::thread::sleep(Duration::from_millis(BACKOFF[attempt.min(BACKOFF.len() - 1)]));
                    attempt += 1;
                }
                Err(error) => return Err(error),
            }
        }
    }
}

/// Runs one leased job pinned to the slot's core; records come back as JSON objects. An
/// exclusive job runs alone on the machine, so its untimed generation may use every core (the
/// global pool, started before any pinning); any other job keeps all its work on its own core.
fn run_job(lease: &Lease, pool: &rayon::ThreadPool) -> Result<Vec<String>, String> {
    let spec: JobSpec =
        serde_json::from_str(&lease.params_json).map_err(|e| format!("job {}: unreadable parameters: {e}", lease.job_id))?;
    let run = || jobs::run(&spec, lease.attempt);
    let ran = std::panic::catch_unwind(AssertUnwindSafe(|| if lease.exclusive { run() } else { pool.install(run) }));
    match ran {
        Ok(Ok(records)) => records
            .iter()
            .map(|r| serde_json::to_string(r).map_err(|e| format!("unserialisable record: {e}")))
            .collect(),
        Ok(Err(error)) => Err(error.to_string()),
        Err(_) => Err(format!("job {} panicked", lease.job_id)),
    }
}
