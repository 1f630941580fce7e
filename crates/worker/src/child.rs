//! Jobs that run code from outside this build ([`jobs::JobSpec::runs_foreign_code`]: overlap
//! points with C plugins) run in a child process, so that a plugin that crashes fails its job
//! and the worker goes on. The child is a fresh `exec` of the worker's own executable (never a
//! `fork` of this multi-threaded process), told by [`RUN_JOB`] to run one job: its spec (JSON)
//! on stdin, its records (a JSON array) on stdout, an error as its exit status and last lines of
//! stderr. Spawned from the slot's pinned thread, the child inherits that thread's core (Linux
//! gives a child its parent thread's affinity mask), and is told to use one thread.

use std::io::{Read, Write};
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Command, Stdio};

use jobs::{JobSpec, signal_name};

/// The hidden subcommand of the executable that runs one job as a child.
pub const RUN_JOB: &str = "__run-job";
/// What a failed child's error quotes of its stderr, at most.
const STDERR_TAIL: usize = 2000;

/// Runs the job of `params_json` (attempt `attempt`) in a child: `exe __run-job --attempt N`.
/// Its records as JSON objects, or why it failed: the job's error as the child printed it, or
/// the signal that killed it (`SIGSEGV`, `SIGABRT` …), with the tail of its stderr.
pub fn run_in_child(exe: &Path, params_json: &str, attempt: u32) -> Result<Vec<String>, String> {
    let mut child = Command::new(exe)
        .args([RUN_JOB, "--attempt", &attempt.to_string()])
        .env("RAYON_NUM_THREADS", "1")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {} {RUN_JOB}: {e}", exe.display()))?;
    // The spec is small (well below a pipe's buffer), so writing it all before reading cannot
    // deadlock; the pipe closes when `stdin` is dropped.
    if let Some(mut stdin) = child.stdin.take() {
        stdin
            .write_all(params_json.as_bytes())
            .map_err(|e| format!("cannot hand the job to its child process: {e}"))?;
    }
    let output = child
        .wait_with_output()
        .map_err(|e| format!("lost the job's child process: {e}"))?;
    let stderr = tail(&String::from_utf8_lossy(&output.stderr));
    if let Some(signal) = output.status.signal() {
        return Err(format!(
            "the job's process was killed by {} (foreign code crashed){}",
            signal_name(signal),
            quoted(&stderr)
        ));
    }
    if !output.status.success() {
        return Err(if stderr.is_empty() {
            format!("the job's process exited with {}", output.status)
        } else {
            stderr
        });
    }
    let records: Vec<serde_json::Value> = serde_json::from_slice(&output.stdout)
        .map_err(|e| format!("the job's process wrote no records: {e}{}", quoted(&stderr)))?;
    records
        .into_iter()
        .map(|record| match record {
            serde_json::Value::Object(_) => Ok(record.to_string()),
            other => Err(format!(
                "the job's process wrote a record that is not an object: {other}"
            )),
        })
        .collect()
}

/// The child's side: reads one job (JSON) from `input`, runs it on this thread, writes its
/// records to `output` as a JSON array. An error is returned for the caller to print on
/// stderr and exit non-zero.
pub fn serve(input: &mut impl Read, output: &mut impl Write, attempt: u32) -> Result<(), String> {
    let mut text = String::new();
    input
        .read_to_string(&mut text)
        .map_err(|e| format!("cannot read the job on stdin: {e}"))?;
    let spec: JobSpec =
        serde_json::from_str(&text).map_err(|e| format!("unreadable job on stdin: {e}"))?;
    let records = jobs::run(&spec, attempt).map_err(|e| e.to_string())?;
    serde_json::to_writer(&mut *output, &records)
        .map_err(|e| format!("cannot write the records: {e}"))?;
    output
        .flush()
        .map_err(|e| format!("cannot write the records: {e}"))
}

fn quoted(stderr: &str) -> String {
    if stderr.is_empty() {
        String::new()
    } else {
        format!("; its stderr ended: {stderr}")
    }
}

/// The last [`STDERR_TAIL`] bytes of `text` (on a character boundary), trimmed.
fn tail(text: &str) -> String {
    let text = text.trim();
    let mut start = text.len().saturating_sub(STDERR_TAIL);
    while !text.is_char_boundary(start) {
        start += 1;
    }
    text[start..].to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_noop_job_round_trips_through_the_childs_side() {
        let spec = r#"{"kind":"noop","index":4,"duration_ms":0,"fail_rate":0}"#;
        let mut out = Vec::new();
        serve(&mut spec.as_bytes(), &mut out, 1).expect("runs");
        let records: serde_json::Value = serde_json::from_slice(&out).expect("JSON");
        assert_eq!(records, serde_json::json!([{"index": 4, "duration_ms": 0}]));
        let failing = r#"{"kind":"noop","index":4,"duration_ms":0,"fail_rate":1}"#;
        let error = serve(&mut failing.as_bytes(), &mut Vec::new(), 1).expect_err("fails");
        assert!(error.contains("injected failure"), "{error}");
    }

    #[test]
    fn a_failed_child_is_named_by_its_stderr() {
        // (A child killed by a signal: `crates/cli/tests/plugins.rs`, with a crashing plugin.)
        let error = run_in_child(Path::new("/bin/sh"), "", 1).expect_err("sh fails");
        // `sh __run-job …` finds no script `__run-job`: an exit status, with sh's complaint.
        assert!(error.contains("__run-job"), "{error}");
        assert_eq!(signal_name(11), "SIGSEGV");
        assert_eq!(signal_name(6), "SIGABRT");
        assert_eq!(signal_name(77), "signal 77");
        assert_eq!(tail(&"é".repeat(3000)).len(), 2000);
    }
}
