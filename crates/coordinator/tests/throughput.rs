//! Micro-benchmark: no-op jobs leased and completed per second through an in-process coordinator.
//! Ignored by default; run with
//! `cargo test --release -p coordinator --test throughput -- --ignored --nocapture`.

use std::sync::Arc;
use std::time::Instant;

use coordinator::{
    CompleteOutcome, Completion, Config, Coordinator, NewCampaign, NewJob, Store, SystemClock,
    WorkerInfo,
};

const JOBS: usize = 20_000;
const SLOTS: usize = 4;

fn noop_jobs() -> Vec<NewJob> {
    (0..JOBS)
        .map(|i| NewJob {
            id: format!("{:064x}", i),
            kind: "noop".to_owned(),
            params_json: format!(r#"{{"index":{i},"duration_ms":0}}"#),
            estimate_s: 0.0,
            exclusive: false,
            pass: 0,
            foreign_code: false,
        })
        .collect()
}

fn worker(id: &str) -> WorkerInfo {
    WorkerInfo {
        id: id.to_owned(),
        hostname: "bench".to_owned(),
        cores: vec![0],
        cpu_model: "cpu".to_owned(),
        cpu_flags: String::new(),
        rustc: "1.95".to_owned(),
        git_commit: "bench".to_owned(),
        profile: "release".to_owned(),
        allocation: None,
        allow_commands: false,
    }
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "benchmark: run in release with --ignored --nocapture"]
async fn noop_jobs_per_second() {
    for (batch, batched_completes) in [
        (1u32, false),
        (64, false),
        (16, true),
        (64, true),
        (256, true),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path().join("bench.db")).await.unwrap();
        let c = Coordinator::new(store, Config::default(), Arc::new(SystemClock)).unwrap();
        let campaign = NewCampaign {
            id: "bench".into(),
            name: "bench".into(),
            plan_text: String::new(),
            searches: Vec::new(),
        };
        let jobs = noop_jobs();
        let started = Instant::now();
        c.submit(&campaign, &jobs).await.unwrap();
        let submit = started.elapsed();

        let started = Instant::now();
        let mut slots = Vec::new();
        for slot in 0..SLOTS {
            let c = c.clone();
            let me = format!("slot{slot}");
            c.register(&worker(&me)).await.unwrap();
            slots.push(tokio::spawn(async move {
                let record = [r#"{"elapsed_ms":0}"#.to_owned()];
                loop {
                    let leases = c.lease(&me, batch, true).await.unwrap();
                    if leases.is_empty() {
                        break;
                    }
                    if batched_completes {
                        let completions: Vec<Completion> = leases
                            .into_iter()
                            .map(|lease| Completion {
                                job_id: lease.job_id,
                                token: lease.token,
                                core_id: Some(0),
                                records: record.to_vec(),
                            })
                            .collect();
                        let outcomes = c.complete_batch(&me, &completions).await.unwrap();
                        assert!(outcomes.iter().all(|o| *o == CompleteOutcome::Accepted));
                    } else {
                        for lease in leases {
                            let outcome = c
                                .complete(&me, &lease.job_id, lease.token, Some(0), &record)
                                .await
                                .unwrap();
                            assert_eq!(outcome, CompleteOutcome::Accepted);
                        }
                    }
                }
            }));
        }
        for slot in slots {
            slot.await.unwrap();
        }
        let run = started.elapsed();
        assert_eq!(c.status(None).await.unwrap().done, JOBS as u64);
        println!(
            "lease batch {batch:>3}, {} completes: submit {:>7.0} jobs/s | lease+complete {:>7.0} jobs/s ({JOBS} no-op jobs, {SLOTS} slots)",
            if batched_completes {
                "batched"
            } else {
                "single "
            },
            JOBS as f64 / submit.as_secs_f64(),
            JOBS as f64 / run.as_secs_f64(),
        );
    }
}
