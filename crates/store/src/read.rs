//! Reading: progress, listings, export, the records of a kind of job and read-only SQL.
//! All of it goes through the read-only connections, so it never waits for the writer.

use sqlx::sqlite::SqliteValueRef;
use sqlx::{
    AssertSqlSafe, Column, Decode, Executor, Row, SqlSafeStr, Sqlite, Statement, TypeInfo, ValueRef,
};

use crate::Store;
use crate::error::{Error, Result};
use crate::types::{
    CampaignInfo, ExportRow, FailedJob, JobInfo, JobResults, JobState, QueryResult, Status,
    WorkerInfo, WorkerRecord,
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

    /// Queued jobs that run foreign code (of one campaign, or all) while no worker that allows
    /// them has been seen since `since`: work nobody connected may take. 0 when such a worker
    /// was seen. Reads the queued foreign-code jobs through the partial index's complement only
    /// when no allowing worker is recent.
    pub async fn foreign_code_waiting(&self, campaign: Option<&str>, since: f64) -> Result<u64> {
        let row = sqlx::query(
            "SELECT CASE WHEN EXISTS (SELECT 1 FROM workers
                                      WHERE allow_commands = 1 AND last_seen_at >= ?2)
                    THEN 0
                    ELSE (SELECT count(*) FROM jobs AS j
                          WHERE j.state = 'queued' AND j.foreign_code = 1
                            AND (?1 IS NULL OR j.id IN (SELECT job_id FROM campaign_jobs
                                                        WHERE campaign_id = ?1)))
                    END",
        )
        .bind(campaign)
        .bind(since)
        .fetch_one(&self.reader)
        .await?;
        let n: i64 = row.try_get(0)?;
        Ok(u64::try_from(n).unwrap_or(0))
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
                    (SELECT count(*) FROM jobs WHERE lease_owner = workers.id AND state = 'running'),
                    allocation, allow_commands
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
                        allocation: row.try_get(11)?,
                        allow_commands: row.try_get(12)?,
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

    /// Every job of `kind` that has results, with its parameters and its records (JSON objects,
    /// in the order the job wrote them), in submission order. The store does not look inside
    /// either: what a record of a kind contains is the results layer's business.
    pub async fn results_of(&self, kind: &str) -> Result<Vec<JobResults>> {
        let rows = sqlx::query(
            "SELECT j.id, j.params, r.fields FROM jobs AS j JOIN results AS r ON r.job_id = j.id
             WHERE j.kind = ?1 ORDER BY j.created_at, j.rowid, r.row_index",
        )
        .bind(kind)
        .fetch_all(&self.reader)
        .await?;
        let mut jobs: Vec<JobResults> = Vec::new();
        for row in &rows {
            let job_id: &str = row.try_get(0)?;
            if jobs.last().is_none_or(|j| j.job_id != job_id) {
                jobs.push(JobResults {
                    job_id: job_id.to_owned(),
                    params_json: row.try_get(1)?,
                    records: Vec::new(),
                });
            }
            if let Some(job) = jobs.last_mut() {
                job.records.push(row.try_get(2)?);
            }
        }
        Ok(jobs)
    }

    /// Runs one ad-hoc query on a read-only connection (`sweep query`).
    ///
    /// Three locks: the statement must be a single `SELECT`, `WITH`, `VALUES` or `EXPLAIN` (because
    /// `VACUUM INTO` creates a file even on a read-only connection, and several statements in one
    /// string would all run, and a `PRAGMA` could change the pooled connection for later callers);
    /// the connection is opened read-only; and `PRAGMA query_only` is on.
    pub async fn query_read_only(&self, sql: &str) -> Result<QueryResult> {
        self.query_read_only_with(sql, &[]).await
    }

    /// [`Store::query_read_only`] with values for the query's `?1`, `?2`, … (JSON null, boolean,
    /// number or string): the generic rows the results layer aggregates in SQL.
    pub async fn query_read_only_with(
        &self,
        sql: &str,
        binds: &[serde_json::Value],
    ) -> Result<QueryResult> {
        check_single_query(sql)?;
        let mut conn = self.reader.acquire().await?;
        let sql = AssertSqlSafe(sql.to_owned()).into_sql_str();
        let statement = (&mut *conn).prepare(sql).await?;
        let columns = statement
            .columns()
            .iter()
            .map(|c| c.name().to_owned())
            .collect();
        let mut query = statement.query();
        for value in binds {
            query = match value {
                serde_json::Value::Null => query.bind(None::<String>),
                serde_json::Value::Bool(b) => query.bind(*b),
                serde_json::Value::Number(n) => match n.as_i64() {
                    Some(i) => query.bind(i),
                    None => query.bind(n.as_f64()),
                },
                serde_json::Value::String(s) => query.bind(s.clone()),
                other => return Err(Error::NotAQuery(format!("cannot bind {other}"))),
            };
        }
        let rows = query.fetch_all(&mut *conn).await?;
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
