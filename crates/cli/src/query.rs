//! `sweep query` and `sweep export`: a result database as rows, for other tools.

use std::collections::BTreeSet;
use std::path::PathBuf;

use clap::Args;

use crate::database;
use crate::output::{Format, print_json, print_table, write_csv};

#[derive(Args)]
pub struct QueryArgs {
    /// SQL over the results, e.g. `SELECT algorithm, avg(ns_per_check) FROM overlap_timings GROUP BY 1`.
    sql: String,
    #[arg(long)]
    db: PathBuf,
}

fn cell(value: &serde_json::Value) -> String {
    match value {
        serde_json::Value::Null => String::new(),
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

pub fn query(args: &QueryArgs, format: Format) -> anyhow::Result<()> {
    let result = database::read(&args.db, async |store| {
        Ok(store.query_read_only(&args.sql).await?)
    })?;
    match format {
        Format::Json => {
            let objects: Vec<serde_json::Map<String, serde_json::Value>> = result
                .rows
                .iter()
                .map(|row| {
                    result
                        .columns
                        .iter()
                        .cloned()
                        .zip(row.iter().cloned())
                        .collect()
                })
                .collect();
            print_json(&objects)
        }
        Format::Csv => write_csv(
            &result.columns,
            result.rows.iter().map(|r| r.iter().map(cell).collect()),
        ),
        Format::Table => {
            let header: Vec<&str> = result.columns.iter().map(String::as_str).collect();
            let rows: Vec<Vec<String>> = result
                .rows
                .iter()
                .map(|r| r.iter().map(cell).collect())
                .collect();
            print_table(&header, &rows);
            Ok(())
        }
    }
}

#[derive(Args)]
pub struct ExportArgs {
    #[arg(long)]
    db: PathBuf,
}

/// One row per result record: the identifying columns first, then the union of all fields.
pub fn export(args: &ExportArgs, format: Format) -> anyhow::Result<()> {
    let rows = database::read(&args.db, async |store| Ok(store.export().await?))?;
    let flat: Vec<serde_json::Map<String, serde_json::Value>> = rows
        .into_iter()
        .map(|row| {
            let mut out = serde_json::Map::new();
            out.insert("job_id".into(), row.job_id.into());
            out.insert("campaign".into(), row.campaign.into());
            out.insert("kind".into(), row.kind.into());
            out.insert("attempt".into(), row.attempt.into());
            out.insert("worker".into(), row.worker.into());
            out.insert("core_id".into(), row.core_id.into());
            out.extend(row.fields);
            out
        })
        .collect();
    match format {
        Format::Json => print_json(&flat),
        Format::Csv | Format::Table => {
            let fixed = ["job_id", "campaign", "kind", "attempt", "worker", "core_id"];
            let extra: BTreeSet<&String> = flat
                .iter()
                .flat_map(|r| r.keys())
                .filter(|k| !fixed.contains(&k.as_str()))
                .collect();
            let columns: Vec<String> = fixed
                .iter()
                .map(|s| s.to_string())
                .chain(extra.into_iter().cloned())
                .collect();
            let rows = flat.iter().map(|r| {
                columns
                    .iter()
                    .map(|c| r.get(c).map(cell).unwrap_or_default())
                    .collect()
            });
            write_csv(&columns, rows)
        }
    }
}
