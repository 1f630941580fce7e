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

/// One overlap job (point) and algorithm: the means over its repeats, and what a robust
/// re-estimate needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OverlapRow {
    pub job_id: String,
    pub l_star: f64,
    pub w_star: f64,
    pub r_star: f64,
    pub acceptance_target: f64,
    pub configurations: i64,
    pub precision: String,
    pub algorithm: String,
    pub mean_ms: f64,
    pub ns_per_check: f64,
    /// Measured acceptance (mean over repeats).
    pub acceptance: f64,
    pub repeats: u32,
    /// Each repeat's `ns_per_check`, in no particular order.
    pub repeat_ns_per_check: Vec<f64>,
    /// Each repeat's blocks' ns/check, in no particular order of repeats; empty for points
    /// measured before blocks were kept.
    pub block_ns_per_check: Vec<Vec<f64>>,
    /// Whether the machine was still disturbed after the re-runs; `None` without a noise check.
    pub disturbed: Option<bool>,
    pub reruns: Option<u32>,
    /// Which visit of its point the job measured (0: the first, or the only one).
    #[serde(default)]
    pub visit: u32,
    /// The point's parameters without its visit (the job's canonical params less `visit`): the
    /// rows of one point's visits, and only those, share it.
    #[serde(default)]
    pub point: String,
}

/// How the overlap points of a campaign were measured (`sweep status`, reports).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct OverlapQuality {
    /// Points measured with the noise check.
    pub checked: u64,
    /// Points still measured on a disturbed machine after their re-runs (flagged).
    pub disturbed: u64,
    /// Points re-run at least once because the machine was disturbed.
    pub rerun: u64,
    /// Re-runs in all.
    pub reruns: u64,
    /// Wall time of their measurements, re-runs included, and the part in the timed loops.
    pub wall_s: f64,
    pub timed_s: f64,
}

/// One done EDMD point (the `edmd_runs` view): its parameters, its time per collision and the
/// checks that say whether the run was right.
#[derive(Clone, Debug, PartialEq)]
pub struct EdmdRun {
    pub job_id: String,
    pub shape: String,
    pub n: i64,
    pub phi: f64,
    pub x0: f64,
    /// A superquadric's exponents [n, m, p] (Eq. 77); `None` for other shapes.
    pub exponents: Option<[f64; 3]>,
    pub neighbours: String,
    pub delta_nnl: f64,
    pub tau_c_us: f64,
    /// τ_c from the thread's CPU time; `None` for records written before it was kept.
    pub tau_c_cpu_us: Option<f64>,
    pub pressure_z: f64,
    /// Standard error of Z; `None` when the run had too few blocks to tell.
    pub pressure_z_err: Option<f64>,
    pub eps_d: f64,
    pub eps_nnl: f64,
    pub nr_tol: f64,
    pub nr_max_iter: i64,
    pub nr_relax: f64,
    pub sd_max_iter: i64,
    pub sd_tol: f64,
    pub brent_tol: f64,
    pub seed: i64,
    /// Collisions of the measured run.
    pub collisions: i64,
    pub energy_drift_rel: f64,
    pub overlaps: i64,
    pub solver_failures: i64,
    /// Contact times found by bisection after Newton–Raphson failed.
    pub contact_nr_fallbacks: i64,
    pub nr_iterations_mean: f64,
    pub distance_calls_per_collision: f64,
    pub searches_per_collision: f64,
    pub nnl_rebuilds: i64,
    pub cell_crossings: i64,
    pub init_s: Option<f64>,
    /// Wall and CPU time of the whole job; `None` for records written before they were kept.
    pub wall_s: Option<f64>,
    pub cpu_s: Option<f64>,
    /// Eq. 73 in time (wall clock): list updates and prediction per collision, in µs.
    pub tau_update_us: Option<f64>,
    pub tau_predict_us: Option<f64>,
    /// The collision sequence's fingerprint (hex, 8 digits per block of `sequence_block`
    /// collisions); `None` for records written before it was kept.
    pub sequence_fingerprint: Option<String>,
    pub sequence_block: Option<i64>,
}

/// One algorithm at one overlap point run with `verdict_check` (the `overlap_verdicts` view):
/// its checking set's verdicts against the exact ones, and its mean ns/check at that point.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct OverlapVerdictRow {
    pub job_id: String,
    pub l_star: f64,
    pub w_star: f64,
    pub r_star: f64,
    pub precision: String,
    pub algorithm: String,
    pub ns_per_check: f64,
    pub bulk: u64,
    pub shell: u64,
    pub undecided: u64,
    pub bulk_wrong: u64,
    pub shell_wrong: u64,
    pub shell_max_gap: f64,
    pub shell_by_decade: Vec<u64>,
    pub shell_wrong_by_decade: Vec<u64>,
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
