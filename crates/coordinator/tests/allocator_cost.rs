//! Micro-benchmark: what the allocator and walltime-aware leasing cost on a campaign of a million
//! points. Ignored by default; run with
//! `cargo test --release -p coordinator --test allocator_cost -- --ignored --nocapture`.
//!
//! It times, with 10⁶ jobs queued: one allocator tick's reads (the queue's length and the kinds
//! and estimates of its first 4,096 jobs), a grant to a worker whose time left fits nothing (the
//! worst case: SCAN_AHEAD jobs looked at, none leased), and a grant that fits; then, with
//! 200,000 of them done by workers of allocations, the jobs done per allocation that
//! `sweep workers` reads (O(done)).

use std::sync::Arc;
use std::time::{Duration, Instant};

use coordinator::autoalloc::{HEAD, Report};
use coordinator::{
    Completion, Config, Coordinator, NewCampaign, NewJob, Store, SystemClock, WorkerInfo,
};

const JOBS: usize = 1_000_000;
const DONE: usize = 200_000;

fn worker(id: &str, allocation: &str) -> WorkerInfo {
    WorkerInfo {
        id: id.to_owned(),
        hostname: "node".to_owned(),
        cores: vec![0],
        cpu_model: "cpu".to_owned(),
        cpu_flags: String::new(),
        rustc: "1.95".to_owned(),
        git_commit: "abc".to_owned(),
        profile: "release".to_owned(),
        allocation: Some(allocation.to_owned()),
        allow_commands: false,
    }
}

/// The median of `runs` timings of `f`.
async fn median<F, Fut>(runs: usize, mut f: F) -> Duration
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = ()>,
{
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        let started = Instant::now();
        f().await;
        times.push(started.elapsed());
    }
    times.sort();
    times[runs / 2]
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "benchmark: run in release with --ignored --nocapture"]
async fn allocator_reads_on_a_million_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path().join("bench.db")).await.unwrap();
    let c = Coordinator::new(store, Config::default(), Arc::new(SystemClock)).unwrap();
    let jobs: Vec<NewJob> = (0..JOBS)
        .map(|i| NewJob {
            id: format!("{:064x}", i),
            kind: "noop".to_owned(),
            params_json: format!(r#"{{"index":{i}}}"#),
            estimate_s: 10.0,
            exclusive: false,
            pass: 0,
            foreign_code: false,
        })
        .collect();
    let campaign = NewCampaign {
        id: "bench".into(),
        name: "bench".into(),
        plan_text: String::new(),
        searches: Vec::new(),
    };
    let started = Instant::now();
    c.submit(&campaign, &jobs).await.unwrap();
    println!(
        "submitted {JOBS} jobs in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    drop(jobs);
    let store = c.store().clone();
    c.register(&worker("w1", "1001")).await.unwrap();
    c.register(&worker("w2", "1002")).await.unwrap();

    let sample = median(9, || async {
        let sample = store.queue_sample(HEAD).await.unwrap();
        assert_eq!(sample.queued, JOBS as u64);
    })
    .await;
    println!(
        "allocator tick's reads (queue length + first {HEAD} jobs), {JOBS} queued: {:.1} ms",
        sample.as_secs_f64() * 1e3
    );
    let nothing = median(9, || async {
        let granted = c.lease_within("w1", 1, true, Some(5.0)).await.unwrap();
        assert!(granted.nothing_fits());
    })
    .await;
    println!(
        "a grant where nothing fits ({} jobs looked at): {:.2} ms",
        store::SCAN_AHEAD + 1,
        nothing.as_secs_f64() * 1e3
    );
    let fits = median(9, || async {
        let granted = c.lease_within("w1", 1, true, Some(60.0)).await.unwrap();
        assert_eq!(granted.leases.len(), 1);
    })
    .await;
    let plain = median(9, || async {
        assert_eq!(c.lease("w1", 1, true).await.unwrap().len(), 1);
    })
    .await;
    println!(
        "a grant of one job that fits: {:.2} ms (without a time limit: {:.2} ms)",
        fits.as_secs_f64() * 1e3,
        plain.as_secs_f64() * 1e3
    );

    // Done by the workers of two allocations.
    let started = Instant::now();
    let mut done = 0;
    while done < DONE {
        for w in ["w1", "w2"] {
            let leases = c.lease(w, 512, true).await.unwrap();
            let completions: Vec<Completion> = leases
                .into_iter()
                .map(|l| Completion {
                    job_id: l.job_id,
                    token: l.token,
                    core_id: Some(0),
                    records: vec!["{}".to_owned()],
                })
                .collect();
            done += completions.len();
            c.complete_batch(w, &completions).await.unwrap();
        }
    }
    println!("{done} done in {:.1} s", started.elapsed().as_secs_f64());
    let by_allocation = median(5, || async {
        let done_by = store.allocation_jobs_done().await.unwrap();
        assert_eq!(done_by.values().sum::<u64>() as usize, done);
    })
    .await;
    let report = median(5, || async {
        Report::read(&store, Some(true), None).await.unwrap();
    })
    .await;
    println!(
        "jobs done per allocation ({done} done): {:.0} ms; the rest of the report: {:.2} ms",
        by_allocation.as_secs_f64() * 1e3,
        report.as_secs_f64() * 1e3
    );
}
