//! The store's typed errors. Every variant says what the caller can do about it.

use std::path::PathBuf;

/// Errors of the store. Input problems (unknown ids, malformed JSON, conflicting data) have their own
/// variants so that a coordinator can answer a worker precisely; SQLite failures are wrapped in
/// [`Error::Database`].
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("cannot open database {path}: {source}")]
    Open {
        path: PathBuf,
        #[source]
        source: sqlx::Error,
    },
    #[error("cannot migrate database {path}: {source}")]
    Migrate {
        path: PathBuf,
        #[source]
        source: sqlx::migrate::MigrateError,
    },
    #[error(
        "{path} lacks schema migration {version} (not a sweep database, or written by an older sweep: \
         open it once read-write to migrate)"
    )]
    SchemaOutdated { path: PathBuf, version: i64 },
    #[error("the store was opened read-only")]
    ReadOnly,
    #[error("unknown worker {0:?}: register it first")]
    UnknownWorker(String),
    #[error("unknown job {0:?}")]
    UnknownJob(String),
    #[error("unknown campaign {0:?}")]
    UnknownCampaign(String),
    #[error("job {job_id:?}: params are not a JSON object: {reason}")]
    InvalidParams { job_id: String, reason: String },
    #[error("job {job_id:?}: estimate_s must be finite and >= 0, got {estimate_s}")]
    InvalidEstimate { job_id: String, estimate_s: f64 },
    #[error(
        "job {job_id:?} already exists with a different {field}: the job id must be a hash of kind and params"
    )]
    JobConflict { job_id: String, field: &'static str },
    #[error(
        "worker {worker_id:?} is already registered with a different {field}: results keep the provenance \
         of their worker, so a changed worker needs a new id"
    )]
    WorkerConflict {
        worker_id: String,
        field: &'static str,
    },
    #[error("job {job_id:?}: result record {index} is not a JSON object: {reason}")]
    InvalidRecord {
        job_id: String,
        index: usize,
        reason: String,
    },
    #[error("job {0:?} appears twice in one batch of completions")]
    DuplicateCompletion(String),
    #[error("not a read-only query: {0}")]
    NotAQuery(String),
    #[error("stored data is inconsistent: {0}")]
    Corrupt(String),
    #[error(transparent)]
    Database(#[from] sqlx::Error),
    /// The transaction this write was grouped into did not commit: nothing of it was written, and
    /// the same write may succeed if tried again.
    #[error("database error, nothing written: {0}")]
    NotCommitted(std::sync::Arc<sqlx::Error>),
}

/// Shorthand used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
