//! Exclusive jobs run alone: never beside another job, and nothing is leased while one runs.

mod common;

use common::*;
use std::time::Duration;
use store::CompleteOutcome;

const LEASE: Duration = Duration::from_secs(60);

async fn ids(store: &store::Store, worker: &str, n: u32, exclusive_ok: bool) -> Vec<String> {
    let leases = store
        .lease(worker, n, LEASE, T0, exclusive_ok)
        .await
        .unwrap();
    for lease in &leases {
        assert_eq!(lease.token, leases[0].token, "one token per lease call");
    }
    leases.into_iter().map(|l| l.job_id).collect()
}

async fn done(store: &store::Store, worker: &str, job_id: &str) {
    let job = store.job(job_id).await.unwrap();
    assert_eq!(job.lease_owner.as_deref(), Some(worker));
    let token = store
        .query_read_only(&format!(
            "SELECT lease_token FROM jobs WHERE id = '{job_id}'"
        ))
        .await
        .unwrap()
        .rows[0][0]
        .as_i64()
        .unwrap();
    let outcome = store
        .complete(worker, job_id, token, None, &[], T0)
        .await
        .unwrap();
    assert_eq!(outcome, CompleteOutcome::Accepted);
}

#[tokio::test]
async fn an_exclusive_job_at_the_head_runs_alone() {
    let (_dir, _path, store) = temp_store().await;
    for w in ["w1", "w2"] {
        store.register_worker(&worker(w), T0).await.unwrap();
    }
    let mut jobs = vec![exclusive_job("exclusive-1")];
    jobs.extend(noop_jobs(0, 3));
    store.submit(&campaign("c"), &jobs, T0).await.unwrap();

    assert!(
        ids(&store, "w1", 4, false).await.is_empty(),
        "not for a worker refusing exclusive jobs"
    );
    assert_eq!(ids(&store, "w1", 4, true).await, ["exclusive-1"]);
    assert!(
        ids(&store, "w2", 4, true).await.is_empty(),
        "nothing beside a running exclusive job"
    );
    done(&store, "w1", "exclusive-1").await;
    assert_eq!(
        ids(&store, "w2", 4, true).await,
        ["noop-000000", "noop-000001", "noop-000002"]
    );
}

#[tokio::test]
async fn an_exclusive_job_waits_for_running_jobs_and_blocks_later_ones() {
    let (_dir, _path, store) = temp_store().await;
    for w in ["w1", "w2"] {
        store.register_worker(&worker(w), T0).await.unwrap();
    }
    let mut jobs = noop_jobs(0, 2);
    // Queue order is id order: this id sorts between noop-000001 and noop-000002.
    jobs.push(exclusive_job("noop-000001-exclusive"));
    jobs.extend(noop_jobs(2, 4));
    store.submit(&campaign("c"), &jobs, T0).await.unwrap();

    // A batch stops before the exclusive job.
    assert_eq!(
        ids(&store, "w1", 8, true).await,
        ["noop-000000", "noop-000001"]
    );
    // The exclusive job heads the queue: nothing is leased until the running jobs drain.
    assert!(ids(&store, "w2", 8, true).await.is_empty());
    done(&store, "w1", "noop-000000").await;
    assert!(ids(&store, "w2", 8, true).await.is_empty());
    done(&store, "w1", "noop-000001").await;
    assert_eq!(ids(&store, "w2", 8, true).await, ["noop-000001-exclusive"]);
    assert!(ids(&store, "w1", 8, true).await.is_empty());
    done(&store, "w2", "noop-000001-exclusive").await;
    assert_eq!(
        ids(&store, "w1", 8, true).await,
        ["noop-000002", "noop-000003"]
    );
}
