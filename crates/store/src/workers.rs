//! Worker registration: the provenance recorded with every result.

use sqlx::{Row, SqliteConnection};

use crate::Store;
use crate::error::{Error, Result};
use crate::types::WorkerInfo;

impl Store {
    /// Registers a worker, or refreshes `last_seen_at` of a worker re-registering with the same
    /// provenance. A known id with different provenance is refused ([`Error::WorkerConflict`]): results
    /// point at their worker row, so overwriting it would rewrite the provenance of past results.
    /// Workers should therefore derive their id from their provenance or make it unique per process.
    pub async fn register_worker(&self, worker: &WorkerInfo, now: f64) -> Result<()> {
        let cores = serde_json::to_string(&worker.cores)
            .map_err(|e| Error::Corrupt(format!("cannot encode core list: {e}")))?;
        let worker = worker.clone();
        self.write(1, move |conn| Box::pin(async move {
        let existing = sqlx::query(
            "SELECT hostname, cores, cpu_model, cpu_flags, rustc, git_commit, profile
             FROM workers WHERE id = ?1",
        )
        .bind(&worker.id)
        .fetch_optional(&mut *conn)
        .await?;
        match existing {
            Some(row) => {
                let given = [
                    ("hostname", worker.hostname.as_str()),
                    ("cores", cores.as_str()),
                    ("cpu_model", worker.cpu_model.as_str()),
                    ("cpu_flags", worker.cpu_flags.as_str()),
                    ("rustc", worker.rustc.as_str()),
                    ("git_commit", worker.git_commit.as_str()),
                    ("profile", worker.profile.as_str()),
                ];
                for (index, (field, value)) in given.into_iter().enumerate() {
                    if row.try_get::<&str, _>(index)? != value {
                        return Err(Error::WorkerConflict {
                            worker_id: worker.id.clone(),
                            field,
                        });
                    }
                }
                touch(conn, &worker.id, now).await?;
                // A worker restarted with or without `--allow-commands` says so again.
                sqlx::query("UPDATE workers SET allow_commands = ?2 WHERE id = ?1")
                    .bind(&worker.id)
                    .bind(worker.allow_commands)
                    .execute(&mut *conn)
                    .await?;
                if let Some(allocation) = &worker.allocation {
                    sqlx::query("UPDATE workers SET allocation = ?2 WHERE id = ?1")
                        .bind(&worker.id)
                        .bind(allocation)
                        .execute(&mut *conn)
                        .await?;
                }
            }
            None => {
                sqlx::query(
                    "INSERT INTO workers (id, hostname, cores, cpu_model, cpu_flags, rustc, git_commit,
                                          profile, registered_at, last_seen_at, allocation,
                                          allow_commands)
                     VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?9, ?10, ?11)",
                )
                .bind(&worker.id)
                .bind(&worker.hostname)
                .bind(&cores)
                .bind(&worker.cpu_model)
                .bind(&worker.cpu_flags)
                .bind(&worker.rustc)
                .bind(&worker.git_commit)
                .bind(&worker.profile)
                .bind(now)
                .bind(&worker.allocation)
                .bind(worker.allow_commands)
                .execute(&mut *conn)
                .await?;
            }
        }
        Ok(())
        }))
        .await
    }

    /// Records that a worker is alive (lease and heartbeat do this implicitly).
    pub async fn touch_worker(&self, worker_id: &str, now: f64) -> Result<()> {
        let worker_id = worker_id.to_owned();
        self.write(1, move |conn| {
            Box::pin(async move { touch(conn, &worker_id, now).await })
        })
        .await
    }
}

/// Updates `last_seen_at`, failing with [`Error::UnknownWorker`] for an unregistered id.
pub(crate) async fn touch(conn: &mut SqliteConnection, worker_id: &str, now: f64) -> Result<()> {
    let found = sqlx::query("UPDATE workers SET last_seen_at = ?2 WHERE id = ?1")
        .bind(worker_id)
        .bind(now)
        .execute(&mut *conn)
        .await?
        .rows_affected();
    if found == 0 {
        return Err(Error::UnknownWorker(worker_id.to_owned()));
    }
    Ok(())
}
