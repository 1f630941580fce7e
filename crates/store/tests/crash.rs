//! A process killed in the middle of a completion leaves neither results nor a state change.
//!
//! The test re-runs its own binary as a child that opens the database like a second process, performs
//! the writes of `Store::complete` inside a `BEGIN IMMEDIATE` transaction and aborts before COMMIT.

mod common;

use common::*;
use sqlx::Connection;
use std::process::Command;
use std::time::Duration;
use store::{CompleteOutcome, JobState, Store};

const CHILD_ENV: &str = "SWEEP_STORE_CRASH_CHILD_DB";

#[tokio::test]
async fn killed_mid_transaction_leaves_no_partial_results() {
    if let Ok(db) = std::env::var(CHILD_ENV) {
        crash_in_the_middle_of_a_completion(&db).await;
    }
    let (_dir, path, store) = store_with(&["w1"], 1).await;
    let lease = store
        .lease("w1", 1, Duration::from_secs(60), T0, true)
        .await
        .unwrap()
        .remove(0);

    let status = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "killed_mid_transaction_leaves_no_partial_results",
            "--nocapture",
        ])
        .env(CHILD_ENV, &path)
        .status()
        .unwrap();
    assert!(!status.success(), "the child must die, not finish");

    store.close().await;
    let store = Store::open(&path).await.unwrap();
    assert_eq!(count(&store, "SELECT count(*) FROM results").await, 0);
    assert_eq!(
        store.job(&lease.job_id).await.unwrap().state,
        JobState::Running
    );
    let outcome = store
        .complete(
            "w1",
            &lease.job_id,
            lease.token,
            None,
            &[r#"{"ok":true}"#.to_owned()],
            T0,
        )
        .await
        .unwrap();
    assert_eq!(outcome, CompleteOutcome::Accepted);
    assert_eq!(count(&store, "SELECT count(*) FROM results").await, 1);
}

async fn crash_in_the_middle_of_a_completion(db: &str) -> ! {
    let mut conn = sqlx::SqliteConnection::connect(&format!("sqlite://{db}"))
        .await
        .unwrap();
    let mut tx = conn.begin_with("BEGIN IMMEDIATE").await.unwrap();
    sqlx::query("UPDATE jobs SET state = 'done', lease_expires_at = NULL WHERE state = 'running'")
        .execute(&mut *tx)
        .await
        .unwrap();
    for row in 0..1000 {
        sqlx::query(
            "INSERT INTO results (job_id, attempt, worker_id, core_id, row_index, fields, recorded_at)
             SELECT id, attempts, lease_owner, 0, ?1, '{}', 0 FROM jobs",
        )
        .bind(row)
        .execute(&mut *tx)
        .await
        .unwrap();
    }
    eprintln!("child: 1000 result rows written, aborting before COMMIT");
    std::process::abort();
}
