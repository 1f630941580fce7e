//! Running one job on the calling thread and flattening its result into records.

use std::cell::RefCell;
use std::thread::sleep;
use std::time::{Duration, Instant};

use overlap::foreign::check_foreign;
use overlap::{Calibration, OverlapError, Plugins, PointSpec, Precision, run_point_with};
use serde_json::{Map, Value, json};

use crate::command::run_command;
use crate::plugin::{Loaded, PluginError};
use crate::spec::{JobSpec, NoopSpec};

/// One result record: field name → JSON value (scalars, and the array of an overlap pass's block
/// times).
pub type Record = Map<String, Value>;

#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The overlap spec is out of its domain (it was not validated by a plan) or cannot run.
    #[error("overlap: {0}")]
    Overlap(#[from] OverlapError),
    /// A plugin of the point cannot be used (gone, changed, lacks the point's precision …).
    #[error("overlap: {0}")]
    Plugin(#[from] PluginError),
    /// Two plugins of one point report the same name.
    #[error("overlap: plugins {first} and {second} both call themselves `{name}`")]
    PluginNames {
        name: String,
        first: String,
        second: String,
    },
    /// The scene cannot be simulated, or a solver could not resolve a contact.
    #[error("edmd: {0}")]
    Edmd(#[from] edmd::EdmdError),
    /// The state file an EDMD point starts from cannot be read, or changed since the plan.
    #[error("edmd: from_state: {0}")]
    State(String),
    /// A result that does not serialise as a record (a JSON object).
    #[error("{kind}: the result is not a JSON object")]
    NotARecord { kind: &'static str },
    #[error("noop: fail_rate must lie in [0, 1], got {0}")]
    NoopFailRate(f64),
    /// A program job that could not run, or ran and gave no result: the reason (exit status,
    /// signal, timeout, missing values, another hash) and the last lines of its stderr.
    #[error("command `{label}`: {reason}")]
    Command { label: String, reason: String },
    /// The failure a no-op job was asked to produce.
    #[error("noop job {index}: injected failure on attempt {attempt} (fail_rate {fail_rate})")]
    Injected {
        index: u64,
        attempt: u32,
        fail_rate: f64,
    },
}

/// Runs `spec` on the calling thread (pin it first: the overlap loops are timed there) and
/// returns its records. `attempt` counts from 0 or 1 as the caller likes; only no-op jobs use
/// it, to decide their injected failure.
///
/// Records of an overlap job: one per (algorithm, repeat), in run order,
/// `{"algorithm", "repeat", "ms", "ns_per_check", "acceptance", "total_ms", "block_ns_per_check"}`
/// (`ns_per_check` the 5th percentile of the pass's blocks and `ms` that × N_c; `total_ms` the whole
/// pass; `block_ns_per_check` every block, to 4 significant digits; acceptance as measured),
/// then one point record, the only one without an `algorithm` key:
/// `{"stream_ns_per_config", "generation_ms", "arrays_bytes", "rho", "block_configurations",
/// "repeats", "stop", "timed_s", "wall_s", "reference_compute_ns_before",
/// "reference_compute_ns_after", "reference_compute_ns_baseline", "reference_stream_ns_before",
/// "reference_stream_ns_after", "reference_stream_ns_baseline", "core_share", "disturbed",
/// "disturbance", "reruns", "rerun_reasons"}` (see
/// [`overlap::PointReport`]; `disturbed` is true when the machine was still disturbed after the
/// re-runs, `disturbance` says how), and with `verdict_check` a `verdicts` object
/// ([`overlap::verdicts::VerdictCheck`]: the checking set's verdicts against the exact ones).
/// A no-op job: one record `{"index", "duration_ms"}`.
/// An EDMD job: one record, the fields of `edmd::RunReport` plus `wall_s`, `cpu_s` and
/// `sequence_fingerprint` (the collision sequence's blocks as hex, [`edmd::sequence`]) with
/// `sequence_block`, the collisions per block.
/// A program job: one record `{"label", "wall_s", "cpu_s", "exit_status", "program_hash",
/// "values"}` (`values`: name → number), its program spawned from the calling thread so that it
/// runs on the same cores.
pub fn run(spec: &JobSpec, attempt: u32) -> Result<Vec<Record>, JobError> {
    match spec {
        JobSpec::Overlap(point) => run_overlap(point, spec.generator_seed()),
        JobSpec::Noop(noop) => run_noop(noop, &spec.id(), attempt),
        JobSpec::Edmd(scene) => run_edmd(scene),
        JobSpec::Command(command) => run_command(command),
    }
}

/// An EDMD job: one record, the run report (`collisions`, `tau_c_us`, `pressure_z`, …) and
/// the job's own `wall_s` and `cpu_s` (this thread's CPU time: below the wall time when the
/// core was shared).
fn run_edmd(scene: &edmd::Scene) -> Result<Vec<Record>, JobError> {
    let (wall, cpu) = (Instant::now(), edmd::clock::thread_cpu_seconds());
    let hooks = edmd::Hooks {
        from: crate::states::start_of(scene).map_err(JobError::State)?,
        ..edmd::Hooks::default()
    };
    let mut report = edmd::run_with_hooks(scene, &mut |_| {}, hooks)?.0;
    let (wall_s, cpu_s) = (
        wall.elapsed().as_secs_f64(),
        edmd::clock::thread_cpu_seconds() - cpu,
    );
    let report_sequence = std::mem::take(&mut report.sequence);
    match serde_json::to_value(report) {
        Ok(Value::Object(mut record)) => {
            record.insert("wall_s".into(), json!(wall_s));
            record.insert("cpu_s".into(), json!(cpu_s));
            record.insert(
                "sequence_fingerprint".into(),
                json!(report_sequence.to_hex()),
            );
            record.insert("sequence_block".into(), json!(edmd::sequence::BLOCK));
            Ok(vec![record])
        }
        _ => Err(JobError::NotARecord { kind: "edmd" }),
    }
}

thread_local! {
    /// What this thread measured of its core over its recent points: a worker slot is one
    /// pinned thread, so this is the slot's core.
    static CALIBRATION: RefCell<Calibration> = RefCell::new(Calibration::default());
}

/// `x` to 4 significant digits: block times are stored in bulk, and their noise is far above
/// 0.05 %.
fn four_digits(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(3 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// Mixed into a point's generator seed for its checking set, independent of the timed sets.
const VERDICT_SEED: u64 = 0x7665_7264_6963_7473;

/// Configurations of a plugin's check before timing when the point sets no `verdict_check`
/// (half bulk, half near-contact shell): about 0.1 s, and every decade of the shell's gaps
/// gets thousands of them.
const PLUGIN_CHECK: u64 = 100_000;

/// The kernels of the point's plugins in its precision, from `libraries` (one per plugin, in
/// order); two plugins may not share a name (it is their column).
fn load_plugins(point: &PointSpec, libraries: &[Loaded]) -> Result<Plugins, JobError> {
    let mut plugins = Plugins::default();
    let mut names: Vec<(String, &str)> = Vec::new();
    for (library, file) in libraries.iter().zip(&point.plugins) {
        let name = match point.precision {
            Precision::F32 => {
                let kernel = library.foreign::<f32>()?;
                let name = kernel.name().to_owned();
                plugins.f32.push(kernel);
                name
            }
            Precision::F64 => {
                let kernel = library.foreign::<f64>()?;
                let name = kernel.name().to_owned();
                plugins.f64.push(kernel);
                name
            }
        };
        if let Some((_, first)) = names.iter().find(|(n, _)| *n == name) {
            return Err(JobError::PluginNames {
                name,
                first: (*first).to_owned(),
                second: file.path.clone(),
            });
        }
        names.push((name, &file.path));
    }
    Ok(plugins)
}

fn run_overlap(point: &PointSpec, generator_seed: u64) -> Result<Vec<Record>, JobError> {
    let seeded = PointSpec {
        seed: generator_seed,
        ..point.clone()
    };
    // Kept open until the timing is done: the kernels live in them.
    let libraries = point
        .plugins
        .iter()
        .map(Loaded::open_checked)
        .collect::<Result<Vec<Loaded>, PluginError>>()?;
    let plugins = load_plugins(point, &libraries)?;
    // Before any timing: a plugin that answers wrongly is not measured.
    let check = point.verdict_check.unwrap_or(PLUGIN_CHECK);
    let check_seed = generator_seed ^ VERDICT_SEED;
    for kernel in &plugins.f32 {
        check_foreign(&seeded, kernel, check, check_seed)?;
    }
    for kernel in &plugins.f64 {
        check_foreign(&seeded, kernel, check, check_seed)?;
    }
    let report = CALIBRATION.with_borrow_mut(|calibration| {
        run_point_with(&seeded, &plugins, calibration, &mut |_| {})
    })?;
    drop(plugins);
    drop(libraries);
    let mut records: Vec<Record> = report
        .timings
        .iter()
        .map(|t| {
            record([
                ("algorithm", json!(t.algorithm)),
                ("repeat", json!(t.repeat)),
                ("ms", json!(t.ms)),
                ("ns_per_check", json!(t.ns_per_check)),
                ("acceptance", json!(t.acceptance)),
                ("total_ms", json!(t.total_ms)),
                (
                    "block_ns_per_check",
                    json!(
                        t.block_ns_per_check
                            .iter()
                            .map(|&x| four_digits(x))
                            .collect::<Vec<f64>>()
                    ),
                ),
            ])
        })
        .collect();
    let references = report.references;
    // Outside every timed loop, on a set of its own (from its own seed), once the timing is done.
    let verdicts = point
        .verdict_check
        .map(|n| overlap::verdicts::check_verdicts(&seeded, n, generator_seed ^ VERDICT_SEED));
    records.push(record([
        ("stream_ns_per_config", json!(report.stream_ns_per_config)),
        ("generation_ms", json!(report.generation_ms)),
        ("arrays_bytes", json!(report.arrays_bytes)),
        ("rho", json!(report.rho)),
        ("block_configurations", json!(report.block_configurations)),
        ("repeats", json!(report.repeats)),
        ("stop", json!(report.stop)),
        ("timed_s", json!(report.timed_s)),
        ("wall_s", json!(report.wall_s)),
        (
            "reference_compute_ns_before",
            json!(references.compute_ns_before),
        ),
        (
            "reference_compute_ns_after",
            json!(references.compute_ns_after),
        ),
        (
            "reference_compute_ns_baseline",
            json!(references.compute_ns_baseline),
        ),
        (
            "reference_stream_ns_before",
            json!(references.stream_ns_before),
        ),
        (
            "reference_stream_ns_after",
            json!(references.stream_ns_after),
        ),
        (
            "reference_stream_ns_baseline",
            json!(references.stream_ns_baseline),
        ),
        ("core_share", json!(references.core_share)),
        ("disturbed", json!(report.disturbance.is_some())),
        ("disturbance", json!(report.disturbance)),
        ("reruns", json!(report.reruns)),
        ("rerun_reasons", json!(report.rerun_reasons)),
    ]));
    if let (Some(verdicts), Some(point_record)) = (verdicts, records.last_mut()) {
        point_record.insert("verdicts".into(), json!(verdicts));
    }
    Ok(records)
}

fn run_noop(noop: &NoopSpec, id: &str, attempt: u32) -> Result<Vec<Record>, JobError> {
    if !(0.0..=1.0).contains(&noop.fail_rate) {
        return Err(JobError::NoopFailRate(noop.fail_rate));
    }
    sleep(Duration::from_millis(noop.duration_ms));
    if unit_draw(id, attempt) < noop.fail_rate {
        return Err(JobError::Injected {
            index: noop.index,
            attempt,
            fail_rate: noop.fail_rate,
        });
    }
    Ok(vec![record([
        ("index", json!(noop.index)),
        ("duration_ms", json!(noop.duration_ms)),
    ])])
}

/// A number in [0, 1) fixed by (id, attempt): 53 bits of BLAKE3("id:attempt").
fn unit_draw(id: &str, attempt: u32) -> f64 {
    let hash = blake3::hash(format!("{id}:{attempt}").as_bytes());
    let mut first = [0u8; 8];
    first.copy_from_slice(&hash.as_bytes()[..8]);
    (u64::from_le_bytes(first) >> 11) as f64 / (1u64 << 53) as f64
}

fn record<const N: usize>(fields: [(&str, Value); N]) -> Record {
    fields
        .into_iter()
        .map(|(key, value)| (key.to_owned(), value))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use overlap::{Algorithm, Precision};

    fn noop(index: u64, fail_rate: f64) -> JobSpec {
        JobSpec::Noop(NoopSpec {
            index,
            duration_ms: 0,
            fail_rate,
        })
    }

    #[test]
    fn noop_failures_are_reproducible_and_near_the_rate() {
        let mut failures = 0;
        for index in 0..2000 {
            let job = noop(index, 0.25);
            let first = run(&job, 1).map_err(|e| e.to_string());
            assert_eq!(
                first,
                run(&job, 1).map_err(|e| e.to_string()),
                "same (id, attempt), same outcome"
            );
            failures += usize::from(first.is_err());
        }
        assert!(
            (400..=600).contains(&failures),
            "{failures} failures of 2000 at rate 0.25"
        );
        // A retry is a new draw: some job that failed on attempt 1 succeeds on attempt 2.
        assert!((0..200).any(|i| run(&noop(i, 0.5), 1).is_err() && run(&noop(i, 0.5), 2).is_ok()));
        assert!((0..200).all(|i| run(&noop(i, 0.0), 1).is_ok()));
        assert!((0..200).all(|i| run(&noop(i, 1.0), 1).is_err()));
        assert!(matches!(
            run(&noop(0, 1.5), 1),
            Err(JobError::NoopFailRate(1.5))
        ));
    }

    #[test]
    fn four_significant_digits() {
        assert_eq!(four_digits(28.1349), 28.13);
        assert_eq!(four_digits(1.63449), 1.634);
        assert_eq!(four_digits(12345.6), 12350.0);
        assert_eq!(four_digits(0.0), 0.0);
    }

    #[test]
    fn noop_record() {
        let records = run(&noop(7, 0.0), 0).expect("never fails at rate 0");
        assert_eq!(
            Value::Object(records[0].clone()),
            json!({"index": 7, "duration_ms": 0})
        );
    }

    #[test]
    fn overlap_records_follow_the_convention() {
        let job = JobSpec::Overlap(PointSpec {
            l_star: 3.0,
            w_star: 2.0,
            r_star: 0.5,
            acceptance: 0.4,
            configurations: 20_000,
            repeats: 2,
            precision: Precision::F64,
            algorithms: vec![Algorithm::Qri, Algorithm::OcsiBatch],
            seed: 0,
            ci_target: None,
            time_cap_s: None,
            verdict_check: None,
            visit: None,
            plugins: Vec::new(),
        });
        let records = run(&job, 1).expect("a valid point runs");
        assert_eq!(records.len(), 2 * 2 + 1);
        for r in &records[..4] {
            let keys: Vec<&str> = r.keys().map(String::as_str).collect();
            for key in [
                "algorithm",
                "repeat",
                "ms",
                "ns_per_check",
                "acceptance",
                "total_ms",
                "block_ns_per_check",
            ] {
                assert!(keys.contains(&key), "{keys:?}");
            }
            let blocks = r["block_ns_per_check"].as_array().expect("an array");
            assert_eq!(blocks.len(), 20, "20,000 configurations in blocks of 1,024");
            let acceptance = r["acceptance"].as_f64().expect("a number");
            assert!(
                (acceptance - 0.4).abs() < 0.03,
                "measured acceptance {acceptance}"
            );
        }
        let point = &records[4];
        assert!(!point.contains_key("algorithm"));
        assert!(
            point["stream_ns_per_config"]
                .as_f64()
                .is_some_and(|x| x > 0.0)
        );
        assert!(point["arrays_bytes"].as_u64().is_some_and(|b| b > 0));
        assert_eq!(point["repeats"], 2);
        assert_eq!(point["stop"], "repeats");
        assert!(
            point["disturbed"].is_boolean() && point["reruns"].as_u64().is_some_and(|n| n <= 2)
        );
        assert!(
            point["reference_compute_ns_before"]
                .as_f64()
                .is_some_and(|x| x > 0.0)
        );
        // Same point, same configurations: verdicts (acceptances) are reproducible.
        let again = run(&job, 2).expect("runs again");
        assert_eq!(records[0]["acceptance"], again[0]["acceptance"]);
    }
}
