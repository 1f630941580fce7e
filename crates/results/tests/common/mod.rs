//! A store filled the way a worker fills it: jobs submitted by their specs, leased, completed
//! with records.
#![allow(dead_code)] // each test binary uses a different subset

use std::time::Duration;

use jobs::JobSpec;
use store::{NewCampaign, NewJob, Store, WorkerInfo};
use tempfile::TempDir;

pub const T0: f64 = 1_000_000.0;

pub async fn temp_store() -> (TempDir, std::path::PathBuf, Store) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("sweep.db");
    let store = Store::open(&path).await.expect("open store");
    store
        .register_worker(
            &WorkerInfo {
                id: "w1".into(),
                hostname: "testhost".into(),
                cores: vec![0],
                cpu_model: "Test CPU".into(),
                cpu_flags: String::new(),
                rustc: "rustc".into(),
                git_commit: "abc123".into(),
                profile: "release".into(),
                allocation: None,
                allow_commands: false,
            },
            T0,
        )
        .await
        .expect("a worker");
    (dir, path, store)
}

pub fn new_job(spec: &JobSpec) -> NewJob {
    NewJob {
        id: spec.id(),
        kind: spec.kind().into(),
        params_json: spec.canonical_json(),
        estimate_s: 1.0,
        exclusive: false,
        pass: spec.pass(),
        foreign_code: spec.runs_foreign_code(),
    }
}

/// Submits `specs` as campaign `campaign` and completes every queued job with the records
/// `records` gives for its spec (`None`: the job fails for good, with that reason).
pub async fn complete_all(
    store: &Store,
    campaign: &str,
    specs: &[JobSpec],
    records: impl FnMut(&JobSpec) -> Result<Vec<String>, String>,
) {
    complete_all_at(store, campaign, T0, specs, records).await;
}

/// [`complete_all`] with the campaign made at `at` (Unix seconds).
pub async fn complete_all_at(
    store: &Store,
    campaign: &str,
    at: f64,
    specs: &[JobSpec],
    mut records: impl FnMut(&JobSpec) -> Result<Vec<String>, String>,
) {
    let jobs: Vec<NewJob> = specs.iter().map(new_job).collect();
    let new = NewCampaign {
        id: campaign.into(),
        name: campaign.into(),
        plan_text: String::new(),
        searches: Vec::new(),
    };
    store.submit(&new, &jobs, at).await.expect("submitted");
    loop {
        let leases = store
            .lease("w1", 512, Duration::from_secs(60), at, true)
            .await
            .expect("leases");
        if leases.is_empty() {
            break;
        }
        for lease in leases {
            let spec = specs
                .iter()
                .find(|s| s.id() == lease.job_id)
                .expect("a submitted job");
            match records(spec) {
                Ok(records) => {
                    store
                        .complete("w1", &lease.job_id, lease.token, Some(0), &records, at)
                        .await
                        .expect("completed");
                }
                Err(reason) => {
                    // One attempt allowed: failed for good.
                    store
                        .fail("w1", &lease.job_id, lease.token, &reason, 1, at)
                        .await
                        .expect("failed");
                }
            }
        }
    }
}
