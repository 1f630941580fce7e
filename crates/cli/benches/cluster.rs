//! Load test of the coordinator alone: a large cluster simulated on loopback. A real `sweep
//! coordinator` process serves `clients` client processes (this binary, re-executed), each one
//! registered worker acting as `slots` slots over one gRPC connection, as a real worker does. A
//! slot leases what the workers' pacing asks for given `job_ms` (`worker::pace`: 512 no-op jobs
//! at once, one job at a time from 100 ms up), "runs" them by sleeping `job_ms` each, and reports
//! them in one call; each client heartbeats the leases its slots hold.
//!
//! `cargo bench -p cli --bench cluster -- [jobs=1000000] [clients=8] [slots=128] [job_ms=0]`
//!
//! Prints the sustained completion rate (between 10 % and 90 % of the jobs done), p50/p99/max of
//! each RPC as the clients saw it, and the coordinator's RSS along the campaign.

use std::collections::HashSet;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use queue::{CompleteOutcome, Completion, JobQueue, LeaseRef, WorkerInfo};
use worker::pace::Pace;
use worker::remote::Remote;

use common::{Proc, rss_kib};

mod common;

const SWEEP: &str = env!("CARGO_BIN_EXE_sweep");
/// Set in a client process: the coordinator's URL.
const CLIENT_ENV: &str = "SWEEP_CLUSTER_CLIENT";
const TOKEN: &str = "cluster-bench-token";
const RPCS: [&str; 3] = ["lease", "complete", "heartbeat"];
/// Backoff between retries of a failed call, as the workers' slots do.
const RETRY: Duration = Duration::from_millis(100);

struct Settings {
    jobs: u64,
    clients: usize,
    slots: usize,
    job_ms: u64,
}

fn settings() -> Settings {
    let mut s = Settings {
        jobs: 1_000_000,
        clients: 8,
        slots: 128,
        job_ms: 0,
    };
    for arg in std::env::args().skip(1) {
        let Some((key, value)) = arg.split_once('=') else {
            continue;
        }; // `--bench`
        let number: u64 = value
            .parse()
            .unwrap_or_else(|_| panic!("{arg}: not a number"));
        match key {
            "jobs" => s.jobs = number,
            "clients" => s.clients = number as usize,
            "slots" => s.slots = number as usize,
            "job_ms" => s.job_ms = number,
            _ => panic!("unknown setting {key} (jobs, clients, slots, job_ms)"),
        }
    }
    s
}

/// Latencies in log buckets 5 % wide, from 1 µs.
#[derive(Clone, Default)]
struct Histogram {
    counts: Vec<u64>,
}

const BUCKETS_PER_E: f64 = 20.0;

impl Histogram {
    fn record(&mut self, took: Duration) {
        let micros = took.as_micros().max(1) as f64;
        let bucket = (micros.ln() * BUCKETS_PER_E) as usize;
        if self.counts.len() <= bucket {
            self.counts.resize(bucket + 1, 0);
        }
        self.counts[bucket] += 1;
    }

    fn merge(&mut self, other: &Histogram) {
        if self.counts.len() < other.counts.len() {
            self.counts.resize(other.counts.len(), 0);
        }
        self.counts
            .iter_mut()
            .zip(&other.counts)
            .for_each(|(a, b)| *a += b);
    }

    fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// The upper edge of the bucket holding quantile `q`, in ms.
    fn quantile_ms(&self, q: f64) -> f64 {
        let rank = (q * self.total() as f64).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (bucket, count) in self.counts.iter().enumerate() {
            seen += count;
            if seen >= rank {
                return ((bucket + 1) as f64 / BUCKETS_PER_E).exp() / 1000.0;
            }
        }
        f64::NAN
    }
}

// ---------------------------------------------------------------------------------------------
// A client process: one worker of `slots` simulated slots.

fn client(url: String, id: usize, slots: usize, job_ms: u64) {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(async move {
        let worker_id = format!("sim-{id}-{}", std::process::id());
        let token = wire::auth::Token::new(TOKEN).unwrap();
        let remote = Arc::new(Remote::new(&url, Some(token), None, worker_id.clone()).unwrap());
        let info = WorkerInfo {
            id: worker_id,
            hostname: format!("sim-{id}"),
            cores: (0..slots as u32).collect(),
            cpu_model: "simulated".into(),
            cpu_flags: String::new(),
            rustc: "simulated".into(),
            git_commit: "simulated".into(),
            profile: "release".into(),
            allocation: None,
            allow_commands: false,
        };
        let lease_for = remote.register(&info).await.unwrap();
        let done = Arc::new(AtomicU64::new(0));
        // The driver closes our stdin once every job is done: leases lost to a call past its
        // deadline come back only when they expire, so an empty queue does not mean the end.
        let stop = Arc::new(AtomicBool::new(false));
        {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let _ = std::io::copy(&mut std::io::stdin(), &mut std::io::sink());
                stop.store(true, Ordering::Relaxed);
            });
        }
        let failed_calls = Arc::new(AtomicU64::new(0));
        let held: Arc<Mutex<HashSet<LeaseRef>>> = Arc::default();
        let latencies: Arc<Mutex<Vec<Histogram>>> =
            Arc::new(Mutex::new(vec![Histogram::default(); RPCS.len()]));
        let record = {
            let latencies = latencies.clone();
            move |rpc: usize, took: Duration| latencies.lock().unwrap()[rpc].record(took)
        };

        let progress = {
            let done = done.clone();
            tokio::spawn(async move {
                loop {
                    tokio::time::sleep(Duration::from_millis(250)).await;
                    println!("progress {}", done.load(Ordering::Relaxed));
                }
            })
        };
        let heartbeat = {
            let (remote, held, record) = (remote.clone(), held.clone(), record.clone());
            tokio::spawn(async move {
                loop {
                    tokio::time::sleep(lease_for / 4).await;
                    let leases: Vec<LeaseRef> = held.lock().unwrap().iter().cloned().collect();
                    if !leases.is_empty() {
                        let started = Instant::now();
                        match remote.heartbeat(leases).await {
                            Ok(_) => record(2, started.elapsed()),
                            Err(error) => assert!(error.is_transient(), "heartbeat: {error}"),
                        }
                    }
                }
            })
        };
        let slot_tasks: Vec<_> = (0..slots)
            .map(|slot| {
                let (remote, held, done, record) =
                    (remote.clone(), held.clone(), done.clone(), record.clone());
                let (failed_calls, stop) = (failed_calls.clone(), stop.clone());
                tokio::spawn(async move {
                    let mut pace = Pace::default();
                    loop {
                        let started = Instant::now();
                        let leases = match remote.lease(pace.batch(), None).await {
                            Ok(granted) => granted.leases,
                            Err(error) if error.is_transient() => {
                                // Past its deadline in the coordinator's queue: the coordinator drops
                                // the lease unapplied, and the slot asks again, as a worker does.
                                failed_calls.fetch_add(1, Ordering::Relaxed);
                                tokio::time::sleep(RETRY).await;
                                continue;
                            }
                            Err(error) => panic!("lease: {error}"),
                        };
                        record(0, started.elapsed());
                        if leases.is_empty() {
                            if stop.load(Ordering::Relaxed) {
                                return;
                            }
                            tokio::time::sleep(RETRY).await;
                            continue;
                        }
                        held.lock()
                            .unwrap()
                            .extend(leases.iter().map(|l| l.reference()));
                        let mut completions = Vec::with_capacity(leases.len());
                        for lease in &leases {
                            // tokio rounds a sleep up to the next millisecond: a no-op job does not sleep.
                            if job_ms > 0 {
                                tokio::time::sleep(Duration::from_millis(job_ms)).await;
                            }
                            pace.observe_job(Duration::from_millis(job_ms));
                            let record = format!(r#"{{"slot":{slot},"elapsed_ms":{job_ms}}}"#);
                            completions.push(Completion {
                                job_id: lease.job_id.clone(),
                                token: lease.token,
                                core_id: Some(slot as u32),
                                records: vec![record],
                            });
                        }
                        let started = Instant::now();
                        let outcomes = loop {
                            match remote.complete(completions.clone()).await {
                                Ok(outcomes) => break outcomes,
                                Err(error) => assert!(error.is_transient(), "complete: {error}"),
                            }
                            failed_calls.fetch_add(1, Ordering::Relaxed);
                            tokio::time::sleep(RETRY).await;
                        };
                        record(1, started.elapsed());
                        let accepted = outcomes
                            .iter()
                            .filter(|o| **o == CompleteOutcome::Accepted)
                            .count();
                        let mut held = held.lock().unwrap();
                        leases.iter().for_each(|l| {
                            held.remove(&l.reference());
                        });
                        done.fetch_add(accepted as u64, Ordering::Relaxed);
                    }
                })
            })
            .collect();
        for task in slot_tasks {
            task.await.unwrap();
        }
        heartbeat.abort();
        progress.abort();
        println!("progress {}", done.load(Ordering::Relaxed));
        println!("failed {}", failed_calls.load(Ordering::Relaxed));
        for (rpc, histogram) in latencies.lock().unwrap().iter().enumerate() {
            let counts: Vec<String> = histogram.counts.iter().map(u64::to_string).collect();
            println!("latency {rpc} {}", counts.join(","));
        }
        println!("finished");
    });
}

// ---------------------------------------------------------------------------------------------
// The driver.

/// A memory figure of the coordinator (see [`rss_kib`]) in MB.
fn rss_mb(pid: u32, field: &str) -> f64 {
    rss_kib(pid, field) as f64 / 1024.0
}

/// What the driver learns from one client's stdout.
#[derive(Default)]
struct Report {
    done: AtomicU64,
    /// Calls that failed (past their deadline) and were made again.
    failed: AtomicU64,
    latencies: Mutex<Vec<Histogram>>,
}

fn main() {
    if let Ok(url) = std::env::var(CLIENT_ENV) {
        let s = settings();
        let id = std::env::var("SWEEP_CLUSTER_ID")
            .ok()
            .and_then(|i| i.parse().ok())
            .unwrap_or(0);
        return client(url, id, s.slots, s.job_ms);
    }
    let s = settings();
    let dir = tempfile::tempdir().unwrap();
    let token = dir.path().join("token");
    std::fs::write(&token, TOKEN).unwrap();
    let db = dir.path().join("cluster.db");
    let mut coordinator = Command::new(SWEEP)
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
        .env("RUST_LOG", "info")
        .env("NO_COLOR", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let coordinator_log = {
        let stderr = BufReader::new(coordinator.stderr.take().unwrap());
        std::thread::spawn(move || {
            stderr
                .lines()
                .map_while(Result::ok)
                .collect::<Vec<String>>()
        })
    };
    let mut line = String::new();
    BufReader::new(coordinator.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let url = format!("http://{}", line.trim().trim_start_matches("listening on "));
    let coordinator = Proc(coordinator);
    let pid = coordinator.0.id();
    println!(
        "{} no-op jobs; coordinator + {} client processes × {} slots on loopback; jobs of {} ms (paced: {} per lease)",
        s.jobs,
        s.clients,
        s.slots,
        s.job_ms,
        {
            let mut pace = Pace::default();
            pace.observe_job(Duration::from_millis(s.job_ms));
            pace.batch()
        }
    );

    let plan = dir.path().join("plan.toml");
    std::fs::write(
        &plan,
        format!(
            "name = \"cluster\"\n[[noop]]\ncount = {}\nduration_ms = {}\n",
            s.jobs, s.job_ms
        ),
    )
    .unwrap();
    let started = Instant::now();
    let submitted = Command::new(SWEEP)
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
    println!(
        "submit: {:.1} s; coordinator RSS after submit {:.0} MB (peak {:.0} MB)",
        started.elapsed().as_secs_f64(),
        rss_mb(pid, "VmRSS:"),
        rss_mb(pid, "VmHWM:")
    );

    let exe = std::env::current_exe().unwrap();
    let reports: Vec<Arc<Report>> = (0..s.clients).map(|_| Arc::default()).collect();
    let started = Instant::now();
    let clients: Vec<Proc> = reports
        .iter()
        .enumerate()
        .map(|(id, report)| {
            let mut child = Command::new(&exe)
                .args([format!("slots={}", s.slots), format!("job_ms={}", s.job_ms)])
                .env(CLIENT_ENV, &url)
                .env("SWEEP_CLUSTER_ID", id.to_string())
                .stdin(Stdio::piped())
                .stdout(Stdio::piped())
                .spawn()
                .unwrap();
            let stdout = child.stdout.take().unwrap();
            let report = report.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                    if let Some(done) = line.strip_prefix("progress ") {
                        report.done.store(done.parse().unwrap(), Ordering::Relaxed);
                    } else if let Some(failed) = line.strip_prefix("failed ") {
                        report
                            .failed
                            .store(failed.parse().unwrap(), Ordering::Relaxed);
                    } else if let Some(rest) = line.strip_prefix("latency ") {
                        let (rpc, counts) = rest.split_once(' ').unwrap();
                        let counts = counts
                            .split(',')
                            .filter(|c| !c.is_empty())
                            .map(|c| c.parse().unwrap())
                            .collect();
                        let mut latencies = report.latencies.lock().unwrap();
                        latencies.resize(RPCS.len(), Histogram::default());
                        latencies[rpc.parse::<usize>().unwrap()] = Histogram { counts };
                    }
                }
            });
            Proc(child)
        })
        .collect();

    // (seconds since the clients started, jobs done, coordinator RSS in MB)
    let mut samples: Vec<(f64, u64, f64)> = Vec::new();
    let mut clients = clients;
    loop {
        std::thread::sleep(Duration::from_millis(500));
        let done: u64 = reports.iter().map(|r| r.done.load(Ordering::Relaxed)).sum();
        samples.push((started.elapsed().as_secs_f64(), done, rss_mb(pid, "VmRSS:")));
        if samples.len().is_multiple_of(10) {
            let (t, done, rss) = samples[samples.len() - 1];
            eprintln!("{t:.0} s: {done} jobs done, coordinator RSS {rss:.0} MB");
        }
        if done >= s.jobs {
            // Every job is done: the clients' slots stop at their next empty lease.
            clients.iter_mut().for_each(|c| drop(c.0.stdin.take()));
        }
        let running = clients
            .iter_mut()
            .map(|c| c.0.try_wait())
            .filter(|exit| matches!(exit, Ok(None)))
            .count();
        if running == 0 {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(3600),
            "stalled at {done}"
        );
    }
    std::thread::sleep(Duration::from_millis(200)); // the readers take the last lines
    drop(clients);
    let done: u64 = reports.iter().map(|r| r.done.load(Ordering::Relaxed)).sum();
    assert_eq!(done, s.jobs, "results accepted by the coordinator");

    let crossing = |fraction: f64| {
        samples
            .iter()
            .find(|(_, d, _)| *d as f64 >= fraction * s.jobs as f64)
            .copied()
            .unwrap_or_default()
    };
    let (t10, d10, _) = crossing(0.1);
    let (t90, d90, _) = crossing(0.9);
    let sustained = if t90 > t10 {
        format!("{:.0}/s", (d90 - d10) as f64 / (t90 - t10))
    } else {
        "too short to tell".to_string()
    };
    println!(
        "completions: {sustained} sustained (10 % → 90 % of the jobs), {:.0}/s overall ({:.1} s)",
        s.jobs as f64 / samples.last().map_or(f64::NAN, |l| l.0),
        samples.last().map_or(f64::NAN, |l| l.0),
    );
    for (rpc, name) in RPCS.iter().enumerate() {
        let mut all = Histogram::default();
        for report in &reports {
            if let Some(h) = report.latencies.lock().unwrap().get(rpc) {
                all.merge(h);
            }
        }
        if all.total() > 0 {
            println!(
                "{name:>9}: {:>8} calls, p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
                all.total(),
                all.quantile_ms(0.5),
                all.quantile_ms(0.99),
                all.quantile_ms(1.0)
            );
        }
    }
    let failed: u64 = reports
        .iter()
        .map(|r| r.failed.load(Ordering::Relaxed))
        .sum();
    println!("calls that failed (deadline) and were made again: {failed}");
    let rss: Vec<String> = [0.1, 0.25, 0.5, 0.75, 1.0]
        .iter()
        .map(|&f| format!("{:.0}", crossing(f).2))
        .collect();
    println!(
        "coordinator RSS (MB) at 10/25/50/75/100 % done: {}; peak {:.0} MB",
        rss.join(" / "),
        rss_mb(pid, "VmHWM:")
    );
    // SIGTERM: the coordinator logs how its writes were grouped, then exits.
    let _ = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status();
    let mut coordinator = coordinator;
    let _ = coordinator.0.wait();
    for line in coordinator_log.join().unwrap_or_default() {
        if line.contains("database writes") || line.contains("ERROR") {
            println!("coordinator: {line}");
        }
    }
}
