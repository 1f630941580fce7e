//! Local mode: the worker slots of `sweep run` call this process's [`Coordinator`] through the
//! same [`JobQueue`] contract a remote worker uses over gRPC.

use queue::{CompleteOutcome, Completion, FailOutcome, Granted, JobQueue, LeaseRef, QueueError};

use crate::{Coordinator, Error};

/// The coordinator in this process, seen by one registered worker.
#[derive(Clone)]
pub struct Embedded {
    pub coordinator: Coordinator,
    pub worker_id: String,
}

/// Sorted as the gRPC service sorts its status codes: a busy database may pass, the rest recurs.
fn queue_error(error: Error) -> QueueError {
    if error.is_transient() {
        QueueError::Transport(error.to_string())
    } else {
        QueueError::Rejected(error.to_string())
    }
}

impl JobQueue for Embedded {
    async fn lease(&self, max_jobs: u32, seconds_left: Option<f64>) -> Result<Granted, QueueError> {
        self.coordinator
            .lease_within(&self.worker_id, max_jobs, true, seconds_left)
            .await
            .map_err(queue_error)
    }

    async fn heartbeat(&self, held: Vec<LeaseRef>) -> Result<Vec<LeaseRef>, QueueError> {
        self.coordinator
            .heartbeat(&self.worker_id, &held)
            .await
            .map_err(queue_error)
    }

    async fn complete(
        &self,
        completions: Vec<Completion>,
    ) -> Result<Vec<CompleteOutcome>, QueueError> {
        self.coordinator
            .complete_batch(&self.worker_id, &completions)
            .await
            .map_err(queue_error)
    }

    async fn fail(&self, lease: &LeaseRef, error: String) -> Result<FailOutcome, QueueError> {
        self.coordinator
            .fail(&self.worker_id, &lease.job_id, lease.token, &error)
            .await
            .map_err(queue_error)
    }

    async fn release(&self, leases: Vec<LeaseRef>) -> Result<(), QueueError> {
        self.coordinator
            .release(&self.worker_id, &leases)
            .await
            .map(drop)
            .map_err(queue_error)
    }
}
