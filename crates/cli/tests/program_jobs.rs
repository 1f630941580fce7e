//! Program jobs (`[[command]]`) in local mode: a rebuilt program is a new point and both
//! results are kept; a failing program fails its job with the reason and writes nothing; the
//! peers report puts a program's τ_c beside our EDMD spheres'.

use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::Output;

fn sweep(args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(args)
        .output()
        .expect("the sweep binary runs")
}

fn ok(out: Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON")
}

fn script(dir: &Path, name: &str, body: &str) {
    let path = dir.join(name);
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

fn query(db: &str, sql: &str) -> Vec<serde_json::Value> {
    ok(sweep(&["query", sql, "--db", db, "--format", "json"]))
        .as_array()
        .cloned()
        .unwrap_or_default()
}

#[test]
fn a_rebuilt_program_runs_again_and_both_results_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("c.db").display().to_string();
    let plan = dir.path().join("plan.toml");
    std::fs::write(
        &plan,
        "[[command]]\nlabel = \"v\"\nprogram = \"prog\"\nargs = [\"{n}\"]\nn = [1, 2]\n",
    )
    .unwrap();
    let plan = plan.display().to_string();
    script(
        dir.path(),
        "prog",
        "echo \"{\\\"version\\\": 1, \\\"n\\\": $1}\"",
    );
    let first = ok(sweep(&["run", &plan, "--db", &db, "--format", "json"]));
    assert_eq!(first["status"]["done"], 2, "{first}");
    // The same build again: nothing new.
    let again = ok(sweep(&["run", &plan, "--db", &db, "--format", "json"]));
    assert_eq!(again["new_jobs"], 0, "{again}");
    script(
        dir.path(),
        "prog",
        "echo \"{\\\"version\\\": 2, \\\"n\\\": $1}\"",
    );
    let rebuilt = ok(sweep(&["run", &plan, "--db", &db, "--format", "json"]));
    // New points (a new campaign of the same plan), run; the old ones stay done.
    assert_eq!(rebuilt["new_jobs"], 2, "{rebuilt}");
    assert_eq!(rebuilt["status"]["done"], 2, "{rebuilt}");
    let done = query(&db, "SELECT count(*) AS n FROM jobs WHERE state = 'done'");
    assert_eq!(done[0]["n"], 4);
    let versions = query(
        &db,
        "SELECT value, count(DISTINCT job_id) AS jobs FROM command_results WHERE name = 'version' \
         GROUP BY value ORDER BY value",
    );
    assert_eq!(
        versions,
        [
            serde_json::json!({"value": 1, "jobs": 2}),
            serde_json::json!({"value": 2, "jobs": 2})
        ]
    );
    let hashes = query(
        &db,
        "SELECT count(DISTINCT json_extract(params, '$.program_hash')) AS n FROM jobs",
    );
    assert_eq!(hashes[0]["n"], 2);
    let exported = ok(sweep(&["export", "--db", &db, "--format", "json"]));
    let commands = exported
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["kind"] == "command")
        .count();
    assert_eq!(commands, 4, "{exported}");
}

#[test]
fn a_failing_program_fails_its_job_with_the_reason_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("c.db").display().to_string();
    script(dir.path(), "bad", "echo 'segfault soon' >&2; kill -SEGV $$");
    let plan = dir.path().join("plan.toml");
    std::fs::write(&plan, "[[command]]\nlabel = \"bad\"\nprogram = \"bad\"\n").unwrap();
    let out = sweep(&[
        "run",
        &plan.display().to_string(),
        "--db",
        &db,
        "--format",
        "json",
    ]);
    let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    let errors = query(&db, "SELECT last_error FROM jobs WHERE state = 'failed'");
    assert_eq!(
        errors.len(),
        1,
        "{status} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let error = errors[0]["last_error"].as_str().unwrap_or_default();
    assert!(
        error.contains("killed by SIGSEGV") && error.contains("segfault soon"),
        "{error}"
    );
    assert!(query(&db, "SELECT * FROM results").is_empty());
}

#[test]
fn the_peers_report_compares_tau_c_per_n() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("c.db").display().to_string();
    // A "peer" ten times slower than a fixed 1 µs, or printing its τ_c as text.
    script(
        dir.path(),
        "peer",
        "echo \"{\\\"tau_c_us\\\": $(( $2 + 10 )), \\\"collisions\\\": 1000}\"",
    );
    let plan = dir.path().join("plan.toml");
    std::fs::write(
        &plan,
        "[[edmd]]\nshape = \"sphere\"\nn = [32, 64]\nphi = 0.3\ncollisions = 2000\nseed = [1, 2]\n\n\
         [[command]]\nlabel = \"peer\"\nprogram = \"peer\"\nargs = [\"{n}\", \"{seed}\"]\n\
         n = [32, 64]\nphi = 0.3\nseed = [1, 2]\n",
    )
    .unwrap();
    ok(sweep(&[
        "run",
        &plan.display().to_string(),
        "--db",
        &db,
        "--format",
        "json",
    ]));
    let report = ok(sweep(&[
        "report", "peers", "--db", &db, "--label", "peer", "--format", "json",
    ]));
    let points = report.as_array().unwrap();
    assert_eq!(points.len(), 2, "{report}");
    for p in points {
        assert_eq!(p["ours_runs"], 2);
        assert_eq!(p["theirs_runs"], 2);
        let theirs = p["theirs_tau_c_us"].as_f64().unwrap();
        assert!((theirs - (11f64 * 12.0).sqrt()).abs() < 1e-9, "{p}");
        let ratio = p["ratio"].as_f64().unwrap();
        let ours = p["ours_tau_c_us"].as_f64().unwrap();
        assert!((ratio - theirs / ours).abs() < 1e-9 * ratio, "{p}");
        let ci = p["ratio_ci95"].as_array().unwrap();
        assert!(ci[0].as_f64().unwrap() < ratio && ratio < ci[1].as_f64().unwrap());
    }
    let table = sweep(&["report", "peers", "--db", &db, "--label", "peer"]);
    assert!(String::from_utf8_lossy(&table.stdout).contains("| 32 | 0.3 |"));
    let missing = sweep(&["report", "peers", "--db", &db, "--label", "nobody"]);
    assert!(!missing.status.success());
}
