//! Submitting and cancelling campaigns.

use sqlx::{Row, SqliteConnection};

use crate::Store;
use crate::error::{Error, Result};
use crate::types::{NewCampaign, NewJob, StoredSearch, SubmitOutcome};

impl Store {
    /// Records a campaign and its jobs in one transaction.
    ///
    /// Jobs are identified by their id (a hash of kind and canonical params), so resubmitting a plan or
    /// extending it only queues the points that are not known yet; known points are linked to the
    /// campaign and keep their state and results. The exception is a known job that is `failed` or
    /// `cancelled`: resubmitting is how a user asks for it again, so it is queued with attempts reset
    /// (it keeps its `created_at`, hence its place at the front of the queue). Resubmitting a cancelled
    /// campaign un-cancels it.
    ///
    /// `estimate_s` and `exclusive` of a known job are not updated: they belong to the first submission.
    /// A known job id whose kind or params differ is an error ([`Error::JobConflict`]) and nothing is
    /// written: the caller's hashing is broken and mixing the two points would corrupt results.
    pub async fn submit(
        &self,
        campaign: &NewCampaign,
        jobs: &[NewJob],
        now: f64,
    ) -> Result<SubmitOutcome> {
        for job in jobs {
            validate_job(job)?;
        }
        // The jobs travel as JSON documents of SUBMIT_CHUNK jobs and each step is one set-based
        // statement per document, all in one write: the submission is atomic, and SQLite never
        // parses more than one chunk at a time. They go in id order, the order they are leased
        // in, so that every B-tree keyed by job id (and the table's rowids) is filled sequentially
        // instead of one random page per job, and leasing then completes consecutive rows.
        let mut sorted: Vec<&NewJob> = jobs.iter().collect();
        sorted.sort_unstable_by(|a, b| a.id.cmp(&b.id));
        let documents = sorted
            .chunks(SUBMIT_CHUNK)
            .map(|chunk| Ok((serde_json::to_string(chunk)?, chunk.len() as u64)))
            .collect::<std::result::Result<Vec<(String, u64)>, serde_json::Error>>()
            .map_err(|e| Error::Corrupt(format!("cannot encode jobs: {e}")))?;
        drop(sorted);
        let campaign = campaign.clone();
        let submitted = jobs.len() as u64;
        self.write(jobs.len(), move |conn| {
            Box::pin(async move {
                sqlx::query(
                    "INSERT INTO campaigns (id, name, plan_text, created_at) VALUES (?1, ?2, ?3, ?4)
                     ON CONFLICT (id) DO UPDATE SET cancelled_at = NULL",
                )
                .bind(&campaign.id)
                .bind(&campaign.name)
                .bind(&campaign.plan_text)
                .bind(now)
                .execute(&mut *conn)
                .await?;
                for search in &campaign.searches {
                    sqlx::query(
                        "INSERT INTO searches (campaign_id, search) VALUES (?1, ?2)
                         ON CONFLICT DO NOTHING",
                    )
                    .bind(&campaign.id)
                    .bind(search)
                    .execute(&mut *conn)
                    .await?;
                }
                let (mut new_jobs, mut requeued) = (0, 0);
                for (document, len) in documents {
                    let (new, again) =
                        submit_chunk(conn, &campaign.id, &document, len, now).await?;
                    new_jobs += new;
                    requeued += again;
                }
                Ok(SubmitOutcome {
                    campaign_id: campaign.id.clone(),
                    new_jobs,
                    requeued,
                    // A job listed twice in one submission counts as known the second time.
                    already_known: submitted.saturating_sub(new_jobs + requeued),
                })
            })
        })
        .await
    }

    /// Every search stored with a campaign (see [`NewCampaign::searches`]), in the order the
    /// campaigns were created.
    pub async fn searches(&self) -> Result<Vec<StoredSearch>> {
        let rows = sqlx::query(
            "SELECT c.id, c.name, c.cancelled_at IS NOT NULL, s.search
             FROM searches AS s JOIN campaigns AS c ON c.id = s.campaign_id
             ORDER BY c.created_at, c.id, s.rowid",
        )
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                Ok(StoredSearch {
                    campaign_id: row.try_get(0)?,
                    campaign_name: row.try_get(1)?,
                    cancelled: row.try_get(2)?,
                    search: row.try_get(3)?,
                })
            })
            .collect()
    }

    /// Cancels a campaign: its queued jobs become `cancelled`, except jobs that also belong to another
    /// campaign that is not cancelled. Running jobs are left to finish (their results are valid and a
    /// worker cannot be interrupted mid-measurement anyway). Returns the number of jobs cancelled.
    pub async fn cancel(&self, campaign_id: &str, now: f64) -> Result<u64> {
        let campaign_id = campaign_id.to_owned();
        self.write(1, move |conn| {
            Box::pin(async move {
                let found = sqlx::query(
                    "UPDATE campaigns SET cancelled_at = coalesce(cancelled_at, ?2) WHERE id = ?1",
                )
                .bind(&campaign_id)
                .bind(now)
                .execute(&mut *conn)
                .await?
                .rows_affected();
                if found == 0 {
                    return Err(Error::UnknownCampaign(campaign_id));
                }
                let cancelled = sqlx::query(
                    "UPDATE jobs SET state = 'cancelled', finished_at = ?2
             WHERE state = 'queued'
               AND id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1)
               AND NOT EXISTS (
                   SELECT 1 FROM campaign_jobs AS cj JOIN campaigns AS c ON c.id = cj.campaign_id
                   WHERE cj.job_id = jobs.id AND c.cancelled_at IS NULL)",
                )
                .bind(&campaign_id)
                .bind(now)
                .execute(&mut *conn)
                .await?
                .rows_affected();
                Ok(cancelled)
            })
        })
        .await
    }
}

/// Jobs per JSON document of a submission: bounds the memory SQLite needs to parse one.
const SUBMIT_CHUNK: usize = 10_000;

/// Inserts one document of `len` jobs for [`Store::submit`]; answers the jobs inserted and
/// requeued.
async fn submit_chunk(
    conn: &mut SqliteConnection,
    campaign_id: &str,
    document: &str,
    len: u64,
    now: f64,
) -> Result<(u64, u64)> {
    let new_jobs = sqlx::query(
        "INSERT INTO jobs (id, kind, params, estimate_s, exclusive, created_at, pass, foreign_code)
         SELECT value ->> 'id', value ->> 'kind', value ->> 'params_json',
                value ->> 'estimate_s', value ->> 'exclusive', ?2, value ->> 'pass',
                coalesce(value ->> 'foreign_code', 0)
         FROM json_each(?1) WHERE true
         ON CONFLICT (id) DO NOTHING",
    )
    .bind(document)
    .bind(now)
    .execute(&mut *conn)
    .await?
    .rows_affected();
    // Only known jobs can conflict or be queued again: none when every job was new.
    let requeued = if new_jobs < len {
        known_jobs(conn, document).await?
    } else {
        0
    };
    sqlx::query(
        "INSERT INTO campaign_jobs (campaign_id, job_id)
         SELECT ?2, value ->> 'id' FROM json_each(?1) WHERE true
         ON CONFLICT DO NOTHING",
    )
    .bind(document)
    .bind(campaign_id)
    .execute(&mut *conn)
    .await?;
    Ok((new_jobs, requeued))
}

/// Refuses a document whose known jobs differ in kind or params ([`Error::JobConflict`]), and
/// queues again those of them that failed or were cancelled; answers how many.
async fn known_jobs(conn: &mut SqliteConnection, document: &str) -> Result<u64> {
    let conflict = sqlx::query(
        "SELECT d.value ->> 'id', j.kind <> d.value ->> 'kind'
         FROM json_each(?1) AS d CROSS JOIN jobs AS j ON j.id = d.value ->> 'id'
         WHERE j.kind <> d.value ->> 'kind' OR j.params <> d.value ->> 'params_json'
         LIMIT 1",
    )
    .bind(document)
    .fetch_optional(&mut *conn)
    .await?;
    if let Some(row) = conflict {
        let kind_differs: bool = row.try_get(1)?;
        return Err(Error::JobConflict {
            job_id: row.try_get(0)?,
            field: if kind_differs { "kind" } else { "params" },
        });
    }
    let requeued = sqlx::query(
        "UPDATE jobs SET state = 'queued', attempts = 0, last_error = NULL,
                lease_owner = NULL, lease_token = NULL, lease_expires_at = NULL,
                started_at = NULL, finished_at = NULL
         WHERE id IN (SELECT value ->> 'id' FROM json_each(?1))
           AND +state IN ('failed', 'cancelled')",
    )
    .bind(document)
    .execute(&mut *conn)
    .await?
    .rows_affected();
    Ok(requeued)
}

/// Checks what SQLite's CHECK constraints would reject, but with an error that names the job.
fn validate_job(job: &NewJob) -> Result<()> {
    match serde_json::from_str::<serde_json::Value>(&job.params_json) {
        Ok(serde_json::Value::Object(_)) => {}
        Ok(other) => {
            return Err(Error::InvalidParams {
                job_id: job.id.clone(),
                reason: format!("found a JSON {}", json_kind(&other)),
            });
        }
        Err(e) => {
            return Err(Error::InvalidParams {
                job_id: job.id.clone(),
                reason: e.to_string(),
            });
        }
    }
    if !(job.estimate_s.is_finite() && job.estimate_s >= 0.0) {
        return Err(Error::InvalidEstimate {
            job_id: job.id.clone(),
            estimate_s: job.estimate_s,
        });
    }
    Ok(())
}

/// Names a JSON value's type for error messages.
pub(crate) fn json_kind(value: &serde_json::Value) -> &'static str {
    match value {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "boolean",
        serde_json::Value::Number(_) => "number",
        serde_json::Value::String(_) => "string",
        serde_json::Value::Array(_) => "array",
        serde_json::Value::Object(_) => "object",
    }
}
