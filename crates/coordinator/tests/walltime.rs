//! Walltime-aware leasing: a worker that says how many seconds it has left gets only jobs expected
//! to finish within them, one after the other, each expected to take its estimate times what its
//! kind has been observed to take (learned from reports, and from the database after a restart).

use std::sync::Arc;
use std::time::Duration;

use coordinator::{Config, Coordinator, ManualClock, NewCampaign, NewJob, Store, WorkerInfo};

fn worker(id: &str) -> WorkerInfo {
    WorkerInfo {
        id: id.to_owned(),
        hostname: "host".to_owned(),
        cores: vec![0],
        cpu_model: "cpu".to_owned(),
        cpu_flags: String::new(),
        rustc: "1.95".to_owned(),
        git_commit: "abc".to_owned(),
        profile: "release".to_owned(),
        allocation: None,
        allow_commands: false,
    }
}

/// A job leased in the order of its id, estimated at `estimate_s`.
fn job(id: &str, kind: &str, estimate_s: f64, exclusive: bool) -> NewJob {
    NewJob {
        id: id.to_owned(),
        kind: kind.to_owned(),
        params_json: format!(r#"{{"id":"{id}"}}"#),
        estimate_s,
        exclusive,
        pass: 0,
        foreign_code: false,
    }
}

async fn setup(dir: &tempfile::TempDir, jobs: &[NewJob]) -> (Coordinator, Arc<ManualClock>) {
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let clock = Arc::new(ManualClock::new(1_000.0));
    let config = Config {
        lease_for: Duration::from_secs(600),
        ..Config::default()
    };
    let coordinator = Coordinator::new(store, config, clock.clone()).unwrap();
    coordinator.register(&worker("w")).await.unwrap();
    let campaign = NewCampaign {
        id: "c".into(),
        name: "c".into(),
        plan_text: String::new(),
        searches: Vec::new(),
    };
    coordinator.submit(&campaign, jobs).await.unwrap();
    (coordinator, clock)
}

fn ids(granted: &coordinator::Granted) -> Vec<&str> {
    granted.leases.iter().map(|l| l.job_id.as_str()).collect()
}

#[tokio::test]
async fn only_jobs_that_fit_one_after_the_other_are_leased() {
    let dir = tempfile::tempdir().unwrap();
    let jobs = [
        job("a", "edmd", 10.0, false),
        job("b", "edmd", 100.0, false),
        job("c", "edmd", 30.0, false),
        job("d", "edmd", 15.0, false),
    ];
    let (coordinator, _) = setup(&dir, &jobs).await;
    // 50 s: a (10) and c (30) fit one after the other; b does not, and d no more after them.
    let granted = coordinator
        .lease_within("w", 10, true, Some(50.0))
        .await
        .unwrap();
    assert_eq!(ids(&granted), ["a", "c"]);
    assert_eq!(granted.passed_over, 2);
    assert!(!granted.nothing_fits());
    // 4 s: nothing queued fits: the worker should stop.
    let granted = coordinator
        .lease_within("w", 10, true, Some(4.0))
        .await
        .unwrap();
    assert!(granted.leases.is_empty());
    assert!(granted.nothing_fits(), "{granted:?}");
    // The jobs passed over are still queued for a worker with more time.
    let granted = coordinator.lease_within("w", 10, true, None).await.unwrap();
    assert_eq!(ids(&granted), ["b", "d"]);
    assert_eq!(granted.passed_over, 0);
}

#[tokio::test]
async fn a_kind_seen_slower_than_estimated_is_expected_slower() {
    let dir = tempfile::tempdir().unwrap();
    let jobs = [
        job("a", "edmd", 10.0, false),
        job("b", "edmd", 10.0, false),
        job("c", "overlap", 10.0, false),
    ];
    let (coordinator, clock) = setup(&dir, &jobs).await;
    let first = coordinator
        .lease_within("w", 1, true, Some(25.0))
        .await
        .unwrap();
    assert_eq!(ids(&first), ["a"]);
    // It takes 30 s where 10 were estimated: an edmd job is now expected to take 3 times its
    // estimate, and b (10 s, so 30) no longer fits 25 s; the overlap job still does.
    clock.advance(Duration::from_secs(30));
    let lease = &first.leases[0];
    coordinator
        .complete("w", &lease.job_id, lease.token, Some(0), &["{}".to_owned()])
        .await
        .unwrap();
    assert_eq!(coordinator.durations().await.unwrap().scale("edmd"), 3.0);
    let granted = coordinator
        .lease_within("w", 10, true, Some(25.0))
        .await
        .unwrap();
    assert_eq!(ids(&granted), ["c"]);
    assert_eq!(granted.passed_over, 1);

    // A coordinator started again on the database learns the same from the done jobs.
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let again = Coordinator::new(store, Config::default(), clock).unwrap();
    assert_eq!(again.durations().await.unwrap().scale("edmd"), 3.0);
}

#[tokio::test]
async fn an_exclusive_job_that_does_not_fit_still_holds_the_queue() {
    let dir = tempfile::tempdir().unwrap();
    let jobs = [
        job("a", "overlap", 100.0, true),
        job("b", "overlap", 1.0, false),
    ];
    let (coordinator, _) = setup(&dir, &jobs).await;
    // The exclusive job heads the queue and does not fit: nothing may run before it.
    let granted = coordinator
        .lease_within("w", 10, true, Some(50.0))
        .await
        .unwrap();
    assert!(granted.leases.is_empty());
    assert!(granted.nothing_fits());
    let granted = coordinator
        .lease_within("w", 10, true, Some(500.0))
        .await
        .unwrap();
    assert_eq!(ids(&granted), ["a"]);
}
