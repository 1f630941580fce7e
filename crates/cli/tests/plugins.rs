//! Overlap plugins as a user meets them: `sweep run` on a plan whose points time the example C
//! plugins, a wrong one and a crashing one, in real processes (the crashing plugin takes down
//! only its job's child process).

use std::path::Path;
use std::process::{Command, Output};

fn sweep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(args)
        .output()
        .expect("the sweep binary runs")
}

/// One sweep of the plan: a point at `l_star` timing `algorithms` and `plugins`.
fn sweep_table(l_star: u32, precision: &str, plugins: &[&str]) -> String {
    let names: Vec<String> = plugins
        .iter()
        .map(|p| {
            format!(
                "\"plugins/{}\"",
                Path::new(p).file_name().unwrap().to_string_lossy()
            )
        })
        .collect();
    format!(
        "[[overlap]]\nl_star = {l_star}\nw_star = 3\nr_star = 0.6\nconfigurations = 20000\n\
         repeats = 2\nprecision = \"{precision}\"\nalgorithms = [\"ocsi\", \"arvo\"]\nplugins = [{}]\n",
        names.join(", ")
    )
}

#[test]
fn a_crashing_and_a_wrong_plugin_fail_their_points_while_the_campaign_finishes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("plugins")).unwrap();
    let all = [
        plugin_fixtures::C_OCSI,
        plugin_fixtures::C_ARVO,
        plugin_fixtures::SEGFAULT,
        plugin_fixtures::ALWAYS_OVERLAP,
    ];
    for plugin in all {
        let name = Path::new(plugin).file_name().unwrap();
        std::fs::copy(plugin, dir.path().join("plugins").join(name)).unwrap();
    }
    let examples = [plugin_fixtures::C_OCSI, plugin_fixtures::C_ARVO];
    let plan = [
        "name = \"plugins\"\n".to_owned(),
        sweep_table(2, "f64", &examples),
        sweep_table(5, "f64", &[plugin_fixtures::SEGFAULT]),
        sweep_table(3, "f64", &examples),
        sweep_table(4, "f32", &[plugin_fixtures::ALWAYS_OVERLAP]),
    ]
    .concat();
    let plan_file = dir.path().join("plan.toml");
    std::fs::write(&plan_file, plan).unwrap();
    let db = dir.path().join("r.db");
    let (plan_file, db) = (plan_file.to_str().unwrap(), db.to_str().unwrap());

    let out = sweep(&["run", plan_file, "--db", db, "--format", "json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "two points fail");
    assert!(stderr.contains("2 points failed"), "{stderr}");
    let status: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON status");
    assert_eq!(status["status"]["done"], 2, "{status}");
    assert_eq!(status["status"]["failed"], 2, "{status}");

    // Why each failed, as stored.
    let out = sweep(&[
        "query",
        "--db",
        db,
        "--format",
        "json",
        "SELECT last_error FROM jobs WHERE state = 'failed' ORDER BY last_error",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    let errors: Vec<&str> = rows
        .iter()
        .map(|r| r["last_error"].as_str().unwrap())
        .collect();
    assert_eq!(errors.len(), 2, "{errors:?}");
    let wrong = errors
        .iter()
        .find(|e| e.contains("always_overlap"))
        .expect("the wrong one");
    assert!(wrong.contains("wrong verdict, not timed"), "{wrong}");
    assert!(
        wrong.contains("r_sc = [") && wrong.contains("radius = 0.6"),
        "{wrong}"
    );
    let crashed = errors
        .iter()
        .find(|e| e.contains("SIGSEGV"))
        .expect("the crashing one");
    assert!(crashed.contains("libsegfault.so"), "{crashed}");

    // The examples have their columns beside the built-in kernels, from the same sets.
    let out = sweep(&["report", "table2", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let text = table.to_string();
    for name in ["\"ocsi\"", "\"arvo\"", "\"c_ocsi\"", "\"c_arvo\""] {
        assert!(text.contains(name), "{name} in {text}");
    }
    assert!(
        !text.contains("segfault"),
        "a crashed plugin has no column: {text}"
    );
    // … and their rows of panels in Fig. 3 (f64).
    let out = sweep(&["report", "fig3", "--db", db, "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let points: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let text = points.to_string();
    assert!(
        text.contains("\"c_ocsi\"") && text.contains("\"c_arvo\""),
        "{text}"
    );
}
