//! No-op jobs per second through a real coordinator and real worker processes on loopback (one
//! slot each, pinned to cores 0 and 1 in turn), every state change committed to SQLite before it
//! is acknowledged; and the coordinator's memory over a long campaign.
//!
//! `cargo bench -p cli --bench orchestrator [-- JOBS [BATCH…]]` (default 20000 jobs): the default
//! settings (paced leases) with 2 and with 8 worker processes, then each `--lease-batch BATCH`
//! given (default: 1, the old default) with 2 workers; then a 100,000-job campaign at the default
//! settings with 2 workers, sampling the coordinator's RSS. With `SWEEP_BASELINE=/path/to/sweep`
//! (another build), each throughput run is made with that binary too, right before ours.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{Proc, rss_kib};

mod common;

const SWEEP: &str = env!("CARGO_BIN_EXE_sweep");

fn status(bin: &str, url: &str, token: &Path) -> serde_json::Value {
    let out = Command::new(bin)
        .args([
            "status",
            "--coordinator",
            url,
            "--token-file",
            token.to_str().unwrap(),
            "--format",
            "json",
        ])
        .output()
        .unwrap();
    serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()["status"].clone()
}

struct Run {
    jobs_per_second: f64,
    peak_rss_kib: u64,
    rss_samples: Vec<(u64, u64)>,
}

fn campaign(bin: &str, jobs: u64, workers: usize, batch: Option<u32>) -> Run {
    let dir = tempfile::tempdir().unwrap();
    let token = dir.path().join("token");
    std::fs::write(&token, "bench-token").unwrap();
    let db = dir.path().join("bench.db");
    let mut coordinator = Command::new(bin)
        .args([
            "coordinator",
            "--listen",
            "127.0.0.1:0",
            "--db",
            db.to_str().unwrap(),
        ])
        .args([
            "--token-file",
            token.to_str().unwrap(),
            "--lease-secs",
            "60",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(coordinator.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let url = format!("http://{}", line.trim().trim_start_matches("listening on "));
    let coordinator = Proc(coordinator);
    let plan = dir.path().join("noop.toml");
    std::fs::write(
        &plan,
        format!("name = \"bench\"\n[[noop]]\ncount = {jobs}\nduration_ms = 0\n"),
    )
    .unwrap();
    let submitted = Command::new(bin)
        .args([
            "submit",
            plan.to_str().unwrap(),
            "--coordinator",
            &url,
            "--token-file",
            token.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        submitted.status.success(),
        "{}",
        String::from_utf8_lossy(&submitted.stderr)
    );

    let started = Instant::now();
    let batch: Vec<String> = batch
        .map(|b| vec!["--lease-batch".into(), b.to_string()])
        .unwrap_or_default();
    let workers: Vec<Proc> = (0..workers)
        .map(|worker| {
            Proc(
                Command::new(bin)
                    .args([
                        "worker",
                        "--coordinator",
                        &url,
                        "--cores",
                        &(worker % 2).to_string(),
                    ])
                    .args(&batch)
                    .args(["--token-file", token.to_str().unwrap()])
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .unwrap(),
            )
        })
        .collect();
    let mut rss_samples = Vec::new();
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let s = status(bin, &url, &token);
        let done = s["done"].as_u64().unwrap_or(0);
        rss_samples.push((done, rss_kib(coordinator.0.id(), "VmRSS:")));
        if done == jobs {
            break;
        }
        assert!(started.elapsed() < Duration::from_secs(600), "stalled: {s}");
    }
    let elapsed = started.elapsed().as_secs_f64();
    let peak_rss_kib = rss_kib(coordinator.0.id(), "VmHWM:");
    drop(workers);
    Run {
        jobs_per_second: jobs as f64 / elapsed,
        peak_rss_kib,
        rss_samples,
    }
}

fn main() {
    // `cargo bench` passes `--bench`; plain numbers are ours.
    let numbers: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let jobs = numbers.first().copied().unwrap_or(20_000);
    let batches: Vec<u32> = if numbers.len() > 1 {
        numbers[1..].iter().map(|&b| b as u32).collect()
    } else {
        vec![1]
    };
    println!(
        "{jobs} no-op jobs, coordinator + worker processes on loopback, SQLite WAL, durable before acknowledged"
    );
    let mut runs: Vec<(String, usize, Option<u32>)> = vec![
        ("default settings".into(), 2, None),
        ("default settings".into(), 8, None),
    ];
    runs.extend(
        batches
            .iter()
            .map(|&b| (format!("--lease-batch {b}"), 2, Some(b))),
    );
    let baseline = std::env::var("SWEEP_BASELINE").ok();
    let binaries: Vec<(&str, &str)> = baseline
        .iter()
        .map(|b| ("baseline", b.as_str()))
        .chain([("this build", SWEEP)])
        .collect();
    for (name, workers, batch) in runs {
        for &(build, bin) in &binaries {
            let run = campaign(bin, jobs, workers, batch);
            println!(
                "{build:>10} {name:>18}, {workers} workers: {:>8.0} jobs/s, coordinator peak RSS {:.1} MB",
                run.jobs_per_second,
                run.peak_rss_kib as f64 / 1024.0
            );
        }
    }
    let long = 100_000;
    let run = campaign(SWEEP, long, 2, None);
    let at = |fraction: f64| {
        run.rss_samples
            .iter()
            .find(|(done, _)| *done as f64 >= fraction * long as f64)
            .map_or(0, |s| s.1)
    };
    println!(
        "{long} jobs, default settings, 2 workers: {:.0} jobs/s; coordinator RSS at 10% {:.1} MB, 50% {:.1} MB, 100% {:.1} MB, peak {:.1} MB",
        run.jobs_per_second,
        at(0.1) as f64 / 1024.0,
        at(0.5) as f64 / 1024.0,
        at(1.0) as f64 / 1024.0,
        run.peak_rss_kib as f64 / 1024.0
    );
}
