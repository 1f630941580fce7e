//! Program jobs read back: each done job's parameters (the [`jobs::CommandSpec`] it was
//! submitted as) and its one record (`jobs::run`: `label`, `wall_s`, `cpu_s`, `exit_status`,
//! `program_hash`, `values`).

use std::collections::BTreeMap;

use jobs::JobSpec;
use report::CommandRow;
use serde::Deserialize;
use store::Store;

use crate::error::{Result, corrupt};

#[derive(Deserialize)]
struct CommandRecord {
    wall_s: f64,
    cpu_s: f64,
    program_hash: String,
    values: BTreeMap<String, f64>,
}

/// Every done program job, in submission order.
pub async fn command_runs(store: &Store) -> Result<Vec<CommandRow>> {
    store
        .results_of("command")
        .await?
        .into_iter()
        .map(|job| {
            let spec = match serde_json::from_str(&job.params_json) {
                Ok(JobSpec::Command(spec)) => spec,
                Ok(other) => {
                    return Err(corrupt(
                        "command",
                        &job.job_id,
                        format!("its parameters are a {} job's", other.kind()),
                    ));
                }
                Err(e) => {
                    return Err(corrupt(
                        "command",
                        &job.job_id,
                        format!("unreadable parameters: {e}"),
                    ));
                }
            };
            let [record] = job.records.as_slice() else {
                return Err(corrupt(
                    "command",
                    &job.job_id,
                    format!("{} records where a run writes one", job.records.len()),
                ));
            };
            let r: CommandRecord = serde_json::from_str(record)
                .map_err(|e| corrupt("command", &job.job_id, format!("malformed record: {e}")))?;
            Ok(CommandRow {
                job_id: job.job_id,
                label: spec.label,
                params: spec.params,
                program_hash: r.program_hash,
                wall_s: r.wall_s,
                cpu_s: r.cpu_s,
                values: r.values,
            })
        })
        .collect()
}
