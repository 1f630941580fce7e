//! Overlap jobs' records read back: one [`OverlapVisit`] per (job, algorithm) with what a
//! re-estimate needs, and the verdict checks of the accuracy report.
//!
//! What `jobs::run` writes for an overlap job: one record per (algorithm, repeat), the only ones
//! with an `algorithm` key (`ms`, `ns_per_check`, `acceptance`, and the pass's blocks since they
//! are kept), then one point record (the noise check: `disturbed`, `reruns`; with
//! `verdict_check`, `verdicts`). The job's parameters are the [`jobs::JobSpec`] it was submitted
//! as.

use std::collections::BTreeMap;

use jobs::JobSpec;
use overlap::PointSpec;
use overlap::verdicts::VerdictCheck;
use report::VerdictRow;
use serde::Deserialize;
use store::{JobResults, Store};

use crate::error::{Result, corrupt};

/// One visit of an overlap point (one job) and one algorithm: the means over its repeats, and
/// what a robust re-estimate needs.
#[derive(Debug, Clone, PartialEq)]
pub struct OverlapVisit {
    pub job_id: String,
    pub l_star: f64,
    pub w_star: f64,
    pub r_star: f64,
    pub acceptance_target: f64,
    pub configurations: u64,
    pub precision: String,
    pub algorithm: String,
    pub mean_ms: f64,
    pub ns_per_check: f64,
    /// Measured acceptance (mean over repeats).
    pub acceptance: f64,
    pub repeats: u32,
    /// Each repeat's `ns_per_check`, in no particular order.
    pub repeat_ns_per_check: Vec<f64>,
    /// Each repeat's blocks' ns/check, in no particular order of repeats; empty for points
    /// measured before blocks were kept.
    pub block_ns_per_check: Vec<Vec<f64>>,
    /// Whether the machine was still disturbed after the re-runs; `None` without a noise check.
    pub disturbed: Option<bool>,
    pub reruns: Option<u32>,
    /// Which visit of its point the job measured (0: the first, or the only one).
    pub visit: u32,
    /// The point's parameters without its visit (the canonical JSON of the job's spec less
    /// `visit` and `verdict_check`): the visits of one point, and only those, share it.
    pub point: String,
}

/// The fields of an overlap record that reports read; serde skips every other field. A timing
/// has an `algorithm`; the point record has the noise check and the verdicts.
#[derive(Deserialize)]
struct OverlapRecord {
    algorithm: Option<String>,
    ms: Option<f64>,
    ns_per_check: Option<f64>,
    acceptance: Option<f64>,
    block_ns_per_check: Option<Vec<f64>>,
    disturbed: Option<bool>,
    reruns: Option<u32>,
    verdicts: Option<VerdictCheck>,
}

/// One job's records, gathered per algorithm.
#[derive(Default)]
struct PointRecords {
    algorithms: BTreeMap<String, AlgorithmRecords>,
    disturbed: Option<bool>,
    reruns: Option<u32>,
    verdicts: Option<VerdictCheck>,
}

#[derive(Default)]
struct AlgorithmRecords {
    sum_ms: f64,
    sum_acceptance: f64,
    repeat_ns_per_check: Vec<f64>,
    blocks: Vec<Vec<f64>>,
    /// A record lacked `ms`, `ns_per_check` or `acceptance`.
    incomplete: bool,
}

impl PointRecords {
    fn add(&mut self, record: OverlapRecord) {
        let Some(algorithm) = record.algorithm else {
            self.disturbed = self.disturbed.or(record.disturbed);
            self.reruns = self.reruns.or(record.reruns);
            self.verdicts = self.verdicts.take().or(record.verdicts);
            return;
        };
        let t = self.algorithms.entry(algorithm).or_default();
        match (record.ms, record.ns_per_check, record.acceptance) {
            (Some(ms), Some(ns), Some(acceptance)) => {
                t.sum_ms += ms;
                t.sum_acceptance += acceptance;
                t.repeat_ns_per_check.push(ns);
            }
            _ => t.incomplete = true,
        }
        t.blocks.extend(record.block_ns_per_check);
    }
}

/// An overlap job as stored: its spec and its records, gathered.
struct OverlapJob {
    job_id: String,
    spec: PointSpec,
    records: PointRecords,
}

fn read(job: JobResults) -> Result<OverlapJob> {
    let bad = |what: String| corrupt("overlap", &job.job_id, what);
    let spec = match serde_json::from_str(&job.params_json) {
        Ok(JobSpec::Overlap(spec)) => spec,
        Ok(other) => return Err(bad(format!("its parameters are a {} job's", other.kind()))),
        Err(e) => return Err(bad(format!("unreadable parameters: {e}"))),
    };
    let mut records = PointRecords::default();
    for text in &job.records {
        let record =
            serde_json::from_str(text).map_err(|e| bad(format!("malformed record: {e}")))?;
        records.add(record);
    }
    Ok(OverlapJob {
        job_id: job.job_id,
        spec,
        records,
    })
}

async fn jobs(store: &Store) -> Result<Vec<OverlapJob>> {
    store
        .results_of("overlap")
        .await?
        .into_iter()
        .map(read)
        .collect()
}

/// Every done overlap job, one row per algorithm, ordered by precision, R*, L*, W*, acceptance
/// target and algorithm, then the point's other parameters and the visit (so the visits of a
/// point are consecutive). A record lacking a timing field, or malformed, is an error rather
/// than skipped, so a table never silently loses points.
pub async fn overlap_visits(store: &Store) -> Result<Vec<OverlapVisit>> {
    let mut rows = Vec::new();
    for job in jobs(store).await? {
        let spec = &job.spec;
        // Only the first visit runs the verdict check (it is about answers, not speed): the
        // visits of a point differ in `visit` and `verdict_check` alone.
        let point = JobSpec::Overlap(PointSpec {
            visit: None,
            verdict_check: None,
            ..spec.clone()
        })
        .canonical_json();
        for (algorithm, t) in job.records.algorithms {
            if t.incomplete {
                return Err(corrupt(
                    "overlap",
                    &job.job_id,
                    "lacks ms, ns_per_check or acceptance in a result record",
                ));
            }
            let n = t.repeat_ns_per_check.len() as f64;
            // Blocks of some repeats only (never written so) would bias a re-estimate.
            let blocked = t.blocks.len() == t.repeat_ns_per_check.len();
            rows.push(OverlapVisit {
                job_id: job.job_id.clone(),
                l_star: spec.l_star,
                w_star: spec.w_star,
                r_star: spec.r_star,
                acceptance_target: spec.acceptance,
                configurations: spec.configurations,
                precision: spec.precision.name().to_owned(),
                algorithm,
                mean_ms: t.sum_ms / n,
                ns_per_check: t.repeat_ns_per_check.iter().sum::<f64>() / n,
                acceptance: t.sum_acceptance / n,
                repeats: t.repeat_ns_per_check.len() as u32,
                repeat_ns_per_check: t.repeat_ns_per_check,
                block_ns_per_check: if blocked { t.blocks } else { Vec::new() },
                disturbed: job.records.disturbed,
                reruns: job.records.reruns,
                visit: spec.visit.unwrap_or(0),
                point: point.clone(),
            });
        }
    }
    rows.sort_by(|a, b| {
        a.precision
            .cmp(&b.precision)
            .then(a.r_star.total_cmp(&b.r_star))
            .then(a.l_star.total_cmp(&b.l_star))
            .then(a.w_star.total_cmp(&b.w_star))
            .then(a.acceptance_target.total_cmp(&b.acceptance_target))
            .then_with(|| a.algorithm.cmp(&b.algorithm))
            .then_with(|| a.point.cmp(&b.point))
            .then(a.visit.cmp(&b.visit))
    });
    Ok(rows)
}

/// Every (point, algorithm) of the overlap points run with `verdict_check`: its checking set's
/// verdicts against the exact ones and its mean ns/check over the point's repeats, ordered by
/// precision, algorithm and point. An algorithm checked but never timed is an error.
pub async fn overlap_verdicts(store: &Store) -> Result<Vec<VerdictRow>> {
    let mut rows = Vec::new();
    for job in jobs(store).await? {
        let Some(check) = &job.records.verdicts else {
            continue;
        };
        let spec = &job.spec;
        for verdicts in &check.algorithms {
            let algorithm = verdicts.algorithm.name();
            let timed = job
                .records
                .algorithms
                .get(algorithm)
                .map(|t| &t.repeat_ns_per_check)
                .filter(|ns| !ns.is_empty())
                .ok_or_else(|| {
                    corrupt(
                        "overlap",
                        &job.job_id,
                        format!("verdicts of {algorithm} lack ns_per_check (no timing record)"),
                    )
                })?;
            rows.push(VerdictRow {
                l_star: spec.l_star,
                w_star: spec.w_star,
                r_star: spec.r_star,
                precision: spec.precision.name().to_owned(),
                algorithm: algorithm.to_owned(),
                ns_per_check: timed.iter().sum::<f64>() / timed.len() as f64,
                bulk: check.bulk,
                shell: check.shell,
                bulk_wrong: verdicts.bulk_wrong,
                shell_wrong: verdicts.shell_wrong,
                shell_max_gap: check.shell_max_gap,
                shell_by_decade: check.shell_by_decade.clone(),
                shell_wrong_by_decade: verdicts.shell_wrong_by_decade.clone(),
            });
        }
    }
    rows.sort_by(|a, b| {
        a.precision
            .cmp(&b.precision)
            .then_with(|| a.algorithm.cmp(&b.algorithm))
            .then(a.l_star.total_cmp(&b.l_star))
            .then(a.w_star.total_cmp(&b.w_star))
            .then(a.r_star.total_cmp(&b.r_star))
    });
    Ok(rows)
}
