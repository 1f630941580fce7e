//! Concurrent leasing: no job is handed out twice and BEGIN IMMEDIATE avoids "database is locked",
//! both between tasks sharing a store and between two independently opened stores (as two processes).

mod common;

use common::*;
use std::collections::HashSet;
use std::time::Duration;
use store::{CompleteOutcome, Store};

const JOBS: usize = 2_000;
const TASKS: usize = 16;

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn concurrent_leases_never_share_a_job() {
    let (_dir, path, store) = temp_store().await;
    // A second store on the same file has its own writer connection: writes race in SQLite itself.
    let other = Store::open(&path).await.unwrap();
    store
        .submit(&campaign("c"), &noop_jobs(0, JOBS), T0)
        .await
        .unwrap();
    for task in 0..TASKS {
        store
            .register_worker(&worker(&format!("w{task}")), T0)
            .await
            .unwrap();
    }

    let mut handles = Vec::new();
    for task in 0..TASKS {
        let store = if task % 2 == 0 {
            store.clone()
        } else {
            other.clone()
        };
        handles.push(tokio::spawn(async move {
            let worker_id = format!("w{task}");
            let mut mine = Vec::new();
            loop {
                let batch = 1 + (task % 7) as u32;
                let leases = store
                    .lease(&worker_id, batch, Duration::from_secs(60), T0, true)
                    .await
                    .expect("lease must not fail under contention");
                if leases.is_empty() {
                    break;
                }
                for lease in leases {
                    let record = format!(r#"{{"task":{task}}}"#);
                    let outcome = store
                        .complete(&worker_id, &lease.job_id, lease.token, None, &[record], T0)
                        .await
                        .expect("complete must not fail under contention");
                    assert_eq!(outcome, CompleteOutcome::Accepted);
                    mine.push(lease.job_id);
                }
            }
            mine
        }));
    }
    let mut seen = HashSet::new();
    let mut total = 0;
    for handle in handles {
        for job_id in handle.await.unwrap() {
            total += 1;
            assert!(seen.insert(job_id.clone()), "{job_id} leased twice");
        }
    }
    assert_eq!((total, seen.len()), (JOBS, JOBS));
    let status = store.status(None).await.unwrap();
    assert_eq!(
        (status.done, status.queued, status.running),
        (JOBS as u64, 0, 0)
    );
    assert_eq!(
        count(&store, "SELECT count(*) FROM results").await,
        JOBS as i64
    );
    assert_eq!(
        count(&store, "SELECT count(*) FROM jobs WHERE attempts <> 1").await,
        0
    );
}
