//! The results layer's errors: the store's, and stored data that does not hold what its kind of
//! job writes (never skipped: a report that silently lost a point would be a wrong report).

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Store(#[from] store::Error),
    #[error("stored data is inconsistent: {kind} job {job:?}: {what}")]
    Corrupt {
        kind: &'static str,
        job: String,
        what: String,
    },
    /// A total over many jobs' records that did not come back as a number.
    #[error("stored data is inconsistent: {0}")]
    Totals(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The error for job `job` of `kind` whose stored data lacks or garbles `what`.
pub(crate) fn corrupt(kind: &'static str, job: &str, what: impl std::fmt::Display) -> Error {
    Error::Corrupt {
        kind,
        job: job.to_owned(),
        what: what.to_string(),
    }
}
