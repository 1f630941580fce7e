//! The queue contract between a worker and a coordinator: what a worker is handed (a [`Lease`]),
//! what it gives back (a [`Completion`], a failure, a release), what became of it, and the
//! [`JobQueue`] trait a worker calls. Both ends depend on this crate and on nothing of each other:
//! a remote worker links neither the store nor the scheduler, and the coordinator implements the
//! trait for local mode (the same scheduler, called in-process).
//!
//! Plain data with serde, so that a transport (gRPC, JSON) can map it one to one.

use std::future::Future;

use serde::{Deserialize, Serialize};

/// Who a worker is: provenance recorded with every result it produces.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorkerInfo {
    pub id: String,
    pub hostname: String,
    /// The core ids this worker pins its job slots to.
    pub cores: Vec<u32>,
    pub cpu_model: String,
    pub cpu_flags: String,
    pub rustc: String,
    pub git_commit: String,
    /// Cargo build profile (`release`, `dev`, ...).
    pub profile: String,
    /// The batch system's id of the allocation the worker runs in (a Slurm job id); `None` for a
    /// worker started by hand. Not provenance: it only links a worker to the allocation that
    /// brought it.
    #[serde(default)]
    pub allocation: Option<String>,
    /// Started with `--allow-commands`: the worker may be given jobs that run foreign code
    /// (program jobs). Not provenance either; a worker without it never sees such jobs.
    #[serde(default)]
    pub allow_commands: bool,
}

/// A job handed to a worker. The worker must quote `job_id` and `token` when it reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Lease {
    pub job_id: String,
    pub kind: String,
    pub params_json: String,
    /// 1 for the first attempt.
    pub attempt: u32,
    /// Fencing token: unique per lease, never reused, so a report from an older lease is recognised.
    pub token: i64,
    /// Expiry in the coordinator's clock (NaN where the transport does not carry it: a worker only
    /// needs to know the lease duration, which it learns when it registers).
    pub expires_at: f64,
    /// The job must run alone on the machine (exclusive timing).
    pub exclusive: bool,
}

impl Lease {
    /// The reference quoted in heartbeats and reports.
    pub fn reference(&self) -> LeaseRef {
        LeaseRef {
            job_id: self.job_id.clone(),
            token: self.token,
        }
    }
}

/// What a lease call got.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Granted {
    pub leases: Vec<Lease>,
    /// Queued jobs passed over because they are expected to take longer than the time the worker
    /// said it has left (only when it said so). No lease and some passed over: nothing queued at
    /// the head of the queue fits in what is left of the worker's allocation.
    pub passed_over: u64,
}

impl Granted {
    /// Whether queued work exists that the asking worker has no time left for, and none it has.
    pub fn nothing_fits(&self) -> bool {
        self.leases.is_empty() && self.passed_over > 0
    }
}

/// A reference to a lease held by a worker (for heartbeats, failures and releases).
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LeaseRef {
    pub job_id: String,
    pub token: i64,
}

/// One finished job's report.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Completion {
    pub job_id: String,
    pub token: i64,
    /// The core the job ran on, for provenance.
    pub core_id: Option<u32>,
    /// Result records, each a JSON object.
    pub records: Vec<String>,
}

/// What became of a completion report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CompleteOutcome {
    /// Results stored and the job is done.
    Accepted,
    /// The lease was no longer this worker's (expired and reaped, re-leased, cancelled, or done by
    /// another lease): recorded in `late_reports`, results not written.
    Late,
    /// This very lease already completed the job (a retried report): nothing written.
    AlreadyDone,
}

/// What became of a failure report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FailOutcome {
    /// Attempts remain: the job is queued again.
    Requeued,
    /// `max_attempts` reached: the job is failed with this error as `last_error`.
    Failed,
    /// The lease was no longer this worker's: recorded in `late_reports`, the job is untouched.
    Late,
}

/// Why a call to the queue failed, sorted by what the worker should do about it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum QueueError {
    /// The coordinator could not be reached, or was busy or failed inside: worth retrying.
    #[error("transport: {0}")]
    Transport(String),
    /// The coordinator answered that this request cannot succeed (an unknown job, a malformed
    /// record): retrying it would only repeat the answer.
    #[error("rejected by the coordinator: {0}")]
    Rejected(String),
    /// The coordinator refused our credentials: retrying cannot help.
    #[error("refused by the coordinator: {0}")]
    Refused(String),
}

impl QueueError {
    /// Whether the same request may succeed later (the coordinator is away or busy).
    pub fn is_transient(&self) -> bool {
        matches!(self, QueueError::Transport(_))
    }
}

/// What a worker needs from a coordinator, wherever it is. Every state change a call makes is
/// durable before the call returns `Ok`.
pub trait JobQueue: Send + Sync + 'static {
    /// Leases up to `max_jobs` queued jobs, oldest first; none when nothing may be leased now.
    /// With `seconds_left` (a worker whose allocation ends), only jobs expected to finish within
    /// it, one after the other; [`Granted::passed_over`] counts those left for another worker.
    fn lease(
        &self,
        max_jobs: u32,
        seconds_left: Option<f64>,
    ) -> impl Future<Output = Result<Granted, QueueError>> + Send;
    /// Extends `held`; answers the leases still valid.
    fn heartbeat(
        &self,
        held: Vec<LeaseRef>,
    ) -> impl Future<Output = Result<Vec<LeaseRef>, QueueError>> + Send;
    /// Delivers finished jobs' records, several at once: one transaction, one round trip. The
    /// outcomes are in input order. The batch is taken whole or rejected whole.
    fn complete(
        &self,
        completions: Vec<Completion>,
    ) -> impl Future<Output = Result<Vec<CompleteOutcome>, QueueError>> + Send;
    fn fail(
        &self,
        lease: &LeaseRef,
        error: String,
    ) -> impl Future<Output = Result<FailOutcome, QueueError>> + Send;
    /// Gives unstarted leases back without counting an attempt.
    fn release(&self, leases: Vec<LeaseRef>)
    -> impl Future<Output = Result<(), QueueError>> + Send;
}
