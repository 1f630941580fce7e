//! Group commit. Every write of a [`Store`](crate::Store) goes to one task that owns the writer
//! connection. While it runs a transaction, new writes queue up; the next transaction takes all
//! of them (up to [`MAX_GROUP`] writes or [`MAX_GROUP_ROWS`] rows), applies each inside its own savepoint, so that one failing write
//! is undone alone and answers its own error, commits once, and only then answers every caller.
//! Nothing is acknowledged before the commit that made it durable: if the commit fails, every
//! write of the group is answered [`Error::NotCommitted`] and none of it is in the database.
//!
//! A write whose caller gave up waiting before its group began (a gRPC request past its deadline,
//! a dropped future) is not applied at all: the caller was told nothing, so either outcome is
//! allowed, and under overload the queue then sheds the work nobody waits for (a lease answered
//! to no one would hold its jobs until the lease expires).
//!
//! Why: under many concurrent callers (a coordinator serving hundreds of slots), the fixed cost of
//! a transaction (taking the lock, BEGIN, COMMIT and its WAL append) is paid once per group
//! instead of once per call. A lone caller pays one savepoint more than before.
//!
//! The writes of a group run one after the other, in arrival order, inside one `BEGIN IMMEDIATE`
//! transaction: each sees the effects of those before it, exactly as if they had been separate
//! transactions in that order. That is all the exactly-once rules in `leases` rely on.

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use sqlx::SqliteConnection;
use sqlx::sqlite::SqlitePool;
use tokio::sync::{mpsc, oneshot};

use crate::error::{Error, Result};

/// The most writes one transaction takes: bounds how long the first of them waits for its answer.
pub(crate) const MAX_GROUP: usize = 256;

/// The most job rows one transaction takes, by the writes' own estimates (a lease of 500 jobs
/// counts 500): a group stops taking writes once it reaches this. Bounding writes alone let one
/// group of 256 large leases update 10⁵ rows and outlive its callers' deadlines.
pub(crate) const MAX_GROUP_ROWS: usize = 8192;

pub(crate) type BoxFuture<'a, T> = Pin<Box<dyn Future<Output = T> + Send + 'a>>;

/// A handle on the writer task; cheap to clone. The task ends when the last handle is dropped.
#[derive(Debug, Clone)]
pub(crate) struct Writer {
    inbox: mpsc::UnboundedSender<Box<dyn Write>>,
    counts: Arc<Counts>,
}

/// How many writes went into how many transactions since the store was opened.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WriteGroups {
    /// Transactions attempted (committed or not).
    pub transactions: u64,
    pub writes: u64,
    /// Writes dropped unapplied because their caller had stopped waiting.
    pub abandoned: u64,
}

#[derive(Debug, Default)]
struct Counts {
    transactions: AtomicU64,
    writes: AtomicU64,
    abandoned: AtomicU64,
}

impl Writer {
    /// Starts the writer task on the current tokio runtime.
    pub(crate) fn start(pool: SqlitePool) -> Writer {
        let (inbox, queue) = mpsc::unbounded_channel();
        let counts = Arc::new(Counts::default());
        tokio::spawn(run(pool, queue, counts.clone()));
        Writer { inbox, counts }
    }

    pub(crate) fn groups(&self) -> WriteGroups {
        WriteGroups {
            transactions: self.counts.transactions.load(Ordering::Relaxed),
            writes: self.counts.writes.load(Ordering::Relaxed),
            abandoned: self.counts.abandoned.load(Ordering::Relaxed),
        }
    }

    /// Applies `op` in the next group transaction and answers once that transaction committed.
    /// `op` gets the connection inside the transaction (and inside its savepoint); an `Err` from it
    /// undoes its own statements only. `rows` is about how many rows it touches (at least 1 is
    /// counted), for [`MAX_GROUP_ROWS`].
    pub(crate) async fn write<T, F>(&self, rows: usize, op: F) -> Result<T>
    where
        T: Send + 'static,
        F: for<'c> FnOnce(&'c mut SqliteConnection) -> BoxFuture<'c, Result<T>> + Send + 'static,
    {
        let (reply, answer) = oneshot::channel();
        let pending = Pending {
            rows: rows.max(1),
            op: Some(op),
            result: None,
            reply,
        };
        self.inbox
            .send(Box::new(pending))
            .map_err(|_| writer_gone())?;
        answer.await.map_err(|_| writer_gone())?
    }
}

/// The task is gone only when its runtime shut down.
fn writer_gone() -> Error {
    Error::NotCommitted(Arc::new(sqlx::Error::PoolClosed))
}

/// One queued write, its type erased so that writes of any result type share a group.
trait Write: Send + std::fmt::Debug {
    /// Runs the write; answers whether it succeeded (its result is kept for [`Write::answer`]).
    fn apply<'a>(&'a mut self, conn: &'a mut SqliteConnection) -> BoxFuture<'a, bool>;
    /// Answers the caller once the group's fate is known.
    fn answer(self: Box<Self>, group: Result<(), Arc<sqlx::Error>>);
    /// Whether the caller has stopped waiting for the answer.
    fn abandoned(&self) -> bool;
    /// About how many rows it touches.
    fn rows(&self) -> usize;
}

struct Pending<F, T> {
    rows: usize,
    op: Option<F>,
    result: Option<Result<T>>,
    reply: oneshot::Sender<Result<T>>,
}

impl<F, T> std::fmt::Debug for Pending<F, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pending")
            .field("applied", &self.op.is_none())
            .finish_non_exhaustive()
    }
}

impl<F, T> Write for Pending<F, T>
where
    T: Send + 'static,
    F: for<'c> FnOnce(&'c mut SqliteConnection) -> BoxFuture<'c, Result<T>> + Send + 'static,
{
    fn apply<'a>(&'a mut self, conn: &'a mut SqliteConnection) -> BoxFuture<'a, bool> {
        Box::pin(async move {
            let Some(op) = self.op.take() else {
                return false;
            };
            let result = op(conn).await;
            let ok = result.is_ok();
            self.result = Some(result);
            ok
        })
    }

    fn abandoned(&self) -> bool {
        self.reply.is_closed()
    }

    fn rows(&self) -> usize {
        self.rows
    }

    fn answer(self: Box<Self>, group: Result<(), Arc<sqlx::Error>>) {
        let answer = match (self.result, group) {
            // A write that failed was undone alone: its own error is the answer, whatever the group.
            (Some(Err(error)), _) => Err(error),
            (Some(Ok(value)), Ok(())) => Ok(value),
            (_, Err(error)) => Err(Error::NotCommitted(error)),
            (None, Ok(())) => Err(Error::Corrupt(
                "a write of a committed group was never applied".into(),
            )),
        };
        // The caller may have given up waiting (its request was cancelled): nothing to tell.
        let _ = self.reply.send(answer);
    }
}

async fn run(
    pool: SqlitePool,
    mut queue: mpsc::UnboundedReceiver<Box<dyn Write>>,
    counts: Arc<Counts>,
) {
    let mut group = Vec::with_capacity(MAX_GROUP);
    while let Some(first) = queue.recv().await {
        let mut rows = first.rows();
        group.push(first);
        while group.len() < MAX_GROUP && rows < MAX_GROUP_ROWS {
            match queue.try_recv() {
                Ok(next) => {
                    rows += next.rows();
                    group.push(next);
                }
                Err(_) => break,
            }
        }
        let waited_for = group.len();
        group.retain(|write| !write.abandoned());
        counts
            .abandoned
            .fetch_add((waited_for - group.len()) as u64, Ordering::Relaxed);
        if group.is_empty() {
            continue;
        }
        counts.transactions.fetch_add(1, Ordering::Relaxed);
        counts
            .writes
            .fetch_add(group.len() as u64, Ordering::Relaxed);
        let outcome = apply(&pool, &mut group).await.map_err(Arc::new);
        if let Err(error) = &outcome {
            tracing::warn!(%error, writes = group.len(), "a group of writes was not committed");
        }
        for write in group.drain(..) {
            write.answer(outcome.clone());
        }
    }
}

/// One transaction for the whole group. An error here (the lock not obtained, a savepoint that
/// cannot be rolled back because SQLite already abandoned the transaction, the commit) means
/// nothing of the group was written: the transaction is dropped, hence rolled back.
async fn apply(pool: &SqlitePool, group: &mut [Box<dyn Write>]) -> Result<(), sqlx::Error> {
    let mut tx = pool.begin_with("BEGIN IMMEDIATE").await?;
    for write in group.iter_mut() {
        sqlx::query("SAVEPOINT write").execute(&mut *tx).await?;
        if !write.apply(&mut tx).await {
            sqlx::query("ROLLBACK TO write").execute(&mut *tx).await?;
        }
        sqlx::query("RELEASE write").execute(&mut *tx).await?;
    }
    tx.commit().await
}

#[cfg(test)]
mod tests {
    use super::*;
    use sqlx::sqlite::{SqliteConnectOptions, SqlitePoolOptions};

    async fn table() -> (tempfile::TempDir, SqlitePool, Writer) {
        let dir = tempfile::tempdir().expect("temp dir");
        let options = SqliteConnectOptions::new()
            .filename(dir.path().join("w.db"))
            .create_if_missing(true)
            .foreign_keys(true);
        let pool = SqlitePoolOptions::new()
            .max_connections(1)
            .connect_with(options)
            .await
            .expect("pool");
        sqlx::raw_sql(
            "CREATE TABLE parent (id INTEGER PRIMARY KEY);
             CREATE TABLE child (id INTEGER PRIMARY KEY, parent INTEGER NOT NULL REFERENCES parent(id));
             INSERT INTO parent VALUES (1);",
        )
        .execute(&pool)
        .await
        .expect("schema");
        let writer = Writer::start(pool.clone());
        (dir, pool, writer)
    }

    fn insert_child(
        id: i64,
        parent: i64,
    ) -> impl for<'c> FnOnce(&'c mut SqliteConnection) -> BoxFuture<'c, Result<i64>> + Send + 'static
    {
        move |conn| {
            Box::pin(async move {
                sqlx::query("INSERT INTO child VALUES (?1, ?2)")
                    .bind(id)
                    .bind(parent)
                    .execute(&mut *conn)
                    .await?;
                Ok(id)
            })
        }
    }

    async fn children(pool: &SqlitePool) -> Vec<i64> {
        sqlx::query_scalar("SELECT id FROM child ORDER BY id")
            .fetch_all(pool)
            .await
            .expect("read")
    }

    /// Writes sent together share one transaction; the one that fails is undone alone and gets
    /// its own error, the others are committed and answered.
    #[tokio::test]
    async fn a_failing_write_is_undone_alone_inside_its_group() {
        let (_dir, pool, writer) = table().await;
        // `join!` polls all three before the writer task can run: they land in one group.
        let (a, b, c) = tokio::join!(
            writer.write(1, insert_child(10, 1)),
            writer.write(1, |conn| Box::pin(async move {
                sqlx::query("INSERT INTO child VALUES (20, 1)")
                    .execute(&mut *conn)
                    .await?;
                Err::<i64, _>(Error::UnknownJob("20".into()))
            })),
            writer.write(1, insert_child(30, 1)),
        );
        assert_eq!((a.expect("a"), c.expect("c")), (10, 30));
        assert!(matches!(b, Err(Error::UnknownJob(id)) if id == "20"));
        assert_eq!(children(&pool).await, [10, 30]);
        assert_eq!(
            writer.groups(),
            WriteGroups {
                transactions: 1,
                writes: 3,
                abandoned: 0
            }
        );
    }

    /// A group whose commit fails answers every write `NotCommitted`, and none of it is written.
    /// The commit is made to fail by a foreign-key violation deferred to the commit.
    #[tokio::test]
    async fn nothing_is_acknowledged_when_the_commit_fails() {
        let (_dir, pool, writer) = table().await;
        let (a, b) = tokio::join!(
            writer.write(1, insert_child(1, 1)),
            writer.write(1, |conn| Box::pin(async move {
                sqlx::query("PRAGMA defer_foreign_keys = ON")
                    .execute(&mut *conn)
                    .await?;
                sqlx::query("INSERT INTO child VALUES (2, 99)")
                    .execute(&mut *conn)
                    .await?;
                Ok(2)
            }))
        );
        assert!(matches!(a, Err(Error::NotCommitted(_))), "{a:?}");
        assert!(matches!(b, Err(Error::NotCommitted(_))), "{b:?}");
        assert!(children(&pool).await.is_empty());
        assert_eq!(writer.groups().transactions, 1);
        // The writer goes on with the next group.
        assert_eq!(
            writer
                .write(1, insert_child(3, 1))
                .await
                .expect("after a failed group"),
            3
        );
        assert_eq!(children(&pool).await, [3]);
    }

    /// A write whose caller stopped waiting before its group began is not applied.
    #[tokio::test]
    async fn a_write_nobody_waits_for_is_not_applied() {
        let (_dir, pool, writer) = table().await;
        let mut given_up = Box::pin(writer.write(1, insert_child(1, 1)));
        // Polled once, it is queued; dropped before the writer task runs, its caller is gone.
        let polled = std::future::poll_fn(|cx| {
            std::task::Poll::Ready(given_up.as_mut().poll(cx).is_ready())
        })
        .await;
        assert!(!polled);
        drop(given_up);
        assert_eq!(
            writer
                .write(1, insert_child(2, 1))
                .await
                .expect("the next write"),
            2
        );
        assert_eq!(children(&pool).await, [2]);
        assert_eq!(
            writer.groups(),
            WriteGroups {
                transactions: 1,
                writes: 1,
                abandoned: 1
            }
        );
    }

    /// A group stops taking writes once their rows reach `MAX_GROUP_ROWS`: three writes of
    /// 3/5 of it each, sent together, take two transactions (the second write tips the first group
    /// over, the third waits for the next).
    #[tokio::test]
    async fn a_group_is_bounded_by_rows_not_only_by_writes() {
        let (_dir, pool, writer) = table().await;
        let rows = MAX_GROUP_ROWS * 3 / 5;
        let (a, b, c) = tokio::join!(
            writer.write(rows, insert_child(1, 1)),
            writer.write(rows, insert_child(2, 1)),
            writer.write(rows, insert_child(3, 1)),
        );
        assert_eq!((a.expect("a"), b.expect("b"), c.expect("c")), (1, 2, 3));
        assert_eq!(children(&pool).await, [1, 2, 3]);
        assert_eq!(
            writer.groups(),
            WriteGroups {
                transactions: 2,
                writes: 3,
                abandoned: 0
            }
        );
    }
}
