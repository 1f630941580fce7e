-- sweep store, schema 1.
--
-- Times are seconds since the Unix epoch (REAL), supplied by the caller so that the scheduler's clock
-- can be simulated in tests. Job parameters and result records are opaque JSON to the Rust store; only
-- the views at the end know field names, for humans and for reports.
-- Tables are STRICT so that a wrong type is an error instead of a silent affinity conversion.

CREATE TABLE campaigns (
    id           TEXT PRIMARY KEY NOT NULL,          -- hash of the plan, computed by the caller
    name         TEXT NOT NULL,
    plan_text    TEXT NOT NULL,                      -- the plan as submitted, for provenance
    created_at   REAL NOT NULL,
    cancelled_at REAL                                -- NULL unless cancelled (resubmission clears it)
) STRICT;

CREATE TABLE jobs (
    id               TEXT PRIMARY KEY NOT NULL,      -- hash of the canonical params, computed by the caller
    kind             TEXT NOT NULL,
    params           TEXT NOT NULL CHECK (json_valid(params) AND json_type(params) = 'object'),
    estimate_s       REAL NOT NULL CHECK (estimate_s >= 0),
    exclusive        INTEGER NOT NULL CHECK (exclusive IN (0, 1)),
    state            TEXT NOT NULL DEFAULT 'queued'
                     CHECK (state IN ('queued', 'running', 'done', 'failed', 'cancelled')),
    attempts         INTEGER NOT NULL DEFAULT 0 CHECK (attempts >= 0),
    -- The lease: who runs the current attempt, its fencing token and until when. Owner and token are kept
    -- once a job is done so that a repeated report of the same lease is told apart from a foreign one.
    lease_owner      TEXT REFERENCES workers(id),
    lease_token      INTEGER,
    lease_expires_at REAL,
    last_error       TEXT,
    started_at       REAL,                           -- start of the current/last attempt
    finished_at      REAL,
    created_at       REAL NOT NULL,
    CHECK ((state = 'running') = (lease_expires_at IS NOT NULL)),
    CHECK (state <> 'running' OR (lease_owner IS NOT NULL AND lease_token IS NOT NULL))
) STRICT;

-- Leasing takes the oldest queued jobs (created_at, then insertion order = rowid, which every index carries).
CREATE INDEX jobs_state_created ON jobs (state, created_at);
-- Leasing asks whether an exclusive job is running; exclusive jobs are few, so this index is small.
CREATE INDEX jobs_exclusive_state ON jobs (state) WHERE exclusive = 1;
-- The reaper looks for running jobs whose lease has expired.
CREATE INDEX jobs_running_expiry ON jobs (lease_expires_at) WHERE state = 'running';

CREATE TABLE campaign_jobs (
    campaign_id TEXT NOT NULL REFERENCES campaigns(id),
    job_id      TEXT NOT NULL REFERENCES jobs(id),
    PRIMARY KEY (campaign_id, job_id)
) STRICT, WITHOUT ROWID;

-- Status and export go from a job to its campaigns.
CREATE INDEX campaign_jobs_job ON campaign_jobs (job_id);

CREATE TABLE workers (
    id            TEXT PRIMARY KEY NOT NULL,
    hostname      TEXT NOT NULL,
    cores         TEXT NOT NULL CHECK (json_valid(cores)),  -- JSON array of core ids
    cpu_model     TEXT NOT NULL,
    cpu_flags     TEXT NOT NULL,
    rustc         TEXT NOT NULL,
    git_commit    TEXT NOT NULL,
    profile       TEXT NOT NULL,
    registered_at REAL NOT NULL,
    last_seen_at  REAL NOT NULL
) STRICT;

-- One row per record of a job, written once, in the transaction that marks the job done.
CREATE TABLE results (
    job_id      TEXT NOT NULL REFERENCES jobs(id),
    attempt     INTEGER NOT NULL,
    worker_id   TEXT NOT NULL REFERENCES workers(id),
    core_id     INTEGER,
    row_index   INTEGER NOT NULL,
    fields      TEXT NOT NULL CHECK (json_valid(fields) AND json_type(fields) = 'object'),
    recorded_at REAL NOT NULL,
    PRIMARY KEY (job_id, row_index)
) STRICT, WITHOUT ROWID;

-- Reports that arrived from an expired or foreign lease: kept for diagnosis, never counted as results.
CREATE TABLE late_reports (
    job_id      TEXT NOT NULL,
    attempt     INTEGER,                             -- the job's attempt count when the report arrived
    worker_id   TEXT NOT NULL,
    token       INTEGER NOT NULL,                    -- the stale lease the report quoted
    reason      TEXT NOT NULL,
    received_at REAL NOT NULL
) STRICT;

-- Monotonic source of lease tokens: every lease call takes the next value, so a token is never reused,
-- even when a failed job is resubmitted and its attempt count restarts.
CREATE TABLE lease_tokens (
    id   INTEGER PRIMARY KEY CHECK (id = 1),
    last INTEGER NOT NULL
) STRICT;
INSERT INTO lease_tokens (id, last) VALUES (1, 0);

-- One row per overlap job (a point of Tonti & Patti's sweep), with its parameters.
CREATE VIEW overlap_points AS
SELECT
    id                                     AS job_id,
    json_extract(params, '$.l_star')       AS l_star,
    json_extract(params, '$.w_star')       AS w_star,
    json_extract(params, '$.r_star')       AS r_star,
    json_extract(params, '$.acceptance')   AS acceptance_target,
    json_extract(params, '$.precision')    AS precision,
    json_extract(params, '$.configurations') AS configurations,
    state
FROM jobs
WHERE kind = 'overlap';

-- One row per (overlap job, algorithm, repeat): the timings of the paper's Table 1 and Figure 2.
-- A job's other records (the stream baseline, generation time) have no `algorithm` and stay out.
CREATE VIEW overlap_timings AS
SELECT
    p.job_id, p.l_star, p.w_star, p.r_star, p.acceptance_target, p.precision, p.configurations,
    json_extract(r.fields, '$.algorithm')    AS algorithm,
    json_extract(r.fields, '$.repeat')       AS repeat,
    json_extract(r.fields, '$.ms')           AS ms,
    json_extract(r.fields, '$.ns_per_check') AS ns_per_check,
    json_extract(r.fields, '$.acceptance')   AS acceptance,
    r.worker_id,
    r.core_id
FROM overlap_points AS p
JOIN results AS r ON r.job_id = p.job_id AND json_type(r.fields, '$.algorithm') IS NOT NULL;

-- Every result row with the provenance of the worker that produced it.
CREATE VIEW result_provenance AS
SELECT
    r.job_id, j.kind, r.attempt, r.row_index, r.fields, r.core_id, r.recorded_at,
    w.id AS worker_id, w.hostname, w.cpu_model, w.cpu_flags, w.rustc, w.git_commit, w.profile
FROM results AS r
JOIN jobs AS j ON j.id = r.job_id
JOIN workers AS w ON w.id = r.worker_id;
