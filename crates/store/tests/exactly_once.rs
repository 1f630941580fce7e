//! Exactly-once results: repeated, late and failed reports; lease expiry; atomicity of complete().

mod common;

use common::*;
use std::time::Duration;
use store::{CompleteOutcome, Completion, Error, FailOutcome, JobState, LeaseRef};

const LEASE: Duration = Duration::from_secs(10);

fn records(n: usize) -> Vec<String> {
    (0..n)
        .map(|i| format!(r#"{{"algorithm":"ocsi","repeat":{i},"ms":1.5}}"#))
        .collect()
}

#[tokio::test]
async fn completing_twice_is_already_done_and_writes_nothing() {
    let (_dir, _path, store) = store_with(&["w1"], 1).await;
    let lease = store
        .lease("w1", 1, LEASE, T0, true)
        .await
        .unwrap()
        .remove(0);
    assert_eq!((lease.attempt, lease.expires_at), (1, T0 + 10.0));

    let first = store
        .complete(
            "w1",
            &lease.job_id,
            lease.token,
            Some(3),
            &records(3),
            T0 + 1.0,
        )
        .await
        .unwrap();
    assert_eq!(first, CompleteOutcome::Accepted);
    let second = store
        .complete(
            "w1",
            &lease.job_id,
            lease.token,
            Some(3),
            &records(5),
            T0 + 2.0,
        )
        .await
        .unwrap();
    assert_eq!(second, CompleteOutcome::AlreadyDone);

    assert_eq!(count(&store, "SELECT count(*) FROM results").await, 3);
    assert_eq!(count(&store, "SELECT count(*) FROM late_reports").await, 0);
    let job = store.job(&lease.job_id).await.unwrap();
    assert_eq!(
        (job.state, job.finished_at),
        (JobState::Done, Some(T0 + 1.0))
    );
    let rows = store.export().await.unwrap();
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[2].fields["repeat"], 2);
    assert_eq!(
        (rows[0].attempt, rows[0].worker.as_str(), rows[0].core_id),
        (1, "w1", Some(3))
    );
}

#[tokio::test]
async fn a_report_after_expiry_and_re_lease_is_late_and_not_counted() {
    let (_dir, _path, store) = store_with(&["w1", "w2"], 1).await;
    let old = store
        .lease("w1", 1, LEASE, T0, true)
        .await
        .unwrap()
        .remove(0);

    // Not expired yet: nothing to reap. Past expiry: the job is queued again.
    assert_eq!(store.expire_leases(T0 + 5.0, 3).await.unwrap(), 0);
    assert_eq!(store.expire_leases(T0 + 11.0, 3).await.unwrap(), 1);
    let job = store.job(&old.job_id).await.unwrap();
    assert_eq!(job.state, JobState::Queued);
    assert_eq!(
        job.last_error.as_deref(),
        Some("lease expired on attempt 1")
    );

    let new = store
        .lease("w2", 1, LEASE, T0 + 12.0, true)
        .await
        .unwrap()
        .remove(0);
    assert_eq!((new.job_id.as_str(), new.attempt), (old.job_id.as_str(), 2));
    assert_ne!(new.token, old.token);

    // The old lease can neither heartbeat, complete nor fail.
    let lost = store
        .heartbeat(
            "w1",
            &[LeaseRef {
                job_id: old.job_id.clone(),
                token: old.token,
            }],
            T0 + 30.0,
            T0 + 13.0,
        )
        .await
        .unwrap();
    assert!(lost.is_empty());
    let late = store
        .complete(
            "w1",
            &old.job_id,
            old.token,
            Some(0),
            &records(2),
            T0 + 13.0,
        )
        .await
        .unwrap();
    assert_eq!(late, CompleteOutcome::Late);
    let late = store
        .fail("w1", &old.job_id, old.token, "too late", 3, T0 + 13.0)
        .await
        .unwrap();
    assert_eq!(late, FailOutcome::Late);
    let accepted = store
        .complete(
            "w2",
            &new.job_id,
            new.token,
            Some(1),
            &records(2),
            T0 + 14.0,
        )
        .await
        .unwrap();
    assert_eq!(accepted, CompleteOutcome::Accepted);
    // A report of the first lease after the job is done by the second one is late too.
    let late = store
        .complete(
            "w1",
            &old.job_id,
            old.token,
            Some(0),
            &records(2),
            T0 + 15.0,
        )
        .await
        .unwrap();
    assert_eq!(late, CompleteOutcome::Late);

    assert_eq!(count(&store, "SELECT count(*) FROM results").await, 2);
    assert_eq!(
        count(
            &store,
            "SELECT count(*) FROM results WHERE worker_id = 'w2' AND attempt = 2"
        )
        .await,
        2
    );
    let reports = store
        .query_read_only(
            "SELECT worker_id, token, reason FROM late_reports ORDER BY received_at, rowid",
        )
        .await
        .unwrap();
    assert_eq!(reports.rows.len(), 3);
    assert!(
        reports
            .rows
            .iter()
            .all(|r| r[0] == "w1" && r[1] == old.token)
    );
    assert_eq!(
        reports.rows[0][2],
        format!("completion: job re-leased to w2 (token {})", new.token)
    );
    assert_eq!(
        reports.rows[2][2],
        "completion: job already done by another lease"
    );
}

#[tokio::test]
async fn an_expired_but_unreaped_lease_still_completes() {
    let (_dir, _path, store) = store_with(&["w1"], 1).await;
    let lease = store
        .lease("w1", 1, LEASE, T0, true)
        .await
        .unwrap()
        .remove(0);
    let outcome = store
        .complete(
            "w1",
            &lease.job_id,
            lease.token,
            None,
            &records(1),
            T0 + 100.0,
        )
        .await
        .unwrap();
    assert_eq!(outcome, CompleteOutcome::Accepted);
    assert_eq!(store.expire_leases(T0 + 200.0, 3).await.unwrap(), 0);
}

#[tokio::test]
async fn heartbeats_extend_leases() {
    let (_dir, _path, store) = store_with(&["w1"], 2).await;
    let leases = store.lease("w1", 2, LEASE, T0, true).await.unwrap();
    let refs: Vec<LeaseRef> = leases
        .iter()
        .map(|l| LeaseRef {
            job_id: l.job_id.clone(),
            token: l.token,
        })
        .collect();
    let bogus = LeaseRef {
        job_id: leases[0].job_id.clone(),
        token: leases[0].token + 1000,
    };
    let valid = store
        .heartbeat(
            "w1",
            &[refs.clone(), vec![bogus]].concat(),
            T0 + 20.0,
            T0 + 8.0,
        )
        .await
        .unwrap();
    assert_eq!(valid, refs);
    assert_eq!(store.expire_leases(T0 + 15.0, 3).await.unwrap(), 0);
    assert_eq!(
        store.job(&refs[0].job_id).await.unwrap().lease_expires_at,
        Some(T0 + 20.0)
    );
    assert_eq!(store.expire_leases(T0 + 21.0, 3).await.unwrap(), 2);
}

#[tokio::test]
async fn a_heartbeat_racing_the_report_keeps_the_completed_lease() {
    let (_dir, _path, store) = store_with(&["w1", "w2"], 1).await;
    let lease = store
        .lease("w1", 1, LEASE, T0, true)
        .await
        .unwrap()
        .remove(0);
    let held = LeaseRef {
        job_id: lease.job_id.clone(),
        token: lease.token,
    };
    store
        .complete("w1", &lease.job_id, lease.token, None, &[], T0 + 1.0)
        .await
        .unwrap();
    // Completed under this very lease: not lost. Another worker or token: lost.
    let beat = |worker: &'static str, token: i64| {
        let store = &store;
        let job_id = lease.job_id.clone();
        async move {
            store
                .heartbeat(worker, &[LeaseRef { job_id, token }], T0 + 30.0, T0 + 2.0)
                .await
                .unwrap()
        }
    };
    assert_eq!(beat("w1", lease.token).await, [held]);
    assert!(beat("w2", lease.token).await.is_empty());
    assert!(beat("w1", lease.token + 1).await.is_empty());
    assert_eq!(
        store.job(&lease.job_id).await.unwrap().state,
        JobState::Done
    );
}

#[tokio::test]
async fn a_job_failing_max_attempts_times_is_failed_with_its_last_error() {
    let (_dir, _path, store) = store_with(&["w1"], 1).await;
    for attempt in 1..=3u32 {
        let lease = store
            .lease("w1", 1, LEASE, T0, true)
            .await
            .unwrap()
            .remove(0);
        assert_eq!(lease.attempt, attempt);
        let error = format!("boom {attempt}");
        let outcome = store.fail("w1", &lease.job_id, lease.token, &error, 3, T0);
        let expected = if attempt < 3 {
            FailOutcome::Requeued
        } else {
            FailOutcome::Failed
        };
        assert_eq!(outcome.await.unwrap(), expected);
    }
    assert!(
        store
            .lease("w1", 1, LEASE, T0, true)
            .await
            .unwrap()
            .is_empty()
    );
    let job = store.job("noop-000000").await.unwrap();
    assert_eq!((job.state, job.attempts), (JobState::Failed, 3));
    assert_eq!(job.last_error.as_deref(), Some("boom 3"));
    let status = store.status(None).await.unwrap();
    assert_eq!((status.failed, status.estimate_s_remaining), (1, 0.0));
}

#[tokio::test]
async fn a_job_whose_lease_expires_max_attempts_times_is_failed() {
    let (_dir, _path, store) = store_with(&["w1"], 1).await;
    let mut now = T0;
    for _ in 0..2 {
        assert_eq!(
            store.lease("w1", 1, LEASE, now, true).await.unwrap().len(),
            1
        );
        now += 11.0;
        assert_eq!(store.expire_leases(now, 2).await.unwrap(), 1);
    }
    let job = store.job("noop-000000").await.unwrap();
    assert_eq!((job.state, job.attempts), (JobState::Failed, 2));
    assert_eq!(
        job.last_error.as_deref(),
        Some("lease expired on attempt 2 of 2")
    );
}

#[tokio::test]
async fn a_complete_with_an_invalid_record_writes_nothing_and_leaves_the_job_running() {
    let (_dir, _path, store) = store_with(&["w1"], 1).await;
    let lease = store
        .lease("w1", 1, LEASE, T0, true)
        .await
        .unwrap()
        .remove(0);
    for bad in ["[1,2]", "{\"ms\": 1.0", "42"] {
        let mut batch = records(3);
        batch.push(bad.to_owned());
        let err = store
            .complete("w1", &lease.job_id, lease.token, None, &batch, T0)
            .await
            .unwrap_err();
        assert!(
            matches!(err, Error::InvalidRecord { index: 3, .. }),
            "{err}"
        );
    }
    assert_eq!(count(&store, "SELECT count(*) FROM results").await, 0);
    assert_eq!(
        store.job(&lease.job_id).await.unwrap().state,
        JobState::Running
    );
    // The same lease can still report properly.
    let ok = store
        .complete("w1", &lease.job_id, lease.token, None, &records(3), T0)
        .await
        .unwrap();
    assert_eq!(ok, CompleteOutcome::Accepted);
    assert!(matches!(
        store.complete("w1", "no-such-job", 1, None, &[], T0).await,
        Err(Error::UnknownJob(_))
    ));
}

#[tokio::test]
async fn a_batch_of_completions_sorts_out_each_report() {
    let (_dir, _path, store) = store_with(&["w1", "w2"], 4).await;
    let mine = store.lease("w1", 3, LEASE, T0, true).await.unwrap();
    let theirs = store
        .lease("w2", 1, LEASE, T0, true)
        .await
        .unwrap()
        .remove(0);
    let completion = |job_id: &str, token: i64, n: usize| Completion {
        job_id: job_id.to_owned(),
        token,
        core_id: Some(7),
        records: records(n),
    };
    // Job 0 is completed alone first, so in the batch it is a repeated report.
    let two = records(2);
    let first = store.complete("w1", &mine[0].job_id, mine[0].token, Some(7), &two, T0);
    assert_eq!(first.await.unwrap(), CompleteOutcome::Accepted);

    let batch = vec![
        completion(&mine[1].job_id, mine[1].token, 3),
        completion(&mine[0].job_id, mine[0].token, 2),
        completion(&theirs.job_id, theirs.token, 1), // w2's lease quoted by w1
        completion(&mine[2].job_id, mine[2].token, 1),
    ];
    let outcomes = store.complete_batch("w1", &batch, T0 + 1.0).await.unwrap();
    use CompleteOutcome::*;
    assert_eq!(outcomes, [Accepted, AlreadyDone, Late, Accepted]);
    assert_eq!(
        count(&store, "SELECT count(*) FROM results").await,
        2 + 3 + 1
    );
    assert_eq!(
        count(&store, "SELECT count(*) FROM results WHERE core_id = 7").await,
        6
    );
    assert_eq!(count(&store, "SELECT count(*) FROM late_reports").await, 1);
    let rows = store
        .query_read_only(&format!(
            "SELECT row_index, fields ->> 'repeat' FROM results WHERE job_id = '{}' ORDER BY row_index",
            mine[1].job_id
        ))
        .await
        .unwrap()
        .rows;
    assert_eq!(
        rows,
        [[0, 0], [1, 1], [2, 2]].map(|r| r.map(serde_json::Value::from).to_vec())
    );
    assert_eq!(
        store.job(&theirs.job_id).await.unwrap().state,
        JobState::Running
    );
}

#[tokio::test]
async fn a_bad_batch_of_completions_writes_nothing() {
    let (_dir, _path, store) = store_with(&["w1"], 2).await;
    let leases = store.lease("w1", 2, LEASE, T0, true).await.unwrap();
    let good = |i: usize| Completion {
        job_id: leases[i].job_id.clone(),
        token: leases[i].token,
        core_id: None,
        records: records(2),
    };
    let mut invalid = good(1);
    invalid.records.push("\"not an object\"".to_owned());
    let unknown = Completion {
        job_id: "nope".to_owned(),
        ..good(1)
    };
    let cases = [
        (vec![good(0), invalid], "invalid record"),
        (vec![good(0), good(0)], "duplicate"),
        (vec![good(0), unknown], "unknown job"),
    ];
    for (batch, what) in cases {
        let err = store.complete_batch("w1", &batch, T0).await.unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidRecord { index: 2, .. }
                    | Error::DuplicateCompletion(_)
                    | Error::UnknownJob(_)
            ),
            "{what}: {err}"
        );
    }
    assert_eq!(count(&store, "SELECT count(*) FROM results").await, 0);
    assert_eq!(
        count(&store, "SELECT count(*) FROM jobs WHERE state = 'running'").await,
        2
    );
    let outcomes = store
        .complete_batch("w1", &[good(0), good(1)], T0)
        .await
        .unwrap();
    assert_eq!(outcomes, [CompleteOutcome::Accepted; 2]);
}
