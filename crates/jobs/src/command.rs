//! Program jobs (`[[command]]`): a foreign program run once per point, its result read from
//! its stdout.
//!
//! A point is the program's absolute path, its BLAKE3 content hash, its arguments after
//! substitution and its parameters: a rebuilt program is a new point, never mistaken for the
//! old one. Before running, the program is hashed again; another hash refuses the job.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

use regex::Regex;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};

use crate::child::{self, End};
use crate::run::{JobError, Record};

/// One run of a foreign program.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CommandSpec {
    /// Names the program in reports.
    pub label: String,
    /// Absolute path, resolved when the plan was read.
    pub program: String,
    /// BLAKE3 of the program's bytes when the plan was read (lowercase hex).
    pub program_hash: String,
    /// The arguments, `{key}` already substituted.
    pub args: Vec<String>,
    /// The swept parameters of this point (`seed` always among them).
    pub params: BTreeMap<String, Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timeout_s: Option<f64>,
    /// Value name → regex with one capture group; empty: the last JSON line is the result.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub values: BTreeMap<String, String>,
}

/// BLAKE3 of a file's bytes, lowercase hex.
pub(crate) fn hash_file(path: &Path) -> std::io::Result<String> {
    let mut hasher = blake3::Hasher::new();
    hasher.update_reader(std::fs::File::open(path)?)?;
    Ok(hasher.finalize().to_hex().to_string())
}

/// Runs the program on the calling thread's cores and returns its one record:
/// `{"label", "wall_s", "cpu_s", "exit_status", "program_hash", "values": {name: number}}`.
pub(crate) fn run_command(spec: &CommandSpec) -> Result<Vec<Record>, JobError> {
    let fail = |reason: String| JobError::Command {
        label: spec.label.clone(),
        reason,
    };
    let program = Path::new(&spec.program);
    let hash = hash_file(program)
        .map_err(|e| fail(format!("cannot read the program {}: {e}", spec.program)))?;
    if hash != spec.program_hash {
        return Err(fail(format!(
            "the program {} has BLAKE3 {hash} here, the plan was read with {}: not run \
             (resubmit the plan to measure this build)",
            spec.program, spec.program_hash
        )));
    }
    let timeout = spec.timeout_s.map(Duration::from_secs_f64);
    let outcome = child::run(program, &spec.args, timeout)
        .map_err(|e| fail(format!("cannot run {}: {e}", spec.program)))?;
    let with_stderr = |reason: String| {
        if outcome.stderr_tail.is_empty() {
            fail(format!("{reason} (stderr empty)"))
        } else {
            fail(format!(
                "{reason}; last lines of stderr: {}",
                outcome.stderr_tail.join(" | ")
            ))
        }
    };
    match outcome.end {
        End::Exited(0) => {}
        End::Exited(code) => return Err(with_stderr(format!("exit status {code}"))),
        End::Signalled(signal) => {
            return Err(with_stderr(format!(
                "killed by {}",
                child::signal_name(signal)
            )));
        }
        End::TimedOut => {
            return Err(with_stderr(format!(
                "timed out after {} s (its process group was killed)",
                spec.timeout_s.unwrap_or(0.0)
            )));
        }
    }
    let stdout = String::from_utf8_lossy(&outcome.stdout);
    let values = if spec.values.is_empty() {
        last_json_values(&stdout)
    } else {
        regex_values(&stdout, &spec.values)
    }
    .map_err(|reason| {
        if outcome.stdout_truncated {
            with_stderr(format!("{reason} (stdout was cut at its first 64 MiB)"))
        } else {
            with_stderr(reason)
        }
    })?;
    let mut record = Map::new();
    record.insert("label".into(), json!(spec.label));
    record.insert("wall_s".into(), json!(outcome.wall_s));
    record.insert("cpu_s".into(), json!(outcome.cpu_s));
    record.insert("exit_status".into(), json!(0));
    record.insert("program_hash".into(), json!(hash));
    record.insert("values".into(), Value::Object(values));
    Ok(vec![record])
}

/// The numeric fields of the last stdout line that parses as a JSON object.
fn last_json_values(stdout: &str) -> Result<Map<String, Value>, String> {
    let object = stdout
        .lines()
        .rev()
        .find_map(|line| match serde_json::from_str::<Value>(line.trim()) {
            Ok(Value::Object(object)) => Some(object),
            _ => None,
        })
        .ok_or("no result: no line of stdout is a JSON object")?;
    let numbers: Map<String, Value> = object
        .into_iter()
        .filter(|(_, v)| v.as_f64().is_some_and(f64::is_finite))
        .collect();
    if numbers.is_empty() {
        return Err("no result: the last JSON line of stdout has no numeric field".to_owned());
    }
    Ok(numbers)
}

/// Each regex's capture group, at its last match over stdout, as a number.
fn regex_values(
    stdout: &str,
    patterns: &BTreeMap<String, String>,
) -> Result<Map<String, Value>, String> {
    let mut values = Map::new();
    for (name, pattern) in patterns {
        let regex = Regex::new(pattern).map_err(|e| format!("value `{name}`: bad regex: {e}"))?;
        let text = regex
            .captures_iter(stdout)
            .last()
            .and_then(|c| c.get(1))
            .ok_or_else(|| format!("no result: value `{name}`: /{pattern}/ matches nothing"))?
            .as_str();
        let x: f64 = text
            .trim()
            .parse()
            .ok()
            .filter(|x: &f64| x.is_finite())
            .ok_or_else(|| format!("value `{name}`: `{text}` is not a number"))?;
        values.insert(name.clone(), json!(x));
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_json_object_line_is_the_result() {
        let out = "{\"a\": 1}\nnoise\n{\"tau\": 2.5, \"name\": \"x\", \"n\": 3}\n[1, 2]\n";
        let values = last_json_values(out).expect("found");
        assert_eq!(Value::Object(values), json!({"tau": 2.5, "n": 3}));
        assert!(last_json_values("nothing here\n").is_err());
        assert!(last_json_values("{\"name\": \"x\"}\n").is_err());
    }

    #[test]
    fn regexes_take_their_group_at_the_last_match() {
        let patterns: BTreeMap<String, String> =
            [("tau".to_owned(), "tau: ([0-9.eE+-]+)".to_owned())].into();
        let values = regex_values("tau: 1\ntau: 2e-3\n", &patterns).expect("matches");
        assert_eq!(values["tau"], json!(2e-3));
        let error = regex_values("nothing", &patterns).expect_err("no match");
        assert!(error.contains("matches nothing"), "{error}");
    }
}
