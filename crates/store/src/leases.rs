//! The job life cycle: lease, heartbeat, complete, fail, expire.
//!
//! Every operation is one write of a `BEGIN IMMEDIATE` transaction (grouped with concurrent writes,
//! applied one after the other: see `writer`), so two callers can never observe the same queued job,
//! and a result is written in the same transaction that marks its job done. A lease is
//! identified by its fencing token; a report quoting a token that no longer owns the job is kept in
//! `late_reports` and otherwise ignored. A lease past its expiry time stays valid until
//! [`Store::expire_leases`] reaps it: the reaper is the single place where a lease dies, so whether a
//! slow report counts does not depend on which of two clocks ticked first.

use std::collections::{HashMap, HashSet};
use std::time::Duration;

use futures_util::TryStreamExt;
use sqlx::{Row, SqliteConnection};

use crate::Store;
use crate::campaigns::json_kind;
use crate::error::{Error, Result};
use crate::types::{
    CompleteOutcome, Completion, FailOutcome, Granted, JobState, Lease, LeaseRef, Ran, Within,
};
use crate::workers::touch;

/// Queued jobs a time-limited grant may look at beyond the jobs it asks for, to find ones that
/// fit (see [`Store::lease_within`]).
pub const SCAN_AHEAD: i64 = 1024;

impl Store {
    /// Leases up to `max_jobs` queued jobs to `worker_id`, oldest submission first and within one in
    /// id order, for `lease_for` from `now`; each leased job becomes `running` with `attempts + 1`.
    /// Ids are parameter hashes, so id order shuffles a plan: machine drift becomes noise, not structure
    /// over the swept plane (migration 0002).
    ///
    /// Exclusive jobs (which must never run alongside another job anywhere) are scheduled as a barrier
    /// in queue order: while one runs nothing is leased; when the oldest queued job is exclusive, it is
    /// leased alone once nothing runs (to a caller with `exclusive_ok`) and nothing else is leased
    /// meanwhile, so running jobs drain instead of starving it; a batch of ordinary jobs stops before
    /// the first exclusive one. A worker that passes `exclusive_ok = false` therefore idles while an
    /// exclusive job heads the queue.
    pub async fn lease(
        &self,
        worker_id: &str,
        max_jobs: u32,
        lease_for: Duration,
        now: f64,
        exclusive_ok: bool,
    ) -> Result<Vec<Lease>> {
        self.lease_within(worker_id, max_jobs, lease_for, now, exclusive_ok, None)
            .await
            .map(|granted| granted.leases)
    }

    /// [`Store::lease`] for a worker whose time is limited: with `within`, a queued job is leased
    /// only if it and the jobs leased before it in this grant are expected to finish within
    /// `within.seconds_left` (a job's expected duration is its estimate times its kind's scale);
    /// the others are passed over, counted in [`Granted::passed_over`], and stay queued for another
    /// worker. An exclusive job passed over is still a barrier: nothing after it is leased. At
    /// most [`SCAN_AHEAD`] queued jobs beyond `max_jobs` are looked at, so a grant costs
    /// O(`max_jobs` + [`SCAN_AHEAD`]) however long the queue.
    pub async fn lease_within(
        &self,
        worker_id: &str,
        max_jobs: u32,
        lease_for: Duration,
        now: f64,
        exclusive_ok: bool,
        within: Option<Within>,
    ) -> Result<Granted> {
        let worker_id = worker_id.to_owned();
        self.write(max_jobs as usize, move |conn| {
            Box::pin(async move {
                touch(conn, &worker_id, now).await?;
                // Two existence tests (O(1) with the indexes), not counts: the rule only asks "is anything
                // running" and "is an exclusive job running".
                let running = sqlx::query(
                    "SELECT EXISTS (SELECT 1 FROM jobs WHERE state = 'running'),
                    EXISTS (SELECT 1 FROM jobs WHERE state = 'running' AND exclusive = 1)",
                )
                .fetch_one(&mut *conn)
                .await?;
                let (any_running, exclusive_running): (bool, bool) =
                    (running.try_get(0)?, running.try_get(1)?);
                if max_jobs == 0 || exclusive_running {
                    return Ok(Granted::default());
                }
                // A worker without `--allow-commands` never sees a job that runs foreign code:
                // its candidates come from the partial index that holds none (migration 0015).
                let allow_commands: bool =
                    sqlx::query("SELECT allow_commands FROM workers WHERE id = ?1")
                        .bind(&worker_id)
                        .fetch_one(&mut *conn)
                        .await?
                        .try_get(0)?;
                let query = match (&within, allow_commands) {
                    (None, true) => sqlx::query(
                        "SELECT id, exclusive FROM jobs WHERE state = 'queued'
             ORDER BY created_at, pass, id LIMIT ?1",
                    )
                    .bind(i64::from(max_jobs)),
                    (None, false) => sqlx::query(
                        "SELECT id, exclusive FROM jobs WHERE state = 'queued' AND foreign_code = 0
             ORDER BY created_at, pass, id LIMIT ?1",
                    )
                    .bind(i64::from(max_jobs)),
                    (Some(_), true) => sqlx::query(
                        "SELECT id, exclusive, kind, estimate_s FROM jobs WHERE state = 'queued'
             ORDER BY created_at, pass, id LIMIT ?1",
                    )
                    .bind(i64::from(max_jobs) + SCAN_AHEAD),
                    (Some(_), false) => sqlx::query(
                        "SELECT id, exclusive, kind, estimate_s FROM jobs
             WHERE state = 'queued' AND foreign_code = 0
             ORDER BY created_at, pass, id LIMIT ?1",
                    )
                    .bind(i64::from(max_jobs) + SCAN_AHEAD),
                };
                // Row by row: a grant whose first jobs fit reads no further.
                let mut candidates = query.fetch(&mut *conn);
                let mut chosen: Vec<String> = Vec::with_capacity(max_jobs as usize);
                let mut passed_over = 0;
                let mut expected_s = 0.0;
                let mut seen = 0;
                while chosen.len() < max_jobs as usize
                    && let Some(row) = candidates.try_next().await?
                {
                    // Whether this job heads the queue.
                    let first = seen == 0;
                    seen += 1;
                    let exclusive: bool = row.try_get(1)?;
                    if let Some(within) = &within {
                        let kind: &str = row.try_get(2)?;
                        let estimate_s: f64 = row.try_get(3)?;
                        let takes = within.expected_s(kind, estimate_s);
                        if expected_s + takes > within.seconds_left {
                            passed_over += 1;
                            if exclusive {
                                break;
                            }
                            continue;
                        }
                        expected_s += takes;
                    }
                    if exclusive {
                        if first && !any_running && exclusive_ok {
                            chosen.push(row.try_get(0)?);
                        }
                        break;
                    }
                    chosen.push(row.try_get(0)?);
                }
                drop(candidates);
                if chosen.is_empty() {
                    return Ok(Granted {
                        leases: Vec::new(),
                        passed_over,
                    });
                }

                let token: i64 = sqlx::query(
                    "UPDATE lease_tokens SET last = last + 1 WHERE id = 1 RETURNING last",
                )
                .fetch_one(&mut *conn)
                .await?
                .try_get(0)?;
                let expires_at = now + lease_for.as_secs_f64();
                let ids = serde_json::to_string(&chosen)
                    .map_err(|e| Error::Corrupt(format!("cannot encode job ids: {e}")))?;
                // The candidates were read as queued in this same transaction, so the primary key alone
                // selects them; adding `state = 'queued'` here made SQLite scan every queued job instead.
                let rows = sqlx::query(
                    "UPDATE jobs SET state = 'running', attempts = attempts + 1, lease_owner = ?1,
                    lease_token = ?2, lease_expires_at = ?3, started_at = ?4, finished_at = NULL
             WHERE id IN (SELECT value FROM json_each(?5))
             RETURNING id, kind, params, attempts, exclusive",
                )
                .bind(&worker_id)
                .bind(token)
                .bind(expires_at)
                .bind(now)
                .bind(&ids)
                .fetch_all(&mut *conn)
                .await?;

                // RETURNING does not keep the queue order; restore it so callers start the oldest job first.
                let position: HashMap<&str, usize> = chosen
                    .iter()
                    .enumerate()
                    .map(|(i, id)| (id.as_str(), i))
                    .collect();
                let mut leases = rows
                    .iter()
                    .map(|row| {
                        Ok(Lease {
                            job_id: row.try_get(0)?,
                            kind: row.try_get(1)?,
                            params_json: row.try_get(2)?,
                            attempt: row.try_get(3)?,
                            token,
                            expires_at,
                            exclusive: row.try_get(4)?,
                        })
                    })
                    .collect::<Result<Vec<Lease>>>()?;
                leases.sort_by_key(|lease| position.get(lease.job_id.as_str()).copied());
                Ok(Granted {
                    leases,
                    passed_over,
                })
            })
        })
        .await
    }

    /// Extends the given leases of `worker_id` to at least `extend_to` and returns those still the
    /// worker's: running under this worker and token, or already completed under them (a heartbeat
    /// races the report of the job it covers). A lease missing from the answer is lost and its job
    /// should be abandoned.
    pub async fn heartbeat(
        &self,
        worker_id: &str,
        leases: &[LeaseRef],
        extend_to: f64,
        now: f64,
    ) -> Result<Vec<LeaseRef>> {
        let document = serde_json::to_string(leases)
            .map_err(|e| Error::Corrupt(format!("cannot encode leases: {e}")))?;
        let worker_id = worker_id.to_owned();
        let kept = self
            .write(leases.len(), move |conn| {
                Box::pin(async move {
                    touch(conn, &worker_id, now).await?;
                    // Set-based statements for all leases (`+state` and CROSS JOIN keep SQLite on the
                    // primary key: through the state index it scans every running or done job for each
                    // lease, seconds inside the write lock once hundreds of leases are held): extend the
                    // running ones, then read back every lease still the worker's, running or done.
                    sqlx::query(
                        "UPDATE jobs SET lease_expires_at = max(lease_expires_at, ?2)
             FROM (SELECT value ->> 'job_id' AS job_id, value ->> 'token' AS token
                   FROM json_each(?3)) AS c
             WHERE jobs.id = c.job_id AND +jobs.state = 'running' AND jobs.lease_owner = ?1
               AND jobs.lease_token = c.token",
                    )
                    .bind(&worker_id)
                    .bind(extend_to)
                    .bind(&document)
                    .execute(&mut *conn)
                    .await?;
                    sqlx::query(
                        "SELECT jobs.id, jobs.lease_token
             FROM (SELECT value ->> 'job_id' AS job_id, value ->> 'token' AS token
                   FROM json_each(?2)) AS c
             CROSS JOIN jobs ON jobs.id = c.job_id
             WHERE +jobs.state IN ('running', 'done') AND jobs.lease_owner = ?1
               AND jobs.lease_token = c.token",
                    )
                    .bind(&worker_id)
                    .bind(&document)
                    .fetch_all(&mut *conn)
                    .await?
                    .iter()
                    .map(|row| Ok((row.try_get(0)?, row.try_get(1)?)))
                    .collect::<Result<HashSet<(String, i64)>>>()
                })
            })
            .await?;
        Ok(leases
            .iter()
            .filter(|l| kept.contains(&(l.job_id.clone(), l.token)))
            .cloned()
            .collect())
    }

    /// Stores the result records of a leased job and marks it done, in one transaction.
    ///
    /// Each record must be a JSON object (one row of results, e.g. one algorithm × repeat); they are
    /// stored in order as `row_index` 0, 1, …. If any record is invalid, nothing is written and the
    /// job stays running. See [`CompleteOutcome`] for stale or repeated reports.
    pub async fn complete(
        &self,
        worker_id: &str,
        job_id: &str,
        token: i64,
        core_id: Option<u32>,
        records: &[String],
        now: f64,
    ) -> Result<CompleteOutcome> {
        let item = CompletionRef {
            job_id,
            token,
            core_id,
            records,
        };
        let (outcomes, _) = self.complete_refs(worker_id, &[item], now).await?;
        outcomes
            .first()
            .copied()
            .ok_or_else(|| Error::Corrupt("a completion produced no outcome".to_owned()))
    }

    /// [`Store::complete`] for many jobs of one worker in one transaction: the cost of a transaction
    /// (lock, statements, commit) is paid once per batch instead of once per job, which is what lets
    /// no-op jobs flow at thousands per second. Outcomes are returned in input order.
    ///
    /// The batch is atomic: an invalid record, an unknown job or a job listed twice fails the whole
    /// batch ([`Error::InvalidRecord`], [`Error::UnknownJob`], [`Error::DuplicateCompletion`]) and
    /// nothing is written.
    pub async fn complete_batch(
        &self,
        worker_id: &str,
        completions: &[Completion],
        now: f64,
    ) -> Result<Vec<CompleteOutcome>> {
        Ok(self
            .complete_batch_ran(worker_id, completions, now)
            .await?
            .0)
    }

    /// [`Store::complete_batch`], also answering how long each accepted job took from its lease
    /// to its report ([`Ran`]): what the coordinator learns a kind's real durations from.
    pub async fn complete_batch_ran(
        &self,
        worker_id: &str,
        completions: &[Completion],
        now: f64,
    ) -> Result<(Vec<CompleteOutcome>, Vec<Ran>)> {
        let items: Vec<CompletionRef<'_>> = completions
            .iter()
            .map(|c| CompletionRef {
                job_id: &c.job_id,
                token: c.token,
                core_id: c.core_id,
                records: &c.records,
            })
            .collect();
        self.complete_refs(worker_id, &items, now).await
    }

    /// The one implementation of completion. The batch travels to SQLite as a single JSON document
    /// so that marking jobs done and inserting all their records are two set-based statements,
    /// whatever the batch size.
    async fn complete_refs(
        &self,
        worker_id: &str,
        items: &[CompletionRef<'_>],
        now: f64,
    ) -> Result<(Vec<CompleteOutcome>, Vec<Ran>)> {
        let document = completions_document(items)?;
        let keys: Vec<(String, i64)> = items
            .iter()
            .map(|item| (item.job_id.to_owned(), item.token))
            .collect();
        let worker_id = worker_id.to_owned();
        self.write(keys.len(), move |conn| Box::pin(async move {
        let rows = sqlx::query(
            "UPDATE jobs SET state = 'done', finished_at = ?2, lease_expires_at = NULL
             FROM (SELECT value ->> 'job_id' AS job_id, value ->> 'token' AS token
                   FROM json_each(?3)) AS c
             WHERE jobs.id = c.job_id AND +jobs.state = 'running' AND jobs.lease_owner = ?1
               AND jobs.lease_token = c.token
             RETURNING jobs.id, jobs.kind, jobs.estimate_s, ?2 - coalesce(jobs.started_at, ?2)",
        )
        .bind(&worker_id)
        .bind(now)
        .bind(&document)
        .fetch_all(&mut *conn)
        .await?;
        let mut accepted = HashSet::with_capacity(rows.len());
        let mut ran = Vec::with_capacity(rows.len());
        for row in &rows {
            accepted.insert(row.try_get::<String, _>(0)?);
            ran.push(Ran {
                kind: row.try_get(1)?,
                estimate_s: row.try_get(2)?,
                ran_s: row.try_get(3)?,
            });
        }
        if !accepted.is_empty() {
            let accepted_ids = serde_json::to_string(&accepted)
                .map_err(|e| Error::Corrupt(format!("cannot encode job ids: {e}")))?;
            sqlx::query(
                "INSERT INTO results (job_id, attempt, worker_id, core_id, row_index, fields, recorded_at)
                 SELECT j.id, j.attempts, ?1, c.value ->> 'core_id', r.key, r.value, ?2
                 FROM json_each(?3) AS c
                 CROSS JOIN json_each(c.value, '$.records') AS r
                 CROSS JOIN jobs AS j ON j.id = c.value ->> 'job_id'
                 WHERE (c.value ->> 'job_id') IN (SELECT value FROM json_each(?4))",
            )
            .bind(&worker_id)
            .bind(now)
            .bind(&document)
            .bind(&accepted_ids)
            .execute(&mut *conn)
            .await?;
        }

        let mut outcomes = Vec::with_capacity(keys.len());
        for (job_id, token) in &keys {
            if accepted.contains(job_id) {
                outcomes.push(CompleteOutcome::Accepted);
                continue;
            }
            let current = current_lease(conn, job_id).await?;
            if current.state == JobState::Done
                && current.owner.as_deref() == Some(worker_id.as_str())
                && current.token == Some(*token)
            {
                outcomes.push(CompleteOutcome::AlreadyDone);
            } else {
                record_late(conn, job_id, &current, &worker_id, *token, "completion", now).await?;
                outcomes.push(CompleteOutcome::Late);
            }
        }
        Ok((outcomes, ran))
        }))
        .await
    }

    /// Reports that a leased job failed with `error`. Below `max_attempts` attempts the job is queued
    /// again (keeping its place at the front of the queue); at `max_attempts` it becomes `failed` with
    /// `error` as its `last_error`.
    pub async fn fail(
        &self,
        worker_id: &str,
        job_id: &str,
        token: i64,
        error: &str,
        max_attempts: u32,
        now: f64,
    ) -> Result<FailOutcome> {
        let (worker_id, job_id, error) =
            (worker_id.to_owned(), job_id.to_owned(), error.to_owned());
        self.write(1, move |conn| {
            Box::pin(async move {
                let current = current_lease(conn, &job_id).await?;
                if !(current.state == JobState::Running
                    && current.owner.as_deref() == Some(worker_id.as_str())
                    && current.token == Some(token))
                {
                    record_late(conn, &job_id, &current, &worker_id, token, "failure", now).await?;
                    return Ok(FailOutcome::Late);
                }
                sqlx::query(
                    "INSERT INTO job_failures (job_id, attempt, worker_id, reason, failed_at)
                     VALUES (?1, ?2, ?3, ?4, ?5)",
                )
                .bind(&job_id)
                .bind(current.attempts)
                .bind(&worker_id)
                .bind(&error)
                .bind(now)
                .execute(&mut *conn)
                .await?;
                let outcome = if current.attempts >= i64::from(max_attempts) {
                    sqlx::query(
                        "UPDATE jobs SET state = 'failed', last_error = ?2, finished_at = ?3,
                        lease_expires_at = NULL
                 WHERE id = ?1",
                    )
                    .bind(&job_id)
                    .bind(&error)
                    .bind(now)
                    .execute(&mut *conn)
                    .await?;
                    FailOutcome::Failed
                } else {
                    sqlx::query(
                        "UPDATE jobs SET state = 'queued', last_error = ?2, lease_owner = NULL,
                        lease_token = NULL, lease_expires_at = NULL
                 WHERE id = ?1",
                    )
                    .bind(&job_id)
                    .bind(&error)
                    .execute(&mut *conn)
                    .await?;
                    FailOutcome::Requeued
                };
                Ok(outcome)
            })
        })
        .await
    }

    /// Gives `leases` of `worker_id` back unstarted: queued again without counting an attempt. A
    /// lease that is no longer the worker's is skipped. Returns how many were released.
    pub async fn release(&self, worker_id: &str, leases: &[LeaseRef], now: f64) -> Result<u64> {
        let (worker_id, leases) = (worker_id.to_owned(), leases.to_vec());
        self.write(leases.len(), move |conn| {
            Box::pin(async move {
                touch(conn, &worker_id, now).await?;
                let mut released = 0;
                for lease in &leases {
                    released += sqlx::query(
                "UPDATE jobs SET state = 'queued', attempts = attempts - 1, lease_owner = NULL,
                        lease_token = NULL, lease_expires_at = NULL, started_at = NULL
                 WHERE id = ?1 AND lease_token = ?2 AND lease_owner = ?3 AND state = 'running'",
            )
            .bind(&lease.job_id)
            .bind(lease.token)
            .bind(&worker_id)
            .execute(&mut *conn)
            .await?
            .rows_affected();
                }
                Ok(released)
            })
        })
        .await
    }

    /// Ends every lease of `worker_id` now, as if it had expired: for a worker known to be dead
    /// (its process is gone), so its jobs need not wait out the lease. The attempts count, as for
    /// any lost lease. Returns how many leases were reaped.
    pub async fn reclaim(&self, worker_id: &str, now: f64, max_attempts: u32) -> Result<u64> {
        let worker_id = worker_id.to_owned();
        self.write(1, move |conn| Box::pin(async move {
            sqlx::query(
                "UPDATE jobs SET lease_expires_at = ?1 WHERE lease_owner = ?2 AND state = 'running'",
            )
            .bind(now - 1.0)
            .bind(&worker_id)
            .execute(&mut *conn)
            .await?;
            Ok(())
        }))
        .await?;
        self.expire_leases(now, max_attempts).await
    }

    /// Reaps leases that expired before `now`: their jobs are queued again, or failed once they have
    /// used `max_attempts` attempts. Returns the number of leases reaped. A later report from a reaped
    /// lease is `Late`.
    pub async fn expire_leases(&self, now: f64, max_attempts: u32) -> Result<u64> {
        self.write(1, move |conn| {
            Box::pin(async move {
                // INDEXED BY: without statistics SQLite picks the state index and reads every
                // running job each second (524,288 of them held by 1,024 paced slots), inside the
                // write lock; the partial index reads only the expired ones.
                sqlx::query(
                    "INSERT INTO job_failures (job_id, attempt, worker_id, reason, failed_at)
                     SELECT id, attempts, lease_owner, 'lease expired on attempt ' || attempts, ?1
                     FROM jobs INDEXED BY jobs_running_expiry
                     WHERE state = 'running' AND lease_expires_at < ?1",
                )
                .bind(now)
                .execute(&mut *conn)
                .await?;
                let reaped = sqlx::query(
                    "UPDATE jobs INDEXED BY jobs_running_expiry SET
                 state = CASE WHEN attempts >= ?2 THEN 'failed' ELSE 'queued' END,
                 last_error = 'lease expired on attempt ' || attempts
                     || CASE WHEN attempts >= ?2 THEN ' of ' || ?2 ELSE '' END,
                 finished_at = CASE WHEN attempts >= ?2 THEN ?1 ELSE NULL END,
                 lease_owner = NULL, lease_token = NULL, lease_expires_at = NULL
             WHERE state = 'running' AND lease_expires_at < ?1",
                )
                .bind(now)
                .bind(max_attempts)
                .execute(&mut *conn)
                .await?
                .rows_affected();
                Ok(reaped)
            })
        })
        .await
    }
}

/// The lease-related state of a job, read inside a write transaction.
struct CurrentLease {
    state: JobState,
    owner: Option<String>,
    token: Option<i64>,
    attempts: i64,
}

async fn current_lease(conn: &mut SqliteConnection, job_id: &str) -> Result<CurrentLease> {
    let row =
        sqlx::query("SELECT state, lease_owner, lease_token, attempts FROM jobs WHERE id = ?1")
            .bind(job_id)
            .fetch_optional(&mut *conn)
            .await?
            .ok_or_else(|| Error::UnknownJob(job_id.to_owned()))?;
    let state: &str = row.try_get(0)?;
    Ok(CurrentLease {
        state: JobState::parse(state)
            .ok_or_else(|| Error::Corrupt(format!("job {job_id:?} has state {state:?}")))?,
        owner: row.try_get(1)?,
        token: row.try_get(2)?,
        attempts: row.try_get(3)?,
    })
}

/// Keeps a stale report for diagnosis, with the reason it did not count.
async fn record_late(
    conn: &mut SqliteConnection,
    job_id: &str,
    current: &CurrentLease,
    worker_id: &str,
    token: i64,
    what: &str,
    now: f64,
) -> Result<()> {
    let why = match current.state {
        JobState::Queued => "lease expired and the job was queued again".to_owned(),
        JobState::Running if current.token == Some(token) => {
            "the lease belongs to another worker".to_owned()
        }
        JobState::Running => format!(
            "job re-leased to {} (token {})",
            current.owner.as_deref().unwrap_or("?"),
            current.token.unwrap_or_default()
        ),
        JobState::Done => "job already done by another lease".to_owned(),
        JobState::Failed => "job already failed".to_owned(),
        JobState::Cancelled => "job cancelled".to_owned(),
    };
    sqlx::query(
        "INSERT INTO late_reports (job_id, attempt, worker_id, token, reason, received_at)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
    )
    .bind(job_id)
    .bind(current.attempts)
    .bind(worker_id)
    .bind(token)
    .bind(format!("{what}: {why}"))
    .bind(now)
    .execute(&mut *conn)
    .await?;
    Ok(())
}

/// One completion as the internal implementation sees it, borrowed from either API.
struct CompletionRef<'a> {
    job_id: &'a str,
    token: i64,
    core_id: Option<u32>,
    records: &'a [String],
}

/// Validates the batch (records are JSON objects, no job twice) and writes it as one JSON array of
/// `{"job_id", "token", "core_id", "records": [...]}`; the records are embedded verbatim.
fn completions_document(items: &[CompletionRef<'_>]) -> Result<String> {
    let mut seen = HashSet::with_capacity(items.len());
    let mut document = String::from("[");
    for (position, item) in items.iter().enumerate() {
        if !seen.insert(item.job_id) {
            return Err(Error::DuplicateCompletion(item.job_id.to_owned()));
        }
        let job_id = serde_json::to_string(item.job_id)
            .map_err(|e| Error::Corrupt(format!("cannot encode job id: {e}")))?;
        let core_id = item
            .core_id
            .map_or_else(|| "null".to_owned(), |c| c.to_string());
        if position > 0 {
            document.push(',');
        }
        document.push_str(&format!(
            r#"{{"job_id":{job_id},"token":{},"core_id":{core_id},"records":["#,
            item.token
        ));
        for (index, record) in item.records.iter().enumerate() {
            let invalid = |reason| Error::InvalidRecord {
                job_id: item.job_id.to_owned(),
                index,
                reason,
            };
            match serde_json::from_str::<serde_json::Value>(record) {
                Ok(serde_json::Value::Object(_)) => {}
                Ok(other) => return Err(invalid(format!("found a JSON {}", json_kind(&other)))),
                Err(e) => return Err(invalid(e.to_string())),
            }
            if index > 0 {
                document.push(',');
            }
            document.push_str(record);
        }
        document.push_str("]}");
    }
    document.push(']');
    Ok(document)
}
