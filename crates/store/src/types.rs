//! Plain data types of the store API. They carry no behaviour and derive serde so that a transport
//! (gRPC, JSON output of the CLI) can map them one to one.

use serde::{Deserialize, Serialize};

/// The queue contract's types, shared with workers that do not link the store.
pub use queue::{CompleteOutcome, Completion, FailOutcome, Lease, LeaseRef, WorkerInfo};

/// A campaign as submitted: its id is a hash of the plan, computed by the caller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NewCampaign {
    pub id: String,
    pub name: String,
    pub plan_text: String,
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
