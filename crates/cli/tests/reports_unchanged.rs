//! Every report of one campaign database, as saved: `fixtures/reports-campaign.db` (made by
//! `sweep run fixtures/reports-campaign.toml`, real records of every kind the reports read: overlap
//! points in both precisions with visits and verdict checks, EDMD runs over every swept knob,
//! superquadrics, a point that failed for good) is read by every report, as JSON, Markdown and
//! SVG, and by the status page; each output must equal the one saved in `fixtures/reports/`,
//! byte for byte. So a change of how results are read, estimated or drawn cannot pass unseen, and
//! a database written by an older `sweep` stays readable once migrated.
//!
//! A change that is meant to alter a report re-saves the outputs with `SWEEP_BLESS=1 cargo test
//! -p cli --test reports_unchanged` and shows the difference in its commit. On a mismatch the
//! output is written next to the test's temporary files and named in the failure.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

const SWEEP: &str = env!("CARGO_BIN_EXE_sweep");

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

/// A copy of the fixture database, migrated to this version's schema as `sweep run` or `sweep
/// coordinator` migrates a database written by an older `sweep` (read-only commands refuse an
/// outdated schema and say so).
fn database(dir: &Path) -> PathBuf {
    let db = dir.join("campaign.db");
    std::fs::copy(fixtures().join("reports-campaign.db"), &db).expect("the fixture database");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(async {
        let store = store::Store::open(&db).await.expect("migrated");
        store.close().await;
    });
    db
}

/// `actual` against `fixtures/reports/NAME`, or saved there with `SWEEP_BLESS=1`.
fn check(name: &str, actual: &[u8]) {
    let expected_path = fixtures().join("reports").join(name);
    if std::env::var_os("SWEEP_BLESS").is_some() {
        std::fs::create_dir_all(expected_path.parent().unwrap()).unwrap();
        std::fs::write(&expected_path, actual).unwrap();
        return;
    }
    let expected = std::fs::read(&expected_path)
        .unwrap_or_else(|e| panic!("{}: {e}", expected_path.display()));
    if expected != actual {
        let got = Path::new(env!("CARGO_TARGET_TMPDIR")).join("reports-unchanged");
        std::fs::create_dir_all(&got).unwrap();
        let got = got.join(name);
        std::fs::write(&got, actual).unwrap();
        let (expected, actual) = (
            String::from_utf8_lossy(&expected),
            String::from_utf8_lossy(actual),
        );
        let line = expected
            .lines()
            .zip(actual.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(expected.lines().count().min(actual.lines().count()));
        panic!(
            "{name} differs from {} at line {} (got {}):\n  saved: {:?}\n  now:   {:?}",
            expected_path.display(),
            line + 1,
            got.display(),
            expected.lines().nth(line).unwrap_or("(end)"),
            actual.lines().nth(line).unwrap_or("(end)"),
        );
    }
}

/// Runs `sweep ARGS`, which must succeed: its stdout, and the lines of its stderr a user reads
/// (what is missing, notes), without logs.
fn sweep(args: &[&str]) -> (Vec<u8>, Vec<u8>) {
    let out = Command::new(SWEEP)
        .args(args)
        .env_remove("RUST_LOG")
        .output()
        .expect("the sweep binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "sweep {args:?}: {stderr}");
    let said: String = stderr
        .lines()
        .filter(|l| {
            ["missing:", "note:", "warning:"]
                .iter()
                .any(|p| l.starts_with(p))
        })
        .map(|l| format!("{l}\n"))
        .collect();
    (out.stdout, said.into_bytes())
}

#[test]
fn every_report_of_the_fixture_database_is_as_saved() {
    let dir = tempfile::tempdir().unwrap();
    let db = database(dir.path());
    let db = db.to_str().unwrap();
    for name in [
        "table1", "table2", "fig2", "fig3", "fig8", "fig9", "fig10", "fig11", "fig13", "accuracy",
    ] {
        let (json, said) = sweep(&["report", name, "--db", db, "--format", "json"]);
        check(&format!("{name}.json"), &json);
        check(&format!("{name}.stderr"), &said);
    }
    for (name, extension) in [("table1", "md"), ("table2", "tex"), ("accuracy", "md")] {
        let out = dir.path().join(format!("{name}.{extension}"));
        sweep(&["report", name, "--db", db, "--out", out.to_str().unwrap()]);
        check(
            &format!("{name}.{extension}"),
            &std::fs::read(&out).unwrap(),
        );
    }
    for name in [
        "fig2", "fig3", "fig7", "fig8", "fig9", "fig10", "fig11", "fig13", "accuracy",
    ] {
        let out = dir.path().join(format!("{name}.svg"));
        sweep(&["report", name, "--db", db, "--out", out.to_str().unwrap()]);
        check(&format!("{name}.svg"), &std::fs::read(&out).unwrap());
    }
    let (status, _) = sweep(&["status", "--db", db, "--format", "json"]);
    check("status.json", &status);
}

/// A coordinator serving the status page; killed when dropped.
struct Coordinator(Child);

impl Drop for Coordinator {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// One GET on a fresh connection: the body of a 200 answer.
fn get(addr: &str, path: &str) -> Vec<u8> {
    use std::io::{Read, Write};
    let mut stream = std::net::TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .unwrap();
    let request = format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    stream.write_all(request.as_bytes()).unwrap();
    let mut response = Vec::new();
    stream.read_to_end(&mut response).unwrap();
    let split = response
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("an HTTP answer");
    let head = String::from_utf8_lossy(&response[..split]);
    assert!(head.starts_with("HTTP/1.1 200"), "GET {path}: {head}");
    response[split + 4..].to_vec()
}

#[test]
fn the_status_page_shows_the_fixture_database_as_saved() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let db = database(dir.path());
    let mut child = Command::new(SWEEP)
        .args([
            "coordinator",
            "--listen",
            "127.0.0.1:0",
            "--http",
            "127.0.0.1:0",
            "--db",
        ])
        .arg(&db)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("the sweep binary runs");
    let stdout = child.stdout.take().unwrap();
    let _coordinator = Coordinator(child);
    let page = std::io::BufReader::new(stdout)
        .lines()
        .map_while(Result::ok)
        .find_map(|l| l.strip_prefix("status page on http://").map(str::to_owned))
        .expect("the page's address on stdout");
    let addr = page.trim_end_matches('/');
    // What changes with the clock of the sample: when it was taken, what it cost, how long ago
    // the worker was seen.
    let mut snapshot: serde_json::Value =
        serde_json::from_slice(&get(addr, "/api/snapshot")).unwrap();
    for volatile in ["taken_at", "sample_s", "next_sample_in_s"] {
        snapshot.as_object_mut().unwrap().remove(volatile);
    }
    for worker in snapshot["workers"].as_array_mut().unwrap() {
        worker.as_object_mut().unwrap().remove("heartbeat_age_s");
    }
    let text = serde_json::to_string_pretty(&snapshot).unwrap() + "\n";
    check("page-snapshot.json", text.as_bytes());
    // The page draws with `sweep report`'s code: the same bytes as the command's outputs.
    for table in ["table1", "table2"] {
        check(
            &format!("{table}.json"),
            &get(addr, &format!("/api/tables/{table}.json")),
        );
    }
    for figure in ["fig2", "fig3", "fig7", "fig13"] {
        check(
            &format!("{figure}.svg"),
            &get(addr, &format!("/api/figures/{figure}.svg")),
        );
    }
}
