//! SQLite persistence for sweep: campaigns, jobs and their leases, results and worker provenance.
//! The store knows no physics: job parameters and result records are opaque JSON objects that it
//! returns as written (only the SQL views in `/migrations` name their fields, for `sweep query`);
//! what a record contains is read by the `results` crate.
//!
//! Map of the crate:
//! - `connect`: [`Store::open`] (read-write, applies migrations) and [`Store::open_read_only`];
//!   the writer/reader pools and pragmas.
//! - `campaigns`: [`Store::submit`] and [`Store::cancel`].
//! - `workers`: [`Store::register_worker`], [`Store::touch_worker`].
//! - `leases`: the job life cycle — [`Store::lease`] (and [`Store::lease_within`] for a worker
//!   whose time is limited), [`Store::heartbeat`], [`Store::complete`], [`Store::complete_batch`],
//!   [`Store::fail`], [`Store::expire_leases`]; the exclusive-job rule and exactly-once results
//!   live here.
//! - `allocations`: the allocations of a batch system and the allocator's state
//!   ([`Store::insert_allocation`], [`Store::allocations`], [`Store::set_allocator_state`]), and
//!   what sizes them ([`Store::queue_sample`], [`Store::recent_durations`]).
//! - `read`: [`Store::status`], [`Store::campaigns`], [`Store::workers`], [`Store::job`],
//!   [`Store::failed_jobs`], [`Store::results_of`] (a kind's jobs with their records),
//!   [`Store::export`], [`Store::query_read_only`].
//! - `activity`: [`Store::recent_failures`] (the `job_failures` log), [`Store::worker_activity`],
//!   [`Store::done_by_kind`]: what the live status page samples.
//! - `writer`: group commit — the task that applies concurrent writes in one transaction.
//! - [`types`] and [`error`]: the plain data and error types of the API.
//!
//! Invariants: every write runs inside a `BEGIN IMMEDIATE` transaction on the single writer
//! connection, grouped with the writes that arrived meanwhile, and is answered after the commit; a
//! job's results are written exactly once, in the transaction that marks it done, and only by the
//! lease (fencing token) that currently owns it; times are caller-supplied Unix seconds, so the
//! scheduler's clock can be simulated.

mod activity;
mod allocations;
mod campaigns;
mod connect;
pub mod error;
mod leases;
mod read;
pub mod types;
mod workers;
mod writer;

pub use activity::{FailureRecord, JobInHand, WorkerActivity};
pub use connect::Store;
pub use error::{Error, Result};
pub use leases::SCAN_AHEAD;
pub use types::{
    Allocation, AllocationState, AllocatorState, CampaignInfo, CompleteOutcome, Completion,
    ExportRow, FailOutcome, FailedJob, Granted, JobInfo, JobResults, JobState, Lease, LeaseRef,
    NewCampaign, NewJob, QueryResult, QueueSample, Ran, Status, StoredSearch, SubmitOutcome,
    Within, WorkerInfo, WorkerRecord,
};
pub use writer::WriteGroups;
