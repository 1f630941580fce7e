//! The slots: one OS thread per core, pinned before it runs anything, each looping lease → run →
//! report. A heartbeat task extends every lease held. Stopping lets each slot finish the job in
//! hand (a timing cannot be interrupted without being lost) and lease nothing more.

use std::collections::HashMap;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use std::future::Future;

use coordinator::{CompleteOutcome, Completion, Lease, LeaseRef};
use jobs::JobSpec;
use tokio::runtime::Handle;

use crate::{JobQueue, WorkerError};

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

pub struct Slots {
    stop: Arc<AtomicBool>,
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
        let stop = Arc::new(AtomicBool::new(false));
        let held: Held = Arc::default();
        let threads = cores
            .into_iter()
            .map(|core| {
                let slot = Slot {
                    queue: queue.clone(),
                    core,
                    stop: stop.clone(),
                    held: held.clone(),
                    runtime: runtime.clone(),
                    options: options.clone(),
                };
                std::thread::Builder::new()
                    .name(format!("slot-core{}", core.id))
                    .spawn(move || slot.run())
                    .map_err(|e| WorkerError::Transport(format!("cannot start a slot thread: {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let heartbeat = runtime.spawn(heartbeat_loop(queue, held, options.heartbeat_every));
        Ok(Slots { stop, threads, heartbeat })
    }

    /// Asks every slot to finish its current job and lease nothing more.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Waits for every slot to exit (after [`Slots::stop`]).
    pub fn join(self) {
        for thread in self.threads {
            if thread.join().is_err() {
                tracing::error!("a slot thread panicked");
            }
        }
        self.heartbeat.abort();
    }
}

async fn heartbeat_loop<Q: JobQueue>(queue: Arc<Q>, held: Held, every: Duration) {
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
            Err(error) => tracing::warn!(%error, "heartbeat failed; retrying at the next beat"),
        }
    }
}

struct Slot<Q> {
    queue: Arc<Q>,
    core: core_affinity::CoreId,
    stop: Arc<AtomicBool>,
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
        while !self.stop.load(Ordering::SeqCst) {
            match self.runtime.block_on(self.queue.lease(self.options.lease_batch)) {
                Ok(leases) if leases.is_empty() => self.sleep(self.options.idle_poll),
                Ok(leases) => {
                    failures = 0;
                    self.run_batch(leases, &pool);
                }
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
        while !left.is_zero() && !self.stop.load(Ordering::SeqCst) {
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
                    self.deliver(|| self.queue.fail(&lease, error.clone()));
                    tracing::warn!(job = %lease.job_id, %error, "job failed");
                    self.forget(&lease.job_id);
                }
            }
            if self.stop.load(Ordering::SeqCst) {
                break;
            }
        }
        let unstarted: Vec<LeaseRef> = leases.map(|l| LeaseRef { job_id: l.job_id, token: l.token }).collect();
        if !unstarted.is_empty() {
            if let Err(error) = self.runtime.block_on(self.queue.release(unstarted)) {
                tracing::warn!(%error, "could not return unstarted leases; they will expire");
            }
        }
        if !completions.is_empty() {
            let ids: Vec<String> = completions.iter().map(|c| c.job_id.clone()).collect();
            let outcomes = self.deliver(|| self.queue.complete(completions.clone()));
            for (id, outcome) in ids.iter().zip(outcomes) {
                if outcome != CompleteOutcome::Accepted {
                    tracing::warn!(job = %id, ?outcome, "result not counted");
                }
                self.forget(id);
            }
        }
    }

    /// Delivers a report, retrying while the coordinator is unreachable: a result is only lost if
    /// the worker itself dies, and then the lease expires and the job runs again.
    fn deliver<T, F: Future<Output = Result<T, WorkerError>>>(&self, call: impl Fn() -> F) -> T {
        let mut attempt = 0;
        loop {
            match self.runtime.block_on(call()) {
                Ok(value) => return value,
                Err(error) => {
                    tracing::warn!(%error, "report failed; retrying");
                    std::thread::sleep(Duration::from_millis(BACKOFF[attempt.min(BACKOFF.len() - 1)]));
                    attempt += 1;
                }
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
