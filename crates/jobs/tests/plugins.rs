//! Overlap plugins through plans and jobs: C shared libraries built from
//! `plugins/example` and `crates/plugin-fixtures/c` by the `plugin-fixtures` crate.

use std::path::Path;

use jobs::{JobSpec, Plan};

/// A folder holding `plan.toml` and, under `plugins/`, a copy of each of `plugins`; the plan
/// names them relative to its folder.
fn plan_with(plugins: &[&str], extra: &str) -> (tempfile::TempDir, Result<Plan, String>) {
    let dir = tempfile::tempdir().expect("a temporary folder");
    std::fs::create_dir(dir.path().join("plugins")).expect("plugins/");
    let mut names = Vec::new();
    for plugin in plugins {
        let file = Path::new(plugin).file_name().expect("a file name");
        std::fs::copy(plugin, dir.path().join("plugins").join(file)).expect("copied");
        names.push(format!("\"plugins/{}\"", file.to_string_lossy()));
    }
    let text = format!(
        "[[overlap]]\nl_star = 2\nw_star = 3\nr_star = 0.6\nconfigurations = 20000\nrepeats = 1\n\
         precision = \"f64\"\nalgorithms = [\"ocsi\", \"arvo\"]\nplugins = [{}]\n{extra}",
        names.join(", ")
    );
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, &text).expect("written");
    let plan = Plan::parse(&text, &file.to_string_lossy()).map_err(|e| e.to_string());
    (dir, plan)
}

fn only_job(plan: &Plan) -> &JobSpec {
    assert_eq!(plan.jobs.len(), 1);
    &plan.jobs[0]
}

#[test]
fn the_plugins_hash_is_part_of_the_id_and_marks_foreign_code() {
    let (dir, plan) = plan_with(&[plugin_fixtures::C_OCSI], "");
    let plan = plan.expect("a valid plan");
    let job = only_job(&plan);
    assert!(job.runs_foreign_code());
    let JobSpec::Overlap(point) = job else {
        panic!("an overlap point")
    };
    let file = &point.plugins[0];
    assert!(Path::new(&file.path).is_absolute(), "{}", file.path);
    assert!(file.path.ends_with("plugins/libc_ocsi.so"));
    assert_eq!(file.blake3, blake3_hex(plugin_fixtures::C_OCSI));
    assert!(job.canonical_json().contains(&file.blake3));

    // The same plan, the plugin rebuilt (other bytes): another point.
    let copy = dir.path().join("plugins/libc_ocsi.so");
    let mut bytes = std::fs::read(&copy).expect("read");
    bytes.extend_from_slice(b"rebuilt");
    std::fs::write(&copy, bytes).expect("written");
    let text = std::fs::read_to_string(dir.path().join("plan.toml")).expect("read");
    let again =
        Plan::parse(&text, &dir.path().join("plan.toml").to_string_lossy()).expect("still valid");
    assert_ne!(only_job(&again).id(), job.id());

    // Without plugins: no foreign code, and the id of a point that never had the key.
    let (_dir, plain) = plan_with(&[], "");
    let error = plain.expect_err("an empty list is refused");
    assert!(error.contains("plugins"), "{error}");
    let text = "[[overlap]]\nl_star = 2\nw_star = 3\nr_star = 0.6\nconfigurations = 20000\n\
                repeats = 1\nprecision = \"f64\"\nalgorithms = [\"ocsi\", \"arvo\"]\n";
    let plain = Plan::parse(text, "plain.toml").expect("valid");
    assert!(!only_job(&plain).runs_foreign_code());
    assert!(!only_job(&plain).canonical_json().contains("plugins"));
    // A plugin's checks are counted in the point's time estimate.
    assert!(job.estimate_seconds() > only_job(&plain).estimate_seconds());
}

fn blake3_hex(path: &str) -> String {
    blake3::hash(&std::fs::read(path).expect("read"))
        .to_hex()
        .to_string()
}

#[test]
fn a_precision_the_plugin_lacks_is_refused_at_plan_time_naming_file_and_symbol() {
    let (_dir, plan) = plan_with(&[plugin_fixtures::F64_ONLY], "");
    plan.expect("f64 is exported");
    let dir = tempfile::tempdir().expect("a temporary folder");
    let text = format!(
        "[[overlap]]\nl_star = 2\nw_star = 3\nr_star = 0.6\nprecision = [\"f64\", \"f32\"]\nplugins = [\"{}\"]\n",
        plugin_fixtures::F64_ONLY
    );
    let file = dir.path().join("p.toml");
    let error = Plan::parse(&text, &file.to_string_lossy())
        .expect_err("f32 is not exported")
        .to_string();
    assert!(error.contains("libf64_only.so"), "{error}");
    assert!(error.contains("sweep_overlap_f32"), "{error}");
    assert!(error.contains("key `plugins`"), "{error}");
    // A file that does not exist, named with the plan's line.
    let text =
        "[[overlap]]\nl_star = 2\nw_star = 3\nr_star = 0.6\nplugins = [\"nowhere/libx.so\"]\n";
    let error = Plan::parse(text, &file.to_string_lossy())
        .expect_err("no such file")
        .to_string();
    assert!(
        error.contains(":5:") && error.contains("nowhere/libx.so"),
        "{error}"
    );
}

#[test]
fn the_example_plugins_pass_the_check_and_are_timed_beside_the_built_ins() {
    let (_dir, plan) = plan_with(&[plugin_fixtures::C_OCSI, plugin_fixtures::C_ARVO], "");
    let plan = plan.expect("valid");
    let records = jobs::run(only_job(&plan), 0).expect("the examples are right");
    let acceptance = |name: &str| {
        let record = records
            .iter()
            .find(|r| r.get("algorithm").and_then(|a| a.as_str()) == Some(name))
            .unwrap_or_else(|| panic!("a timing of {name}: {records:?}"));
        assert!(record["ns_per_check"].as_f64().is_some_and(|ns| ns > 0.0));
        assert_eq!(
            record["block_ns_per_check"].as_array().map(Vec::len),
            Some(20)
        );
        record["acceptance"].as_f64().expect("a number")
    };
    // Same sets: the C kernels find the pairs the built-in ones find.
    let ocsi = acceptance("ocsi");
    assert!((ocsi - 0.4).abs() < 0.03, "{ocsi}");
    assert!((acceptance("c_ocsi") - ocsi).abs() < 1e-3);
    assert!((acceptance("c_arvo") - acceptance("arvo")).abs() < 1e-3);
    assert_eq!(records.len(), 4 + 1, "4 timings and the point record");
}

#[test]
fn a_wrong_plugin_is_refused_naming_the_configuration_and_is_never_timed() {
    let (_dir, plan) = plan_with(&[plugin_fixtures::ALWAYS_OVERLAP], "");
    let plan = plan.expect("valid: its verdicts are checked when it runs");
    let error = jobs::run(only_job(&plan), 0)
        .expect_err("always 1 is wrong")
        .to_string();
    assert!(error.contains("always_overlap: wrong verdict"), "{error}");
    assert!(
        error.contains("says overlap where Eq. 2 says no overlap"),
        "{error}"
    );
    assert!(
        error.contains("r_sc = [") && error.contains("axes = [["),
        "{error}"
    );
    assert!(error.contains("radius = 0.6"), "{error}");
}

#[test]
fn a_plugin_changed_after_the_plan_is_refused_by_the_job() {
    let (dir, plan) = plan_with(&[plugin_fixtures::C_OCSI], "");
    let plan = plan.expect("valid");
    std::fs::copy(
        plugin_fixtures::C_ARVO,
        dir.path().join("plugins/libc_ocsi.so"),
    )
    .expect("replaced");
    let error = jobs::run(only_job(&plan), 0)
        .expect_err("another file")
        .to_string();
    assert!(error.contains("changed since the plan was read"), "{error}");
    assert!(error.contains("libc_ocsi.so"), "{error}");
}
