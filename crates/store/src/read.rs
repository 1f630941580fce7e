//! Reading: progress, listings, export, report rows and ad-hoc read-only SQL.
//! All of it goes through the read-only connections, so it never waits for the writer.

use std::collections::{BTreeMap, HashMap};

use sqlx::sqlite::{SqliteRow, SqliteValueRef};
use sqlx::{
    AssertSqlSafe, Column, Decode, Executor, Row, SqlSafeStr, Sqlite, Statement, TypeInfo, ValueRef,
};

use crate::Store;
use crate::error::{Error, Result};
use crate::types::{
    CampaignInfo, EdmdRun, ExportRow, FailedJob, JobInfo, JobState, OverlapQuality, OverlapRow,
    OverlapVerdictRow, QueryResult, Status, WorkerInfo, WorkerRecord,
};

impl Store {
    /// What a fair lease is sized from: the queued jobs, counted only up to `at_most` (so the count
    /// costs O(`at_most`), not O(queue)), and the slots (cores) of the workers seen since
    /// `active_since`.
    pub async fn lease_share_inputs(&self, at_most: u64, active_since: f64) -> Result<(u64, u64)> {
        let row = sqlx::query(
            "SELECT (SELECT count(*) FROM (SELECT 1 FROM jobs WHERE state = 'queued' LIMIT ?1)),
                    (SELECT coalesce(sum(json_array_length(cores)), 0) FROM workers
                     WHERE last_seen_at >= ?2)",
        )
        .bind(i64::try_from(at_most).unwrap_or(i64::MAX))
        .bind(active_since)
        .fetch_one(&self.reader)
        .await?;
        let (queued, slots): (i64, i64) = (row.try_get(0)?, row.try_get(1)?);
        Ok((queued.max(0) as u64, slots.max(0) as u64))
    }

    /// Job counts of one campaign, or of the whole store with `None`.
    pub async fn status(&self, campaign: Option<&str>) -> Result<Status> {
        let rows = match campaign {
            None => {
                sqlx::query("SELECT state, count(*), total(estimate_s) FROM jobs GROUP BY state")
                    .fetch_all(&self.reader)
                    .await?
            }
            Some(id) => {
                let known = sqlx::query("SELECT 1 FROM campaigns WHERE id = ?1")
                    .bind(id)
                    .fetch_optional(&self.reader)
                    .await?;
                if known.is_none() {
                    return Err(Error::UnknownCampaign(id.to_owned()));
                }
                sqlx::query(
                    "SELECT j.state, count(*), total(j.estimate_s)
                     FROM campaign_jobs AS cj JOIN jobs AS j ON j.id = cj.job_id
                     WHERE cj.campaign_id = ?1 GROUP BY j.state",
                )
                .bind(id)
                .fetch_all(&self.reader)
                .await?
            }
        };
        let mut status = Status::default();
        for row in &rows {
            add_state_count(
                &mut status,
                row.try_get(0)?,
                row.try_get(1)?,
                row.try_get(2)?,
            )?;
        }
        Ok(status)
    }

    /// All campaigns, oldest first, with their progress.
    pub async fn campaigns(&self) -> Result<Vec<CampaignInfo>> {
        let rows = sqlx::query(
            "SELECT c.id, c.name, c.created_at, c.cancelled_at, j.state, count(j.id),
                    total(j.estimate_s)
             FROM campaigns AS c
             LEFT JOIN campaign_jobs AS cj ON cj.campaign_id = c.id
             LEFT JOIN jobs AS j ON j.id = cj.job_id
             GROUP BY c.id, j.state
             ORDER BY c.created_at, c.id",
        )
        .fetch_all(&self.reader)
        .await?;
        let mut campaigns: Vec<CampaignInfo> = Vec::new();
        for row in &rows {
            let id: String = row.try_get(0)?;
            if campaigns.last().is_none_or(|c| c.id != id) {
                campaigns.push(CampaignInfo {
                    id,
                    name: row.try_get(1)?,
                    created_at: row.try_get(2)?,
                    cancelled_at: row.try_get(3)?,
                    status: Status::default(),
                });
            }
            let state: Option<&str> = row.try_get(4)?;
            if let (Some(state), Some(campaign)) = (state, campaigns.last_mut()) {
                add_state_count(
                    &mut campaign.status,
                    state,
                    row.try_get(5)?,
                    row.try_get(6)?,
                )?;
            }
        }
        Ok(campaigns)
    }

    /// All registered workers, in order of registration.
    pub async fn workers(&self) -> Result<Vec<WorkerRecord>> {
        let rows = sqlx::query(
            "SELECT id, hostname, cores, cpu_model, cpu_flags, rustc, git_commit, profile,
                    registered_at, last_seen_at,
                    (SELECT count(*) FROM jobs WHERE lease_owner = workers.id AND state = 'running')
             FROM workers ORDER BY registered_at, id",
        )
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                let id: String = row.try_get(0)?;
                let cores: &str = row.try_get(2)?;
                let cores = serde_json::from_str(cores).map_err(|e| {
                    Error::Corrupt(format!("worker {id:?} has a malformed core list: {e}"))
                })?;
                Ok(WorkerRecord {
                    info: WorkerInfo {
                        hostname: row.try_get(1)?,
                        cores,
                        cpu_model: row.try_get(3)?,
                        cpu_flags: row.try_get(4)?,
                        rustc: row.try_get(5)?,
                        git_commit: row.try_get(6)?,
                        profile: row.try_get(7)?,
                        id,
                    },
                    registered_at: row.try_get(8)?,
                    last_seen_at: row.try_get(9)?,
                    running: row.try_get(10)?,
                })
            })
            .collect()
    }

    /// One job, for diagnosis. Fails with [`Error::UnknownJob`] if absent.
    pub async fn job(&self, job_id: &str) -> Result<JobInfo> {
        let row = sqlx::query(
            "SELECT id, kind, params, estimate_s, exclusive, state, attempts, lease_owner,
                    lease_expires_at, last_error, started_at, finished_at, created_at
             FROM jobs WHERE id = ?1",
        )
        .bind(job_id)
        .fetch_optional(&self.reader)
        .await?
        .ok_or_else(|| Error::UnknownJob(job_id.to_owned()))?;
        let state: &str = row.try_get(5)?;
        Ok(JobInfo {
            id: row.try_get(0)?,
            kind: row.try_get(1)?,
            params_json: row.try_get(2)?,
            estimate_s: row.try_get(3)?,
            exclusive: row.try_get(4)?,
            state: JobState::parse(state)
                .ok_or_else(|| Error::Corrupt(format!("job {job_id:?} has state {state:?}")))?,
            attempts: row.try_get(6)?,
            lease_owner: row.try_get(7)?,
            lease_expires_at: row.try_get(8)?,
            last_error: row.try_get(9)?,
            started_at: row.try_get(10)?,
            finished_at: row.try_get(11)?,
            created_at: row.try_get(12)?,
        })
    }

    /// The jobs of `kind` whose last attempt failed for good (state `failed`), in submission
    /// order, with their parameters and the last reason: a report that judges settings by their
    /// results must also see the points that never produced one. O(failed) by the state index.
    pub async fn failed_jobs(&self, kind: &str) -> Result<Vec<FailedJob>> {
        let rows = sqlx::query(
            "SELECT id, params, coalesce(last_error, '') FROM jobs
             WHERE state = 'failed' AND kind = ?1 ORDER BY created_at, rowid",
        )
        .bind(kind)
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                Ok(FailedJob {
                    id: row.try_get(0)?,
                    params_json: row.try_get(1)?,
                    reason: row.try_get(2)?,
                })
            })
            .collect()
    }

    /// Every results row with its job's identity, in submission order of the jobs.
    /// `campaign` lists all campaigns containing the job (see [`ExportRow::campaign`]).
    pub async fn export(&self) -> Result<Vec<ExportRow>> {
        let rows = sqlx::query(
            "WITH job_campaigns AS (
                 SELECT cj.job_id, group_concat(cj.campaign_id, ',' ORDER BY c.created_at, c.id) AS ids
                 FROM campaign_jobs AS cj JOIN campaigns AS c ON c.id = cj.campaign_id
                 GROUP BY cj.job_id)
             SELECT r.job_id, coalesce(jc.ids, ''), j.kind, r.attempt, r.worker_id, r.core_id, r.fields
             FROM results AS r
             JOIN jobs AS j ON j.id = r.job_id
             LEFT JOIN job_campaigns AS jc ON jc.job_id = r.job_id
             ORDER BY j.created_at, j.rowid, r.row_index",
        )
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                let job_id: String = row.try_get(0)?;
                let fields: &str = row.try_get(6)?;
                let fields = serde_json::from_str(fields).map_err(|e| {
                    Error::Corrupt(format!(
                        "a result of job {job_id:?} is not a JSON object: {e}"
                    ))
                })?;
                Ok(ExportRow {
                    campaign: row.try_get(1)?,
                    kind: row.try_get(2)?,
                    attempt: row.try_get(3)?,
                    worker: row.try_get(4)?,
                    core_id: row.try_get(5)?,
                    fields,
                    job_id,
                })
            })
            .collect()
    }

    /// Overlap timings, one row per (job, algorithm), ordered by precision, R*, L*, W*,
    /// acceptance target and algorithm, then the point's other parameters and the visit (so the
    /// visits of a point are consecutive): the means over repeats, every repeat's `ns_per_check`
    /// and, for points measured in blocks, every block (so a report can re-estimate), with the
    /// point's noise check. A done overlap job lacking a numeric field, or with a malformed
    /// record, is reported as [`Error::Corrupt`] rather than skipped, so a table never silently
    /// loses points.
    ///
    /// The records are read as stored and parsed once, here: with every block kept they are
    /// about 1 kB each, and extracting fields in SQL would parse each several times.
    pub async fn overlap_rows(&self) -> Result<Vec<OverlapRow>> {
        let points = sqlx::query(
            "SELECT p.job_id, CAST(p.l_star AS REAL), CAST(p.w_star AS REAL), CAST(p.r_star AS REAL),
                    CAST(p.acceptance_target AS REAL), CAST(p.configurations AS INTEGER), p.precision,
                    CAST(coalesce(json_extract(j.params, '$.visit'), 0) AS INTEGER),
                    json_remove(j.params, '$.visit')
             FROM overlap_points AS p JOIN jobs AS j ON j.id = p.job_id
             WHERE p.job_id IN (SELECT job_id FROM results)",
        )
        .fetch_all(&self.reader)
        .await?;
        let records = sqlx::query(
            "SELECT r.job_id, r.fields FROM results AS r JOIN jobs AS j ON j.id = r.job_id
             WHERE j.kind = 'overlap' ORDER BY r.job_id, r.row_index",
        )
        .fetch_all(&self.reader)
        .await?;
        let mut by_job: HashMap<String, PointRecords> = HashMap::with_capacity(points.len());
        for row in &records {
            let job_id: String = row.try_get(0)?;
            let record: OverlapRecord = serde_json::from_str(row.try_get(1)?).map_err(|e| {
                Error::Corrupt(format!("overlap job {job_id:?}: malformed record: {e}"))
            })?;
            by_job.entry(job_id).or_default().add(record);
        }
        let mut rows = Vec::new();
        for point in &points {
            let job_id: String = point.try_get(0)?;
            let missing =
                |what: &str| Error::Corrupt(format!("overlap job {job_id:?} lacks {what}"));
            let number = |index: usize, name: &str| -> Result<f64> {
                point
                    .try_get::<Option<f64>, _>(index)?
                    .ok_or_else(|| missing(name))
            };
            let (l_star, w_star, r_star) = (
                number(1, "l_star")?,
                number(2, "w_star")?,
                number(3, "r_star")?,
            );
            let acceptance_target = number(4, "acceptance")?;
            let configurations = point
                .try_get::<Option<i64>, _>(5)?
                .ok_or_else(|| missing("configurations"))?;
            let precision = point
                .try_get::<Option<String>, _>(6)?
                .ok_or_else(|| missing("precision"))?;
            let visit = u32::try_from(point.try_get::<i64, _>(7)?).map_err(|_| {
                Error::Corrupt(format!("overlap job {job_id:?}: visit out of range"))
            })?;
            let point_params: String = point.try_get(8)?;
            let Some(job) = by_job.remove(&job_id) else {
                continue;
            };
            for (algorithm, t) in job.algorithms {
                if !t.complete {
                    return Err(missing("ms, ns_per_check or acceptance in a result record"));
                }
                let n = t.repeat_ns_per_check.len() as f64;
                // Blocks of some repeats only (never written so) would bias a re-estimate.
                let blocked = t.blocks.len() == t.repeat_ns_per_check.len();
                rows.push(OverlapRow {
                    job_id: job_id.clone(),
                    l_star,
                    w_star,
                    r_star,
                    acceptance_target,
                    configurations,
                    precision: precision.clone(),
                    algorithm,
                    mean_ms: t.sum_ms / n,
                    ns_per_check: t.repeat_ns_per_check.iter().sum::<f64>() / n,
                    acceptance: t.sum_acceptance / n,
                    repeats: t.repeat_ns_per_check.len() as u32,
                    repeat_ns_per_check: t.repeat_ns_per_check,
                    block_ns_per_check: if blocked { t.blocks } else { Vec::new() },
                    disturbed: job.disturbed,
                    reruns: job.reruns,
                    visit,
                    point: point_params.clone(),
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

    /// How the overlap points of one campaign (or of the whole store) were measured: how many
    /// carry a noise check, how many were still disturbed after their re-runs, how many were
    /// re-run and what their measurement cost.
    pub async fn overlap_quality(&self, campaign: Option<&str>) -> Result<OverlapQuality> {
        let row = sqlx::query(
            "SELECT count(*), total(m.disturbed), count(*) FILTER (WHERE m.reruns > 0), total(m.reruns),
                    total(m.wall_s), total(m.timed_s)
             FROM overlap_measurements AS m
             WHERE ?1 IS NULL
                OR m.job_id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1)",
        )
        .bind(campaign)
        .fetch_one(&self.reader)
        .await?;
        let count = |i: usize| -> Result<u64> {
            let n: f64 = row
                .try_get::<f64, _>(i)
                .or_else(|_| row.try_get::<i64, _>(i).map(|n| n as f64))?;
            Ok(n.max(0.0) as u64)
        };
        Ok(OverlapQuality {
            checked: count(0)?,
            disturbed: count(1)?,
            rerun: count(2)?,
            reruns: count(3)?,
            wall_s: row.try_get(4)?,
            timed_s: row.try_get(5)?,
        })
    }

    /// Every done EDMD point, ordered by shape, X0, neighbour method, N, Δ_NNL and φ (then the
    /// superquadric exponent p). A record
    /// lacking a field the engine always writes is reported as [`Error::Corrupt`] rather than
    /// skipped; fields added later (`tau_c_cpu_us`, `wall_s`, `cpu_s`) may be absent.
    pub async fn edmd_runs(&self) -> Result<Vec<EdmdRun>> {
        let reals = EDMD_REALS
            .iter()
            .map(|c| format!("CAST({c} AS REAL) AS {c}"))
            .chain(
                EDMD_INTEGERS
                    .iter()
                    .map(|c| format!("CAST({c} AS INTEGER) AS {c}")),
            )
            .collect::<Vec<_>>()
            .join(", ");
        let sql = format!(
            "SELECT job_id, shape, neighbours, sequence_fingerprint, {reals} FROM edmd_runs
             ORDER BY shape, x0, neighbours, n, delta_nnl, phi, eps_d, nr_tol, seed, exponent_p"
        );
        let rows = sqlx::query(AssertSqlSafe(sql).into_sql_str())
            .fetch_all(&self.reader)
            .await?;
        rows.iter().map(edmd_run).collect()
    }

    /// Every (point, algorithm) of the overlap points run with `verdict_check`, ordered by
    /// precision, algorithm and point. A row lacking a count is [`Error::Corrupt`].
    pub async fn overlap_verdicts(&self) -> Result<Vec<OverlapVerdictRow>> {
        let rows = sqlx::query(
            "SELECT v.job_id, CAST(v.l_star AS REAL), CAST(v.w_star AS REAL), CAST(v.r_star AS REAL),
                    v.precision, v.algorithm, CAST(v.ns_per_check AS REAL), v.bulk, v.shell,
                    v.undecided, v.bulk_wrong, v.shell_wrong,
                    CAST(json_extract(r.fields, '$.verdicts.shell_max_gap') AS REAL),
                    v.shell_by_decade, v.shell_wrong_by_decade
             FROM overlap_verdicts AS v
             JOIN results AS r ON r.job_id = v.job_id AND json_type(r.fields, '$.verdicts') = 'object'
             ORDER BY v.precision, v.algorithm, v.l_star, v.w_star, v.r_star",
        )
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                let job_id: String = row.try_get(0)?;
                let missing = |what: &str| {
                    Error::Corrupt(format!("overlap job {job_id:?}: verdicts lack {what}"))
                };
                let real = |i: usize, name: &str| -> Result<f64> {
                    row.try_get::<Option<f64>, _>(i)?
                        .ok_or_else(|| missing(name))
                };
                let count = |i: usize, name: &str| -> Result<u64> {
                    let n = row
                        .try_get::<Option<i64>, _>(i)?
                        .ok_or_else(|| missing(name))?;
                    u64::try_from(n).map_err(|_| missing(name))
                };
                let counts = |i: usize, name: &str| -> Result<Vec<u64>> {
                    let text = row
                        .try_get::<Option<String>, _>(i)?
                        .ok_or_else(|| missing(name))?;
                    serde_json::from_str(&text).map_err(|_| missing(name))
                };
                Ok(OverlapVerdictRow {
                    l_star: real(1, "l_star")?,
                    w_star: real(2, "w_star")?,
                    r_star: real(3, "r_star")?,
                    precision: row
                        .try_get::<Option<String>, _>(4)?
                        .ok_or_else(|| missing("precision"))?,
                    algorithm: row
                        .try_get::<Option<String>, _>(5)?
                        .ok_or_else(|| missing("algorithm"))?,
                    ns_per_check: real(6, "ns_per_check (no timing record)")?,
                    bulk: count(7, "bulk")?,
                    shell: count(8, "shell")?,
                    undecided: count(9, "undecided")?,
                    bulk_wrong: count(10, "bulk_wrong")?,
                    shell_wrong: count(11, "shell_wrong")?,
                    shell_max_gap: real(12, "shell_max_gap")?,
                    shell_by_decade: counts(13, "shell_by_decade")?,
                    shell_wrong_by_decade: counts(14, "shell_wrong_by_decade")?,
                    job_id,
                })
            })
            .collect()
    }

    /// Runs one ad-hoc query on a read-only connection (`sweep query`).
    ///
    /// Three locks: the statement must be a single `SELECT`, `WITH`, `VALUES` or `EXPLAIN` (because
    /// `VACUUM INTO` creates a file even on a read-only connection, and several statements in one
    /// string would all run, and a `PRAGMA` could change the pooled connection for later callers);
    /// the connection is opened read-only; and `PRAGMA query_only` is on.
    pub async fn query_read_only(&self, sql: &str) -> Result<QueryResult> {
        check_single_query(sql)?;
        let mut conn = self.reader.acquire().await?;
        let sql = AssertSqlSafe(sql.to_owned()).into_sql_str();
        let statement = (&mut *conn).prepare(sql).await?;
        let columns = statement
            .columns()
            .iter()
            .map(|c| c.name().to_owned())
            .collect();
        let rows = statement.query().fetch_all(&mut *conn).await?;
        let rows = rows
            .iter()
            .map(|row| {
                (0..row.len())
                    .map(|i| json_value(row.try_get_raw(i)?))
                    .collect()
            })
            .collect::<Result<_>>()?;
        Ok(QueryResult { columns, rows })
    }
}

fn add_state_count(status: &mut Status, state: &str, count: i64, estimate_s: f64) -> Result<()> {
    let count = u64::try_from(count)
        .map_err(|_| Error::Corrupt(format!("negative count {count} of {state} jobs")))?;
    let state =
        JobState::parse(state).ok_or_else(|| Error::Corrupt(format!("job state {state:?}")))?;
    status.total += count;
    match state {
        JobState::Queued => status.queued += count,
        JobState::Running => status.running += count,
        JobState::Done => status.done += count,
        JobState::Failed => status.failed += count,
        JobState::Cancelled => status.cancelled += count,
    }
    if matches!(state, JobState::Queued | JobState::Running) {
        status.estimate_s_remaining += estimate_s;
    }
    Ok(())
}

/// Real-valued columns of `edmd_runs` that [`Store::edmd_runs`] reads.
const EDMD_REALS: [&str; 25] = [
    "phi",
    "x0",
    "exponent_n",
    "exponent_m",
    "exponent_p",
    "delta_nnl",
    "tau_c_us",
    "pressure_z",
    "pressure_z_err",
    "eps_d",
    "eps_nnl",
    "nr_tol",
    "nr_relax",
    "sd_tol",
    "brent_tol",
    "energy_drift_rel",
    "nr_iterations_mean",
    "distance_calls_per_collision",
    "searches_per_collision",
    "init_s",
    "wall_s",
    "cpu_s",
    "tau_c_cpu_us",
    "tau_update_us",
    "tau_predict_us",
];
/// Integer columns of `edmd_runs` that [`Store::edmd_runs`] reads.
const EDMD_INTEGERS: [&str; 11] = [
    "n",
    "nr_max_iter",
    "sd_max_iter",
    "seed",
    "collisions",
    "overlaps",
    "solver_failures",
    "contact_nr_fallbacks",
    "nnl_rebuilds",
    "cell_crossings",
    "sequence_block",
];

fn edmd_run(row: &SqliteRow) -> Result<EdmdRun> {
    let job_id: String = row.try_get("job_id")?;
    let missing = |what: &str| Error::Corrupt(format!("edmd job {job_id:?} lacks {what}"));
    let optional = |name: &str| -> Result<Option<f64>> { Ok(row.try_get::<Option<f64>, _>(name)?) };
    let number = |name: &str| -> Result<f64> { optional(name)?.ok_or_else(|| missing(name)) };
    let integer = |name: &str| -> Result<i64> {
        row.try_get::<Option<i64>, _>(name)?
            .ok_or_else(|| missing(name))
    };
    let text = |name: &str| -> Result<String> {
        row.try_get::<Option<String>, _>(name)?
            .ok_or_else(|| missing(name))
    };
    Ok(EdmdRun {
        shape: text("shape")?,
        n: integer("n")?,
        phi: number("phi")?,
        x0: number("x0")?,
        // A superquadric's three, or none.
        exponents: match (
            optional("exponent_n")?,
            optional("exponent_m")?,
            optional("exponent_p")?,
        ) {
            (Some(n), Some(m), Some(p)) => Some([n, m, p]),
            (None, None, None) => None,
            _ => return Err(missing("one of its three exponents")),
        },
        neighbours: text("neighbours")?,
        delta_nnl: number("delta_nnl")?,
        tau_c_us: number("tau_c_us")?,
        tau_c_cpu_us: optional("tau_c_cpu_us")?,
        pressure_z: number("pressure_z")?,
        // NaN (one block) is written as JSON null.
        pressure_z_err: optional("pressure_z_err")?,
        eps_d: number("eps_d")?,
        eps_nnl: number("eps_nnl")?,
        nr_tol: number("nr_tol")?,
        nr_max_iter: integer("nr_max_iter")?,
        nr_relax: number("nr_relax")?,
        sd_max_iter: integer("sd_max_iter")?,
        sd_tol: number("sd_tol")?,
        brent_tol: number("brent_tol")?,
        seed: integer("seed")?,
        collisions: integer("collisions")?,
        energy_drift_rel: number("energy_drift_rel")?,
        overlaps: integer("overlaps")?,
        solver_failures: integer("solver_failures")?,
        contact_nr_fallbacks: integer("contact_nr_fallbacks")?,
        nr_iterations_mean: number("nr_iterations_mean")?,
        distance_calls_per_collision: number("distance_calls_per_collision")?,
        searches_per_collision: number("searches_per_collision")?,
        nnl_rebuilds: integer("nnl_rebuilds")?,
        cell_crossings: integer("cell_crossings")?,
        init_s: optional("init_s")?,
        wall_s: optional("wall_s")?,
        cpu_s: optional("cpu_s")?,
        tau_update_us: optional("tau_update_us")?,
        tau_predict_us: optional("tau_predict_us")?,
        sequence_fingerprint: row.try_get("sequence_fingerprint")?,
        sequence_block: row.try_get("sequence_block")?,
        job_id,
    })
}

/// The fields of an overlap record that reports read (see `jobs::run`): a timing has an
/// `algorithm`; the point record has the noise check. serde skips every other field.
#[derive(serde::Deserialize)]
struct OverlapRecord {
    algorithm: Option<String>,
    ms: Option<f64>,
    ns_per_check: Option<f64>,
    acceptance: Option<f64>,
    block_ns_per_check: Option<Vec<f64>>,
    disturbed: Option<bool>,
    reruns: Option<u32>,
}

/// One job's records, gathered per algorithm.
#[derive(Default)]
struct PointRecords {
    algorithms: BTreeMap<String, AlgorithmRecords>,
    disturbed: Option<bool>,
    reruns: Option<u32>,
}

struct AlgorithmRecords {
    sum_ms: f64,
    sum_acceptance: f64,
    repeat_ns_per_check: Vec<f64>,
    blocks: Vec<Vec<f64>>,
    /// Every record had `ms`, `ns_per_check` and `acceptance`.
    complete: bool,
}

impl PointRecords {
    fn add(&mut self, record: OverlapRecord) {
        let Some(algorithm) = record.algorithm else {
            self.disturbed = self.disturbed.or(record.disturbed);
            self.reruns = self.reruns.or(record.reruns);
            return;
        };
        let t = self
            .algorithms
            .entry(algorithm)
            .or_insert_with(|| AlgorithmRecords {
                sum_ms: 0.0,
                sum_acceptance: 0.0,
                repeat_ns_per_check: Vec::new(),
                blocks: Vec::new(),
                complete: true,
            });
        match (record.ms, record.ns_per_check, record.acceptance) {
            (Some(ms), Some(ns), Some(acceptance)) => {
                t.sum_ms += ms;
                t.sum_acceptance += acceptance;
                t.repeat_ns_per_check.push(ns);
            }
            _ => t.complete = false,
        }
        t.blocks.extend(record.block_ns_per_check);
    }
}

/// Maps a SQLite value to JSON by its storage class (not by the column's declared type, which
/// expressions do not have).
fn json_value(value: SqliteValueRef<'_>) -> Result<serde_json::Value> {
    use serde_json::Value;
    if value.is_null() {
        return Ok(Value::Null);
    }
    let type_name = value.type_info().name().to_owned();
    let decode_err = |e| Error::Database(sqlx::Error::Decode(e));
    Ok(match type_name.as_str() {
        "REAL" => {
            let x = <f64 as Decode<Sqlite>>::decode(value).map_err(decode_err)?;
            serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
        }
        "TEXT" => Value::String(<String as Decode<Sqlite>>::decode(value).map_err(decode_err)?),
        "BLOB" => {
            let bytes = <Vec<u8> as Decode<Sqlite>>::decode(value).map_err(decode_err)?;
            Value::String(bytes.iter().map(|b| format!("{b:02x}")).collect())
        }
        // INTEGER and the integer-like names sqlx derives from declared types (BOOLEAN, INT4...).
        _ => Value::from(<i64 as Decode<Sqlite>>::decode(value).map_err(decode_err)?),
    })
}

/// Accepts exactly one statement whose first keyword is `SELECT`, `WITH`, `VALUES` or `EXPLAIN`.
/// A small lexer skips string literals, quoted identifiers and comments, so a `;` inside them does not
/// count as the end of the statement.
fn check_single_query(sql: &str) -> Result<()> {
    const ALLOWED: [&str; 4] = ["SELECT", "WITH", "VALUES", "EXPLAIN"];
    let refuse = |why: &str| Err(Error::NotAQuery(why.to_owned()));
    let mut first_word = String::new();
    let mut first_word_done = false;
    let mut ended = false;
    let mut chars = sql.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '-' if chars.peek() == Some(&'-') => {
                chars.by_ref().find(|&c| c == '\n');
                continue;
            }
            '/' if chars.peek() == Some(&'*') => {
                chars.next();
                let mut previous = ' ';
                for c in chars.by_ref() {
                    if previous == '*' && c == '/' {
                        break;
                    }
                    previous = c;
                }
                continue;
            }
            c if c.is_whitespace() => {
                first_word_done |= !first_word.is_empty();
                continue;
            }
            _ => {}
        }
        if ended {
            if c == ';' {
                continue;
            }
            return refuse("only one statement is allowed");
        }
        if !first_word_done && c.is_ascii_alphabetic() {
            first_word.push(c.to_ascii_uppercase());
            continue;
        }
        first_word_done = true;
        match c {
            ';' => ended = true,
            '\'' | '"' | '`' | '[' => {
                let close = if c == '[' { ']' } else { c };
                // A doubled quote inside a literal is an escaped quote: the loop simply reopens it.
                chars.by_ref().find(|&d| d == close);
            }
            _ => {}
        }
    }
    if !ALLOWED.contains(&first_word.as_str()) {
        return refuse("the statement must start with SELECT, WITH, VALUES or EXPLAIN");
    }
    Ok(())
}
