//! A worker: one slot per core of its budget, each an OS thread pinned to its core, each running
//! one leased job at a time through [`jobs::run`], so timing jobs never share a core. Jobs come
//! from a [`JobQueue`]: the coordinator embedded in this process (local mode, [`Embedded`]) or a
//! remote one.
//!
//! - [`provenance`]: what the worker tells the coordinator about its machine and build.
//! - [`slots`]: the pinned threads and the heartbeat that keeps their leases.
//! - [`remote`]: the [`JobQueue`] of a coordinator reached over gRPC.

pub mod provenance;
pub mod remote;
pub mod slots;

use std::future::Future;

use coordinator::{CompleteOutcome, Completion, Coordinator, FailOutcome, Lease, LeaseRef};

pub use slots::{Slots, WorkerOptions};

#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    #[error("coordinator: {0}")]
    Coordinator(#[from] coordinator::Error),
    /// The coordinator could not be reached, or failed inside: worth retrying.
    #[error("transport: {0}")]
    Transport(String),
    /// The coordinator answered that this request cannot succeed (an unknown job, a malformed
    /// record): retrying it would only repeat the answer.
    #[error("rejected by the coordinator: {0}")]
    Rejected(String),
    /// The coordinator refused our credentials: retrying cannot help.
    #[error("refused by the coordinator: {0}")]
    Refused(String),
    #[error("core {0} is not available to this process")]
    NoSuchCore(usize),
    #[error("cannot list this machine's cores")]
    NoCores,
}

impl WorkerError {
    /// Whether the same request may succeed later (the coordinator is away or busy).
    pub fn is_transient(&self) -> bool {
        match self {
            WorkerError::Transport(_) => true,
            WorkerError::Coordinator(error) => error.is_transient(),
            _ => false,
        }
    }
}

/// What a worker needs from a coordinator, wherever it is.
pub trait JobQueue: Send + Sync + 'static {
    fn lease(&self, max_jobs: u32) -> impl Future<Output = Result<Vec<Lease>, WorkerError>> + Send;
    /// Extends `held`; answers the leases still valid.
    fn heartbeat(&self, held: Vec<LeaseRef>) -> impl Future<Output = Result<Vec<LeaseRef>, WorkerError>> + Send;
    /// Delivers finished jobs' records, several at once: one transaction, one round trip.
    fn complete(
        &self,
        completions: Vec<Completion>,
    ) -> impl Future<Output = Result<Vec<CompleteOutcome>, WorkerError>> + Send;
    fn fail(&self, lease: &LeaseRef, error: String) -> impl Future<Output = Result<FailOutcome, WorkerError>> + Send;
    /// Gives unstarted leases back without counting an attempt.
    fn release(&self, leases: Vec<LeaseRef>) -> impl Future<Output = Result<(), WorkerError>> + Send;
}

/// The coordinator in this process: local mode is the same scheduler, called directly.
#[derive(Clone)]
pub struct Embedded {
    pub coordinator: Coordinator,
    pub worker_id: String,
}

impl JobQueue for Embedded {
    async fn lease(&self, max_jobs: u32) -> Result<Vec<Lease>, WorkerError> {
        Ok(self.coordinator.lease(&self.worker_id, max_jobs, true).await?)
    }

    async fn heartbeat(&self, held: Vec<LeaseRef>) -> Result<Vec<LeaseRef>, WorkerError> {
        Ok(self.coordinator.heartbeat(&self.worker_id, &held).await?)
    }

    async fn complete(&self, completions: Vec<Completion>) -> Result<Vec<CompleteOutcome>, WorkerError> {
        Ok(self.coordinator.complete_batch(&self.worker_id, &completions).await?)
    }

    async fn fail(&self, lease: &LeaseRef, error: String) -> Result<FailOutcome, WorkerError> {
        Ok(self.coordinator.fail(&self.worker_id, &lease.job_id, lease.token, &error).await?)
    }

    async fn release(&self, leases: Vec<LeaseRef>) -> Result<(), WorkerError> {
        self.coordinator.release(&self.worker_id, &leases).await?;
        Ok(())
    }
}
