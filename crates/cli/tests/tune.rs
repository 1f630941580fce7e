//! `[[tune]]` in local mode: a search issues its evaluations as jobs finish, survives a kill -9
//! of the run with every finished evaluation reused, and `sweep report tune` says what it found.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn sweep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(args)
        .output()
        .expect("the sweep binary runs")
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON")
}

const PLAN: &str = r#"name = "tune"
[[tune]]
family = "edmd"
knob = "delta_nnl"
range = [0.05, 1.0]
goal = "min tau_c_cpu_us"
max_evaluations = 8
shape = "sphere"
n = 256
phi = 0.4
neighbours = "nnl"
collisions = 300000
"#;

/// (id, finished_at, attempts) of every done job.
fn done_jobs(db: &str) -> Vec<(String, f64, i64)> {
    try_done_jobs(db).unwrap_or_else(|e| panic!("{e}"))
}

/// [`done_jobs`], or why the query failed (the database may not be written yet).
fn try_done_jobs(db: &str) -> Result<Vec<(String, f64, i64)>, String> {
    let out = sweep(&[
        "query",
        "SELECT id, finished_at, attempts FROM jobs WHERE state = 'done' ORDER BY id",
        "--db",
        db,
        "--format",
        "json",
    ]);
    if !out.status.success() {
        return Err(format!(
            "sweep query: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    Ok(rows
        .iter()
        .map(|r| {
            (
                r["id"].as_str().unwrap().to_owned(),
                r["finished_at"].as_f64().unwrap(),
                r["attempts"].as_i64().unwrap(),
            )
        })
        .collect())
}

#[test]
fn a_search_resumed_after_kill_9_reuses_every_finished_evaluation() {
    resumed_after_kill_9(PLAN, 1);
}

/// A table's searches pool their runs ([`tune::pool`]): killed while its leader and followers
/// run, resumed, each finished evaluation is reused and every search concludes.
#[test]
fn a_pooled_table_resumed_after_kill_9_reuses_every_finished_evaluation() {
    resumed_after_kill_9(&PLAN.replace("phi = 0.4", "phi = [0.35, 0.4, 0.45]"), 3);
}

fn resumed_after_kill_9(plan_text: &str, searches: usize) {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("tune.toml");
    std::fs::write(&plan, plan_text).unwrap();
    let plan = plan.to_str().unwrap();
    let db = dir.path().join("t.db").to_str().unwrap().to_owned();

    let log = dir.path().join("run.stderr");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(["run", plan, "--db", &db, "--cores", "0", "--format", "json"])
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    // Why the run made no progress, where it did not: its exit and its log.
    let stalled = |child: &mut std::process::Child, why: &str| -> String {
        format!(
            "{why}; run exited: {:?}; its stderr:\n{}",
            child.try_wait(),
            std::fs::read_to_string(&log).unwrap_or_default()
        )
    };
    let started = Instant::now();
    let before = loop {
        std::thread::sleep(Duration::from_millis(50));
        // Asked before the jobs, so that the jobs of a run that has ended are its last.
        let exited = child.try_wait().ok().flatten();
        let done = if Path::new(&db).exists() {
            try_done_jobs(&db)
        } else {
            Ok(Vec::new())
        };
        // The initial three, and at least one the search issued after them.
        if let Ok(done) = &done
            && done.len() >= 4
        {
            break done.clone();
        }
        if started.elapsed() > Duration::from_secs(120) {
            let why = match &done {
                Ok(done) => format!("no progress in 120 s: {} evaluations done", done.len()),
                Err(e) => format!("no progress in 120 s: {e}"),
            };
            panic!("{}", stalled(&mut child, &why));
        }
        if let Some(status) = exited {
            panic!(
                "{}",
                stalled(&mut child, &format!("the run ended early: {status}"))
            );
        }
    };
    child.kill().unwrap();
    child.wait().unwrap();

    let resumed = json(&sweep(&["run", plan, "--db", &db, "--format", "json"]));
    eprintln!(
        "{} evaluations done before the kill, {} after the resumed run",
        before.len(),
        done_jobs(&db).len()
    );
    let after = done_jobs(&db);
    for job in &before {
        assert!(after.contains(job), "{job:?} was run again or lost");
    }
    assert!(after.len() <= 8 * searches, "over the budget: {after:?}");
    let concluded = resumed["searches"].as_array().unwrap();
    assert_eq!(concluded.len(), searches, "{resumed}");
    for search in concluded {
        let stopped = search["stopped"].as_str().unwrap();
        assert!(
            ["converged", "budget", "pooled"].contains(&stopped),
            "{resumed}"
        );
    }

    // A third run has nothing left to do.
    let again = json(&sweep(&["run", plan, "--db", &db, "--format", "json"]));
    assert_eq!(again["new_jobs"], 0, "{again}");
    assert_eq!(done_jobs(&db), after);

    let report = json(&sweep(&["report", "tune", "--db", &db, "--format", "json"]));
    let rows = report.as_array().unwrap();
    assert_eq!(rows.len(), searches, "{report}");
    let mut evaluations = 0;
    for row in rows {
        assert_eq!(row["knob"], "delta_nnl");
        let used = row["evaluations"].as_u64().unwrap() as usize;
        evaluations += used;
        let best = row["conclusion"]["best"].as_f64().unwrap();
        assert!((0.05..=1.0).contains(&best), "{row}");
        // The path lists every evaluation, each with its τ_c.
        let path = row["path"].as_array().unwrap();
        assert_eq!(path.len(), used);
        assert!(
            path.iter()
                .all(|p| p["value"].as_f64().is_some_and(|v| v > 0.0)),
            "{row}"
        );
    }
    assert_eq!(evaluations, after.len(), "{report}");
}

#[test]
fn sweep_plan_counts_the_searches_of_a_plan() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("tune.toml");
    std::fs::write(&plan, PLAN.replace("phi = 0.4", "phi = [0.3, 0.4]")).unwrap();
    let summary = json(&sweep(&[
        "plan",
        plan.to_str().unwrap(),
        "--format",
        "json",
    ]));
    assert_eq!(summary["searches"], 2, "{summary}");
    assert_eq!(summary["points"], 0, "{summary}");
}
