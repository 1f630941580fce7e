//! What a live view of the coordinator reads besides the counts: the latest failed attempts and
//! what each worker has done and holds. Reads only, through the read-only connections.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};
use sqlx::Row;

use crate::Store;
use crate::error::Result;

/// One failed attempt of a job (`job_failures`, migration 0010).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FailureRecord {
    pub job_id: String,
    pub kind: String,
    /// The attempt that failed (1 for the first).
    pub attempt: u32,
    /// The worker that held the lease; `None` if unknown.
    pub worker: Option<String>,
    pub reason: String,
    pub failed_at: f64,
}

/// A job a worker holds a lease on now.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobInHand {
    pub job_id: String,
    pub kind: String,
    pub started_at: Option<f64>,
}

/// What one worker has done and holds.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WorkerActivity {
    /// Jobs done under this worker's lease.
    pub jobs_done: u64,
    /// Its running jobs, oldest start first.
    pub in_hand: Vec<JobInHand>,
}

impl Store {
    /// The `limit` latest failed attempts, newest first. O(`limit`): the log is read backwards
    /// by rowid.
    pub async fn recent_failures(&self, limit: u32) -> Result<Vec<FailureRecord>> {
        let rows = sqlx::query(
            "SELECT f.job_id, coalesce(j.kind, ''), f.attempt, f.worker_id, f.reason, f.failed_at
             FROM (SELECT * FROM job_failures ORDER BY rowid DESC LIMIT ?1) AS f
             LEFT JOIN jobs AS j ON j.id = f.job_id
             ORDER BY f.failed_at DESC",
        )
        .bind(i64::from(limit))
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                Ok(FailureRecord {
                    job_id: row.try_get(0)?,
                    kind: row.try_get(1)?,
                    attempt: row.try_get(2)?,
                    worker: row.try_get(3)?,
                    reason: row.try_get(4)?,
                    failed_at: row.try_get(5)?,
                })
            })
            .collect()
    }

    /// Jobs done and jobs in hand of every worker that has any. O(done + running) through the
    /// state index: meant for a sampler that runs it every few seconds, not per request.
    pub async fn worker_activity(&self) -> Result<HashMap<String, WorkerActivity>> {
        let mut activity: HashMap<String, WorkerActivity> = HashMap::new();
        let done = sqlx::query(
            "SELECT lease_owner, count(*) FROM jobs
             WHERE state = 'done' AND lease_owner IS NOT NULL GROUP BY lease_owner",
        )
        .fetch_all(&self.reader)
        .await?;
        for row in &done {
            let count: i64 = row.try_get(1)?;
            activity.entry(row.try_get(0)?).or_default().jobs_done = count.max(0) as u64;
        }
        let running = sqlx::query(
            "SELECT lease_owner, id, kind, started_at FROM jobs
             WHERE state = 'running' ORDER BY lease_owner, started_at, id",
        )
        .fetch_all(&self.reader)
        .await?;
        for row in &running {
            let job = JobInHand {
                job_id: row.try_get(1)?,
                kind: row.try_get(2)?,
                started_at: row.try_get(3)?,
            };
            activity
                .entry(row.try_get(0)?)
                .or_default()
                .in_hand
                .push(job);
        }
        Ok(activity)
    }

    /// How many jobs of each kind are done, by kind: which figures have something to draw, and
    /// what the page can say of the kinds that have none. O(done jobs) through the state index.
    pub async fn done_by_kind(&self) -> Result<Vec<(String, u64)>> {
        let rows = sqlx::query(
            "SELECT kind, count(*) FROM jobs WHERE state = 'done' GROUP BY kind ORDER BY kind",
        )
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                let count: i64 = row.try_get(1)?;
                Ok((row.try_get(0)?, count.max(0) as u64))
            })
            .collect()
    }
}
