//! The coordinator's policy: lease expiry by its clock, retries, the reaper, exclusive jobs under
//! concurrent worker slots, and resubmission.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use coordinator::{
    CompleteOutcome, Config, Coordinator, Error, FailOutcome, LeaseRef, ManualClock, NewCampaign,
    NewJob, Store, SystemClock, WorkerInfo,
};

const LEASE: Duration = Duration::from_secs(30);

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

fn campaign(id: &str) -> NewCampaign {
    NewCampaign {
        id: id.to_owned(),
        name: id.to_owned(),
        plan_text: String::new(),
        searches: Vec::new(),
    }
}

fn job(i: usize, exclusive: bool) -> NewJob {
    NewJob {
        id: format!("job-{i:05}"),
        kind: "noop".to_owned(),
        params_json: format!(r#"{{"i":{i}}}"#),
        estimate_s: 0.0,
        exclusive,
        pass: 0,
        foreign_code: false,
    }
}

async fn setup(workers: &[&str]) -> (tempfile::TempDir, Coordinator, Arc<ManualClock>) {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let clock = Arc::new(ManualClock::new(1_000.0));
    let config = Config {
        lease_for: LEASE,
        max_attempts: 2,
        ..Config::default()
    };
    let coordinator = Coordinator::new(store, config, clock.clone()).unwrap();
    for w in workers {
        coordinator.register(&worker(w)).await.unwrap();
    }
    (dir, coordinator, clock)
}

#[tokio::test]
async fn a_config_that_would_expire_or_fail_everything_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let zero_lease = Config {
        lease_for: Duration::ZERO,
        max_attempts: 3,
        ..Config::default()
    };
    let zero_attempts = Config {
        lease_for: LEASE,
        max_attempts: 0,
        ..Config::default()
    };
    let zero_budget = Config {
        in_flight_budget: 0,
        ..Config::default()
    };
    for config in [zero_lease, zero_attempts, zero_budget] {
        let result = Coordinator::new(store.clone(), config, Arc::new(SystemClock));
        assert!(matches!(result, Err(Error::Config(_))));
    }
}

/// A coordinator whose workers have `slots` cores each, `budget` jobs in flight.
async fn setup_slots(
    workers: usize,
    slots: u32,
    budget: u64,
) -> (tempfile::TempDir, Coordinator, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let config = Config {
        lease_for: LEASE,
        in_flight_budget: budget,
        ..Config::default()
    };
    let clock = Arc::new(ManualClock::new(1_000.0));
    let coordinator = Coordinator::new(store, config, clock).unwrap();
    let mut ids = Vec::new();
    for w in 0..workers {
        let info = WorkerInfo {
            cores: (0..slots).collect(),
            ..worker(&format!("w{w}"))
        };
        coordinator.register(&info).await.unwrap();
        ids.push(info.id);
    }
    (dir, coordinator, ids)
}

/// 100 slots each asking for 512 jobs of a 1,000-job queue get 10 each, all of them, instead of
/// the first two taking everything; on a queue smaller than the slots, every grant is one job.
#[tokio::test]
async fn a_small_queue_is_shared_fairly_among_the_slots() {
    let (_dir, coordinator, workers) = setup_slots(10, 10, 32_768).await;
    let jobs: Vec<NewJob> = (0..1000).map(|i| job(i, false)).collect();
    coordinator.submit(&campaign("c"), &jobs).await.unwrap();
    let mut leased = std::collections::HashSet::new();
    for slot in 0..100 {
        let grant = coordinator
            .lease(&workers[slot % workers.len()], 512, true)
            .await
            .unwrap();
        assert_eq!(grant.len(), 10, "slot {slot}");
        leased.extend(grant.into_iter().map(|l| l.job_id));
    }
    assert_eq!(leased.len(), 1000);

    let few: Vec<NewJob> = (1000..1003).map(|i| job(i, false)).collect();
    coordinator.submit(&campaign("d"), &few).await.unwrap();
    for (slot, worker) in workers.iter().enumerate().take(3) {
        let grant = coordinator.lease(worker, 512, true).await.unwrap();
        assert_eq!(grant.len(), 1, "slot {slot} of a 3-job queue");
    }
}

/// On a queue far larger than the budget, a grant is the budget's share per slot, not what the
/// slot asked for: 4 slots under a budget of 64 get 16 jobs a lease.
#[tokio::test]
async fn jobs_in_flight_are_bounded_by_the_budget() {
    let (_dir, coordinator, workers) = setup_slots(1, 4, 64).await;
    let jobs: Vec<NewJob> = (0..1000).map(|i| job(i, false)).collect();
    coordinator.submit(&campaign("c"), &jobs).await.unwrap();
    for _ in 0..4 {
        let grant = coordinator.lease(&workers[0], 512, true).await.unwrap();
        assert_eq!(grant.len(), 16);
    }
    // Asking for fewer than the share gets what was asked.
    assert_eq!(
        coordinator.lease(&workers[0], 3, true).await.unwrap().len(),
        3
    );
}

#[tokio::test]
async fn leases_expire_by_the_coordinator_clock_unless_heartbeaten() {
    let (_dir, c, clock) = setup(&["w1", "w2"]).await;
    c.submit(&campaign("c"), &[job(0, false), job(1, false)])
        .await
        .unwrap();
    // Two one-core workers: a fair share is one job a grant, so w1 leases twice.
    let mut leases = c.lease("w1", 2, true).await.unwrap();
    leases.extend(c.lease("w1", 2, true).await.unwrap());
    assert_eq!(leases.len(), 2);
    assert_eq!(leases[0].expires_at, 1_000.0 + 30.0);

    // Job 0 is kept alive by heartbeats, job 1 is not.
    clock.advance(Duration::from_secs(20));
    let keep = LeaseRef {
        job_id: leases[0].job_id.clone(),
        token: leases[0].token,
    };
    assert_eq!(
        c.heartbeat("w1", std::slice::from_ref(&keep))
            .await
            .unwrap(),
        std::slice::from_ref(&keep)
    );
    clock.advance(Duration::from_secs(20));
    assert_eq!(c.tick().await.unwrap(), 1);

    let retry = c.lease("w2", 5, true).await.unwrap();
    assert_eq!(
        (retry.len(), retry[0].job_id.as_str(), retry[0].attempt),
        (1, "job-00001", 2)
    );
    let stale = c
        .complete("w1", &leases[1].job_id, leases[1].token, Some(0), &[])
        .await
        .unwrap();
    assert_eq!(stale, CompleteOutcome::Late);
    let fresh = c
        .complete("w2", &retry[0].job_id, retry[0].token, Some(0), &[])
        .await
        .unwrap();
    assert_eq!(fresh, CompleteOutcome::Accepted);
    let kept = c
        .complete("w1", &keep.job_id, keep.token, Some(0), &[])
        .await
        .unwrap();
    assert_eq!(kept, CompleteOutcome::Accepted);
    assert_eq!(c.status(None).await.unwrap().done, 2);
}

#[tokio::test]
async fn failures_are_retried_up_to_max_attempts() {
    let (_dir, c, _clock) = setup(&["w1"]).await;
    c.submit(&campaign("c"), &[job(0, false)]).await.unwrap();
    let first = c.lease("w1", 1, true).await.unwrap().remove(0);
    let outcome = c
        .fail("w1", &first.job_id, first.token, "segfault")
        .await
        .unwrap();
    assert_eq!(outcome, FailOutcome::Requeued);
    let second = c.lease("w1", 1, true).await.unwrap().remove(0);
    let outcome = c
        .fail("w1", &second.job_id, second.token, "segfault again")
        .await
        .unwrap();
    assert_eq!(outcome, FailOutcome::Failed);
    let job = c.store().job(&first.job_id).await.unwrap();
    assert_eq!(job.last_error.as_deref(), Some("segfault again"));
    assert_eq!(c.status(None).await.unwrap().failed, 1);
}

#[tokio::test]
async fn the_reaper_requeues_lost_jobs() {
    let (_dir, c, clock) = setup(&["w1"]).await;
    c.submit(&campaign("c"), &[job(0, false)]).await.unwrap();
    c.lease("w1", 1, true).await.unwrap();
    clock.advance(LEASE * 2);
    let reaper = c.spawn_reaper(Duration::from_millis(5));
    let mut queued = 0;
    for _ in 0..200 {
        queued = c.status(None).await.unwrap().queued;
        if queued == 1 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    reaper.abort();
    assert_eq!(queued, 1);
}

#[tokio::test]
async fn resubmission_and_cancellation_through_the_coordinator() {
    let (_dir, c, _clock) = setup(&["w1"]).await;
    let jobs: Vec<NewJob> = (0..10).map(|i| job(i, false)).collect();
    assert_eq!(c.submit(&campaign("a"), &jobs).await.unwrap().new_jobs, 10);
    assert_eq!(c.submit(&campaign("a"), &jobs).await.unwrap().new_jobs, 0);
    let more: Vec<NewJob> = (0..12).map(|i| job(i, false)).collect();
    assert_eq!(c.submit(&campaign("b"), &more).await.unwrap().new_jobs, 2);
    c.lease("w1", 3, true).await.unwrap();
    assert_eq!(c.cancel("b").await.unwrap(), 2); // the two jobs only b contains
    let status = c.status(Some("b")).await.unwrap();
    assert_eq!((status.running, status.queued, status.cancelled), (3, 7, 2));
}

/// Local mode in miniature: 6 slots lease concurrently from a mix of exclusive and ordinary jobs and
/// "run" each for a moment; a shared counter checks that an exclusive job never overlaps another.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn exclusive_jobs_never_overlap_under_concurrent_slots() {
    const SLOTS: usize = 6;
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let c = Coordinator::new(store, Config::default(), Arc::new(SystemClock)).unwrap();
    let jobs: Vec<NewJob> = (0..120).map(|i| job(i, i % 7 == 3)).collect();
    c.submit(&campaign("mixed"), &jobs).await.unwrap();

    let running = Arc::new(AtomicUsize::new(0));
    let exclusive_running = Arc::new(AtomicUsize::new(0));
    let mut slots = Vec::new();
    for slot in 0..SLOTS {
        let (c, running, exclusive_running) =
            (c.clone(), running.clone(), exclusive_running.clone());
        c.register(&worker(&format!("slot{slot}"))).await.unwrap();
        slots.push(tokio::spawn(async move {
            let me = format!("slot{slot}");
            loop {
                let Some(lease) = c.lease(&me, 1, true).await.unwrap().pop() else {
                    if c.status(None).await.unwrap().queued == 0 {
                        break;
                    }
                    tokio::time::sleep(Duration::from_millis(1)).await;
                    continue;
                };
                let exclusive = c.store().job(&lease.job_id).await.unwrap().exclusive;
                let others = running.fetch_add(1, Ordering::SeqCst);
                assert_eq!(
                    exclusive_running.load(Ordering::SeqCst),
                    0,
                    "a job beside an exclusive one"
                );
                if exclusive {
                    assert_eq!(
                        others, 0,
                        "exclusive job {} started beside another",
                        lease.job_id
                    );
                    exclusive_running.fetch_add(1, Ordering::SeqCst);
                }
                tokio::time::sleep(Duration::from_millis(2)).await;
                if exclusive {
                    exclusive_running.fetch_sub(1, Ordering::SeqCst);
                }
                running.fetch_sub(1, Ordering::SeqCst);
                let outcome = c
                    .complete(&me, &lease.job_id, lease.token, None, &[])
                    .await
                    .unwrap();
                assert_eq!(outcome, CompleteOutcome::Accepted);
            }
        }));
    }
    for slot in slots {
        slot.await.unwrap();
    }
    assert_eq!(c.status(None).await.unwrap().done, 120);
}
