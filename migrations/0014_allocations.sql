-- sweep store, schema 14: the allocations a coordinator asks a batch system for (`sweep coordinator
-- --slurm-alloc FILE`), the allocator's own state, and the allocation each worker runs in.
--
-- An allocation is one `sbatch` of deploy/slurm/sweep.sbatch that brings workers. Its row is written
-- when it is submitted (or when submitting it failed: then `external_id` is NULL and `reason` says
-- why) and updated as the batch system reports it; it is never deleted, so that every failure stays
-- visible. `reason`: Slurm's pending reason, how it ended (COMPLETED, TIMEOUT, ...), or why it
-- failed. Allocations that are pending or running are found through a small partial index.
CREATE TABLE allocations (
    id           INTEGER PRIMARY KEY,                 -- ours, in order of submission
    manager      TEXT NOT NULL CHECK (manager IN ('slurm')),
    external_id  TEXT,                                -- the Slurm job id; NULL when sbatch failed
    state        TEXT NOT NULL
                 CHECK (state IN ('pending', 'running', 'ended', 'failed', 'cancelled')),
    nodes        INTEGER NOT NULL CHECK (nodes >= 1),
    cores        INTEGER NOT NULL CHECK (cores >= 1), -- the whole allocation's, all nodes together
    time_limit_s REAL NOT NULL CHECK (time_limit_s > 0),
    submitted_at REAL NOT NULL,
    started_at   REAL,
    ended_at     REAL,
    reason       TEXT NOT NULL DEFAULT '',
    CHECK ((state IN ('pending', 'running')) = (ended_at IS NULL))
) STRICT;
CREATE INDEX allocations_open ON allocations (state) WHERE state IN ('pending', 'running');
CREATE UNIQUE INDEX allocations_external ON allocations (manager, external_id)
    WHERE external_id IS NOT NULL;

-- What the allocator decided last and whether it is backing off: one row, replaced at each change.
CREATE TABLE allocator (
    id         INTEGER PRIMARY KEY CHECK (id = 1),
    updated_at REAL NOT NULL,
    failures   INTEGER NOT NULL CHECK (failures >= 0), -- failed submissions or allocations in a row
    retry_at   REAL,                                   -- no submission before this time (backing off)
    note       TEXT NOT NULL                           -- the last decision, in words
) STRICT;

-- The batch system's id of the allocation a worker runs in (`sweep worker --allocation`, by default
-- SLURM_JOB_ID); NULL for a worker started by hand or in local mode.
ALTER TABLE workers ADD COLUMN allocation TEXT;
CREATE INDEX workers_allocation ON workers (allocation) WHERE allocation IS NOT NULL;
