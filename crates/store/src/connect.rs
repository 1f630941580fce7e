//! Opening a store: connection options, pools, migrations.
//!
//! One writer connection, owned by the group-commit task of [`crate::writer`], serialises all writes
//! of this process (SQLite allows one writer anyway, and queueing is cheaper than spinning on the
//! busy handler); every write transaction still starts with `BEGIN IMMEDIATE` so that writers in
//! *other* processes wait on `busy_timeout` instead of failing with "database is locked" when a
//! deferred transaction tries to upgrade its lock.
//! Readers use separate read-only connections: WAL lets them run while the writer commits, and an
//! accidental write through them is refused by SQLite itself.

use std::path::{Path, PathBuf};
use std::time::Duration;

use sqlx::sqlite::{
    SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteSynchronous,
};
use sqlx::{Row, SqliteConnection};

use crate::error::{Error, Result};
use crate::writer::{BoxFuture, WriteGroups, Writer};

/// The schema, embedded at compile time from `/migrations`.
static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("../../migrations");

const BUSY_TIMEOUT: Duration = Duration::from_secs(5);
const READERS: u32 = 4;
/// The writer's page cache, in KiB (negative `cache_size` means KiB): bounds the coordinator's memory.
const WRITER_CACHE_KIB: &str = "-65536";

/// A sweep database. Cheap to clone (pools and the writer task are shared).
#[derive(Debug, Clone)]
pub struct Store {
    /// `None` when opened with [`Store::open_read_only`].
    writer: Option<(SqlitePool, Writer)>,
    pub(crate) reader: SqlitePool,
}

impl Store {
    /// Opens (creating it if missing) the database at `path` and applies pending migrations. Starts
    /// the task that groups writes into transactions: call it inside a tokio runtime.
    ///
    /// Two processes creating the same new file at the same instant may race on switching it to WAL;
    /// opening an existing database concurrently is safe.
    pub async fn open(path: impl AsRef<Path>) -> Result<Store> {
        let path = path.as_ref();
        let open_err = |source| Error::Open {
            path: path.to_owned(),
            source,
        };
        let writer_options = SqliteConnectOptions::new()
            .filename(path)
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(SqliteSynchronous::Normal)
            // A group transaction touches pages all over the jobs and results B-trees (job ids are
            // hashes): with SQLite's default 2 MB cache it spilled and re-read them mid-transaction,
            // and the savepoint of each write journaled into a temporary file. Both in memory, bounded.
            .pragma("cache_size", WRITER_CACHE_KIB)
            .pragma("temp_store", "MEMORY")
            .busy_timeout(BUSY_TIMEOUT)
            .foreign_keys(true);
        let writer = SqlitePoolOptions::new()
            .max_connections(1)
            .min_connections(1)
            .connect_with(writer_options)
            .await
            .map_err(open_err)?;
        MIGRATOR
            .run(&writer)
            .await
            .map_err(|source| Error::Migrate {
                path: path.to_owned(),
                source,
            })?;
        let reader = reader_pool(path).await.map_err(open_err)?;
        let group_writer = Writer::start(writer.clone());
        Ok(Store {
            writer: Some((writer, group_writer)),
            reader,
        })
    }

    /// Opens an existing database for reading only (`sweep query`, reports): never creates or modifies
    /// the file, and every write statement fails. The schema must be up to date.
    pub async fn open_read_only(path: impl AsRef<Path>) -> Result<Store> {
        let path = path.as_ref();
        let reader = reader_pool(path).await.map_err(|source| Error::Open {
            path: path.to_owned(),
            source,
        })?;
        check_schema(&reader, path).await?;
        Ok(Store {
            writer: None,
            reader,
        })
    }

    /// Closes all connections. Readers close first so that the writer is the last connection, which
    /// checkpoints the WAL into the database file and removes it.
    pub async fn close(&self) {
        self.reader.close().await;
        if let Some((writer, _)) = &self.writer {
            writer.close().await;
        }
    }

    /// How many writes went into how many transactions since this store was opened (group commit
    /// at work: under concurrent callers, several writes per transaction). Zero when read-only.
    pub fn write_groups(&self) -> WriteGroups {
        self.writer
            .as_ref()
            .map(|(_, writer)| writer.groups())
            .unwrap_or_default()
    }

    /// Applies `op` as one write of the next group transaction (see [`crate::writer`]) and answers
    /// once that transaction committed. An `Err` from `op` undoes its own statements only. `rows`:
    /// about how many rows it touches, which bounds the size of its group.
    pub(crate) async fn write<T, F>(&self, rows: usize, op: F) -> Result<T>
    where
        T: Send + 'static,
        F: for<'c> FnOnce(&'c mut SqliteConnection) -> BoxFuture<'c, Result<T>> + Send + 'static,
    {
        let (_, writer) = self.writer.as_ref().ok_or(Error::ReadOnly)?;
        writer.write(rows, op).await
    }
}

/// Read-only connections, with `query_only` as a second lock on the door.
async fn reader_pool(path: &Path) -> std::result::Result<SqlitePool, sqlx::Error> {
    let options = SqliteConnectOptions::new()
        .filename(path)
        .read_only(true)
        .create_if_missing(false)
        .busy_timeout(BUSY_TIMEOUT)
        .pragma("query_only", "ON");
    SqlitePoolOptions::new()
        .max_connections(READERS)
        .min_connections(1)
        .connect_with(options)
        .await
}

/// A read-only store cannot migrate, so it refuses a database that lacks any embedded migration.
async fn check_schema(reader: &SqlitePool, path: &Path) -> Result<()> {
    let outdated = |version| Error::SchemaOutdated {
        path: PathBuf::from(path),
        version,
    };
    let first = MIGRATOR.iter().next().map_or(0, |m| m.version);
    let applied: Vec<(i64, Vec<u8>)> =
        match sqlx::query("SELECT version, checksum FROM _sqlx_migrations WHERE success = 1")
            .fetch_all(reader)
            .await
        {
            Ok(rows) => rows
                .iter()
                .map(|row| Ok((row.try_get(0)?, row.try_get(1)?)))
                .collect::<std::result::Result<_, sqlx::Error>>()?,
            Err(sqlx::Error::Database(e)) if e.message().contains("no such table") => {
                return Err(outdated(first));
            }
            Err(e) => return Err(e.into()),
        };
    for migration in MIGRATOR
        .iter()
        .filter(|m| !m.migration_type.is_down_migration())
    {
        match applied
            .iter()
            .find(|(version, _)| *version == migration.version)
        {
            Some((_, checksum)) if checksum[..] == migration.checksum[..] => {}
            Some(_) => {
                return Err(Error::Corrupt(format!(
                    "migration {} was applied from a different SQL text",
                    migration.version
                )));
            }
            None => return Err(outdated(migration.version)),
        }
    }
    Ok(())
}
