//! End to end: a real coordinator and real workers, separate processes on loopback (port 0, so
//! the OS picks free ports), driven by the `sweep` CLI as a user would. Processes are killed with
//! SIGKILL to check that nothing is lost or counted twice.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const SWEEP: &str = env!("CARGO_BIN_EXE_sweep");

/// A child process killed when dropped, so a failing test leaves nothing running.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Proc {
    fn kill9(&mut self) {
        self.0.kill().expect("SIGKILL");
        self.0.wait().expect("reaped");
    }
}

struct Cluster {
    dir: tempfile::TempDir,
    db: PathBuf,
    token_file: PathBuf,
}

impl Cluster {
    fn new() -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        let token_file = dir.path().join("token");
        std::fs::write(&token_file, "e2e-secret-token\n").unwrap();
        let db = dir.path().join("campaign.db");
        Cluster {
            dir,
            db,
            token_file,
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn token(&self) -> &str {
        self.token_file.to_str().unwrap()
    }

    /// Starts a coordinator on `listen` and returns it with its URL, read from its stdout.
    fn coordinator(&self, listen: &str) -> (Proc, String) {
        self.coordinator_with(listen, &[])
    }

    /// `extra` may override the short default lease (1 s, so killed workers are noticed quickly).
    fn coordinator_with(&self, listen: &str, extra: &[&str]) -> (Proc, String) {
        let lease: &[&str] = if extra.contains(&"--lease-secs") {
            &[]
        } else {
            &["--lease-secs", "1"]
        };
        let mut child = Command::new(SWEEP)
            .args([
                "coordinator",
                "--listen",
                listen,
                "--db",
                self.db.to_str().unwrap(),
            ])
            .args(["--token-file", self.token(), "--max-attempts", "5"])
            .args(lease)
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let addr = line
            .trim()
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("unexpected: {line:?}"))
            .to_string();
        (Proc(child), format!("http://{addr}"))
    }

    fn worker(&self, url: &str, core: &str, token_file: Option<&str>) -> Proc {
        self.worker_with(url, core, token_file, &[])
    }

    fn worker_with(&self, url: &str, core: &str, token_file: Option<&str>, extra: &[&str]) -> Proc {
        let mut cmd = Command::new(SWEEP);
        cmd.args(["worker", "--coordinator", url, "--cores", core])
            .args(extra)
            .env_remove("SWEEP_TOKEN");
        if let Some(token) = token_file {
            cmd.args(["--token-file", token]);
        }
        Proc(
            cmd.stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap(),
        )
    }

    fn sweep(&self, args: &[&str]) -> Output {
        Command::new(SWEEP)
            .args(args)
            .env_remove("SWEEP_TOKEN")
            .output()
            .unwrap()
    }

    fn plan(&self, name: &str, text: &str) -> String {
        let path = self.path(name);
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    }

    fn submit(&self, url: &str, plan: &str) -> serde_json::Value {
        let out = self.sweep(&[
            "submit",
            plan,
            "--coordinator",
            url,
            "--token-file",
            self.token(),
            "--format",
            "json",
        ]);
        assert!(
            out.status.success(),
            "submit: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    }

    fn status(&self, url: &str) -> serde_json::Value {
        let out = self.sweep(&[
            "status",
            "--coordinator",
            url,
            "--token-file",
            self.token(),
            "--format",
            "json",
        ]);
        assert!(
            out.status.success(),
            "status: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()["status"].clone()
    }

    fn wait_done(&self, url: &str, total: u64, within: Duration) {
        let started = Instant::now();
        loop {
            let status = self.status(url);
            if status["done"] == total {
                return;
            }
            assert!(
                started.elapsed() < within,
                "not done in {within:?}: {status}"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// The workers the coordinator lists, once at least one has registered.
    fn registered_workers(&self, url: &str) -> Vec<serde_json::Value> {
        let started = Instant::now();
        loop {
            let out = self.sweep(&[
                "workers",
                "--coordinator",
                url,
                "--token-file",
                self.token(),
                "--format",
                "json",
            ]);
            assert!(out.status.success());
            let workers: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
            if !workers.is_empty() {
                return workers;
            }
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "no worker registered"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Result rows per job id, read from the database (read-only, while the coordinator runs).
    fn rows_per_job(&self) -> HashMap<String, usize> {
        let out = self.sweep(&[
            "export",
            "--db",
            self.db.to_str().unwrap(),
            "--format",
            "json",
        ]);
        assert!(
            out.status.success(),
            "export: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
        let mut counts = HashMap::new();
        for row in rows {
            *counts
                .entry(row["job_id"].as_str().unwrap().to_string())
                .or_default() += 1;
        }
        counts
    }
}

impl Cluster {
    /// The first column of the first row of a read-only query, as an integer.
    fn count(&self, sql: &str) -> u64 {
        let out = self.sweep(&[
            "query",
            sql,
            "--db",
            self.db.to_str().unwrap(),
            "--format",
            "json",
        ]);
        assert!(
            out.status.success(),
            "query: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let rows: Vec<serde_json::Map<String, serde_json::Value>> =
            serde_json::from_slice(&out.stdout).unwrap();
        rows[0]
            .values()
            .next()
            .and_then(serde_json::Value::as_u64)
            .unwrap()
    }
}

fn noop_plan(count: u32, duration_ms: u32) -> String {
    format!("name = \"e2e\"\n[[noop]]\ncount = {count}\nduration_ms = {duration_ms}\n")
}

fn assert_exactly_once(cluster: &Cluster, total: usize) {
    let rows = cluster.rows_per_job();
    assert_eq!(rows.len(), total, "jobs with results");
    assert!(
        rows.values().all(|&n| n == 1),
        "a job has several result rows: {rows:?}"
    );
}

#[test]
fn two_workers_run_a_campaign_to_completion() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator("127.0.0.1:0");
    let _a = cluster.worker(&url, "0", Some(cluster.token()));
    let _b = cluster.worker(&url, "1", Some(cluster.token()));
    let submitted = cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(200, 2)));
    assert_eq!(submitted["new_jobs"], 200);
    cluster.wait_done(&url, 200, Duration::from_secs(60));
    assert_exactly_once(&cluster, 200);
    let again = cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(200, 2)));
    assert_eq!(again["new_jobs"], 0, "resubmission scheduled work");
}

#[test]
fn a_worker_killed_mid_job_loses_nothing() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator("127.0.0.1:0");
    let mut doomed = cluster.worker(&url, "0", Some(cluster.token()));
    cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(30, 150)));
    // Let the doomed worker take jobs, then kill it while it holds one.
    let started = Instant::now();
    while cluster.status(&url)["done"].as_u64().unwrap() < 3 {
        assert!(started.elapsed() < Duration::from_secs(30), "no progress");
        std::thread::sleep(Duration::from_millis(50));
    }
    doomed.kill9();
    let _survivor = cluster.worker(&url, "1", Some(cluster.token()));
    cluster.wait_done(&url, 30, Duration::from_secs(60));
    assert_exactly_once(&cluster, 30);
}

#[test]
fn a_coordinator_killed_mid_campaign_resumes_from_its_database() {
    let cluster = Cluster::new();
    let (mut coordinator, url) = cluster.coordinator("127.0.0.1:0");
    let addr = url.trim_start_matches("http://").to_string();
    let _a = cluster.worker(&url, "0", Some(cluster.token()));
    let _b = cluster.worker(&url, "1", Some(cluster.token()));
    cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(60, 50)));
    let started = Instant::now();
    while cluster.status(&url)["done"].as_u64().unwrap() < 10 {
        assert!(started.elapsed() < Duration::from_secs(30), "no progress");
        std::thread::sleep(Duration::from_millis(50));
    }
    coordinator.kill9();
    std::thread::sleep(Duration::from_millis(500));
    // Same database, same address: the workers reconnect by themselves.
    let (_restarted, url2) = cluster.coordinator(&addr);
    assert_eq!(url, url2);
    cluster.wait_done(&url, 60, Duration::from_secs(90));
    assert_exactly_once(&cluster, 60);
}

#[test]
fn workers_without_the_right_token_are_refused_and_run_nothing() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator("127.0.0.1:0");
    cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(5, 0)));
    let wrong = cluster.path("wrong");
    std::fs::write(&wrong, "not-the-token").unwrap();
    for token in [Some(wrong.to_str().unwrap()), None] {
        let worker = cluster.worker(&url, "0", token);
        let out = worker_output(worker, Duration::from_secs(20));
        assert!(
            !out.status.success(),
            "a worker with token {token:?} kept running"
        );
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("refused"),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert_eq!(cluster.status(&url)["done"], 0);
    assert!(cluster.rows_per_job().is_empty());
    // An admin call without the token is refused too.
    let out = cluster.sweep(&["status", "--coordinator", &url]);
    assert!(!out.status.success());
}

/// Waits for a worker to exit by itself (it should, when refused).
fn worker_output(mut worker: Proc, within: Duration) -> Output {
    let started = Instant::now();
    while worker.0.try_wait().unwrap().is_none() {
        assert!(started.elapsed() < within, "the worker did not exit");
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut stderr = String::new();
    if let Some(pipe) = worker.0.stderr.take() {
        let _ = std::io::Read::read_to_string(&mut BufReader::new(pipe), &mut stderr);
    }
    Output {
        status: worker.0.wait().unwrap(),
        stdout: Vec::new(),
        stderr: stderr.into_bytes(),
    }
}

#[test]
fn a_bad_plan_is_refused_remotely_with_the_local_message_and_writes_nothing() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator("127.0.0.1:0");
    let plan = cluster.plan(
        "bad.toml",
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nacceptance = 1.5\n",
    );
    let local = cluster.sweep(&["plan", &plan]);
    let remote = cluster.sweep(&[
        "submit",
        &plan,
        "--coordinator",
        &url,
        "--token-file",
        cluster.token(),
    ]);
    assert!(!local.status.success() && !remote.status.success());
    let (local, remote) = (
        String::from_utf8_lossy(&local.stderr),
        String::from_utf8_lossy(&remote.stderr),
    );
    assert!(local.contains("acceptance"), "{local}");
    assert_eq!(
        local, remote,
        "the remote refusal differs from the local one"
    );
    assert_eq!(
        cluster.status(&url)["total"],
        0,
        "a refused plan left jobs behind"
    );
}

#[test]
fn a_coordinator_will_not_listen_off_loopback_without_a_token() {
    let cluster = Cluster::new();
    let out = cluster.sweep(&[
        "coordinator",
        "--listen",
        "0.0.0.0:0",
        "--db",
        cluster.db.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("token"));
    assert!(
        !Path::new(&cluster.db).exists(),
        "the database was created anyway"
    );
}

/// `--slurm-alloc`: a bad allocation file, or no sbatch to submit with, is refused in one line
/// naming the file, line and key (or the command), before the database is created.
#[test]
fn a_bad_allocation_file_or_a_missing_sbatch_is_refused_before_anything_is_written() {
    let cluster = Cluster::new();
    let coordinator = |alloc: &str, path: &str| {
        Command::new(SWEEP)
            .args(["coordinator", "--listen", "127.0.0.1:0", "--db"])
            .arg(&cluster.db)
            .args(["--slurm-alloc", alloc])
            .env("PATH", path)
            .output()
            .unwrap()
    };
    let bad = cluster.plan(
        "bad-alloc.toml",
        "time_limit = \"1:00:00\"\ncores = 4\npartiton = \"short\"\n",
    );
    let out = coordinator(&bad, "/usr/bin:/bin");
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(said.lines().count(), 1, "{said}");
    assert!(
        said.contains("bad-alloc.toml:3:1: unknown field `partiton`"),
        "{said}"
    );
    let no_limit = cluster.plan("no-limit.toml", "cores = 4\ntime_limit = \"soon\"\n");
    let said =
        String::from_utf8_lossy(&coordinator(&no_limit, "/usr/bin:/bin").stderr).into_owned();
    assert!(
        said.contains("no-limit.toml:2:14: key `time_limit`: \"soon\" is not a Slurm time limit"),
        "{said}"
    );
    // A good file where Slurm's commands cannot be found.
    let good = cluster.plan("alloc.toml", "time_limit = \"1:00:00\"\ncores = 4\n");
    let empty = cluster.path("empty-path");
    std::fs::create_dir(&empty).unwrap();
    let out = coordinator(&good, empty.to_str().unwrap());
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        said.contains("cannot find sbatch, squeue, scancel on PATH"),
        "{said}"
    );
    assert!(!cluster.db.exists(), "the database was created anyway");
}

/// A worker whose allocation ends (`--deadline`) runs only what is expected to finish by then,
/// leaves the rest queued and stops by itself, saying why; one with nothing to do stops after
/// `--idle-timeout`. Both through a real coordinator (the time left travels in the lease call).
#[test]
fn a_worker_runs_only_what_fits_before_its_deadline_and_stops_when_idle() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator_with("127.0.0.1:0", &["--lease-secs", "10"]);
    let plan = cluster.plan(
        "mixed.toml",
        "name = \"mixed\"\n[[noop]]\ncount = 3\nduration_ms = 50\n\
         [[noop]]\ncount = 1\nduration_ms = 600000\n",
    );
    let campaign = cluster.submit(&url, &plan)["campaign"]
        .as_str()
        .unwrap()
        .to_owned();
    let deadline = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
        + 30.0;
    let worker = cluster.worker_with(
        &url,
        "0",
        Some(cluster.token()),
        &["--deadline", &deadline.to_string(), "--allocation", "4242"],
    );
    let listed = cluster.registered_workers(&url);
    assert_eq!(listed[0]["allocation"], "4242");
    let out = worker_output(worker, Duration::from_secs(60));
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(
        said.contains("stopping: the jobs at the head of the queue are expected to take longer"),
        "{said}"
    );
    let status = cluster.status(&url);
    assert_eq!(
        (status["done"].as_u64(), status["queued"].as_u64()),
        (Some(3), Some(1))
    );
    assert_eq!(
        cluster.count("SELECT count(*) FROM job_failures"),
        0,
        "the long job was never started"
    );

    // With the long job cancelled nothing is queued: a worker with an idle timeout stops.
    let cancelled = cluster.sweep(&[
        "cancel",
        &campaign,
        "--coordinator",
        &url,
        "--token-file",
        cluster.token(),
    ]);
    assert!(cancelled.status.success());
    let idle = cluster.worker_with(&url, "0", Some(cluster.token()), &["--idle-timeout", "1"]);
    let out = worker_output(idle, Duration::from_secs(60));
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("stopping: no job for"), "{said}");
}

/// TLS end to end: a CA made here, a coordinator serving its certificate, a worker and the admin
/// commands verifying it with `--ca`; a client without the CA cannot talk to it.
#[test]
fn a_campaign_runs_over_tls() {
    use rcgen::{BasicConstraints, CertificateParams, IsCa, Issuer, KeyPair};
    let cluster = Cluster::new();
    let ca_key = KeyPair::generate().unwrap();
    let mut ca_params = CertificateParams::new(Vec::<String>::new()).unwrap();
    ca_params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    let ca_cert = ca_params.self_signed(&ca_key).unwrap();
    let key = KeyPair::generate().unwrap();
    let cert = CertificateParams::new(vec!["127.0.0.1".to_string()])
        .unwrap()
        .signed_by(&key, &Issuer::new(ca_params, ca_key))
        .unwrap();
    let (ca, cert_file, key_file) = (
        cluster.path("ca.pem"),
        cluster.path("cert.pem"),
        cluster.path("key.pem"),
    );
    std::fs::write(&ca, ca_cert.pem()).unwrap();
    std::fs::write(&cert_file, cert.pem()).unwrap();
    std::fs::write(&key_file, key.serialize_pem()).unwrap();

    let (_coordinator, url) = cluster.coordinator_with(
        "127.0.0.1:0",
        &[
            "--tls-cert",
            cert_file.to_str().unwrap(),
            "--tls-key",
            key_file.to_str().unwrap(),
        ],
    );
    let url = url.replace("http://", "https://");
    let ca = ca.to_str().unwrap();
    let tls = |args: &[&str]| {
        let mut all = args.to_vec();
        all.extend([
            "--coordinator",
            &url,
            "--token-file",
            cluster.token(),
            "--ca",
            ca,
            "--format",
            "json",
        ]);
        cluster.sweep(&all)
    };
    let plan = cluster.plan("p.toml", &noop_plan(20, 1));
    let submitted = tls(&["submit", &plan]);
    assert!(
        submitted.status.success(),
        "{}",
        String::from_utf8_lossy(&submitted.stderr)
    );
    let _worker = Proc(
        Command::new(SWEEP)
            .args([
                "worker",
                "--coordinator",
                &url,
                "--cores",
                "0",
                "--token-file",
                cluster.token(),
                "--ca",
                ca,
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let started = Instant::now();
    loop {
        let out = tls(&["status"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        if status["status"]["done"] == 20 {
            break;
        }
        assert!(started.elapsed() < Duration::from_secs(60), "{status}");
        std::thread::sleep(Duration::from_millis(100));
    }
    assert_exactly_once(&cluster, 20);
    // Without the CA the certificate is not trusted; over plain HTTP/2 the TLS server does not answer.
    let untrusted = cluster.sweep(&[
        "status",
        "--coordinator",
        &url,
        "--token-file",
        cluster.token(),
    ]);
    assert!(!untrusted.status.success());
}

/// SIGTERM: the worker finishes the job in hand, returns its unstarted leases at once (no wait
/// for expiry, no attempt counted) and exits cleanly.
#[test]
fn a_terminated_worker_finishes_its_job_and_returns_the_rest() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator_with("127.0.0.1:0", &["--lease-secs", "60"]);
    cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(10, 300)));
    let mut worker =
        cluster.worker_with(&url, "0", Some(cluster.token()), &["--lease-batch", "10"]);
    let started = Instant::now();
    while cluster.status(&url)["running"].as_u64().unwrap() < 10 {
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "never leased the batch"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(400));
    let pid = worker.0.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-TERM", &pid])
            .status()
            .unwrap()
            .success()
    );
    let exited = Instant::now();
    let code = loop {
        if let Some(code) = worker.0.try_wait().unwrap() {
            break code;
        }
        assert!(
            exited.elapsed() < Duration::from_secs(10),
            "the worker ignored SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(code.success(), "unclean exit: {code:?}");
    // Within the 60 s lease: only a release can have put the rest back in the queue.
    let status = cluster.status(&url);
    assert_eq!(status["running"], 0, "{status}");
    let done = status["done"].as_u64().unwrap();
    assert!((1..10).contains(&done), "{status}");
    assert_eq!(status["queued"].as_u64().unwrap(), 10 - done, "{status}");
    assert_exactly_once(&cluster, done as usize);
    // The returned jobs run again, on their first counted attempt.
    let _again = cluster.worker(&url, "1", Some(cluster.token()));
    cluster.wait_done(&url, 10, Duration::from_secs(30));
    assert_exactly_once(&cluster, 10);
}

#[test]
fn cancel_stops_queued_work_and_workers_are_listed() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator("127.0.0.1:0");
    let submitted = cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(25, 0)));
    let campaign = submitted["campaign"].as_str().unwrap().to_string();
    let out = cluster.sweep(&[
        "cancel",
        &campaign,
        "--coordinator",
        &url,
        "--token-file",
        cluster.token(),
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cancelled: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(cancelled["cancelled"], 25);
    let _worker = cluster.worker(&url, "0", Some(cluster.token()));
    let listed = cluster.registered_workers(&url);
    assert_eq!(listed.len(), 1);
    assert_eq!(listed[0]["cores"], serde_json::json!([0]));
    assert!(
        !listed[0]["cpu_model"].as_str().unwrap().is_empty(),
        "provenance missing"
    );
    std::thread::sleep(Duration::from_millis(500));
    let status = cluster.status(&url);
    assert_eq!(
        (status["cancelled"].as_u64(), status["done"].as_u64()),
        (Some(25), Some(0)),
        "{status}"
    );
    assert!(cluster.rows_per_job().is_empty(), "a cancelled job ran");
}

/// `--core-count N` (what the Slurm and Kubernetes recipes pass) takes the first N cores of the
/// worker's affinity mask, and asking for more than the mask holds is a one-line error.
#[test]
fn a_core_count_takes_the_first_cores_of_the_affinity_mask() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator("127.0.0.1:0");
    let spawn = |count: &str| {
        let mut cmd = Command::new(SWEEP);
        cmd.args([
            "worker",
            "--coordinator",
            &url,
            "--token-file",
            cluster.token(),
            "--core-count",
            count,
        ]);
        Proc(
            cmd.env_remove("SWEEP_TOKEN")
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap(),
        )
    };
    let mask: Vec<usize> = core_affinity::get_core_ids()
        .unwrap()
        .into_iter()
        .map(|c| c.id)
        .collect();
    let _worker = spawn("1");
    let listed = cluster.registered_workers(&url);
    assert_eq!(listed[0]["cores"], serde_json::json!([mask[0]]));

    let too_many = (mask.len() + 1).to_string();
    let out = worker_output(spawn(&too_many), Duration::from_secs(20));
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with(&format!(
            "error: --core-count {too_many}: only {} cores",
            mask.len()
        )),
        "{stderr}"
    );
}

/// An EDMD sweep goes through a coordinator and a worker like any plan, and the figures and the
/// accuracy report read its results from the coordinator's database.
#[test]
fn an_edmd_sweep_through_a_coordinator_feeds_the_edmd_reports() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator_with("127.0.0.1:0", &["--lease-secs", "30"]);
    let _worker = cluster.worker(&url, "0", Some(cluster.token()));
    let plan = "name = \"edmd-e2e\"\n[[edmd]]\nshape = \"ellipsoid\"\nn = 64\nphi = 0.3\nx0 = 2.0\nneighbours = \"nnl\"\n\
                delta_nnl = [0.02, 0.06, 0.2]\ncollisions = 400\nequilibrate = 40\n\n\
                [[edmd]]\nshape = \"ellipsoid\"\nn = 64\nphi = 0.3\nx0 = 2.0\nneighbours = \"nnl\"\ndelta_nnl = 0.06\n\
                eps_d = [1e-6, 1e-4]\ncollisions = 400\nequilibrate = 40\n";
    let submitted = cluster.submit(&url, &cluster.plan("edmd.toml", plan));
    assert_eq!(submitted["new_jobs"], 5);
    cluster.wait_done(&url, 5, Duration::from_secs(120));
    let db = cluster.db.to_str().unwrap();
    let out = cluster.sweep(&[
        "report",
        "fig10",
        "--db",
        db,
        "--length-unit",
        "sigma",
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "fig10: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let fig10: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let xs: Vec<f64> = fig10["curves"][0]["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["x"].as_f64().unwrap())
        .collect();
    assert_eq!(xs, vec![0.02, 0.06, 0.2], "{fig10}");
    assert!(
        fig10["curves"][0]["minimum"]["x"].as_f64().is_some(),
        "{fig10}"
    );
    let out = cluster.sweep(&["report", "accuracy", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "accuracy: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(study["knobs"][0]["knob"], "eps_d", "{study}");
    let values: Vec<f64> = study["knobs"][0]["settings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["value"].as_f64().unwrap())
        .collect();
    assert_eq!(values, vec![1e-6, 1e-5, 1e-4], "tightest first: {study}");
}

/// Timing jobs (longer than the workers' 100 ms pacing window) are leased one at a time: no slot
/// ever holds a second lease, so no job waits on a busy worker while another slot idles. Checked
/// while running (never more running jobs than slots) and afterwards from the leases' times (no
/// two leases of one single-slot worker overlap).
#[test]
fn long_jobs_run_one_per_slot_at_a_time() {
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator_with("127.0.0.1:0", &["--lease-secs", "5"]);
    let _a = cluster.worker(&url, "0", Some(cluster.token()));
    let _b = cluster.worker(&url, "1", Some(cluster.token()));
    cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(12, 250)));
    let started = Instant::now();
    loop {
        let status = cluster.status(&url);
        assert!(
            status["running"].as_u64().unwrap() <= 2,
            "more jobs running than slots: {status}"
        );
        if status["done"] == 12 {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "not done: {status}"
        );
        std::thread::sleep(Duration::from_millis(30));
    }
    assert_exactly_once(&cluster, 12);
    let overlapping = cluster.count(
        "SELECT count(*) FROM jobs AS a JOIN jobs AS b ON a.lease_owner = b.lease_owner AND a.id < b.id
         WHERE a.started_at < b.finished_at AND b.started_at < a.finished_at",
    );
    assert_eq!(
        overlapping, 0,
        "a single-slot worker held two leases at once"
    );
    assert_eq!(
        cluster.count("SELECT count(*) FROM jobs WHERE attempts <> 1"),
        0
    );
}

/// kill -9 of a worker holding hundreds of leases (no-op jobs: its paced leases are large, and
/// the next one is prefetched): every job it held comes back after its lease expires, and every
/// job is done exactly once.
#[test]
fn a_worker_killed_holding_a_large_adaptive_lease_loses_nothing() {
    const JOBS: u64 = 20_000;
    let cluster = Cluster::new();
    let (_coordinator, url) = cluster.coordinator("127.0.0.1:0");
    cluster.submit(&url, &cluster.plan("p.toml", &noop_plan(JOBS as u32, 0)));
    let mut doomed = cluster.worker(&url, "0", Some(cluster.token()));
    let started = Instant::now();
    while cluster.status(&url)["done"].as_u64().unwrap() < 1_000 {
        assert!(started.elapsed() < Duration::from_secs(60), "no progress");
        std::thread::sleep(Duration::from_millis(20));
    }
    doomed.kill9();
    let status = cluster.status(&url);
    let (held, done) = (
        status["running"].as_u64().unwrap(),
        status["done"].as_u64().unwrap(),
    );
    assert!(held >= 100, "the killed worker held only {held} leases");
    let _survivor = cluster.worker(&url, "1", Some(cluster.token()));
    cluster.wait_done(&url, JOBS, Duration::from_secs(120));
    assert_exactly_once(&cluster, JOBS as usize);
    // A report the killed worker had already sent may land after the snapshot: those jobs were
    // held but are done, not lost.
    let reported_late = cluster.count("SELECT count(*) FROM results WHERE core_id = 0") - done;
    let lost = held - reported_late;
    let re_leased = cluster.count("SELECT count(*) FROM jobs WHERE attempts >= 2");
    assert!(
        re_leased >= lost,
        "{lost} leases lost with the worker, {re_leased} jobs leased again"
    );
}

/// One HTTP/1.1 request on a fresh connection to the status page: (status, head, body).
fn http(
    addr: &str,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &str,
) -> (u16, String, String) {
    use std::io::{Read, Write};
    let mut stream = std::net::TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let mut request = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Length: {}\r\n",
        body.len()
    );
    for (k, v) in headers {
        request.push_str(&format!("{k}: {v}\r\n"));
    }
    request.push_str("\r\n");
    request.push_str(body);
    stream.write_all(request.as_bytes()).unwrap();
    let mut response = String::new();
    stream.read_to_string(&mut response).unwrap();
    let (head, body) = response.split_once("\r\n\r\n").unwrap_or((&response, ""));
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    (status, head.to_string(), body.to_string())
}

fn http_json(addr: &str, path: &str) -> serde_json::Value {
    let (status, _, body) = http(addr, "GET", path, &[], "");
    assert_eq!(status, 200, "GET {path}: {body}");
    serde_json::from_str(&body).unwrap_or_else(|e| panic!("GET {path}: {e}: {body}"))
}

/// A coordinator with `--http`: its gRPC URL and the page's address, both read from its stdout.
fn coordinator_with_page(
    cluster: &Cluster,
    http_listen: &str,
    token: bool,
) -> (Proc, String, String) {
    let mut cmd = Command::new(SWEEP);
    cmd.args([
        "coordinator",
        "--listen",
        "127.0.0.1:0",
        "--db",
        cluster.db.to_str().unwrap(),
    ])
    .args([
        "--lease-secs",
        "4",
        "--max-attempts",
        "2",
        "--http",
        http_listen,
    ])
    .env_remove("SWEEP_TOKEN");
    if token {
        cmd.args(["--token-file", cluster.token()]);
    }
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let mut next = || lines.next().expect("a line").unwrap();
    let grpc = next()
        .strip_prefix("listening on ")
        .expect("listening on …")
        .to_string();
    let page = next();
    let page = page
        .strip_prefix("status page on http://")
        .unwrap_or_else(|| panic!("{page:?}"))
        .trim_end_matches('/')
        .to_string();
    (Proc(child), format!("http://{grpc}"), page)
}

/// The status page of a coordinator with two workers shows what the store holds: the counts of
/// `sweep status`, the workers of `sweep workers`, every failed attempt with its worker, and
/// Table 1 / Fig. 2 exactly as `sweep report` makes them. Unauthenticated, it cancels nothing;
/// with the token (the login form's cookie) it cancels.
#[test]
fn the_status_page_shows_the_campaign_as_the_store_has_it() {
    let cluster = Cluster::new();
    let db = cluster.db.to_str().unwrap().to_string();
    let (_coordinator, url, page) = coordinator_with_page(&cluster, "127.0.0.1:0", true);
    let (status, head, body) = http(&page, "GET", "/", &[], "");
    assert_eq!(status, 200, "{head}");
    assert!(
        body.contains("<title>sweep: status</title>") && body.contains("src=\"/page.js\""),
        "{body}"
    );
    assert!(
        !body.contains("http://") && !body.contains("https://"),
        "the page fetches nothing from elsewhere"
    );
    let (status, _, script) = http(&page, "GET", "/page.js", &[], "");
    assert_eq!(status, 200);
    assert!(script.contains("/api/snapshot") && !script.contains("https://"));

    let plan = "name = \"page\"\n\
        [[noop]]\ncount = 16\nduration_ms = 50\n\
        [[noop]]\ncount = 2\nduration_ms = 0\nfail_rate = 1.0\n\
        [[overlap]]\nl_star = [1, 2]\nw_star = 1\nr_star = 0.5\nacceptance = 0.4\nconfigurations = 20_000\nrepeats = 1\nprecision = \"f32\"\n\
        algorithms = [\"arvo\", \"qri\", \"qrf\", \"sse\", \"ocsi\", \"ocsi_batch\"]\n";
    let submitted = cluster.submit(&url, &cluster.plan("page.toml", plan));
    let id = submitted["campaign"].as_str().unwrap().to_string();
    let total = 20;

    // No workers yet: a cancel without the token, or with a wrong one, changes nothing.
    let store_status = |campaign: &str| -> serde_json::Value {
        let out = cluster.sweep(&[
            "status",
            "--db",
            &db,
            "--campaign",
            campaign,
            "--format",
            "json",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let before = store_status(&id);
    let cancel = format!("/api/campaigns/{id}/cancel");
    for headers in [
        &[][..],
        &[("Authorization", "Bearer wrong-token")][..],
        &[("Cookie", "sweep_session=abc")][..],
    ] {
        let (status, _, body) = http(&page, "POST", &cancel, headers, "");
        assert_eq!(status, 401, "{headers:?}: {body}");
    }
    assert_eq!(
        http(&page, "GET", &cancel, &[], "").0,
        405,
        "a GET changes nothing either"
    );
    let after = store_status(&id);
    assert_eq!(after, before, "nothing changed");
    assert_eq!(after["status"]["queued"], total);

    let _w0 = cluster.worker(&url, "0", Some(cluster.token()));
    let _w1 = cluster.worker(&url, "1", Some(cluster.token()));
    let started = Instant::now();
    loop {
        let s = cluster.status(&url);
        if s["done"].as_u64().unwrap() + s["failed"].as_u64().unwrap() == total {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "not finished: {s}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    // The page samples every second or so: wait for it to see the end.
    let started = Instant::now();
    let campaigns = loop {
        let campaigns = http_json(&page, "/api/campaigns");
        if campaigns[0]["progress"] == 1.0 && campaigns[0]["status"]["running"] == 0 {
            break campaigns;
        }
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the page never reached 100 %: {campaigns}"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    let expected = store_status(&id);
    let shown = &campaigns.as_array().unwrap()[0];
    assert_eq!(campaigns.as_array().unwrap().len(), 1);
    assert_eq!(shown["campaign"], expected["campaign"]);
    assert_eq!(
        shown["status"], expected["status"],
        "the counts of `sweep status --format json`"
    );
    assert_eq!(shown["timing"], expected["timing"]);
    assert_eq!(shown["status"]["done"], 18);
    assert_eq!(shown["status"]["failed"], 2);
    assert_eq!(shown["remaining_s"], 0.0);

    // Workers: the fields of `sweep workers --format json`, and what each did.
    let listed = cluster.registered_workers(&url);
    let workers = http_json(&page, "/api/workers");
    let workers = workers.as_array().unwrap();
    assert_eq!(workers.len(), 2);
    for expected in &listed {
        let shown = workers
            .iter()
            .find(|w| w["id"] == expected["id"])
            .expect("every worker is listed");
        for (key, value) in expected.as_object().unwrap() {
            if key != "last_seen_at" {
                assert_eq!(&shown[key], value, "worker field {key}");
            }
        }
        assert!(shown["heartbeat_age_s"].as_f64().unwrap() < 4.0, "{shown}");
        assert_eq!(shown["stale"], false);
        assert!(!shown["cpu_model"].as_str().unwrap().is_empty());
    }
    let done_by_workers: u64 = workers
        .iter()
        .map(|w| w["jobs_done"].as_u64().unwrap())
        .sum();
    assert_eq!(done_by_workers, 18, "every done job is some worker's");

    // Failures: both attempts of both failing jobs, each with its worker and reason.
    let failures = http_json(&page, "/api/failures");
    let failures = failures.as_array().unwrap();
    assert_eq!(
        failures.len() as u64,
        cluster.count("SELECT count(*) FROM job_failures")
    );
    assert_eq!(failures.len(), 4, "{failures:?}");
    for f in failures {
        assert!(listed.iter().any(|w| w["id"] == f["worker"]), "{f}");
        assert!(
            f["reason"].as_str().unwrap().contains("injected failure"),
            "{f}"
        );
    }

    // Figures: what `sweep report` writes, byte for byte.
    let figures = http_json(&page, "/api/figures");
    let names: Vec<&str> = figures
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["table1", "fig2"]);
    // The no-op jobs have no figure, and the page says so.
    let snapshot = http_json(&page, "/api/snapshot");
    let absent = snapshot["figures_absent"].as_array().unwrap();
    assert_eq!(absent.len(), 1, "{absent:?}");
    assert!(
        absent[0]
            .as_str()
            .unwrap()
            .starts_with("no figure for no-op jobs ("),
        "{absent:?}"
    );
    let (status, head, svg) = http(&page, "GET", "/api/figures/fig2.svg", &[], "");
    assert_eq!(status, 200, "{svg}");
    assert!(
        head.to_ascii_lowercase()
            .contains("content-type: image/svg+xml"),
        "{head}"
    );
    assert!(
        svg.trim_start().starts_with("<svg"),
        "{}",
        &svg[..svg.len().min(200)]
    );
    let out_svg = cluster.path("fig2.svg");
    let out = cluster.sweep(&[
        "report",
        "fig2",
        "--db",
        &db,
        "--out",
        out_svg.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read_to_string(&out_svg).unwrap() == svg,
        "the page's Fig. 2 is `sweep report fig2`'s"
    );
    let table = http_json(&page, "/api/tables/table1.json");
    let out = cluster.sweep(&["report", "table1", "--db", &db, "--format", "json"]);
    assert_eq!(
        table,
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    );
    assert_eq!(
        table.as_array().unwrap().len(),
        6,
        "one row per algorithm at one R*"
    );

    // With the token (the login form's cookie), a cancel works: a second campaign, long jobs.
    let second = cluster.submit(
        &url,
        &cluster.plan(
            "long.toml",
            "name = \"long\"\n[[noop]]\ncount = 30\nduration_ms = 400\n",
        ),
    );
    let second = second["campaign"].as_str().unwrap().to_string();
    let (status, head, _) = http(
        &page,
        "POST",
        "/login",
        &[("Content-Type", "application/x-www-form-urlencoded")],
        "token=e2e-secret-token",
    );
    assert_eq!(status, 303, "{head}");
    let cookie = head
        .lines()
        .find_map(|l| l.strip_prefix("set-cookie: "))
        .expect("a cookie")
        .to_string();
    assert!(
        cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"),
        "{cookie}"
    );
    let session = cookie.split(';').next().unwrap();
    let (status, _, body) = http(
        &page,
        "POST",
        &format!("/api/campaigns/{second}/cancel"),
        &[("Cookie", session)],
        "",
    );
    assert_eq!(status, 200, "{body}");
    let cancelled = serde_json::from_str::<serde_json::Value>(&body).unwrap()["cancelled"]
        .as_u64()
        .unwrap();
    assert!(cancelled > 0, "{body}");
    let s = store_status(&second);
    assert_eq!(s["status"]["cancelled"], cancelled);
    assert_eq!(s["status"]["queued"], 0);
    // The bearer header works as well (nothing left to cancel).
    let (status, _, body) = http(
        &page,
        "POST",
        &format!("/api/campaigns/{second}/cancel"),
        &[("Authorization", "Bearer e2e-secret-token")],
        "",
    );
    assert_eq!(
        (status, body.contains("\"cancelled\":0")),
        (200, true),
        "{body}"
    );
}

/// A non-loopback address of this machine (the one a route to the outside would leave from), if
/// there is one. No packet is sent: connecting a UDP socket only picks a route.
fn non_loopback_address() -> Option<std::net::IpAddr> {
    let socket = std::net::UdpSocket::bind("0.0.0.0:0").ok()?;
    socket.connect("192.0.2.254:9").ok()?;
    let ip = socket.local_addr().ok()?.ip();
    (!ip.is_loopback() && !ip.is_unspecified()).then_some(ip)
}

/// Off loopback the page is refused without the token (the coordinator does not even start
/// without one), and served with it.
#[test]
fn the_status_page_off_loopback_needs_the_token() {
    let cluster = Cluster::new();
    let out = cluster.sweep(&[
        "coordinator",
        "--listen",
        "127.0.0.1:0",
        "--db",
        cluster.db.to_str().unwrap(),
        "--http",
        "0.0.0.0:0",
    ]);
    assert!(!out.status.success());
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains("--http 0.0.0.0:0") && message.contains("without a token"),
        "{message}"
    );

    let Some(ip) = non_loopback_address() else {
        eprintln!(
            "no non-loopback address on this machine: the remote-client case is covered by crates/dashboard/tests/policy.rs only"
        );
        return;
    };
    let (_coordinator, _url, page) = coordinator_with_page(&cluster, &format!("{ip}:0"), true);
    for path in [
        "/api/campaigns",
        "/api/workers",
        "/api/failures",
        "/api/snapshot",
        "/api/figures/fig2.svg",
        "/page.js",
    ] {
        let (status, _, body) = http(&page, "GET", path, &[], "");
        assert_eq!(status, 401, "GET {path}: {body}");
    }
    let (status, head, _) = http(&page, "GET", "/", &[], "");
    assert_eq!(
        status, 303,
        "the page sends a browser to the login form: {head}"
    );
    assert_eq!(http(&page, "GET", "/login", &[], "").0, 200);
    let (status, _, body) = http(
        &page,
        "GET",
        "/api/campaigns",
        &[("Authorization", "Bearer e2e-secret-token")],
        "",
    );
    assert_eq!((status, body.as_str()), (200, "[]"));
}

/// Headless Chromium on the page (`--dump-dom` for the DOM after the script ran, `--screenshot`
/// for a picture), with a fresh profile each time.
fn chromium(args: &[&str], profile: &Path) -> Output {
    let browser = std::env::var("SWEEP_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    let out = Command::new(&browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
        ])
        .args([
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        // Virtual time runs the page's polls and waits for their fetches before the DOM is taken.
        .args(["--window-size=1400,1700", "--virtual-time-budget=5000"])
        .args(args)
        .output()
        .unwrap_or_else(|e| {
            panic!("{browser}: {e} (apt-get install chromium, or set SWEEP_CHROMIUM)")
        });
    assert!(
        out.status.success(),
        "{browser}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The markup of the element carrying `data-figure="NAME"`, up to the next figure.
fn figure_markup<'a>(dom: &'a str, name: &str) -> &'a str {
    let start = dom
        .find(&format!("data-figure=\"{name}\""))
        .unwrap_or_else(|| panic!("no figure {name} in the page"));
    let rest = &dom[start..];
    let end = rest[1..].find("data-figure=").map_or(rest.len(), |i| i + 1);
    &rest[..end]
}

/// The page in a real browser during a campaign: at the start it shows partial progress, at the
/// end 100 % and Fig. 2 drawn as an inline SVG (and Table 1) as of the final done count.
/// Screenshots of both go to target/tmp/status-page/. Needs Debian's chromium; only with
/// SWEEP_BROWSER_TEST=1 (`.ci/run` installs it then). About 30 s.
#[test]
fn the_status_page_in_a_browser() {
    if std::env::var("SWEEP_BROWSER_TEST").as_deref() != Ok("1") {
        eprintln!("skipped: SWEEP_BROWSER_TEST=1 runs it (needs /usr/bin/chromium)");
        return;
    }
    let begun = Instant::now();
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("status-page");
    std::fs::create_dir_all(&shots).unwrap();
    let cluster = Cluster::new();
    let (_coordinator, url, page) = coordinator_with_page(&cluster, "127.0.0.1:0", true);
    let page_url = format!("http://{page}/");
    let plan = "name = \"browser\"\n\
        [[noop]]\ncount = 40\nduration_ms = 400\n\
        [[noop]]\ncount = 2\nduration_ms = 0\nfail_rate = 1.0\n\
        [[overlap]]\nl_star = [1, 2, 3]\nw_star = [1, 2, 3]\nr_star = 0.5\nacceptance = 0.4\nconfigurations = 20_000\nrepeats = 1\nprecision = \"f32\"\n\
        algorithms = [\"arvo\", \"qri\", \"qrf\", \"sse\", \"ocsi\", \"ocsi_batch\"]\n";
    let total = 51;
    cluster.submit(&url, &cluster.plan("browser.toml", plan));
    let _w0 = cluster.worker(&url, "0", Some(cluster.token()));
    let _w1 = cluster.worker(&url, "1", Some(cluster.token()));
    let finished =
        |s: &serde_json::Value| s["done"].as_u64().unwrap() + s["failed"].as_u64().unwrap();
    let started = Instant::now();
    while finished(&cluster.status(&url)) < 3 {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no job finished"
        );
        std::thread::sleep(Duration::from_millis(100));
    }

    let start_png = shots.join("status-page-start.png");
    let at = Instant::now();
    chromium(
        &[&format!("--screenshot={}", start_png.display()), &page_url],
        &cluster.path("profile-start"),
    );
    let start_shot_s = at.elapsed().as_secs_f64();
    let dom = String::from_utf8(
        chromium(
            &["--dump-dom", &page_url],
            &cluster.path("profile-start-dom"),
        )
        .stdout,
    )
    .unwrap();
    assert!(
        dom.contains("data-progress=\""),
        "the page shows the campaign's progress: {dom}"
    );
    assert!(
        !dom.contains("data-progress=\"100.0\""),
        "the campaign is not over yet: the start is seen"
    );

    let started = Instant::now();
    while finished(&cluster.status(&url)) < total {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "campaign not finished"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    // The page samples the store every second or so; the browser's own polls then catch up.
    let done_total = loop {
        let snapshot = http_json(&page, "/api/snapshot");
        if snapshot["campaigns"][0]["progress"] == 1.0
            && snapshot["campaigns"][0]["status"]["running"] == 0
        {
            break snapshot["done_total"].as_u64().unwrap();
        }
        assert!(
            started.elapsed() < Duration::from_secs(140),
            "the page never reached 100 %"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    let dom = String::from_utf8(
        chromium(&["--dump-dom", &page_url], &cluster.path("profile-end-dom")).stdout,
    )
    .unwrap();
    assert!(
        dom.contains("data-progress=\"100.0\""),
        "the page reached 100 %: {dom}"
    );
    let fig2 = figure_markup(&dom, "fig2");
    assert!(fig2.contains("<svg"), "Fig. 2 is drawn inline: {fig2}");
    assert!(
        fig2.contains(&format!("data-drawn-at=\"{done_total}\"")),
        "Fig. 2 as of the last job: {fig2}"
    );
    assert!(
        figure_markup(&dom, "table1").contains("ocsi_batch"),
        "Table 1 is shown"
    );
    assert!(dom.contains("injected failure"), "the failures are listed");
    let end_png = shots.join("status-page-end.png");
    chromium(
        &[&format!("--screenshot={}", end_png.display()), &page_url],
        &cluster.path("profile-end"),
    );
    for png in [&start_png, &end_png] {
        let bytes = std::fs::read(png).unwrap();
        assert!(
            bytes.starts_with(b"\x89PNG") && bytes.len() > 10_000,
            "{}",
            png.display()
        );
    }
    eprintln!(
        "browser test: screenshots {} and {}; one Chromium load {start_shot_s:.1} s; whole test {:.1} s",
        start_png.display(),
        end_png.display(),
        begun.elapsed().as_secs_f64()
    );
}

/// Program jobs run foreign code: a worker started without `--allow-commands` is never leased
/// one (it runs the campaign's other jobs while the program jobs stay queued), and one started
/// with it runs them all, each on its first attempt.
#[test]
fn only_a_worker_started_with_allow_commands_receives_program_jobs() {
    use std::os::unix::fs::PermissionsExt;
    let cluster = Cluster::new();
    let program = cluster.path("prog");
    std::fs::write(
        &program,
        "#!/bin/sh\nsleep 0.05\necho \"{\\\"n\\\": $1, \\\"core\\\": $SWEEP_CORE}\"\n",
    )
    .unwrap();
    std::fs::set_permissions(&program, std::fs::Permissions::from_mode(0o755)).unwrap();
    let plan = "name = \"commands\"\n[[noop]]\ncount = 20\nduration_ms = 20\n\n\
                [[command]]\nlabel = \"echo\"\nprogram = \"prog\"\nargs = [\"{n}\"]\nn = { from = 1, to = 10 }\n";
    let (_coordinator, url) = cluster.coordinator_with("127.0.0.1:0", &["--lease-secs", "30"]);
    let _plain = cluster.worker(&url, "0", Some(cluster.token()));
    let submitted = cluster.submit(&url, &cluster.plan("commands.toml", plan));
    assert_eq!(submitted["new_jobs"], 30);
    cluster.wait_done(&url, 20, Duration::from_secs(60));
    std::thread::sleep(Duration::from_millis(500));
    let status = cluster.status(&url);
    assert_eq!(
        (status["done"].as_u64(), status["queued"].as_u64()),
        (Some(20), Some(10)),
        "the plain worker must leave the program jobs queued: {status}"
    );
    let db = cluster.db.to_str().unwrap();
    let waiting = cluster.sweep(&["status", "--db", db]);
    assert!(
        String::from_utf8_lossy(&waiting.stderr)
            .contains("10 program job(s) queued and no worker started with --allow-commands"),
        "{}",
        String::from_utf8_lossy(&waiting.stderr)
    );
    let _allowed = cluster.worker_with(&url, "1", Some(cluster.token()), &["--allow-commands"]);
    cluster.wait_done(&url, 30, Duration::from_secs(60));
    assert_exactly_once(&cluster, 30);
    let quiet = cluster.sweep(&["status", "--db", db]);
    assert!(!String::from_utf8_lossy(&quiet.stderr).contains("program job"));
    let on = |allow: u8, kind: &str| {
        cluster.count(&format!(
            "SELECT count(*) FROM results r JOIN jobs j ON j.id = r.job_id \
             JOIN workers w ON w.id = r.worker_id WHERE j.kind = '{kind}' AND w.allow_commands = {allow}"
        ))
    };
    assert_eq!(on(0, "command"), 0, "a program job ran on the plain worker");
    assert_eq!(on(1, "command"), 10);
    assert_eq!(on(0, "noop"), 20);
    assert_eq!(
        cluster.count("SELECT count(*) FROM jobs WHERE kind = 'command' AND attempts <> 1"),
        0,
        "a program job was leased and refused"
    );
    // The view of program results: two values per job, the core being the allowed worker's.
    assert_eq!(cluster.count("SELECT count(*) FROM command_results"), 20);
    assert_eq!(
        cluster.count(
            "SELECT count(*) FROM command_results WHERE name = 'core' AND value = 1 \
             AND label = 'echo' AND json_extract(parameters, '$.n') BETWEEN 1 AND 10"
        ),
        10
    );
}

/// A `[[tune]]` search driven by a coordinator that is killed (-9) mid-search and started
/// again on its database: every evaluation finished before is reused, none is run twice, and
/// the search ends within its budget.
#[test]
fn a_search_survives_a_coordinator_killed_mid_search() {
    let cluster = Cluster::new();
    let (mut coordinator, url) = cluster.coordinator("127.0.0.1:0");
    let addr = url.trim_start_matches("http://").to_string();
    let _worker = cluster.worker(&url, "0", Some(cluster.token()));
    let plan = cluster.plan(
        "tune.toml",
        "name = \"tune\"\n[[tune]]\nfamily = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0.05, 1.0]\n\
         goal = \"min tau_c_cpu_us\"\nmax_evaluations = 8\nshape = \"sphere\"\nn = 256\nphi = 0.4\n\
         neighbours = \"nnl\"\ncollisions = 300000\n",
    );
    let submitted = cluster.submit(&url, &plan);
    assert_eq!(submitted["new_jobs"], 0, "a search's jobs come as it goes");
    let done = |sql: &str| cluster.count(sql);
    let started = Instant::now();
    while done("SELECT count(*) FROM jobs WHERE state = 'done'") < 4 {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the search did not start"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    coordinator.kill9();
    let before = done("SELECT count(*) FROM jobs WHERE state = 'done'");
    let finished_before = cluster
        .count("SELECT CAST(total(finished_at) * 1000 AS INTEGER) FROM jobs WHERE state = 'done'");
    std::thread::sleep(Duration::from_millis(500));
    let (_restarted, url2) = cluster.coordinator(&addr);
    assert_eq!(url, url2);
    let db = cluster.db.to_str().unwrap().to_owned();
    let concluded = loop {
        let out = cluster.sweep(&["report", "tune", "--db", &db, "--format", "json"]);
        if out.status.success() {
            let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            if !rows[0]["conclusion"].is_null() {
                break rows[0].clone();
            }
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the search did not end"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    let after = done("SELECT count(*) FROM jobs WHERE state = 'done'");
    assert!(after >= before && after <= 8, "{before} → {after}");
    assert_eq!(
        done("SELECT count(*) FROM jobs WHERE attempts > 1"),
        0,
        "a job ran twice"
    );
    // The runs done before the kill kept their finish times (the sum of the first `before`).
    assert_eq!(
        cluster.count(&format!(
            "SELECT CAST(total(finished_at) * 1000 AS INTEGER) FROM
             (SELECT finished_at FROM jobs WHERE state = 'done' ORDER BY finished_at LIMIT {before})"
        )),
        finished_before
    );
    assert_eq!(
        concluded["evaluations"].as_u64(),
        Some(after),
        "{concluded}"
    );
}
