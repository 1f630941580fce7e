//! Plain data types of the store API. They carry no behaviour and derive serde so that a transport
//! (gRPC, JSON output of the CLI) can map them one to one.

use serde::{Deserialize, Serialize};

/// The queue contract's types, shared with workers that do not link the store.
pub use queue::{CompleteOutcome, Completion, FailOutcome, Granted, Lease, LeaseRef, WorkerInfo};

/// A campaign as submitted: its id is a hash of the plan, computed by the caller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NewCampaign {
    pub id: String,
    pub name: String,
    pub plan_text: String,
    /// Its adaptive searches (JSON documents the store does not read), kept with it.
    #[serde(default)]
    pub searches: Vec<String>,
}

/// A search stored with its campaign.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StoredSearch {
    pub campaign_id: String,
    pub campaign_name: String,
    pub cancelled: bool,
    pub search: String,
}

/// A job (one point of a sweep) as submitted. `id` must be a hash of `kind` and the canonical
/// `params_json` so that resubmitting a point finds the existing job.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NewJob {
    pub id: String,
    pub kind: String,
    /// A JSON object; opaque to the store.
    pub params_json: String,
    /// Expected run time, used for the ETA of [`Status::estimate_s_remaining`].
    pub estimate_s: f64,
    /// Run this job only while no other job runs anywhere (memory-bound timings disturb each other).
    pub exclusive: bool,
    /// Scheduling pass: of the jobs submitted at one time, every queued job of an earlier pass is
    /// leased before any of a later one (the visits of an overlap point; 0 for most jobs).
    #[serde(default)]
    pub pass: u32,
    /// Running the job executes foreign code (a program job): it is leased only to workers that
    /// allow it ([`WorkerInfo::allow_commands`]). The submitter decides; the store knows no kinds.
    #[serde(default)]
    pub foreign_code: bool,
}

/// What [`crate::Store::submit`] did.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SubmitOutcome {
    pub campaign_id: String,
    /// Jobs that did not exist and are now queued.
    pub new_jobs: u64,
    /// Known jobs that had failed or been cancelled and are queued again with attempts reset.
    pub requeued: u64,
    /// Known jobs left as they are (queued, running or done): they are only linked to the campaign.
    pub already_known: u64,
}

/// A registered worker, as listed by [`crate::Store::workers`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkerRecord {
    pub info: WorkerInfo,
    pub registered_at: f64,
    pub last_seen_at: f64,
    /// Jobs this worker holds leases on now.
    pub running: u32,
}

/// Job counts by state and the estimated work left.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Status {
    pub total: u64,
    pub queued: u64,
    pub running: u64,
    pub done: u64,
    pub failed: u64,
    pub cancelled: u64,
    /// Sum of `estimate_s` over queued and running jobs (CPU seconds, not wall time).
    pub estimate_s_remaining: f64,
}

/// A campaign with its progress, as listed by [`crate::Store::campaigns`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CampaignInfo {
    pub id: String,
    pub name: String,
    pub created_at: f64,
    pub cancelled_at: Option<f64>,
    pub status: Status,
}

/// One results row with the identity of its job, for `sweep export`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExportRow {
    pub job_id: String,
    /// The ids of all campaigns that contain the job, oldest campaign first, joined by `,`
    /// (a job shared by several plans is measured once and belongs to each of them).
    pub campaign: String,
    pub kind: String,
    pub attempt: u32,
    pub worker: String,
    pub core_id: Option<u32>,
    pub fields: serde_json::Map<String, serde_json::Value>,
}

/// One job's results as stored: its parameters and its records, each a JSON object, in the
/// order the job wrote them. Opaque to the store.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobResults {
    pub job_id: String,
    pub params_json: String,
    pub records: Vec<String>,
}

/// Result of an ad-hoc read-only query: column names and rows of JSON values
/// (INTEGER → number, REAL → number or null if not finite, TEXT → string, BLOB → lowercase hex string).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct QueryResult {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<serde_json::Value>>,
}

/// Life cycle of a job: `queued → running → done`, or back to `queued` on failure or lease expiry until
/// `max_attempts`, then `failed`. `cancelled` comes from cancelling the campaign while queued.
/// Resubmitting a failed or cancelled job queues it again.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JobState {
    Queued,
    Running,
    Done,
    Failed,
    Cancelled,
}

impl JobState {
    /// The spelling used in the `jobs.state` column.
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Done => "done",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }

    pub(crate) fn parse(s: &str) -> Option<JobState> {
        Some(match s {
            "queued" => JobState::Queued,
            "running" => JobState::Running,
            "done" => JobState::Done,
            "failed" => JobState::Failed,
            "cancelled" => JobState::Cancelled,
            _ => return None,
        })
    }
}

/// A job that failed for good: its parameters (the JSON it was submitted with) and the reason
/// its last attempt gave (empty when none was recorded).
#[derive(Clone, Debug, PartialEq)]
pub struct FailedJob {
    pub id: String,
    pub params_json: String,
    pub reason: String,
}

/// One job as stored, for diagnosis (`sweep status` of a single job, tests).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobInfo {
    pub id: String,
    pub kind: String,
    pub params_json: String,
    pub estimate_s: f64,
    pub exclusive: bool,
    pub state: JobState,
    pub attempts: u32,
    pub lease_owner: Option<String>,
    pub lease_expires_at: Option<f64>,
    pub last_error: Option<String>,
    pub started_at: Option<f64>,
    pub finished_at: Option<f64>,
    pub created_at: f64,
}

/// The time a worker has left, for [`crate::Store::lease_within`]: a job is expected to take its
/// `estimate_s` times its kind's scale (the coordinator learns the scales from the durations it
/// observes; a kind it has not seen takes 1).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Within {
    pub seconds_left: f64,
    pub scale: std::collections::HashMap<String, f64>,
}

impl Within {
    /// The seconds a job of `kind` estimated at `estimate_s` is expected to take.
    pub fn expected_s(&self, kind: &str, estimate_s: f64) -> f64 {
        estimate_s * self.scale.get(kind).copied().unwrap_or(1.0)
    }
}

/// How long a job took, from its lease to its report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ran {
    pub kind: String,
    pub estimate_s: f64,
    pub ran_s: f64,
}

/// The head of the queue, as the allocator sizes allocations from it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct QueueSample {
    /// Queued jobs in all.
    pub queued: u64,
    /// Kind and estimate of the first queued jobs in lease order (a fixed shuffle of each plan,
    /// so a fair sample of it).
    pub head: Vec<(String, f64)>,
}

/// Where an allocation is in its life: `pending` (submitted, waiting in the batch system),
/// `running`, then `ended` (it ran and stopped), `failed` (the submission failed, or it ended
/// without ever starting a worker) or `cancelled` (by the allocator: nothing left to do).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AllocationState {
    Pending,
    Running,
    Ended,
    Failed,
    Cancelled,
}

impl AllocationState {
    /// The spelling used in the `allocations.state` column and in every output.
    pub fn as_str(self) -> &'static str {
        match self {
            AllocationState::Pending => "pending",
            AllocationState::Running => "running",
            AllocationState::Ended => "ended",
            AllocationState::Failed => "failed",
            AllocationState::Cancelled => "cancelled",
        }
    }

    pub fn parse(s: &str) -> Option<AllocationState> {
        Some(match s {
            "pending" => AllocationState::Pending,
            "running" => AllocationState::Running,
            "ended" => AllocationState::Ended,
            "failed" => AllocationState::Failed,
            "cancelled" => AllocationState::Cancelled,
            _ => return None,
        })
    }

    /// Pending or running: the batch system still has it.
    pub fn is_open(self) -> bool {
        matches!(self, AllocationState::Pending | AllocationState::Running)
    }
}

/// One allocation as recorded (migration 0014).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Allocation {
    pub id: i64,
    /// `slurm`.
    pub manager: String,
    /// The batch system's id (a Slurm job id); `None` when the submission failed.
    pub external_id: Option<String>,
    pub state: AllocationState,
    pub nodes: u32,
    /// Cores of the whole allocation.
    pub cores: u32,
    pub time_limit_s: f64,
    pub submitted_at: f64,
    pub started_at: Option<f64>,
    pub ended_at: Option<f64>,
    /// Slurm's pending reason, how it ended, or why it failed.
    pub reason: String,
}

/// The allocator's state: how many submissions or allocations failed in a row, when it may
/// submit again, and its last decision in words.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct AllocatorState {
    pub updated_at: f64,
    pub failures: u32,
    pub retry_at: Option<f64>,
    pub note: String,
}
