//! Local mode as a user meets it: `sweep run` on real plans and a real database file, killed,
//! resumed, extended, and fed bad plans.

use std::collections::HashSet;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn sweep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(args)
        .output()
        .expect("the sweep binary runs")
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn run_plan(plan: &str, db: &str) -> serde_json::Value {
    let out = sweep(&["run", plan, "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "sweep run failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON status")
}

/// (job_id, attempt) of every exported record of kind noop.
fn exported_noops(db: &str) -> Vec<(String, u64)> {
    let out = sweep(&["export", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    rows.iter()
        .filter(|r| r["kind"] == "noop")
        .map(|r| {
            (
                r["job_id"].as_str().unwrap().to_string(),
                r["attempt"].as_u64().unwrap(),
            )
        })
        .collect()
}

fn export_ok(db: &str) -> bool {
    Path::new(db).exists()
        && sweep(&["export", "--db", db, "--format", "json"])
            .status
            .success()
}

fn noop_plan(count: u32, duration_ms: u32) -> String {
    format!("name = \"noops\"\n[[noop]]\ncount = {count}\nduration_ms = {duration_ms}\n")
}

#[test]
fn a_rerun_schedules_nothing_and_an_extension_only_the_new_points() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("r.db").to_str().unwrap().to_string();
    let first = run_plan(&write(dir.path(), "a.toml", &noop_plan(20, 0)), &db);
    assert_eq!(first["new_jobs"], 20, "{first}");
    assert_eq!(exported_noops(&db).len(), 20);

    let again = run_plan(&write(dir.path(), "a.toml", &noop_plan(20, 0)), &db);
    assert_eq!(again["new_jobs"], 0, "{again}");
    assert_eq!(again["already_known"], 20, "{again}");
    assert_eq!(exported_noops(&db).len(), 20, "a rerun ran jobs again");

    let extended = run_plan(&write(dir.path(), "b.toml", &noop_plan(30, 0)), &db);
    assert_eq!(extended["new_jobs"], 10, "{extended}");
    let rows = exported_noops(&db);
    let ids: HashSet<&String> = rows.iter().map(|(id, _)| id).collect();
    assert_eq!(
        (rows.len(), ids.len()),
        (30, 30),
        "every point exactly once"
    );
}

/// kill -9 in the middle of a run, then a rerun: every point has exactly one result row.
#[test]
fn a_killed_run_resumes_without_duplicates_or_losses() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("k.db").to_str().unwrap().to_string();
    let plan = write(dir.path(), "slow.toml", &noop_plan(40, 50));
    let mut child = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(["run", &plan, "--db", &db, "--format", "json"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait until some, but not all, results are in; then kill without warning.
    let started = Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(50));
        // The file exists before its schema does: until the run has migrated it, export refuses.
        let done = if export_ok(&db) {
            exported_noops(&db).len()
        } else {
            0
        };
        if done >= 5 {
            break;
        }
        assert!(started.elapsed() < Duration::from_secs(30), "no progress");
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = exported_noops(&db).len();
    assert!(before < 40, "the run finished before it could be killed");

    let resumed = run_plan(&plan, &db);
    assert_eq!(resumed["status"]["done"], 40, "{resumed}");
    let rows = exported_noops(&db);
    let ids: HashSet<&String> = rows.iter().map(|(id, _)| id).collect();
    assert_eq!(rows.len(), 40, "lost or duplicated rows");
    assert_eq!(ids.len(), 40);
}

/// Bad plans fail before the database is touched: byte for byte the same afterwards.
#[test]
fn bad_plans_name_the_key_and_leave_the_database_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("b.db").to_str().unwrap().to_string();
    run_plan(&write(dir.path(), "ok.toml", &noop_plan(3, 0)), &db);
    let snapshot = |db: &str| -> Vec<(String, Vec<u8>)> {
        let mut files: Vec<_> = std::fs::read_dir(Path::new(db).parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.to_str().unwrap().starts_with(db))
            .map(|p| (p.display().to_string(), std::fs::read(&p).unwrap()))
            .collect();
        files.sort();
        files
    };
    let before = snapshot(&db);
    let overlap = |line: &str| {
        format!(
            "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nconfigurations = 1000\n{line}\n"
        )
    };
    let superquadric = |exponents: &str| {
        format!(
            "[[edmd]]\nshape = \"superquadric\"\nn = 8\nphi = 0.2\nx0 = 2\nexponents = {exponents}\n"
        )
    };
    let cases: Vec<(String, &str)> = vec![
        (overlap("acceptance = 1.5"), "acceptance"),
        (overlap("acceptance = 0"), "acceptance"),
        (overlap("repeats = 0"), "repeats"),
        (overlap("precision = \"f16\""), "precision"),
        (overlap("algorithms = [\"ocsi\", \"fast\"]"), "algorithms"),
        (overlap("colour = \"red\""), "colour"),
        (overlap("seed = \"abc\""), "seed"),
        (overlap("ci_target = 2"), "ci_target"),
        (overlap("time_cap_s = 5"), "time_cap_s"),
        (
            "[[overlap]]\nl_star = -1\nw_star = 1\nr_star = 0.5\n".into(),
            "l_star",
        ),
        (
            "[[overlap]]\nl_star = 1\nw_star = 0\nr_star = 0.5\n".into(),
            "w_star",
        ),
        (
            "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = nan\n".into(),
            "r_star",
        ),
        (
            "[[overlap]]\nl_star = { from = 5, to = 1 }\nw_star = 1\nr_star = 0.5\n".into(),
            "l_star",
        ),
        (
            "[[overlap]]\nl_star = { from = 1, to = 5, step = 0 }\nw_star = 1\nr_star = 0.5\n"
                .into(),
            "l_star",
        ),
        (
            "[[overlap]]\nl_star = []\nw_star = 1\nr_star = 0.5\n".into(),
            "l_star",
        ),
        ("[[overlap]]\nw_star = 1\nr_star = 0.5\n".into(), "l_star"),
        (
            "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nconfigurations = 0\n".into(),
            "configurations",
        ),
        ("[[noop]]\ncount = -3\n".into(), "count"),
        ("[[noop]]\ncount = 3\nfail_rate = 2\n".into(), "fail_rate"),
        (
            "[[noop]]\ncount = 3\nduration_ms = \"slow\"\n".into(),
            "duration_ms",
        ),
        (superquadric("[[2, 2, 2], [2, 2]]"), "exponents"),
        (superquadric("[[2, 2, 2],\n [2, 1.5, 2]]"), "exponents"),
        (superquadric("[2, 2, \"p\"]"), "exponents"),
        (superquadric("[2, [2, 2, 2]]"), "exponents"),
    ];
    assert!(cases.len() >= 15);
    for (i, (plan, key)) in cases.iter().enumerate() {
        let path = write(dir.path(), &format!("bad{i}.toml"), plan);
        let out = sweep(&["run", &path, "--db", &db]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "accepted:\n{plan}");
        assert!(
            err.contains(&format!("bad{i}.toml:")) && err.contains(key),
            "case {i}: `{key}` not named: {err}"
        );
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "case {i}: not one line: {err}"
        );
        assert!(snapshot(&db) == before, "case {i} changed the database");
        // An exponents list is named at its own line: the second list of a sweep on line 7.
        if plan.contains("[2, 1.5, 2]") {
            assert!(
                err.contains(&format!(
                    "bad{i}.toml:7:2: key `exponents`: each exponent must lie in"
                )),
                "{err}"
            );
        }
    }
}

/// An overlap campaign as a user reads it back: every point with an estimate and a 95 %
/// interval in `report fig2 --format json`, Table 1 with its dispersion, the noise check counted
/// by `status`, the blocks kept for re-estimating, and a point with `ci_target` measured until
/// precise or capped.
#[test]
fn overlap_results_carry_their_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("o.db");
    let db = db.to_str().unwrap();
    let plan = write(
        dir.path(),
        "o.toml",
        "name = \"o\"\n[[overlap]]\nl_star = [1, 4]\nw_star = [1, 4]\nr_star = 5\nconfigurations = 20_000\nrepeats = 2\nalgorithms = [\"qri\", \"ocsi\"]\n\
         [[overlap]]\nl_star = 2\nw_star = 2\nr_star = 5\nconfigurations = 20_000\nrepeats = 2\nalgorithms = [\"qri\"]\nci_target = 0.001\ntime_cap_s = 0.5\n",
    );
    run_plan(&plan, db);

    let out = sweep(&["report", "fig2", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let points: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(points.len(), 4 * 2 + 1);
    for p in &points {
        let (lo, ns, hi) = (
            p["ci95_lo_ns_per_check"].as_f64(),
            p["ns_per_check"].as_f64().unwrap(),
            p["ci95_hi_ns_per_check"].as_f64(),
        );
        assert!(lo.unwrap() <= ns && ns <= hi.unwrap(), "{p}");
        assert!(p["disturbed"].is_boolean() && p["reruns"].is_u64(), "{p}");
    }

    let out = sweep(&["report", "table1", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    for row in &table {
        for key in [
            "r_star",
            "precision",
            "algorithm",
            "mean_ms",
            "ns_per_check",
            "points",
        ] {
            assert!(
                row.get(key).is_some(),
                "the contract's `{key}` is missing: {row}"
            );
        }
        assert!(row["ci95_ms"].as_f64().is_some_and(|h| h > 0.0), "{row}");
    }
    let out = sweep(&["report", "table1", "--db", db]);
    assert!(
        String::from_utf8_lossy(&out.stdout).contains(" ± "),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );

    let out = sweep(&["status", "--db", db, "--format", "json"]);
    let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(status["timing"]["checked"], 5, "{status}");

    // Every pass kept its blocks (20,000 configurations: 20 blocks of 1,024); the capped point
    // measured at least its two sets and says why it stopped.
    let out = sweep(&[
        "query",
        "SELECT json_array_length(block_ns_per_check) AS blocks FROM overlap_timings",
        "--db",
        db,
        "--format",
        "json",
    ]);
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert!(rows.iter().all(|r| r["blocks"] == 20), "{rows:?}");
    let out = sweep(&[
        "query",
        "SELECT stop, repeats FROM overlap_measurements WHERE ci_target IS NOT NULL",
        "--db",
        db,
        "--format",
        "json",
    ]);
    let capped: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(capped.len(), 1);
    assert!(
        ["precise", "time_cap"].contains(&capped[0]["stop"].as_str().unwrap()),
        "{capped:?}"
    );
    assert!(capped[0]["repeats"].as_u64().unwrap() >= 2);

    let svg = dir.path().join("fig2.svg");
    let out = sweep(&[
        "report",
        "fig2",
        "--db",
        db,
        "--ci",
        "--out",
        svg.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<circle"));
}

/// `report --statistic`: each point's estimate is the statistic asked for of its stored blocks
/// (checked against the blocks read back with `query`), Table 1 defaults to the mean and Fig. 2
/// to the 5th percentile, every output names its statistic, and a bad or misplaced value is a
/// one-line error naming the flag.
/// `visits`: one job per visit, every first visit started before any second one; the reports
/// give one row per point with its visits pooled; more visits later add only the new jobs.
#[test]
fn visits_run_visit_major_and_pool_in_the_reports() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("v.db");
    let db = db.to_str().unwrap();
    let plan = |visits: u32| {
        format!(
            "name = \"v\"\n[[overlap]]\nl_star = [1, 4, 8]\nw_star = 1\nr_star = 5\nconfigurations = 20_000\nrepeats = 2\nalgorithms = [\"qri\"]\nvisits = {visits}\n"
        )
    };
    let two = run_plan(&write(dir.path(), "v2.toml", &plan(2)), db);
    assert_eq!(two["new_jobs"], 6, "{two}");
    // Short jobs are leased a few at a time (the worker prefetches): a batch may hold the last
    // first visits and the first second ones, but no second visit is leased before a first.
    let out = sweep(&[
        "query",
        "SELECT (SELECT max(started_at) FROM jobs WHERE pass = 0) <= (SELECT min(started_at) FROM jobs WHERE pass = 1) AS ordered, \
         (SELECT count(*) FROM jobs WHERE pass = 1) AS second",
        "--db",
        db,
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let order: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (order[0]["ordered"].as_i64(), order[0]["second"].as_i64()),
        (Some(1), Some(3)),
        "{order:?}"
    );
    let out = sweep(&["report", "fig2", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let points: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(points.len(), 3, "one row per point");
    for point in &points {
        assert_eq!(point["visits"], 2, "{point}");
        assert_eq!(point["repeats"], 4, "{point}");
        let (lo, hi) = (
            point["ci95_lo_ns_per_check"].as_f64().unwrap(),
            point["ci95_hi_ns_per_check"].as_f64().unwrap(),
        );
        assert!(
            lo <= point["ns_per_check"].as_f64().unwrap()
                && point["ns_per_check"].as_f64().unwrap() <= hi,
            "{point}"
        );
    }
    let three = run_plan(&write(dir.path(), "v3.toml", &plan(3)), db);
    assert_eq!(
        (three["new_jobs"].as_u64(), three["already_known"].as_u64()),
        (Some(3), Some(6)),
        "{three}"
    );
}

#[test]
fn reports_estimate_by_the_statistic_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("s.db");
    let db = db.to_str().unwrap();
    let plan = write(
        dir.path(),
        "s.toml",
        "name = \"s\"\n[[overlap]]\nl_star = [1, 4]\nw_star = 1\nr_star = 5\nconfigurations = 20_000\nrepeats = 2\nalgorithms = [\"qri\", \"ocsi\"]\n",
    );
    run_plan(&plan, db);
    let out = sweep(&[
        "query",
        "SELECT l_star, algorithm, block_ns_per_check FROM overlap_timings",
        "--db",
        db,
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut blocks: std::collections::HashMap<(i64, String), Vec<f64>> = Default::default();
    for row in serde_json::from_slice::<Vec<serde_json::Value>>(&out.stdout).unwrap() {
        let these: Vec<f64> =
            serde_json::from_str(row["block_ns_per_check"].as_str().unwrap()).unwrap();
        blocks
            .entry((
                row["l_star"].as_i64().unwrap(),
                row["algorithm"].as_str().unwrap().to_owned(),
            ))
            .or_default()
            .extend(these);
    }
    assert_eq!(blocks.len(), 4);
    // Independent of the estimator's code: the mean, and the linearly interpolated quantile.
    let expected = |statistic: &str, values: &[f64]| -> f64 {
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let at = |q: f64| {
            let x = q * (sorted.len() - 1) as f64;
            let i = x.floor() as usize;
            sorted[i] + (x - i as f64) * (sorted[(i + 1).min(sorted.len() - 1)] - sorted[i])
        };
        match statistic {
            "mean" => values.iter().sum::<f64>() / values.len() as f64,
            "median" => at(0.5),
            _ => at(0.05),
        }
    };
    let report = |args: &[&str]| -> Vec<serde_json::Value> {
        let out = sweep(&[&["report"], args, &["--db", db, "--format", "json"]].concat());
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    for (args, statistic) in [
        (&["fig2"][..], "p5"),
        (&["fig2", "--statistic", "mean"][..], "mean"),
        (&["fig2", "--statistic", "median"][..], "median"),
        (&["fig2", "--statistic", "p5"][..], "p5"),
    ] {
        let points = report(args);
        assert_eq!(points.len(), 4);
        for p in &points {
            assert_eq!(p["statistic"], statistic, "{args:?}: {p}");
            let values = &blocks[&(
                p["l_star"].as_f64().unwrap() as i64,
                p["algorithm"].as_str().unwrap().to_owned(),
            )];
            let want = expected(statistic, values);
            let got = p["ns_per_check"].as_f64().unwrap();
            assert!(
                (got / want - 1.0).abs() < 1e-9,
                "{args:?}: {got} for {want}: {p}"
            );
            assert!(
                p["ci95_lo_ns_per_check"].as_f64().unwrap() <= got
                    && got <= p["ci95_hi_ns_per_check"].as_f64().unwrap()
            );
        }
    }
    // Table 1: the mean by default; each cell the mean over its points of their estimates.
    for (args, statistic) in [
        (&["table1"][..], "mean"),
        (&["table1", "--statistic", "p5"][..], "p5"),
    ] {
        let table = report(args);
        for row in &table {
            assert_eq!(row["statistic"], statistic, "{row}");
            let algorithm = row["algorithm"].as_str().unwrap().to_owned();
            let want = [1, 4]
                .iter()
                .map(|&l| expected(statistic, &blocks[&(l, algorithm.clone())]))
                .sum::<f64>()
                / 2.0;
            assert!(
                (row["ns_per_check"].as_f64().unwrap() / want - 1.0).abs() < 1e-9,
                "{row}"
            );
        }
    }
    let out = sweep(&["report", "table1", "--db", db, "--statistic", "median"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("Each point's estimate (median): the median of its timed blocks."),
        "{text}"
    );
    let csv = dir.path().join("t.csv");
    assert!(
        sweep(&[
            "report",
            "table1",
            "--db",
            db,
            "--out",
            csv.to_str().unwrap()
        ])
        .status
        .success()
    );
    let csv = std::fs::read_to_string(&csv).unwrap();
    assert!(
        csv.lines().next().unwrap().ends_with(",statistic")
            && csv.lines().nth(1).unwrap().ends_with(",mean"),
        "{csv}"
    );
    let svg = dir.path().join("f.svg");
    assert!(
        sweep(&["report", "fig2", "--db", db, "--out", svg.to_str().unwrap()])
            .status
            .success()
    );
    assert!(
        std::fs::read_to_string(&svg)
            .unwrap()
            .contains("p5 of the blocks")
    );

    for (args, named) in [
        (
            &["report", "table1", "--db", db, "--statistic", "p10"][..],
            "--statistic",
        ),
        (
            &["report", "fig7", "--db", db, "--statistic", "mean"][..],
            "--statistic",
        ),
    ] {
        let out = sweep(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} accepted");
        assert!(err.contains(named), "{args:?}: {err}");
        assert_eq!(
            err.trim_end()
                .lines()
                .filter(|l| l.starts_with("error") || l.starts_with("Error"))
                .count(),
            1,
            "{args:?}: {err}"
        );
    }
}

#[test]
fn an_edmd_sweep_lands_in_edmd_runs_and_draws_figure_7() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("edmd.db");
    let db = db.to_str().unwrap();
    let plan = write(
        dir.path(),
        "edmd.toml",
        "name = \"fig7-small\"\n[[edmd]]\nshape = \"sphere\"\nn = 64\nphi = [0.2, 0.3]\ncollisions = 2000\nequilibrate = 200\n",
    );
    run_plan(&plan, db);
    let out = sweep(&[
        "query",
        "SELECT phi, tau_c_us > 0, overlaps FROM edmd_runs ORDER BY phi",
        "--db",
        db,
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows.len(), 2, "{rows:?}");
    for (row, phi) in rows.iter().zip([0.2, 0.3]) {
        assert_eq!(row["phi"], phi);
        assert_eq!(row["tau_c_us > 0"], 1);
        assert_eq!(row["overlaps"], 0);
    }

    let png = dir.path().join("fig7.png");
    let out = sweep(&["report", "fig7", "--db", db, "--out", png.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);

    // A database without EDMD results: a clear error and no file.
    let empty = dir.path().join("noops.db");
    run_plan(
        &write(dir.path(), "noops.toml", &noop_plan(3, 0)),
        empty.to_str().unwrap(),
    );
    let nothing = dir.path().join("none.png");
    let out = sweep(&[
        "report",
        "fig7",
        "--db",
        empty.to_str().unwrap(),
        "--out",
        nothing.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("no EDMD results"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!nothing.exists());
}

/// The EDMD figures and the accuracy report from a campaign run in local mode: a report whose
/// points are not there yet names them and fails, writing nothing; once the plan is extended, it
/// draws. Every record carries the job's wall and CPU time.
#[test]
fn edmd_reports_name_missing_points_then_draw_once_the_plan_is_extended() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("figures.db");
    let db = db.to_str().unwrap();
    let nnl = "[[edmd]]\nshape = \"ellipsoid\"\nn = 64\nphi = 0.3\nx0 = [0.5, 2.0]\nneighbours = \"nnl\"\ndelta_nnl = 0.06\n\
               eps_d = [1e-6, 1e-5]\ncollisions = 400\nequilibrate = 40\n";
    run_plan(
        &write(dir.path(), "a.toml", &format!("name = \"figures\"\n{nnl}")),
        db,
    );

    let png = dir.path().join("fig8.png");
    let out = sweep(&["report", "fig8", "--db", db, "--out", png.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "fig8 drew without a sweep over X0");
    assert!(
        err.contains("ellipsoid LL runs at φ = 0.3 over three or more X0"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    assert!(!png.exists(), "an empty figure was written");

    let ll = "[[edmd]]\nshape = \"ellipsoid\"\nn = 64\nphi = 0.3\nx0 = [0.5, 1.0, 2.0]\nneighbours = [\"ll\", \"nnl\"]\n\
              delta_nnl = 0.06\neps_d = 1e-5\ncollisions = 400\nequilibrate = 40\n";
    let extended = run_plan(
        &write(
            dir.path(),
            "b.toml",
            &format!("name = \"figures\"\n{nnl}\n{ll}"),
        ),
        db,
    );
    assert_eq!(extended["new_jobs"], 4, "{extended}");
    let out = sweep(&[
        "report",
        "fig8",
        "--db",
        db,
        "--out",
        png.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
    let fig8: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ratios = fig8["ratios"][0]["points"].as_array().unwrap();
    assert_eq!(ratios.len(), 3, "{fig8}");
    assert!(ratios.iter().all(|p| p["ratio"].as_f64().unwrap() > 0.0));

    let svg = dir.path().join("fig9.svg");
    let out = sweep(&["report", "fig9", "--db", db, "--out", svg.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read_to_string(&svg)
            .unwrap()
            .contains("smallest semi-axis")
    );
    let md = dir.path().join("accuracy.md");
    let out = sweep(&[
        "report",
        "accuracy",
        "--db",
        db,
        "--out",
        md.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read_to_string(&md)
            .unwrap()
            .contains("**Recommended: eps_d = ")
    );

    // The EDMD family alone: the overlap one is named missing; every setting is compared with the
    // tightest run's collision sequence, and Eq. 73 is split in time.
    let out = sweep(&["report", "accuracy", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("missing: overlap points with `verdict_check`")
    );
    let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let runs = study["knobs"][0]["state_points"][0]["runs"]
        .as_array()
        .unwrap();
    let reference = &runs[0];
    assert!(
        reference["identical_collisions"].as_u64().unwrap() > 0,
        "{study}"
    );
    assert_eq!(
        reference["identical_collisions"], reference["compared_collisions"],
        "the reference is itself"
    );
    assert!(
        runs[1]["identical_collisions"].as_u64().unwrap()
            <= runs[1]["compared_collisions"].as_u64().unwrap()
    );
    assert!(
        runs.iter().all(|r| r["update_share"]
            .as_f64()
            .is_some_and(|s| s > 0.0 && s < 1.0)),
        "{study}"
    );

    // Then overlap points with a checking set: the report has both families.
    let overlap = "[[overlap]]\nl_star = 2\nw_star = 3\nr_star = 0.5\nconfigurations = 20000\nrepeats = 1\n\
                   precision = [\"f32\", \"f64\"]\nalgorithms = [\"ocsi\", \"ocsi_batch\"]\nverdict_check = 4000\n";
    let extended = run_plan(
        &write(
            dir.path(),
            "c.toml",
            &format!("name = \"figures\"\n{nnl}\n{ll}\n{overlap}"),
        ),
        db,
    );
    assert_eq!(extended["new_jobs"], 2, "{extended}");
    let out = sweep(&["report", "accuracy", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let settings = study["overlap"]["settings"].as_array().unwrap();
    assert_eq!(settings.len(), 4, "{study}");
    assert!(
        settings
            .iter()
            .all(|s| s["bulk"].as_u64().unwrap() + s["shell"].as_u64().unwrap() == 4000),
        "{study}"
    );
    let wrong = |precision: &str| -> u64 {
        settings
            .iter()
            .filter(|s| s["precision"] == precision)
            .map(|s| s["shell_wrong"].as_u64().unwrap())
            .sum()
    };
    assert!(wrong("f32") > wrong("f64"), "{study}");
    assert!(
        study["overlap"]["recommended"]["algorithm"].is_string(),
        "{study}"
    );
    assert!(study["missing"].as_array().unwrap().is_empty(), "{study}");
    let png = dir.path().join("accuracy.png");
    let out = sweep(&[
        "report",
        "accuracy",
        "--db",
        db,
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);

    // A reader that closes the pipe at once (`| head`) ends the report quietly, not in a panic.
    let mut child = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(["report", "accuracy", "--db", db, "--format", "json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{out:?}");
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("panicked"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let out = sweep(&[
        "query",
        "SELECT count(*) AS runs, min(wall_s > 0 AND cpu_s > 0 AND cpu_s <= wall_s * 1.05) AS timed FROM edmd_runs",
        "--db",
        db,
        "--format",
        "json",
    ]);
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows[0]["runs"], 8, "{rows:?}");
    assert_eq!(rows[0]["timed"], 1, "{rows:?}");
    let out = sweep(&["report", "fig10", "--db", db, "--format", "json"]);
    assert!(!out.status.success(), "fig10 without a sweep over Δ_NNL");
    assert!(String::from_utf8_lossy(&out.stderr).contains("over three or more Δ_NNL"));
}

/// A result database holding Fig. 13's campaign, written through the store as a worker would:
/// superquadrics p ∈ {2, 3, 4, 6, 8, 10} at X0 = 0.5 and 2, φ = 0.256, N = 512, LL and NNL, with
/// τ_c = base·p/2 (CPU clock), and (if `with_ellipsoids`) the hard ellipsoids of the same state
/// points at a fifth of the p = 2 time. The points are the plan's (`jobs` specs, canonical ids),
/// so the report reads them as it reads a real campaign's.
fn fig13_database(path: &Path, with_ellipsoids: bool) {
    let mut points: Vec<(edmd::Scene, f64)> = Vec::new();
    for x0 in [0.5, 2.0] {
        for (neighbours, base) in [(edmd::Neighbours::Ll, 100.0), (edmd::Neighbours::Nnl, 60.0)] {
            let scene = |shape| edmd::Scene {
                x0,
                neighbours,
                delta_nnl: 0.06,
                collisions: 20_000,
                ..edmd::Scene::new(shape, 512, 0.256)
            };
            for p in [2.0, 3.0, 4.0, 6.0, 8.0, 10.0] {
                let superquadric = edmd::Scene {
                    exponents: Some([2.0, 2.0, p]),
                    ..scene(edmd::ShapeKind::Superquadric)
                };
                points.push((superquadric, base * p / 2.0));
            }
            if with_ellipsoids {
                points.push((scene(edmd::ShapeKind::Ellipsoid), base / 5.0));
            }
        }
    }
    let jobs: Vec<store::NewJob> = points
        .iter()
        .map(|(scene, _)| {
            let spec = jobs::JobSpec::Edmd(scene.clone());
            store::NewJob {
                id: spec.id(),
                kind: spec.kind().into(),
                params_json: spec.canonical_json(),
                estimate_s: 1.0,
                exclusive: false,
                pass: spec.pass(),
                foreign_code: spec.runs_foreign_code(),
            }
        })
        .collect();
    let tau: std::collections::HashMap<String, f64> = jobs
        .iter()
        .zip(&points)
        .map(|(job, (_, tau))| (job.id.clone(), *tau))
        .collect();
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(async {
        let store = store::Store::open(path).await.unwrap();
        let worker = store::WorkerInfo {
            id: "w".into(),
            hostname: "fixture".into(),
            cores: vec![0],
            cpu_model: "fixture".into(),
            cpu_flags: String::new(),
            rustc: "rustc".into(),
            git_commit: "fixture".into(),
            profile: "release".into(),
            allocation: None,
            allow_commands: false,
        };
        store.register_worker(&worker, 1.0).await.unwrap();
        let campaign = store::NewCampaign { id: "fig13".into(), name: "fig13".into(), plan_text: String::new(), searches: Vec::new() };
        store.submit(&campaign, &jobs, 1.0).await.unwrap();
        loop {
            let leases = store.lease("w", 64, Duration::from_secs(60), 2.0, true).await.unwrap();
            if leases.is_empty() {
                break;
            }
            for lease in leases {
                let tau_c = tau[&lease.job_id];
                let record = serde_json::json!({
                    "collisions": 20_000, "tau_c_us": tau_c * 1.1, "tau_c_cpu_us": tau_c, "pressure_z": 3.0,
                    "pressure_z_err": 0.05, "temperature": 1.0, "energy_drift_rel": 1e-13, "momentum_drift": 1e-14,
                    "overlaps": 0, "solver_failures": 0, "contact_nr_fallbacks": 0, "nr_iterations_mean": 4.0,
                    "distance_calls_per_collision": 3.0, "searches_per_collision": 2.0, "nnl_rebuilds": 10,
                    "cell_crossings": 100, "init_s": 0.5, "wall_s": 2.0, "cpu_s": 1.9,
                });
                store.complete("w", &lease.job_id, lease.token, Some(0), &[record.to_string()], 3.0).await.unwrap();
            }
        }
        store.close().await;
    });
}

/// `sweep report fig13` from a database: the figure and its data (τ_c against p per X0 and
/// method, the superquadric/ellipsoid ratio against the paper's 5–6); without the ellipsoids it
/// still draws and names them; without superquadrics it fails naming every curve, writing nothing.
#[test]
fn fig13_is_drawn_from_the_database_and_names_what_it_lacks() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fig13.db");
    fig13_database(&db, true);
    let db = db.to_str().unwrap();
    let png = dir.path().join("fig13.png");
    let out = sweep(&[
        "report",
        "fig13",
        "--db",
        db,
        "--out",
        png.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
    let figure: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(figure["tau_c"], "τ_c (µs, CPU time)", "{figure}");
    assert_eq!(figure["missing"].as_array().unwrap().len(), 0, "{figure}");
    assert_eq!(figure["paper_ratio"], serde_json::json!([5.0, 6.0]));
    let curves = figure["curves"].as_array().unwrap();
    assert_eq!(curves.len(), 4, "{figure}");
    for curve in curves {
        let base = if curve["neighbours"] == "ll" {
            100.0
        } else {
            60.0
        };
        let points = curve["points"].as_array().unwrap();
        assert_eq!(points.len(), 6, "{curve}");
        for point in points {
            let p = point["x"].as_f64().unwrap();
            assert!(
                (point["tau_c_us"].as_f64().unwrap() - base * p / 2.0).abs() < 1e-9,
                "{curve}"
            );
        }
    }
    let ratios = figure["ellipsoid_ratios"].as_array().unwrap();
    assert_eq!(ratios.len(), 4, "{figure}");
    assert!(
        ratios
            .iter()
            .all(|r| (r["ratio"].as_f64().unwrap() - 5.0).abs() < 1e-9),
        "{figure}"
    );

    let svg = dir.path().join("fig13.svg");
    let out = sweep(&[
        "report",
        "fig13",
        "--db",
        db,
        "--out",
        svg.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read_to_string(&svg)
            .unwrap()
            .contains("τ_c(p = 2)/τ_c(HE) = 5.00")
    );

    // Superquadrics without their reference ellipsoids: drawn, the four references named.
    let partial = dir.path().join("partial.db");
    fig13_database(&partial, false);
    let out = sweep(&[
        "report",
        "fig13",
        "--db",
        partial.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.matches("missing: ellipsoid ").count(), 4, "{err}");

    // Ellipsoids only (Fig. 8's database): nothing to draw, one line naming the four curves.
    let ellipsoids = dir.path().join("ellipsoids.db");
    let plan = "[[edmd]]\nshape = \"ellipsoid\"\nn = 64\nphi = 0.3\nx0 = 2.0\ncollisions = 200\nequilibrate = 20\n";
    run_plan(
        &write(dir.path(), "e.toml", plan),
        ellipsoids.to_str().unwrap(),
    );
    let nothing = dir.path().join("nothing.png");
    let out = sweep(&[
        "report",
        "fig13",
        "--db",
        ellipsoids.to_str().unwrap(),
        "--out",
        nothing.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "fig13 drew without superquadrics");
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    assert!(err.contains("fig13: nothing to draw"), "{err}");
    assert_eq!(
        err.matches("with exponents [2, 2, p] for p = 2, 3, 4, 6, 8, 10")
            .count(),
        4,
        "{err}"
    );
    assert!(!nothing.exists(), "an empty figure was written");
}
