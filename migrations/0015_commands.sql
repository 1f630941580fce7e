-- sweep store, schema 15: program jobs (`[[command]]`) and who may run them.
--
-- A job that runs foreign code (a program job) is leased only to a worker started with
-- `--allow-commands`: `jobs.foreign_code` is set by the submitter (the store knows no kinds),
-- `workers.allow_commands` by the worker's registration. A worker without it never sees such a
-- job; its grants walk the partial index below, which holds no foreign-code job, so a queue full
-- of them costs it nothing.
ALTER TABLE jobs ADD COLUMN foreign_code INTEGER NOT NULL DEFAULT 0 CHECK (foreign_code IN (0, 1));
ALTER TABLE workers ADD COLUMN allow_commands INTEGER NOT NULL DEFAULT 0
    CHECK (allow_commands IN (0, 1));
CREATE INDEX jobs_queued_no_foreign_code ON jobs (created_at, pass, id)
    WHERE state = 'queued' AND foreign_code = 0;

-- A program job's values, one row per value: its record is
-- {label, wall_s, cpu_s, exit_status, program_hash, values: {name: number}}.
CREATE VIEW command_results AS
SELECT
    cj.campaign_id                          AS campaign,
    j.id                                    AS job_id,
    json_extract(j.params, '$.label')       AS label,
    json_extract(j.params, '$.params')      AS parameters,
    v.key                                   AS name,
    v.value                                 AS value
FROM jobs j
JOIN campaign_jobs cj ON cj.job_id = j.id
JOIN results r ON r.job_id = j.id
JOIN json_each(r.fields, '$.values') v
WHERE j.kind = 'command' AND j.state = 'done';
