//! Helpers shared by the store's integration tests.
#![allow(dead_code)] // each test binary uses a different subset

use store::{NewCampaign, NewJob, Store, WorkerInfo};
use tempfile::TempDir;

pub const T0: f64 = 1_000_000.0;

/// A fresh store in its own temporary directory (kept alive by the returned guard).
pub async fn temp_store() -> (TempDir, std::path::PathBuf, Store) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("sweep.db");
    let store = Store::open(&path).await.expect("open store");
    (dir, path, store)
}

/// A fresh store with `workers` registered and campaign `c` of `jobs` no-op jobs submitted, at T0.
pub async fn store_with(workers: &[&str], jobs: usize) -> (TempDir, std::path::PathBuf, Store) {
    let (dir, path, store) = temp_store().await;
    for w in workers {
        store.register_worker(&worker(w), T0).await.unwrap();
    }
    store
        .submit(&campaign("c"), &noop_jobs(0, jobs), T0)
        .await
        .unwrap();
    (dir, path, store)
}

pub fn worker(id: &str) -> WorkerInfo {
    WorkerInfo {
        id: id.to_owned(),
        hostname: "testhost".to_owned(),
        cores: vec![0, 1],
        cpu_model: "Test CPU".to_owned(),
        cpu_flags: "avx2 avx512f".to_owned(),
        rustc: "rustc 1.95.0".to_owned(),
        git_commit: "abc123".to_owned(),
        profile: "release".to_owned(),
        allocation: None,
        allow_commands: false,
    }
}

pub fn campaign(id: &str) -> NewCampaign {
    NewCampaign {
        id: id.to_owned(),
        name: format!("campaign {id}"),
        plan_text: "name = 'x'".to_owned(),
        searches: Vec::new(),
    }
}

/// No-op jobs `noop-{from}..noop-{to}` (ids stand in for the caller's hashes).
pub fn noop_jobs(from: usize, to: usize) -> Vec<NewJob> {
    (from..to)
        .map(|i| NewJob {
            id: format!("noop-{i:06}"),
            kind: "noop".to_owned(),
            params_json: format!(r#"{{"index":{i},"duration_ms":0}}"#),
            estimate_s: 0.5,
            exclusive: false,
            pass: 0,
            foreign_code: false,
        })
        .collect()
}

pub fn exclusive_job(id: &str) -> NewJob {
    NewJob {
        id: id.to_owned(),
        kind: "noop".to_owned(),
        params_json: format!(r#"{{"name":"{id}"}}"#),
        estimate_s: 1.0,
        exclusive: true,
        pass: 0,
        foreign_code: false,
    }
}

/// Counts rows of a table through the read-only path.
pub async fn count(store: &Store, sql: &str) -> i64 {
    let result = store.query_read_only(sql).await.expect("count query");
    result.rows[0][0].as_i64().expect("integer count")
}
