-- sweep store, schema 10: every failed attempt of a job, with the worker that held it and why, for
-- the status page's "last failures" (jobs.last_error keeps only the latest reason, and a retried
-- job forgets its worker). Written in the transaction that fails the attempt or reaps its lease.
-- Read newest first by rowid, so the last N cost O(N) whatever the table's size.
CREATE TABLE job_failures (
    job_id    TEXT NOT NULL REFERENCES jobs(id),
    attempt   INTEGER NOT NULL,
    worker_id TEXT REFERENCES workers(id),          -- who held the lease
    reason    TEXT NOT NULL,
    failed_at REAL NOT NULL
) STRICT;
