//! The scheduling core of sweep: hands jobs to workers under leases, takes their reports, retries
//! failures, reaps lost leases and keeps exclusive jobs alone. It knows no physics (jobs are opaque
//! JSON) and no transport: the same [`Coordinator`] is called directly by the worker slots of local
//! mode (`sweep run`) and wrapped by the gRPC service of `sweep coordinator`.
//!
//! Map of the crate:
//! - [`Coordinator`] (this file): the operations a worker or an admin needs, each a thin layer over
//!   one [`store`] transaction that supplies the time and the retry policy.
//! - [`clock`]: [`SystemClock`] for production, [`ManualClock`] for tests that advance time.
//! - [`durations`]: how long each kind of job really takes against its estimate, learned from
//!   the reports: what walltime-aware leasing ([`Coordinator::lease_within`]) and the allocator
//!   expect a job to take.
//! - [`autoalloc`]: the allocator of `--slurm-alloc`: submits Slurm allocations of workers while
//!   work is queued, sized to it, and follows them.
//! - [`grpc`]: the `sweep.v1` Worker and Admin services over this coordinator, with auth and TLS.
//! - [`embedded`]: the [`queue::JobQueue`] of local mode, this coordinator called in-process.
//!
//! Where the guarantees live: exactly-once results, fencing tokens and the exclusive-job rule are
//! enforced inside the store's transactions, so they hold across processes sharing one database, not
//! only inside one coordinator.

pub mod autoalloc;
pub mod clock;
pub mod durations;
pub mod embedded;
pub mod grpc;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use tokio::task::JoinHandle;

pub use clock::{Clock, ManualClock, SystemClock};
pub use durations::Durations;
pub use embedded::Embedded;
pub use store::{
    CompleteOutcome, Completion, FailOutcome, Granted, Lease, LeaseRef, NewCampaign, NewJob,
    Status, Store, SubmitOutcome, WorkerInfo,
};

/// Errors of the coordinator.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid coordinator configuration: {0}")]
    Config(&'static str),
    #[error(transparent)]
    Store(#[from] store::Error),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Whether the same request may succeed later: the database was busy or unavailable. Every
    /// other error (an unknown job, a malformed record, a read-only store) will recur.
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            Error::Store(store::Error::Database(_) | store::Error::NotCommitted(_))
        )
    }
}

/// Scheduling policy.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Config {
    /// How long a lease lasts without a heartbeat. Workers should heartbeat several times per lease.
    pub lease_for: Duration,
    /// Attempts (failures or lost leases) before a job is marked failed.
    pub max_attempts: u32,
    /// The jobs one round of grants may hand out across the cluster: a lease is capped at a fair
    /// share, `min(queued, in_flight_budget) / active slots` (at least 1), so no worker hoards the
    /// queue and the jobs in flight stay near this whatever the slot count (a paced no-op slot asks
    /// for 512: 1,024 of them held 524,288 leases, more than the writer could turn over before
    /// their callers' deadlines).
    #[serde(default = "default_in_flight_budget")]
    pub in_flight_budget: u64,
}

fn default_in_flight_budget() -> u64 {
    32_768
}

impl Default for Config {
    fn default() -> Self {
        Config {
            lease_for: Duration::from_secs(60),
            max_attempts: 3,
            in_flight_budget: default_in_flight_budget(),
        }
    }
}

/// How often, in seconds of the coordinator's clock, the fair lease share is recomputed (sooner
/// after anything that queues jobs or adds slots).
const SHARE_REFRESH_S: f64 = 1.0;

/// The fair share of one grant, as last computed.
#[derive(Debug, Default)]
struct LeaseShare {
    computed_at: Option<f64>,
    per_grant: u32,
}

/// The scheduler: a [`Store`] plus policy and clock. Cheap to clone; clones share everything.
#[derive(Clone)]
pub struct Coordinator {
    store: Store,
    config: Config,
    clock: Arc<dyn Clock>,
    share: Arc<tokio::sync::Mutex<LeaseShare>>,
    /// Set by what may grow the queue or the slots (submit, register, a requeue): the share is
    /// recomputed at the next lease instead of up to [`SHARE_REFRESH_S`] later.
    share_stale: Arc<AtomicBool>,
    /// What the reports taught about each kind's durations; first filled from the store's
    /// latest done jobs when someone asks.
    durations: Arc<std::sync::Mutex<Durations>>,
    durations_seeded: Arc<tokio::sync::OnceCell<()>>,
    queue_grew: Arc<tokio::sync::Notify>,
    /// An allocator submits workers for this coordinator (set by [`autoalloc::Allocator`]).
    allocating: Arc<AtomicBool>,
}

/// Done jobs a coordinator learns durations from when it starts on a database.
const SEED_DURATIONS: u32 = 256;

impl std::fmt::Debug for Coordinator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Coordinator")
            .field("config", &self.config)
            .finish_non_exhaustive()
    }
}

impl Coordinator {
    /// A coordinator over `store`. Fails on a zero lease duration or zero attempts, which would make
    /// every job expire or fail at once.
    pub fn new(store: Store, config: Config, clock: Arc<dyn Clock>) -> Result<Self> {
        if config.lease_for.is_zero() {
            return Err(Error::Config("lease_for must be positive"));
        }
        if config.max_attempts == 0 {
            return Err(Error::Config("max_attempts must be at least 1"));
        }
        if config.in_flight_budget == 0 {
            return Err(Error::Config("in_flight_budget must be at least 1"));
        }
        Ok(Coordinator {
            store,
            config,
            clock,
            share: Arc::default(),
            share_stale: Arc::default(),
            durations: Arc::default(),
            durations_seeded: Arc::default(),
            queue_grew: Arc::default(),
            allocating: Arc::default(),
        })
    }

    /// What the reports taught about each kind's durations (seeded from the store's latest done
    /// jobs on first use).
    pub async fn durations(&self) -> Result<Durations> {
        self.durations_seeded
            .get_or_try_init(|| async {
                let seen = self.store.recent_durations(SEED_DURATIONS).await?;
                let mut durations = self.lock_durations();
                // Oldest first, so the newest stay if there are more than a kind keeps.
                seen.iter().rev().for_each(|ran| durations.observe(ran));
                Ok::<(), Error>(())
            })
            .await?;
        Ok(self.lock_durations().clone())
    }

    fn lock_durations(&self) -> std::sync::MutexGuard<'_, Durations> {
        // Plain data: a panic while it was held cannot have left it half-changed in a way that
        // matters (a ratio is pushed or not).
        self.durations
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The most jobs one grant may take now: `min(queued, in_flight_budget) / active slots`, at
    /// least 1 (a slot always gets work while any is queued). The inputs are read at most every
    /// [`SHARE_REFRESH_S`] (counting the queue is O(budget), too much for every lease).
    async fn fair_share(&self, now: f64) -> Result<u32> {
        let mut share = self.share.lock().await;
        let stale = self.share_stale.swap(false, Ordering::AcqRel);
        if let Some(at) = share.computed_at
            && !stale
            && (at..at + SHARE_REFRESH_S).contains(&now)
        {
            return Ok(share.per_grant);
        }
        let budget = self.config.in_flight_budget;
        let active_since = now - self.config.lease_for.as_secs_f64();
        let (queued, slots) = self.store.lease_share_inputs(budget, active_since).await?;
        let per_grant = (queued.min(budget) / slots.max(1)).max(1);
        share.per_grant = u32::try_from(per_grant).unwrap_or(u32::MAX);
        share.computed_at = Some(now);
        Ok(share.per_grant)
    }

    fn share_changed(&self) {
        self.share_stale.store(true, Ordering::Release);
    }

    /// The coordinator's clock, now (Unix seconds).
    pub fn now(&self) -> f64 {
        self.clock.now()
    }

    /// Notified whenever a submission may have queued jobs: what waits for work (the
    /// allocator) wakes at once instead of at its next period.
    pub fn queue_grew(&self) -> Arc<tokio::sync::Notify> {
        self.queue_grew.clone()
    }

    /// Whether an allocator submits workers for this coordinator (`--slurm-alloc`).
    pub fn allocating(&self) -> bool {
        self.allocating.load(Ordering::Acquire)
    }

    /// Records that an allocator submits workers for this coordinator.
    pub fn set_allocating(&self) {
        self.allocating.store(true, Ordering::Release);
    }

    /// The underlying store, for reads (reports, export, queries).
    pub fn store(&self) -> &Store {
        &self.store
    }

    pub fn config(&self) -> Config {
        self.config
    }

    /// Registers a worker (or refreshes a re-registration with identical provenance).
    pub async fn register(&self, worker: &WorkerInfo) -> Result<()> {
        self.store.register_worker(worker, self.clock.now()).await?;
        self.share_changed();
        Ok(())
    }

    /// Leases up to `max_jobs` jobs to `worker_id` for [`Config::lease_for`], and no more than a
    /// fair share of the queue (see [`Config::in_flight_budget`]). `exclusive_ok` says the worker
    /// may take a job that must run alone (see [`Store::lease`] for the exclusive rule).
    pub async fn lease(
        &self,
        worker_id: &str,
        max_jobs: u32,
        exclusive_ok: bool,
    ) -> Result<Vec<Lease>> {
        let now = self.clock.now();
        if max_jobs == 0 {
            return Ok(Vec::new());
        }
        let max_jobs = max_jobs.min(self.fair_share(now).await?);
        Ok(self
            .store
            .lease(
                worker_id,
                max_jobs,
                self.config.lease_for,
                now,
                exclusive_ok,
            )
            .await?)
    }

    /// [`Coordinator::lease`] for a worker with `seconds_left` (its allocation ends): only jobs
    /// expected to finish within them, one after the other, each expected to take its estimate
    /// times what its kind has been observed to take per second of estimate ([`Durations`]).
    /// Without `seconds_left`, exactly [`Coordinator::lease`].
    pub async fn lease_within(
        &self,
        worker_id: &str,
        max_jobs: u32,
        exclusive_ok: bool,
        seconds_left: Option<f64>,
    ) -> Result<Granted> {
        let Some(seconds_left) = seconds_left else {
            let leases = self.lease(worker_id, max_jobs, exclusive_ok).await?;
            return Ok(Granted {
                leases,
                passed_over: 0,
            });
        };
        let now = self.clock.now();
        if max_jobs == 0 {
            return Ok(Granted::default());
        }
        let max_jobs = max_jobs.min(self.fair_share(now).await?);
        let within = store::Within {
            seconds_left: seconds_left.max(0.0),
            scale: self.durations().await?.scales(),
        };
        Ok(self
            .store
            .lease_within(
                worker_id,
                max_jobs,
                self.config.lease_for,
                now,
                exclusive_ok,
                Some(within),
            )
            .await?)
    }

    /// Extends the worker's leases by [`Config::lease_for`] from now; returns those still valid.
    /// A lease missing from the answer was lost: the worker should drop that job.
    pub async fn heartbeat(&self, worker_id: &str, leases: &[LeaseRef]) -> Result<Vec<LeaseRef>> {
        let now = self.clock.now();
        let extend_to = now + self.config.lease_for.as_secs_f64();
        Ok(self
            .store
            .heartbeat(worker_id, leases, extend_to, now)
            .await?)
    }

    /// Reports a job's result records (each a JSON object); see [`CompleteOutcome`].
    pub async fn complete(
        &self,
        worker_id: &str,
        job_id: &str,
        token: i64,
        core_id: Option<u32>,
        records: &[String],
    ) -> Result<CompleteOutcome> {
        let completion = Completion {
            job_id: job_id.to_owned(),
            token,
            core_id,
            records: records.to_vec(),
        };
        let outcomes = self.complete_batch(worker_id, &[completion]).await?;
        outcomes.first().copied().ok_or_else(|| {
            Error::Store(store::Error::Corrupt(
                "a completion produced no outcome".to_owned(),
            ))
        })
    }

    /// Reports many jobs of one worker in one transaction (see [`Store::complete_batch`]): the way to
    /// sustain thousands of short jobs per second. Outcomes are in input order.
    pub async fn complete_batch(
        &self,
        worker_id: &str,
        completions: &[Completion],
    ) -> Result<Vec<CompleteOutcome>> {
        let now = self.clock.now();
        let (outcomes, ran) = self
            .store
            .complete_batch_ran(worker_id, completions, now)
            .await?;
        if !ran.is_empty() {
            let mut durations = self.lock_durations();
            ran.iter().for_each(|r| durations.observe(r));
        }
        Ok(outcomes)
    }

    /// Reports a failed attempt; the job is retried until [`Config::max_attempts`].
    pub async fn fail(
        &self,
        worker_id: &str,
        job_id: &str,
        token: i64,
        error: &str,
    ) -> Result<FailOutcome> {
        let now = self.clock.now();
        let outcome = self
            .store
            .fail(
                worker_id,
                job_id,
                token,
                error,
                self.config.max_attempts,
                now,
            )
            .await?;
        self.share_changed();
        Ok(outcome)
    }

    /// Gives unstarted leases back without counting an attempt (a worker shutting down).
    pub async fn release(&self, worker_id: &str, leases: &[LeaseRef]) -> Result<u64> {
        let released = self
            .store
            .release(worker_id, leases, self.clock.now())
            .await?;
        self.share_changed();
        Ok(released)
    }

    /// Ends every lease of a worker known to be dead, so its jobs run again at once.
    pub async fn reclaim(&self, worker_id: &str) -> Result<u64> {
        let reaped = self
            .store
            .reclaim(worker_id, self.clock.now(), self.config.max_attempts)
            .await?;
        self.share_changed();
        Ok(reaped)
    }

    /// Reaps expired leases (their jobs are retried, or failed after [`Config::max_attempts`]).
    /// Returns how many were reaped. Called periodically, e.g. by [`Coordinator::spawn_reaper`].
    pub async fn tick(&self) -> Result<u64> {
        let reaped = self
            .store
            .expire_leases(self.clock.now(), self.config.max_attempts)
            .await?;
        if reaped > 0 {
            self.share_changed();
        }
        Ok(reaped)
    }

    /// Runs [`Coordinator::tick`] every `every` until the returned task is aborted. Errors are logged,
    /// not fatal: a busy database at one tick is retried at the next.
    pub fn spawn_reaper(&self, every: Duration) -> JoinHandle<()> {
        let coordinator = self.clone();
        tokio::spawn(async move {
            let mut interval = tokio::time::interval(every);
            interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            loop {
                interval.tick().await;
                match coordinator.tick().await {
                    Ok(0) => {}
                    Ok(reaped) => tracing::info!(reaped, "expired leases reaped"),
                    Err(error) => tracing::warn!(%error, "reaping expired leases failed"),
                }
            }
        })
    }

    /// Submits a campaign; only jobs not known yet are scheduled (see [`Store::submit`]).
    pub async fn submit(&self, campaign: &NewCampaign, jobs: &[NewJob]) -> Result<SubmitOutcome> {
        let outcome = self.store.submit(campaign, jobs, self.clock.now()).await?;
        self.share_changed();
        if outcome.new_jobs + outcome.requeued > 0 {
            self.queue_grew.notify_one();
        }
        Ok(outcome)
    }

    /// Job counts of one campaign, or of everything with `None`.
    pub async fn status(&self, campaign: Option<&str>) -> Result<Status> {
        Ok(self.store.status(campaign).await?)
    }

    /// Cancels a campaign's queued jobs; returns how many were cancelled.
    pub async fn cancel(&self, campaign_id: &str) -> Result<u64> {
        Ok(self.store.cancel(campaign_id, self.clock.now()).await?)
    }
}
