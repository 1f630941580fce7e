//! Submission, resubmission, cancellation, status and worker registration.

mod common;

use common::*;
use std::time::Duration;
use store::{Error, FailOutcome, JobState, NewJob};

const LEASE: Duration = Duration::from_secs(60);

#[tokio::test]
async fn open_creates_the_file_and_reopens_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("new.db");
    let store = store::Store::open(&path).await.unwrap();
    store
        .submit(&campaign("c1"), &noop_jobs(0, 3), T0)
        .await
        .unwrap();
    store.close().await;
    assert!(path.exists());
    let again = store::Store::open(&path).await.unwrap();
    assert_eq!(again.status(None).await.unwrap().queued, 3);
}

#[tokio::test]
async fn resubmitting_schedules_nothing_and_extending_schedules_only_new_jobs() {
    let (_dir, _path, store) = temp_store().await;
    let first = store
        .submit(&campaign("c1"), &noop_jobs(0, 10), T0)
        .await
        .unwrap();
    assert_eq!(
        (first.new_jobs, first.requeued, first.already_known),
        (10, 0, 0)
    );

    let again = store
        .submit(&campaign("c1"), &noop_jobs(0, 10), T0 + 1.0)
        .await
        .unwrap();
    assert_eq!(
        (again.new_jobs, again.requeued, again.already_known),
        (0, 0, 10)
    );

    // An extended plan is another campaign sharing the first ten points.
    let extended = store
        .submit(&campaign("c2"), &noop_jobs(0, 15), T0 + 2.0)
        .await
        .unwrap();
    assert_eq!((extended.new_jobs, extended.already_known), (5, 10));

    let all = store.status(None).await.unwrap();
    assert_eq!((all.total, all.queued), (15, 15));
    assert_eq!(all.estimate_s_remaining, 7.5);
    assert_eq!(store.status(Some("c1")).await.unwrap().total, 10);
    assert_eq!(store.status(Some("c2")).await.unwrap().total, 15);
    assert!(matches!(
        store.status(Some("nope")).await,
        Err(Error::UnknownCampaign(_))
    ));

    let campaigns = store.campaigns().await.unwrap();
    assert_eq!(
        campaigns.iter().map(|c| c.id.as_str()).collect::<Vec<_>>(),
        ["c1", "c2"]
    );
    assert_eq!(campaigns[1].status.queued, 15);
}

#[tokio::test]
async fn resubmission_keeps_done_jobs_and_requeues_failed_ones() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w1"), T0).await.unwrap();
    store
        .submit(&campaign("c1"), &noop_jobs(0, 2), T0)
        .await
        .unwrap();
    let leases = store.lease("w1", 2, LEASE, T0, true).await.unwrap();
    store
        .complete("w1", &leases[0].job_id, leases[0].token, Some(0), &[], T0)
        .await
        .unwrap();
    let failed = store
        .fail("w1", &leases[1].job_id, leases[1].token, "boom", 1, T0)
        .await
        .unwrap();
    assert_eq!(failed, FailOutcome::Failed);
    let failed_jobs = store.failed_jobs("noop").await.unwrap();
    assert_eq!(failed_jobs.len(), 1, "{failed_jobs:?}");
    assert_eq!(failed_jobs[0].id, leases[1].job_id);
    assert_eq!(failed_jobs[0].reason, "boom");
    let params: serde_json::Value = serde_json::from_str(&failed_jobs[0].params_json).unwrap();
    assert!(params.is_object(), "{params}");
    assert!(store.failed_jobs("edmd").await.unwrap().is_empty());

    let again = store
        .submit(&campaign("c1"), &noop_jobs(0, 2), T0 + 1.0)
        .await
        .unwrap();
    assert_eq!(
        (again.new_jobs, again.requeued, again.already_known),
        (0, 1, 1)
    );
    let job = store.job(&leases[1].job_id).await.unwrap();
    assert_eq!(
        (job.state, job.attempts, job.last_error),
        (JobState::Queued, 0, None)
    );
    assert_eq!(
        store.job(&leases[0].job_id).await.unwrap().state,
        JobState::Done
    );
    // Requeued, it is no longer failed.
    assert!(store.failed_jobs("noop").await.unwrap().is_empty());
}

#[tokio::test]
async fn a_conflicting_or_malformed_submission_writes_nothing() {
    let (_dir, _path, store) = temp_store().await;
    store
        .submit(&campaign("c1"), &noop_jobs(0, 2), T0)
        .await
        .unwrap();

    let mut changed = noop_jobs(2, 4);
    changed.push(NewJob {
        params_json: r#"{"other":1}"#.to_owned(),
        ..noop_jobs(0, 1)[0].clone()
    });
    let err = store
        .submit(&campaign("c2"), &changed, T0)
        .await
        .unwrap_err();
    assert!(
        matches!(
            err,
            Error::JobConflict {
                field: "params",
                ..
            }
        ),
        "{err}"
    );

    let mut malformed = noop_jobs(4, 6);
    malformed[1].params_json = "[1, 2]".to_owned();
    let err = store
        .submit(&campaign("c3"), &malformed, T0)
        .await
        .unwrap_err();
    assert!(matches!(err, Error::InvalidParams { .. }), "{err}");

    assert_eq!(store.status(None).await.unwrap().total, 2);
    assert_eq!(store.campaigns().await.unwrap().len(), 1);
}

#[tokio::test]
async fn cancel_spares_running_jobs_and_jobs_of_other_campaigns() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w1"), T0).await.unwrap();
    store
        .submit(&campaign("a"), &noop_jobs(0, 4), T0)
        .await
        .unwrap();
    store
        .submit(&campaign("b"), &noop_jobs(3, 5), T0)
        .await
        .unwrap(); // shares noop-3
    let leased = store.lease("w1", 1, LEASE, T0, true).await.unwrap();
    assert_eq!(leased[0].job_id, "noop-000000");

    assert_eq!(store.cancel("a", T0).await.unwrap(), 2); // noop-1, noop-2
    let a = store.status(Some("a")).await.unwrap();
    assert_eq!((a.running, a.cancelled, a.queued), (1, 2, 1));
    assert!(matches!(
        store.cancel("zzz", T0).await,
        Err(Error::UnknownCampaign(_))
    ));

    // Resubmitting the campaign brings its cancelled jobs back.
    let again = store
        .submit(&campaign("a"), &noop_jobs(0, 4), T0)
        .await
        .unwrap();
    assert_eq!(again.requeued, 2);
    assert!(store.campaigns().await.unwrap()[0].cancelled_at.is_none());
}

#[tokio::test]
async fn workers_keep_their_provenance() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w1"), T0).await.unwrap();
    store
        .register_worker(&worker("w1"), T0 + 5.0)
        .await
        .unwrap(); // same provenance: a refresh
    let mut rebuilt = worker("w1");
    rebuilt.git_commit = "def456".to_owned();
    let err = store.register_worker(&rebuilt, T0).await.unwrap_err();
    assert!(
        matches!(
            err,
            Error::WorkerConflict {
                field: "git_commit",
                ..
            }
        ),
        "{err}"
    );

    let workers = store.workers().await.unwrap();
    assert_eq!(workers.len(), 1);
    assert_eq!(workers[0].info, worker("w1"));
    assert_eq!(
        (workers[0].registered_at, workers[0].last_seen_at),
        (T0, T0 + 5.0)
    );
    assert!(matches!(
        store.touch_worker("ghost", T0).await,
        Err(Error::UnknownWorker(_))
    ));
    assert!(matches!(
        store.lease("ghost", 1, LEASE, T0, true).await,
        Err(Error::UnknownWorker(_))
    ));
}

#[tokio::test]
async fn a_job_listed_twice_in_one_submission_is_one_job() {
    let (_dir, _path, store) = temp_store().await;
    let mut jobs = noop_jobs(0, 3);
    jobs.push(jobs[1].clone());
    let outcome = store.submit(&campaign("c"), &jobs, T0).await.unwrap();
    assert_eq!((outcome.new_jobs, outcome.already_known), (3, 1));
    assert_eq!(store.status(Some("c")).await.unwrap().total, 3);

    let mut other_kind = noop_jobs(5, 6);
    other_kind.push(NewJob {
        kind: "edmd".to_owned(),
        ..other_kind[0].clone()
    });
    let err = store
        .submit(&campaign("d"), &other_kind, T0)
        .await
        .unwrap_err();
    assert!(
        matches!(err, Error::JobConflict { field: "kind", .. }),
        "{err}"
    );
    assert_eq!(store.status(None).await.unwrap().total, 3);
}

#[tokio::test]
async fn a_campaign_is_leased_in_id_order_and_older_campaigns_first() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w"), T0).await.unwrap();
    // Ids that sort differently from the order of submission, as parameter hashes do.
    let job = |id: &str| NewJob {
        id: id.to_owned(),
        kind: "noop".to_owned(),
        params_json: format!(r#"{{"name":"{id}"}}"#),
        estimate_s: 0.1,
        exclusive: false,
        pass: 0,
        foreign_code: false,
    };
    let older: Vec<NewJob> = ["c9", "a3", "f0", "07"].into_iter().map(job).collect();
    let newer: Vec<NewJob> = ["55", "00"].into_iter().map(job).collect();
    store.submit(&campaign("old"), &older, T0).await.unwrap();
    store
        .submit(&campaign("new"), &newer, T0 + 1.0)
        .await
        .unwrap();

    let mut leased = Vec::new();
    for _ in 0..6 {
        let leases = store.lease("w", 1, LEASE, T0 + 2.0, true).await.unwrap();
        leased.extend(leases.into_iter().map(|l| l.job_id));
    }
    assert_eq!(leased, ["07", "a3", "c9", "f0", "00", "55"]);
}

/// The visits of overlap points: of one submission, every job of pass 0 (in id order) before
/// any of pass 1, and so on; a later submission still waits for the earlier one's every pass.
#[tokio::test]
async fn a_submission_is_leased_pass_by_pass() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w"), T0).await.unwrap();
    let job = |(id, pass): (&str, u32)| NewJob {
        id: id.to_owned(),
        kind: "noop".to_owned(),
        params_json: format!(r#"{{"name":"{id}"}}"#),
        estimate_s: 0.1,
        exclusive: false,
        pass,
        foreign_code: false,
    };
    let visits: Vec<NewJob> = [("c9", 0), ("a3", 1), ("f0", 0), ("07", 2), ("55", 1)]
        .into_iter()
        .map(job)
        .collect();
    store
        .submit(&campaign("visits"), &visits, T0)
        .await
        .unwrap();
    store
        .submit(&campaign("later"), &[job(("00", 0))], T0 + 1.0)
        .await
        .unwrap();
    // Resubmitting changes nothing: the jobs, their passes and their order are known.
    let again = store
        .submit(&campaign("visits"), &visits, T0 + 2.0)
        .await
        .unwrap();
    assert_eq!((again.new_jobs, again.already_known), (0, 5));

    let mut leased = Vec::new();
    for _ in 0..6 {
        let leases = store.lease("w", 1, LEASE, T0 + 3.0, true).await.unwrap();
        leased.extend(leases.into_iter().map(|l| l.job_id));
    }
    assert_eq!(leased, ["c9", "f0", "55", "a3", "07", "00"]);
    assert_eq!(
        count(&store, "SELECT count(*) FROM jobs WHERE pass = 1").await,
        2
    );
}
