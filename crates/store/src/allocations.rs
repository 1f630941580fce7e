//! The allocations a coordinator asks a batch system for, the allocator's state, and what the
//! allocator reads to size them (migration 0014). Writes go through the group-commit writer like
//! every other; they are few (one per submission or change of an allocation's state).

use std::collections::HashMap;

use sqlx::Row;
use sqlx::sqlite::SqliteRow;

use crate::Store;
use crate::error::{Error, Result};
use crate::types::{Allocation, AllocationState, AllocatorState, QueueSample, Ran};

/// The columns [`allocation`] reads, in its order.
macro_rules! columns {
    () => {
        "id, manager, external_id, state, nodes, cores, time_limit_s, submitted_at, started_at,
         ended_at, reason"
    };
}

fn allocation(row: &SqliteRow) -> Result<Allocation> {
    let id: i64 = row.try_get(0)?;
    let state: &str = row.try_get(3)?;
    Ok(Allocation {
        id,
        manager: row.try_get(1)?,
        external_id: row.try_get(2)?,
        state: AllocationState::parse(state)
            .ok_or_else(|| Error::Corrupt(format!("allocation {id} has state {state:?}")))?,
        nodes: row.try_get(4)?,
        cores: row.try_get(5)?,
        time_limit_s: row.try_get(6)?,
        submitted_at: row.try_get(7)?,
        started_at: row.try_get(8)?,
        ended_at: row.try_get(9)?,
        reason: row.try_get(10)?,
    })
}

impl Store {
    /// Records a new allocation (its `id` is ignored) and answers the id it was given.
    pub async fn insert_allocation(&self, allocation: &Allocation) -> Result<i64> {
        let a = allocation.clone();
        self.write(1, move |conn| {
            Box::pin(async move {
                let row = sqlx::query(
                    "INSERT INTO allocations (manager, external_id, state, nodes, cores,
                         time_limit_s, submitted_at, started_at, ended_at, reason)
                     VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10) RETURNING id",
                )
                .bind(&a.manager)
                .bind(&a.external_id)
                .bind(a.state.as_str())
                .bind(a.nodes)
                .bind(a.cores)
                .bind(a.time_limit_s)
                .bind(a.submitted_at)
                .bind(a.started_at)
                .bind(a.ended_at)
                .bind(&a.reason)
                .fetch_one(&mut *conn)
                .await?;
                Ok(row.try_get(0)?)
            })
        })
        .await
    }

    /// Writes what changed of an allocation: its state, times and reason.
    pub async fn update_allocation(&self, allocation: &Allocation) -> Result<()> {
        let a = allocation.clone();
        self.write(1, move |conn| {
            Box::pin(async move {
                let found = sqlx::query(
                    "UPDATE allocations SET state = ?2, started_at = ?3, ended_at = ?4, reason = ?5
                     WHERE id = ?1",
                )
                .bind(a.id)
                .bind(a.state.as_str())
                .bind(a.started_at)
                .bind(a.ended_at)
                .bind(&a.reason)
                .execute(&mut *conn)
                .await?
                .rows_affected();
                if found == 0 {
                    return Err(Error::Corrupt(format!("no allocation {}", a.id)));
                }
                Ok(())
            })
        })
        .await
    }

    /// The allocations still pending or running, oldest first (a partial index holds them).
    pub async fn open_allocations(&self) -> Result<Vec<Allocation>> {
        let rows = sqlx::query(concat!(
            "SELECT ",
            columns!(),
            " FROM allocations WHERE state IN ('pending', 'running') ORDER BY id"
        ))
        .fetch_all(&self.reader)
        .await?;
        rows.iter().map(allocation).collect()
    }

    /// The `recent` latest allocations and every open one, newest first.
    pub async fn allocations(&self, recent: u32) -> Result<Vec<Allocation>> {
        let rows = sqlx::query(concat!(
            "SELECT ",
            columns!(),
            " FROM allocations
             WHERE id IN (SELECT id FROM allocations ORDER BY id DESC LIMIT ?1)
                OR state IN ('pending', 'running')
             ORDER BY id DESC"
        ))
        .bind(i64::from(recent))
        .fetch_all(&self.reader)
        .await?;
        rows.iter().map(allocation).collect()
    }

    /// How many workers registered from each of the allocations `external_ids` (absent: none).
    /// O(`external_ids`) through the index on `workers.allocation`.
    pub async fn allocation_workers(
        &self,
        external_ids: &[String],
    ) -> Result<HashMap<String, u32>> {
        if external_ids.is_empty() {
            return Ok(HashMap::new());
        }
        let ids = serde_json::to_string(external_ids)
            .map_err(|e| Error::Corrupt(format!("cannot encode allocation ids: {e}")))?;
        let rows = sqlx::query(
            "SELECT allocation, count(*) FROM workers
             WHERE allocation IN (SELECT value FROM json_each(?1)) GROUP BY allocation",
        )
        .bind(ids)
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| Ok((row.try_get(0)?, row.try_get(1)?)))
            .collect()
    }

    /// Jobs done by the workers of each allocation. O(done jobs): it reads every done job's
    /// owner, so it is meant for a person's command, not for a loop.
    pub async fn allocation_jobs_done(&self) -> Result<HashMap<String, u64>> {
        // CROSS JOIN keeps SQLite on the done jobs first (the state index), each owner found by
        // its primary key; the other order scans the done jobs once per worker.
        let rows = sqlx::query(
            "SELECT w.allocation, count(*) FROM jobs AS j
             CROSS JOIN workers AS w ON w.id = j.lease_owner
             WHERE j.state = 'done' AND w.allocation IS NOT NULL GROUP BY w.allocation",
        )
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                let done: i64 = row.try_get(1)?;
                Ok((row.try_get(0)?, done.max(0) as u64))
            })
            .collect()
    }

    /// Replaces the allocator's state.
    pub async fn set_allocator_state(&self, state: &AllocatorState) -> Result<()> {
        let s = state.clone();
        self.write(1, move |conn| {
            Box::pin(async move {
                sqlx::query(
                    "INSERT INTO allocator (id, updated_at, failures, retry_at, note)
                     VALUES (1, ?1, ?2, ?3, ?4)
                     ON CONFLICT (id) DO UPDATE SET updated_at = ?1, failures = ?2, retry_at = ?3,
                         note = ?4",
                )
                .bind(s.updated_at)
                .bind(s.failures)
                .bind(s.retry_at)
                .bind(&s.note)
                .execute(&mut *conn)
                .await?;
                Ok(())
            })
        })
        .await
    }

    /// The allocator's state; `None` if no allocator ever ran on this database.
    pub async fn allocator_state(&self) -> Result<Option<AllocatorState>> {
        let row = sqlx::query("SELECT updated_at, failures, retry_at, note FROM allocator")
            .fetch_optional(&self.reader)
            .await?;
        row.map(|row| {
            Ok(AllocatorState {
                updated_at: row.try_get(0)?,
                failures: row.try_get(1)?,
                retry_at: row.try_get(2)?,
                note: row.try_get(3)?,
            })
        })
        .transpose()
    }

    /// The queued jobs in all and the kind and estimate of the first `head` of them in lease
    /// order. The count reads the state index only (no row), the head `head` rows: cheap enough
    /// for every few seconds with 10⁶ jobs queued (MEASUREMENTS.md).
    pub async fn queue_sample(&self, head: u32) -> Result<QueueSample> {
        let queued: i64 = sqlx::query("SELECT count(*) FROM jobs WHERE state = 'queued'")
            .fetch_one(&self.reader)
            .await?
            .try_get(0)?;
        let rows = sqlx::query(
            "SELECT kind, estimate_s FROM jobs WHERE state = 'queued'
             ORDER BY created_at, pass, id LIMIT ?1",
        )
        .bind(i64::from(head))
        .fetch_all(&self.reader)
        .await?;
        Ok(QueueSample {
            queued: queued.max(0) as u64,
            head: rows
                .iter()
                .map(|row| Ok((row.try_get(0)?, row.try_get(1)?)))
                .collect::<Result<_>>()?,
        })
    }

    /// How long the last `limit` done jobs (in lease order, backwards) took from lease to report:
    /// what a coordinator that starts on a database knows of each kind's durations.
    pub async fn recent_durations(&self, limit: u32) -> Result<Vec<Ran>> {
        let rows = sqlx::query(
            "SELECT kind, estimate_s, finished_at - started_at FROM jobs
             WHERE state = 'done' AND finished_at IS NOT NULL AND started_at IS NOT NULL
             ORDER BY created_at DESC, pass DESC, id DESC LIMIT ?1",
        )
        .bind(i64::from(limit))
        .fetch_all(&self.reader)
        .await?;
        rows.iter()
            .map(|row| {
                Ok(Ran {
                    kind: row.try_get(0)?,
                    estimate_s: row.try_get(1)?,
                    ran_s: row.try_get(2)?,
                })
            })
            .collect()
    }
}
