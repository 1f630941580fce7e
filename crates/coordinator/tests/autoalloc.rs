//! The allocator against a fake Slurm and a manual clock: how many allocations it submits for the
//! work queued and what it has learned of durations, what it does when sbatch fails or an
//! allocation ends without a worker (shown, and backed off), and how it follows allocations to
//! their end, cancels pending ones when nothing is queued, and takes over after a restart.

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use coordinator::autoalloc::config::AllocConfig;
use coordinator::autoalloc::slurm::{Batch, JobStatus};
use coordinator::autoalloc::{Allocator, Launch, Report};
use coordinator::{Config, Coordinator, ManualClock, NewCampaign, NewJob, Store, WorkerInfo};
use store::AllocationState;

/// What the fake Slurm was asked and what it says.
#[derive(Default)]
struct SlurmState {
    next_id: u64,
    /// The arguments of every sbatch call, refused or not.
    sbatch_calls: Vec<Vec<String>>,
    jobs: HashMap<String, JobStatus>,
    /// sbatch answers this error.
    refuse: Option<String>,
    /// squeue answers this error.
    squeue_fails: Option<String>,
    cancelled: Vec<String>,
}

#[derive(Clone, Default)]
struct FakeSlurm(Arc<Mutex<SlurmState>>);

impl FakeSlurm {
    fn state(&self) -> std::sync::MutexGuard<'_, SlurmState> {
        self.0.lock().unwrap()
    }

    fn set(&self, id: &str, state: &str, left_s: Option<f64>) {
        self.state().jobs.insert(
            id.to_owned(),
            JobStatus {
                state: state.to_owned(),
                reason: String::new(),
                left_s,
            },
        );
    }

    fn calls(&self) -> usize {
        self.state().sbatch_calls.len()
    }
}

impl Batch for FakeSlurm {
    async fn submit(&self, args: &[String]) -> Result<String, String> {
        let mut state = self.state();
        state.sbatch_calls.push(args.to_vec());
        if let Some(error) = &state.refuse {
            return Err(error.clone());
        }
        state.next_id += 1;
        let id = (100 + state.next_id).to_string();
        state.jobs.insert(
            id.clone(),
            JobStatus {
                state: "PENDING".into(),
                reason: "Priority".into(),
                left_s: None,
            },
        );
        Ok(id)
    }

    async fn query(&self, ids: &[String]) -> Result<HashMap<String, JobStatus>, String> {
        let state = self.state();
        if let Some(error) = &state.squeue_fails {
            return Err(error.clone());
        }
        Ok(ids
            .iter()
            .filter_map(|id| state.jobs.get(id).map(|s| (id.clone(), s.clone())))
            .collect())
    }

    async fn cancel(&self, id: &str) -> Result<(), String> {
        let mut state = self.state();
        state.cancelled.push(id.to_owned());
        if let Some(job) = state.jobs.get_mut(id) {
            job.state = "CANCELLED".into();
        }
        Ok(())
    }
}

struct Setup {
    dir: tempfile::TempDir,
    coordinator: Coordinator,
    clock: Arc<ManualClock>,
    slurm: FakeSlurm,
}

impl Setup {
    async fn new() -> Setup {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path().join("c.db")).await.unwrap();
        let clock = Arc::new(ManualClock::new(1_000_000.0));
        let config = Config {
            lease_for: Duration::from_secs(600),
            ..Config::default()
        };
        let coordinator = Coordinator::new(store, config, clock.clone()).unwrap();
        Setup {
            dir,
            coordinator,
            clock,
            slurm: FakeSlurm::default(),
        }
    }

    /// An allocator with the allocation file `text` (its directory in the test's).
    async fn allocator(&self, text: &str) -> Allocator<FakeSlurm> {
        let config = AllocConfig::parse(text, Path::new("alloc.toml"), self.dir.path()).unwrap();
        let launch = Launch {
            script: self.dir.path().join("sweep-workers.sbatch"),
            coordinator_url: "http://login:7070".into(),
            export: vec![("SWEEP".into(), "/shared/sweep".into())],
        };
        Allocator::new(config, launch, self.coordinator.clone(), self.slurm.clone())
            .await
            .unwrap()
    }

    /// Queues `count` no-op jobs estimated at `estimate_s` each.
    async fn queue(&self, name: &str, count: usize, estimate_s: f64) {
        let jobs: Vec<NewJob> = (0..count)
            .map(|i| NewJob {
                id: format!("{name}-{i:05}"),
                kind: "noop".into(),
                params_json: format!(r#"{{"i":{i}}}"#),
                estimate_s,
                exclusive: false,
                pass: 0,
                foreign_code: false,
            })
            .collect();
        let campaign = NewCampaign {
            id: name.into(),
            name: name.into(),
            plan_text: String::new(),
            searches: Vec::new(),
        };
        self.coordinator.submit(&campaign, &jobs).await.unwrap();
    }

    /// Registers a worker from the allocation with Slurm id `allocation`.
    async fn worker_from(&self, allocation: &str) {
        let info = WorkerInfo {
            id: format!("node:{allocation}"),
            hostname: "node".into(),
            cores: vec![0, 1],
            cpu_model: "cpu".into(),
            cpu_flags: String::new(),
            rustc: "1.95".into(),
            git_commit: "abc".into(),
            profile: "release".into(),
            allocation: Some(allocation.into()),
            allow_commands: false,
        };
        self.coordinator.register(&info).await.unwrap();
    }

    async fn report(&self) -> Report {
        Report::read(self.coordinator.store(), None, None)
            .await
            .unwrap()
    }

    fn advance(&self, seconds: u64) {
        self.clock.advance(Duration::from_secs(seconds));
    }
}

/// 10 minutes, 2 cores, up to 3 in flight, no stop margin: an allocation supplies 1,200 CPU-s.
const SMALL: &str = r#"
time_limit = "10:00"
cores = 2
max_in_flight = 3
stop_margin_s = 0
idle_timeout_s = 60
partition = "short"
"#;

#[tokio::test]
async fn nothing_is_submitted_while_nothing_is_queued() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    let tick = allocator.tick().await.unwrap();
    assert!(tick.submitted.is_empty());
    assert_eq!(s.slurm.calls(), 0);
    assert!(tick.note.starts_with("nothing queued"), "{}", tick.note);
    let report = s.report().await;
    assert!(report.configured, "the allocator's state is recorded");
    assert_eq!(report.note, tick.note);
    assert_eq!(report.updated_at, Some(1_000_000.0));
    // The same decision is not written again at every tick, but at least every minute.
    s.advance(30);
    allocator.tick().await.unwrap();
    assert_eq!(s.report().await.updated_at, Some(1_000_000.0));
    s.advance(30);
    allocator.tick().await.unwrap();
    assert_eq!(s.report().await.updated_at, Some(1_000_060.0));
}

#[tokio::test]
async fn allocations_follow_the_remaining_work_up_to_the_limit() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    // 10 jobs of 30 s: 300 CPU-s, one allocation covers them.
    s.queue("small", 10, 30.0).await;
    let tick = allocator.tick().await.unwrap();
    assert_eq!(tick.submitted, ["101"]);
    let args = s.slurm.state().sbatch_calls[0].clone();
    for expected in [
        "--time=10:00",
        "--nodes=1",
        "--cpus-per-task=2",
        "--partition=short",
        "--signal=B:USR1@0",
        "--export=ALL,SWEEP=/shared/sweep",
        "--coordinator",
        "http://login:7070",
        "--idle-timeout",
    ] {
        assert!(args.iter().any(|a| a == expected), "{expected} in {args:?}");
    }
    assert_eq!(allocator.tick().await.unwrap().submitted.len(), 0);

    // 100 more of 30 s: 3,300 CPU-s, less the 1,200 in flight: two more, the limit.
    s.queue("more", 100, 30.0).await;
    let tick = allocator.tick().await.unwrap();
    assert_eq!(tick.submitted, ["102", "103"]);
    // 1,000 more: still three at most.
    s.queue("lots", 1000, 30.0).await;
    let tick = allocator.tick().await.unwrap();
    assert!(tick.submitted.is_empty());
    assert!(tick.note.contains("at the limit of 3"), "{}", tick.note);
    let report = s.report().await;
    assert_eq!(report.counts(), "3 pending");
    assert!(report.allocations.iter().all(|a| a.allocation.cores == 2));
}

#[tokio::test]
async fn no_more_allocations_than_the_jobs_keep_busy() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    // Three jobs of 590 s are 1,770 CPU-s, two allocations' worth, and keep two allocations of
    // two cores busy: two, not the three allowed; a single such job gets one.
    s.queue("few", 3, 590.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted.len(), 2);
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("one", 1, 590.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted.len(), 1);
}

#[tokio::test]
async fn observed_durations_grow_the_work() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    // 30 jobs of 10 s: 300 CPU-s, one allocation.
    s.queue("c", 30, 10.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted, ["101"]);
    // A worker from it finds that a job takes 100 s, not 10: the 29 jobs left are 2,900 CPU-s,
    // against the 1,000 the allocation has left (2 cores, 500 s): two more.
    s.worker_from("101").await;
    let lease = s.coordinator.lease("node:101", 1, true).await.unwrap();
    s.advance(100);
    s.slurm.set("101", "RUNNING", Some(500.0));
    s.coordinator
        .complete("node:101", &lease[0].job_id, lease[0].token, Some(0), &[])
        .await
        .unwrap();
    let tick = allocator.tick().await.unwrap();
    assert_eq!(tick.submitted, ["102", "103"], "{}", tick.note);
}

#[tokio::test]
async fn jobs_longer_than_an_allocation_get_none_and_say_so() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("long", 5, 1000.0).await;
    let tick = allocator.tick().await.unwrap();
    assert!(tick.submitted.is_empty());
    assert_eq!(s.slurm.calls(), 0);
    assert!(
        tick.note
            .contains("5 queued jobs are expected to take longer than an allocation's 600 s"),
        "{}",
        tick.note
    );
}

#[tokio::test]
async fn a_failing_sbatch_is_shown_and_backed_off_not_looped() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("c", 100, 30.0).await;
    s.slurm.state().refuse = Some(
        "sbatch: error: invalid partition specified: short / sbatch: error: Batch job \
         submission failed: Invalid partition name specified"
            .into(),
    );
    let tick = allocator.tick().await.unwrap();
    assert_eq!(
        (tick.refused, s.slurm.calls()),
        (1, 1),
        "one try, not three"
    );
    let report = s.report().await;
    assert_eq!(report.failures, 1);
    assert_eq!(report.retry_at, Some(1_000_060.0));
    let failed = &report.allocations[0].allocation;
    assert_eq!(failed.state, AllocationState::Failed);
    assert_eq!(failed.external_id, None);
    assert!(
        failed
            .reason
            .starts_with("sbatch failed: sbatch: error: invalid partition"),
        "{}",
        failed.reason
    );
    // Ticks within the pause submit nothing, and say why.
    for _ in 0..5 {
        s.advance(10);
        let tick = allocator.tick().await.unwrap();
        assert!(
            tick.note.starts_with("backing off after 1 failures"),
            "{}",
            tick.note
        );
    }
    assert_eq!(s.slurm.calls(), 1);
    // After a minute, one more try; then two minutes.
    s.advance(10);
    allocator.tick().await.unwrap();
    assert_eq!(s.slurm.calls(), 2);
    s.advance(119);
    allocator.tick().await.unwrap();
    assert_eq!(s.slurm.calls(), 2);
    s.advance(1);
    allocator.tick().await.unwrap();
    assert_eq!((s.slurm.calls(), s.report().await.failures), (3, 3));

    // Fixed: the next try after the pause submits, and a worker registering from that
    // allocation ends the back-off.
    s.slurm.state().refuse = None;
    s.advance(240);
    let tick = allocator.tick().await.unwrap();
    assert_eq!(tick.submitted.len(), 3, "{}", tick.note);
    s.slurm.set(&tick.submitted[0], "RUNNING", Some(500.0));
    s.worker_from(&tick.submitted[0]).await;
    allocator.tick().await.unwrap();
    let report = s.report().await;
    assert_eq!((report.failures, report.retry_at), (0, None));
    assert_eq!(report.counts(), "2 pending, 1 running, 3 failed");
}

#[tokio::test]
async fn an_allocation_that_ends_without_a_worker_fails_with_what_it_printed() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("c", 10, 30.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted, ["101"]);
    std::fs::create_dir_all(s.dir.path().join("allocations")).unwrap();
    std::fs::write(
        s.dir.path().join("allocations/slurm-101.out"),
        "sweep.sbatch: no token file /shared/sweep/token\n\n",
    )
    .unwrap();
    s.slurm.set("101", "FAILED", Some(590.0));
    s.advance(5);
    let tick = allocator.tick().await.unwrap();
    assert!(tick.submitted.is_empty(), "backing off: {}", tick.note);
    let report = s.report().await;
    let a = &report.allocations[0].allocation;
    assert_eq!(a.state, AllocationState::Failed);
    assert!(
        a.reason
            .starts_with("ended (FAILED) without starting a worker;")
            && a.reason
                .ends_with("says: sweep.sbatch: no token file /shared/sweep/token"),
        "{}",
        a.reason
    );
    assert_eq!(a.ended_at, Some(1_000_005.0));
    assert_eq!(report.failures, 1);
}

#[tokio::test]
async fn allocations_are_followed_to_their_end_and_replaced() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("c", 10, 30.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted, ["101"]);
    // Running for 100 s of its 600, with a worker.
    s.slurm.set("101", "RUNNING", Some(500.0));
    s.worker_from("101").await;
    allocator.tick().await.unwrap();
    let a = s.report().await.allocations[0].clone();
    assert_eq!(a.allocation.state, AllocationState::Running);
    assert_eq!(a.allocation.started_at, Some(1_000_000.0 - 100.0));
    assert_eq!(a.workers, 1);
    // Its time limit ends it; the queued work gets a new allocation at the same tick.
    s.advance(500);
    s.slurm.set("101", "TIMEOUT", Some(0.0));
    let tick = allocator.tick().await.unwrap();
    assert_eq!(tick.submitted, ["102"]);
    let report = s.report().await;
    let ended = &report.allocations[1].allocation;
    assert_eq!(
        (ended.state, ended.reason.as_str()),
        (AllocationState::Ended, "TIMEOUT")
    );
    assert_eq!(report.failures, 0, "an allocation that ran is no failure");
}

#[tokio::test]
async fn pending_allocations_are_cancelled_when_nothing_is_queued() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("c", 100, 30.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted.len(), 3);
    s.slurm.set("101", "RUNNING", Some(600.0));
    s.coordinator.cancel("c").await.unwrap();
    let tick = allocator.tick().await.unwrap();
    assert_eq!(tick.cancelled, ["102", "103"]);
    assert_eq!(
        s.slurm.state().cancelled,
        ["102", "103"],
        "the running one is left to idle out"
    );
    let report = s.report().await;
    assert_eq!(report.counts(), "1 running, 2 cancelled");
}

#[tokio::test]
async fn nothing_is_submitted_while_squeue_fails() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("c", 10, 30.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted.len(), 1);
    s.slurm.state().squeue_fails =
        Some("squeue: error: slurm_receive_msg: Socket timed out".into());
    s.queue("more", 1000, 30.0).await;
    let tick = allocator.tick().await.unwrap();
    assert!(tick.submitted.is_empty());
    assert!(
        tick.note.contains("squeue: error: slurm_receive_msg"),
        "{}",
        tick.note
    );
    // Nor is what squeue cannot confirm as pending cancelled: it may have started since.
    s.coordinator.cancel("c").await.unwrap();
    s.coordinator.cancel("more").await.unwrap();
    let tick = allocator.tick().await.unwrap();
    assert!(tick.cancelled.is_empty());
    assert!(s.slurm.state().cancelled.is_empty());
}

#[tokio::test]
async fn a_new_allocator_takes_over_the_allocations_in_flight() {
    let s = Setup::new().await;
    let mut allocator = s.allocator(SMALL).await;
    s.queue("c", 10, 30.0).await;
    assert_eq!(allocator.tick().await.unwrap().submitted, ["101"]);
    drop(allocator);
    let mut again = s.allocator(SMALL).await;
    assert_eq!(again.open().len(), 1);
    // Nothing new while it is in flight; its end is seen.
    s.slurm.set("101", "RUNNING", Some(600.0));
    s.worker_from("101").await;
    assert!(again.tick().await.unwrap().submitted.is_empty());
    s.slurm.state().jobs.remove("101");
    s.coordinator.cancel("c").await.unwrap();
    again.tick().await.unwrap();
    let a = &s.report().await.allocations[0].allocation;
    assert_eq!(
        (a.state, a.reason.as_str()),
        (AllocationState::Ended, "gone from squeue")
    );
}
