//! The slots: one OS thread per core, pinned before it runs anything, each looping lease → run →
//! report. A heartbeat task extends every lease whose job has started. Stopping lets each slot
//! finish the job in hand (a timing cannot be interrupted without being lost), return the leases
//! it has not started, and lease nothing more.
//!
//! Leasing is paced ([`crate::pace`]): as many jobs as fit a short window of observed run time,
//! the next lease asked for before the current one runs out when jobs are short, and a leased job
//! not started within half its lease duration is given back instead of started. Reports of short
//! jobs travel while the next jobs run (at most one report in flight per slot); a slot of long
//! jobs reports before it leases again, so it holds one lease at a time. A lease stays held, hence
//! heartbeaten, until its report has landed.
//!
//! Calls that fail for a reason that may pass (the coordinator away or busy) are retried; a report
//! is never dropped for that. A call the coordinator rejects is not retried: a rejected result is
//! reported as a failure of its job instead, and refused credentials halt the worker
//! ([`Slots::halted`]).

use std::collections::HashMap;
use std::future::Future;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use jobs::JobSpec;
use queue::{CompleteOutcome, Completion, JobQueue, Lease, LeaseRef, QueueError};
use tokio::runtime::Handle;
use tokio::sync::watch;

use crate::WorkerError;
use crate::child::run_in_child;
use crate::pace::Pace;

#[derive(Clone, Debug)]
pub struct WorkerOptions {
    /// Core ids (as `core_affinity` numbers them); one slot each.
    pub cores: Vec<usize>,
    pub heartbeat_every: Duration,
    /// Wait between lease attempts when the queue is empty.
    pub idle_poll: Duration,
    /// Jobs leased per call; `None`: paced by the observed run time ([`crate::pace`]).
    pub lease_batch: Option<u32>,
    /// How long a lease lasts without a heartbeat (the coordinator's setting). A leased job not
    /// started within half of it is given back.
    pub lease_for: Duration,
    /// Unix time by which the worker's jobs must be done (its allocation ends, less a margin):
    /// it leases only jobs the coordinator expects to finish by then, and stops then, or as soon
    /// as nothing queued fits in what is left.
    pub deadline: Option<f64>,
    /// Stop once no slot has had a job for this long.
    pub idle_timeout: Option<Duration>,
    /// The executable that runs a job in a child process (`EXE __run-job`, see
    /// [`crate::child`]): the worker's own binary, given by it (this crate does not assume it is
    /// linked into `sweep`). Without it, a job that runs foreign code fails.
    pub child_exe: Option<PathBuf>,
}

/// Leases currently held by this worker, by job id.
type Held = Arc<Mutex<HashMap<String, LeaseRef>>>;

/// Shared by the slots, the heartbeat and the owner of [`Slots`]: the stop flag, why the worker
/// halted by itself (an error) or finished (its work done: idle, out of time), and which slots
/// have work.
struct Control {
    stop: AtomicBool,
    halted: watch::Sender<Option<String>>,
    finished: watch::Sender<Option<String>>,
    activity: Mutex<Activity>,
}

/// Which slots have work, and since when none has.
struct Activity {
    busy: Vec<bool>,
    all_idle_since: Option<Instant>,
}

impl Activity {
    /// Every slot idle from `since`.
    fn idle(slots: usize, since: Instant) -> Activity {
        Activity {
            busy: vec![false; slots],
            all_idle_since: Some(since),
        }
    }

    /// Records whether `slot` has work, at `now`; answers how long no slot has had any.
    fn mark(&mut self, slot: usize, busy: bool, now: Instant) -> Option<Duration> {
        if let Some(b) = self.busy.get_mut(slot) {
            *b = busy;
        }
        if self.busy.iter().any(|&b| b) {
            self.all_idle_since = None;
            return None;
        }
        let since = *self.all_idle_since.get_or_insert(now);
        Some(now.saturating_duration_since(since))
    }
}

impl Control {
    fn stopping(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Stops every slot because the worker's work is over (idle, out of time); the first reason
    /// is kept.
    fn finish(&self, reason: String) {
        self.finished.send_if_modified(|finished| {
            let first = finished.is_none();
            if first {
                tracing::info!(%reason, "the worker stops");
                *finished = Some(reason);
            }
            first
        });
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Records whether `slot` has work; answers how long no slot has had any.
    fn mark(&self, slot: usize, busy: bool) -> Option<Duration> {
        let mut activity = self
            .activity
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        activity.mark(slot, busy, Instant::now())
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
    pub fn start<Q: JobQueue>(
        queue: Arc<Q>,
        options: WorkerOptions,
        runtime: Handle,
    ) -> Result<Slots, WorkerError> {
        let available = core_affinity::get_core_ids().ok_or(WorkerError::NoCores)?;
        let mut cores = Vec::with_capacity(options.cores.len());
        for &core in &options.cores {
            cores.push(
                *available
                    .iter()
                    .find(|c| c.id == core)
                    .ok_or(WorkerError::NoSuchCore(core))?,
            );
        }
        let control = Arc::new(Control {
            stop: AtomicBool::new(false),
            halted: watch::Sender::new(None),
            finished: watch::Sender::new(None),
            activity: Mutex::new(Activity::idle(cores.len(), Instant::now())),
        });
        let held: Held = Arc::default();
        let threads = cores
            .into_iter()
            .enumerate()
            .map(|(index, core)| {
                let slot = Slot {
                    index,
                    reporter: Reporter {
                        queue: queue.clone(),
                        held: held.clone(),
                        control: control.clone(),
                    },
                    core,
                    runtime: runtime.clone(),
                    options: options.clone(),
                };
                std::thread::Builder::new()
                    .name(format!("slot-core{}", core.id))
                    .spawn(move || slot.run())
                    .map_err(WorkerError::Thread)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let heartbeat = runtime.spawn(heartbeat_loop(
            queue,
            held,
            options.heartbeat_every,
            control.clone(),
        ));
        Ok(Slots {
            control,
            threads,
            heartbeat,
        })
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

    /// Resolves, with the reason, once the worker has stopped because its work is over: idle for
    /// [`WorkerOptions::idle_timeout`], at its [`WorkerOptions::deadline`], or nothing queued
    /// fits in the time it has left. Never resolves otherwise.
    pub async fn finished(&self) -> String {
        let mut finished = self.control.finished.subscribe();
        match finished.wait_for(Option::is_some).await {
            Ok(reason) => reason.clone().unwrap_or_default(),
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

async fn heartbeat_loop<Q: JobQueue>(
    queue: Arc<Q>,
    held: Held,
    every: Duration,
    control: Arc<Control>,
) {
    let mut interval = tokio::time::interval(every);
    loop {
        interval.tick().await;
        let leases: Vec<LeaseRef> = held
            .lock()
            .map(|h| h.values().cloned().collect())
            .unwrap_or_default();
        if leases.is_empty() {
            continue;
        }
        match queue.heartbeat(leases.clone()).await {
            Ok(valid) => {
                let lost: Vec<&str> = leases
                    .iter()
                    .filter(|l| !valid.contains(l))
                    .map(|l| l.job_id.as_str())
                    .collect();
                if let Some(first) = lost.first() {
                    // One line per beat, not per job: a paced lease holds hundreds.
                    tracing::warn!(
                        leases = lost.len(),
                        first,
                        "leases lost: their results will be recorded as late"
                    );
                }
            }
            Err(error @ QueueError::Refused(_)) => control.halt(error.to_string()),
            Err(error) => tracing::warn!(%error, "heartbeat failed; retrying at the next beat"),
        }
    }
}

/// Jobs leased together, when they were asked for (their leases are at least that old), and how
/// long the call took; whether queued jobs exist that none fit the time left (`seconds_left`).
struct Leased {
    leases: Vec<Lease>,
    asked_at: Instant,
    round_trip: Duration,
    nothing_fits: bool,
    seconds_left: Option<f64>,
}

fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// A lease call under way while the slot runs jobs.
type Prefetch = tokio::task::JoinHandle<Result<Leased, QueueError>>;

struct Slot<Q> {
    /// Its place among the worker's slots.
    index: usize,
    reporter: Reporter<Q>,
    core: core_affinity::CoreId,
    runtime: Handle,
    options: WorkerOptions,
}

/// Bounded exponential backoff while the coordinator is away.
const BACKOFF: [u64; 6] = [100, 200, 500, 1000, 2000, 5000];

impl<Q: JobQueue> Slot<Q> {
    fn control(&self) -> &Control {
        &self.reporter.control
    }

    fn run(self) {
        if !core_affinity::set_for_current(self.core) {
            tracing::error!(
                core = self.core.id,
                "cannot pin the slot: it will not run jobs"
            );
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
        let mut pace = Pace::default();
        let mut prefetch: Option<Prefetch> = None;
        let mut reporting: Option<tokio::task::JoinHandle<()>> = None;
        let mut failures = 0usize;
        while !self.control().stopping() {
            let prefetched = prefetch.take().map(|call| self.settle(call));
            let leased = match prefetched {
                // A prefetch that found nothing may have been too early (our own job kept an
                // exclusive one waiting): ask again now rather than idle.
                Some(Ok(leased)) if !leased.leases.is_empty() => Ok(leased),
                _ => {
                    let Some(left) = self.seconds_left() else {
                        break;
                    };
                    self.runtime.block_on(lease_timed(
                        &*self.reporter.queue,
                        self.batch(&pace),
                        left,
                    ))
                }
            };
            match leased {
                Ok(leased) if leased.nothing_fits => {
                    self.control().finish(format!(
                        "the jobs at the head of the queue are expected to take longer than the \
                         {:.0} s this worker has left before its deadline",
                        leased.seconds_left.unwrap_or(0.0)
                    ));
                }
                Ok(leased) if leased.leases.is_empty() => {
                    let idle = self.control().mark(self.index, false);
                    if let (Some(idle), Some(timeout)) = (idle, self.options.idle_timeout)
                        && idle >= timeout
                    {
                        self.control().finish(format!(
                            "no job for {:.0} s (--idle-timeout)",
                            idle.as_secs_f64()
                        ));
                    } else {
                        self.sleep(self.options.idle_poll);
                    }
                }
                Ok(leased) => {
                    self.control().mark(self.index, true);
                    failures = 0;
                    pace.observe_lease(leased.round_trip);
                    let completions = self.run_leased(leased, &pool, &mut pace, &mut prefetch);
                    if let Some(previous) = reporting.take() {
                        let _ = self.runtime.block_on(previous);
                    }
                    if completions.is_empty() {
                        continue;
                    }
                    if pace.short_jobs() {
                        let reporter = self.reporter.clone();
                        reporting = Some(
                            self.runtime
                                .spawn(async move { reporter.report(completions).await }),
                        );
                    } else {
                        self.runtime.block_on(self.reporter.report(completions));
                    }
                }
                Err(error) if !error.is_transient() => {
                    self.control().halt(format!("cannot lease jobs: {error}"))
                }
                Err(error) => {
                    tracing::warn!(%error, "lease failed; backing off");
                    self.sleep(Duration::from_millis(
                        BACKOFF[failures.min(BACKOFF.len() - 1)],
                    ));
                    failures += 1;
                }
            }
        }
        if let Some(call) = prefetch
            && let Ok(leased) = self.settle(call)
        {
            self.give_back(leased.leases.iter().map(Lease::reference).collect());
        }
        if let Some(report) = reporting {
            let _ = self.runtime.block_on(report);
        }
    }

    fn batch(&self, pace: &Pace) -> u32 {
        self.options.lease_batch.unwrap_or_else(|| pace.batch())
    }

    /// Seconds to the deadline (`Some(None)` without one); `None` once it has passed, and
    /// then the worker is told to stop.
    fn seconds_left(&self) -> Option<Option<f64>> {
        let Some(deadline) = self.options.deadline else {
            return Some(None);
        };
        let left = deadline - unix_now();
        if left <= 0.0 {
            self.control()
                .finish("reached its deadline (the end of its allocation less the margin)".into());
            return None;
        }
        Some(Some(left))
    }

    /// Waits for a prefetch; a failed one is logged (the slot asks again at once).
    fn settle(&self, call: Prefetch) -> Result<Leased, QueueError> {
        let result = self.runtime.block_on(call).unwrap_or_else(|e| {
            Err(QueueError::Transport(format!(
                "the lease call was lost: {e}"
            )))
        });
        if let Err(error @ QueueError::Refused(_)) = &result {
            self.control().halt(error.to_string());
        }
        result
    }

    /// Sleeps up to `duration`, waking early when asked to stop.
    fn sleep(&self, duration: Duration) {
        let step = Duration::from_millis(20);
        let mut left = duration;
        while !left.is_zero() && !self.control().stopping() {
            let nap = left.min(step);
            std::thread::sleep(nap);
            left -= nap;
        }
    }

    /// Runs the leased jobs in order and answers their completions (failures are reported here).
    /// Unstarted leases go back when stopping, or once they have waited half their duration: a
    /// slot never starts a job whose lease may be about to expire, nor sits on it.
    fn run_leased(
        &self,
        leased: Leased,
        pool: &rayon::ThreadPool,
        pace: &mut Pace,
        prefetch: &mut Option<Prefetch>,
    ) -> Vec<Completion> {
        let total = leased.leases.len();
        let mut completions = Vec::with_capacity(total);
        let mut leases = leased.leases.into_iter();
        let mut started = 0;
        while started < total {
            if self.control().stopping() || leased.asked_at.elapsed() > self.options.lease_for / 2 {
                break;
            }
            // A job before took longer than expected: what is left may not finish in time.
            if self.seconds_left().is_none() {
                break;
            }
            let Some(lease) = leases.next() else { break };
            if prefetch.is_none()
                && pace.prefetch_now(total - started)
                && let Some(left) = self.seconds_left()
            {
                let queue = self.reporter.queue.clone();
                let batch = self.batch(pace);
                *prefetch = Some(
                    self.runtime
                        .spawn(async move { lease_timed(&*queue, batch, left).await }),
                );
            }
            started += 1;
            self.reporter.hold(&lease);
            let began = Instant::now();
            let ran = run_job(&lease, pool, self.options.child_exe.as_deref());
            pace.observe_job(began.elapsed());
            match ran {
                Ok(records) => completions.push(Completion {
                    job_id: lease.job_id,
                    token: lease.token,
                    core_id: Some(self.core.id as u32),
                    records,
                }),
                Err(error) => {
                    tracing::warn!(job = %lease.job_id, %error, "job failed");
                    self.runtime
                        .block_on(self.reporter.report_failure(&lease.reference(), error));
                }
            }
        }
        let unstarted: Vec<LeaseRef> = leases.map(|l| l.reference()).collect();
        if !unstarted.is_empty() && !self.control().stopping() {
            tracing::info!(
                jobs = unstarted.len(),
                "giving back leases not started within half their duration (jobs longer than their pace)"
            );
        }
        self.give_back(unstarted);
        completions
    }

    fn give_back(&self, unstarted: Vec<LeaseRef>) {
        if unstarted.is_empty() {
            return;
        }
        if let Err(error) = self
            .runtime
            .block_on(self.reporter.queue.release(unstarted))
        {
            tracing::warn!(%error, "could not return unstarted leases; they will expire");
        }
    }
}

/// One lease call, timed from when it was asked.
async fn lease_timed<Q: JobQueue>(
    queue: &Q,
    batch: u32,
    seconds_left: Option<f64>,
) -> Result<Leased, QueueError> {
    let asked_at = Instant::now();
    let granted = queue.lease(batch, seconds_left).await?;
    Ok(Leased {
        nothing_fits: granted.nothing_fits(),
        leases: granted.leases,
        asked_at,
        round_trip: asked_at.elapsed(),
        seconds_left,
    })
}

/// What the slots share to deliver reports: the queue, the leases held, the stop control.
struct Reporter<Q> {
    queue: Arc<Q>,
    held: Held,
    control: Arc<Control>,
}

impl<Q> Clone for Reporter<Q> {
    fn clone(&self) -> Self {
        Reporter {
            queue: self.queue.clone(),
            held: self.held.clone(),
            control: self.control.clone(),
        }
    }
}

impl<Q: JobQueue> Reporter<Q> {
    fn hold(&self, lease: &Lease) {
        if let Ok(mut held) = self.held.lock() {
            held.insert(lease.job_id.clone(), lease.reference());
        }
    }

    fn forget(&self, job_id: &str) {
        if let Ok(mut held) = self.held.lock() {
            held.remove(job_id);
        }
    }

    /// Reports finished jobs in one call. The coordinator takes a batch whole or not at all, so
    /// when it rejects one, each job is reported on its own: one malformed result must not cost
    /// the others theirs.
    async fn report(&self, completions: Vec<Completion>) {
        let delivered = self
            .deliver(|| self.queue.complete(completions.clone()))
            .await;
        match delivered {
            Err(QueueError::Transport(_) | QueueError::Rejected(_)) if completions.len() > 1 => {
                for completion in completions {
                    let alone = vec![completion];
                    let delivered = self.deliver(|| self.queue.complete(alone.clone())).await;
                    self.settle(alone, delivered).await;
                }
            }
            delivered => self.settle(completions, delivered).await,
        }
    }

    /// Lets the reported leases go, once their report's fate is known; a rejected result is
    /// reported as a failure of its job.
    async fn settle(
        &self,
        completions: Vec<Completion>,
        delivered: Result<Vec<CompleteOutcome>, QueueError>,
    ) {
        match delivered {
            Ok(outcomes) => {
                let mut not_counted = completions
                    .iter()
                    .zip(&outcomes)
                    .filter(|(_, o)| **o != CompleteOutcome::Accepted);
                if let Some((first, outcome)) = not_counted.next() {
                    let results = 1 + not_counted.count();
                    tracing::warn!(results, first = %first.job_id, ?outcome, "results not counted (late or repeated)");
                }
                completions.iter().for_each(|c| self.forget(&c.job_id));
            }
            Err(error @ QueueError::Refused(_)) => {
                // The leases expire and the jobs run again elsewhere.
                self.control.halt(error.to_string());
                completions.iter().for_each(|c| self.forget(&c.job_id));
            }
            Err(error) => {
                for completion in completions {
                    let lease = LeaseRef {
                        job_id: completion.job_id,
                        token: completion.token,
                    };
                    tracing::error!(job = %lease.job_id, %error, "result rejected; reporting the job as failed");
                    self.report_failure(
                        &lease,
                        format!("the coordinator rejected the result: {error}"),
                    )
                    .await;
                }
            }
        }
    }

    /// Reports that a job failed (the coordinator retries it or marks it failed), then lets its
    /// lease go.
    async fn report_failure(&self, lease: &LeaseRef, error: String) {
        match self.deliver(|| self.queue.fail(lease, error.clone())).await {
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
    async fn deliver<T, F: Future<Output = Result<T, QueueError>>>(
        &self,
        call: impl Fn() -> F,
    ) -> Result<T, QueueError> {
        let mut attempt = 0;
        loop {
            match call().await {
                Ok(value) => return Ok(value),
                Err(error) if error.is_transient() => {
                    tracing::warn!(%error, "report failed; retrying");
                    tokio::time::sleep(Duration::from_millis(
                        BACKOFF[attempt.min(BACKOFF.len() - 1)],
                    ))
                    .await;
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
/// A job that runs foreign code runs in a child process instead ([`crate::child`]), started
/// from this (pinned) thread, so it keeps the core; its generation then uses that core only,
/// exclusive or not.
fn run_job(
    lease: &Lease,
    pool: &rayon::ThreadPool,
    child_exe: Option<&Path>,
) -> Result<Vec<String>, String> {
    let spec: JobSpec = serde_json::from_str(&lease.params_json)
        .map_err(|e| format!("job {}: unreadable parameters: {e}", lease.job_id))?;
    if spec.loads_foreign_code() {
        return match child_exe {
            // A crash names no plugin by itself: the job's own (its files).
            Some(exe) => {
                run_in_child(exe, &lease.params_json, lease.attempt).map_err(|e| match &spec {
                    JobSpec::Overlap(point) => {
                        let files: Vec<&str> =
                            point.plugins.iter().map(|f| f.path.as_str()).collect();
                        format!("{e} [plugins: {}]", files.join(", "))
                    }
                    _ => e,
                })
            }
            None => Err(format!(
                "job {} runs foreign code, and this worker has no executable to isolate it in",
                lease.job_id
            )),
        };
    }
    let run = || jobs::run(&spec, lease.attempt);
    let ran = std::panic::catch_unwind(AssertUnwindSafe(|| {
        if lease.exclusive {
            run()
        } else {
            pool.install(run)
        }
    }));
    match ran {
        Ok(Ok(records)) => records
            .iter()
            .map(|r| serde_json::to_string(r).map_err(|e| format!("unserialisable record: {e}")))
            .collect(),
        Ok(Err(error)) => Err(error.to_string()),
        Err(_) => Err(format!("job {} panicked", lease.job_id)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn foreign_code_never_runs_in_the_workers_process() {
        // A plugin point (its file need not exist: it must not be opened here).
        let params_json = r#"{"kind":"overlap","l_star":2,"w_star":2,"r_star":0.5,"acceptance":0.4,"configurations":100,"repeats":1,"precision":"f32","algorithms":["ocsi"],"seed":0,"plugins":[{"path":"/nowhere/libx.so","blake3":"00"}]}"#;
        let spec: JobSpec = serde_json::from_str(params_json).expect("a plugin point");
        assert!(spec.loads_foreign_code());
        let lease = Lease {
            job_id: "j".into(),
            kind: "overlap".into(),
            params_json: params_json.into(),
            attempt: 1,
            token: 1,
            expires_at: f64::NAN,
            exclusive: false,
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a pool");
        let error = run_job(&lease, &pool, None).expect_err("no executable to isolate it in");
        assert!(error.contains("runs foreign code"), "{error}");
        // With an executable, the child runs it (here one that is no sweep: it fails, naming
        // the plugin files).
        let error = run_job(&lease, &pool, Some(Path::new("/bin/false"))).expect_err("fails");
        assert!(error.contains("/nowhere/libx.so"), "{error}");
    }

    #[test]
    fn the_worker_is_idle_only_while_every_slot_is() {
        let start = Instant::now();
        let at = |s: u64| start + Duration::from_secs(s);
        let mut activity = Activity::idle(2, start);
        assert_eq!(activity.mark(0, false, at(5)), Some(Duration::from_secs(5)));
        assert_eq!(activity.mark(1, true, at(6)), None, "slot 1 has work");
        assert_eq!(activity.mark(0, false, at(20)), None, "slot 1 still has");
        // Slot 1 runs out at 30: the worker is idle from then, not from the start.
        assert_eq!(activity.mark(1, false, at(30)), Some(Duration::ZERO));
        assert_eq!(
            activity.mark(0, false, at(42)),
            Some(Duration::from_secs(12))
        );
    }
}
