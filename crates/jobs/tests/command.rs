//! Program jobs: plans (validation, identity), and running them (results and every failure
//! reason), with small /bin/sh programs written to a temporary folder.

use std::os::unix::fs::PermissionsExt;
use std::path::Path;

use jobs::{JobSpec, Plan};
use serde_json::json;

/// Writes an executable shell script `name` into `dir`.
fn script(dir: &Path, name: &str, body: &str) {
    let path = dir.join(name);
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).expect("write script");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).expect("chmod");
}

/// Parses `text` as the file `plan.toml` of `dir`.
fn plan(dir: &Path, text: &str) -> Result<Plan, jobs::PlanError> {
    let file = dir.join("plan.toml");
    Plan::parse(text, &file.display().to_string())
}

fn one_job(dir: &Path, text: &str) -> JobSpec {
    let plan = plan(dir, text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(plan.jobs.len(), 1);
    plan.jobs[0].clone()
}

fn failure(job: &JobSpec) -> String {
    jobs::run(job, 1).expect_err("must fail").to_string()
}

#[test]
fn a_sweep_expands_and_substitutes() {
    let dir = tempfile::tempdir().expect("tempdir");
    script(dir.path(), "prog", "echo '{\"n\": '$1', \"phi\": '$2'}'");
    let plan = plan(
        dir.path(),
        r#"seed = 7
[[command]]
label = "peer"
program = "prog"
args = ["{n}", "{phi}", "--seed", "{seed}", "{{literal}}"]
n = [256, 2048]
phi = 0.45
timeout_s = 30
"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(plan.jobs.len(), 2);
    let JobSpec::Command(first) = &plan.jobs[0] else {
        panic!("a command job");
    };
    assert_eq!(first.args, ["256", "0.45", "--seed", "7", "{literal}"]);
    assert_eq!(first.params["seed"], json!(7));
    assert!(Path::new(&first.program).is_absolute());
    assert!(plan.jobs[0].runs_foreign_code());
    assert_eq!(plan.jobs[0].kind(), "command");
    let records = jobs::run(&plan.jobs[1], 1).expect("runs");
    assert_eq!(records.len(), 1);
    let record = &records[0];
    assert_eq!(record["values"], json!({"n": 2048, "phi": 0.45}));
    assert_eq!(record["label"], "peer");
    assert_eq!(record["exit_status"], 0);
    assert_eq!(record["program_hash"], json!(first.program_hash));
    assert!(record["wall_s"].as_f64().is_some_and(|w| w > 0.0));
    assert!(record["cpu_s"].as_f64().is_some_and(|c| c >= 0.0));
}

#[test]
fn regex_values_read_text_output() {
    let dir = tempfile::tempdir().expect("tempdir");
    script(
        dir.path(),
        "prog",
        "echo 'tau_c: 1.5e-6 us'; echo 'P = 9.4'",
    );
    let job = one_job(
        dir.path(),
        r#"[[command]]
label = "text"
program = "prog"
[command.values]
tau = "tau_c: ([0-9.eE+-]+)"
pressure = "P = ([0-9.]+)"
"#,
    );
    let records = jobs::run(&job, 1).expect("runs");
    assert_eq!(
        records[0]["values"],
        json!({"tau": 1.5e-6, "pressure": 9.4})
    );
    script(dir.path(), "prog", "echo 'nothing'");
    let job = one_job(
        dir.path(),
        "[[command]]\nlabel = \"t\"\nprogram = \"prog\"\n[command.values]\ntau = \"tau: (\\\\d+)\"\n",
    );
    let reason = failure(&job);
    assert!(
        reason.contains("value `tau`") && reason.contains("matches nothing"),
        "{reason}"
    );
}

#[test]
fn failures_say_why_with_stderr() {
    let dir = tempfile::tempdir().expect("tempdir");
    let cases: [(&str, &str, &[&str]); 4] = [
        ("echo oops >&2; exit 3", "", &["exit status 3", "oops"]),
        (
            "echo dying >&2; kill -SEGV $$",
            "",
            &["killed by SIGSEGV", "dying"],
        ),
        ("sleep 20", "timeout_s = 0.3\n", &["timed out after 0.3 s"]),
        (
            "echo not json; echo '[1]'",
            "",
            &["no line of stdout is a JSON object"],
        ),
    ];
    for (i, (body, extra, expected)) in cases.iter().enumerate() {
        let name = format!("prog{i}");
        script(dir.path(), &name, body);
        let job = one_job(
            dir.path(),
            &format!("[[command]]\nlabel = \"f\"\nprogram = \"{name}\"\n{extra}"),
        );
        let reason = failure(&job);
        for part in *expected {
            assert!(reason.contains(part), "{body}: {reason}");
        }
        assert!(reason.starts_with("command `f`:"), "{reason}");
    }
}

/// A rebuilt program is a new point, and the old point's spec is refused by a worker whose copy
/// differs (never run, never mistaken for the new build).
#[test]
fn a_changed_program_is_a_new_point_and_the_old_one_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = "[[command]]\nlabel = \"v\"\nprogram = \"prog\"\n";
    script(dir.path(), "prog", "echo '{\"version\": 1}'");
    let old = one_job(dir.path(), text);
    assert_eq!(
        jobs::run(&old, 1).expect("runs")[0]["values"],
        json!({"version": 1})
    );
    script(dir.path(), "prog", "echo '{\"version\": 2}'");
    let new = one_job(dir.path(), text);
    assert_ne!(old.id(), new.id());
    assert_eq!(
        jobs::run(&new, 1).expect("runs")[0]["values"],
        json!({"version": 2})
    );
    let reason = failure(&old);
    assert!(
        reason.contains("has BLAKE3") && reason.contains("not run"),
        "{reason}"
    );
}

#[test]
fn bad_plans_name_the_key_and_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    script(dir.path(), "prog", "true");
    std::fs::write(dir.path().join("plain"), "not executable").expect("write");
    let cases = [
        ("program = \"missing\"\n", "program", 3),
        ("program = \"plain\"\n", "program", 3),
        ("program = \"prog\"\nargs = [\"{m}\"]\n", "args", 4),
        (
            "program = \"prog\"\n[command.values]\nx = \"(a)(b)\"\n",
            "values.x",
            5,
        ),
        (
            "program = \"prog\"\n[command.values]\nx = \"(a\"\n",
            "values.x",
            5,
        ),
        ("program = \"prog\"\ntimeout_s = -1\n", "timeout_s", 4),
        ("program = \"prog\"\nn = [[1]]\n", "n", 4),
    ];
    for (body, key, line) in cases {
        let text = format!("\n[[command]]\nlabel = \"x\"\n{body}");
        let error = plan(dir.path(), &text).expect_err(body);
        assert_eq!(error.key.as_deref(), Some(key), "{body}: {error}");
        assert_eq!(error.line, line + 1, "{body}: {error}");
        assert!(error.file.ends_with("plan.toml"), "{error}");
    }
    let error = plan(dir.path(), "[[command]]\nprogram = \"prog\"\n").expect_err("no label");
    assert_eq!(error.key.as_deref(), Some("label"));
}
