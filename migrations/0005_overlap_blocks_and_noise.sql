-- sweep store, schema 5: the overlap protocol times each pass in short blocks and checks the machine.
--
-- A timing record now also carries `total_ms` (the whole pass, as the papers time it) and
-- `block_ns_per_check` (a JSON array: every block's ns/check), and its `ns_per_check` is the median of its
-- blocks. The point record carries the noise references measured before and after, whether the machine
-- was still disturbed after the re-runs (`disturbed`, `disturbance`), how many re-runs it took, and what
-- the measurement cost (`repeats`, `stop`, `timed_s`, `wall_s`). Records of earlier schemas lack these
-- fields: the views give NULL for them.

-- The same columns as before, in the same order, then the new ones.
DROP VIEW overlap_timings;
CREATE VIEW overlap_timings AS
SELECT
    p.job_id, p.l_star, p.w_star, p.r_star, p.acceptance_target, p.precision, p.configurations,
    json_extract(r.fields, '$.algorithm')    AS algorithm,
    json_extract(r.fields, '$.repeat')       AS repeat,
    json_extract(r.fields, '$.ms')           AS ms,
    json_extract(r.fields, '$.ns_per_check') AS ns_per_check,
    json_extract(r.fields, '$.acceptance')   AS acceptance,
    r.worker_id,
    r.core_id,
    json_extract(r.fields, '$.total_ms')     AS total_ms,
    json_extract(r.fields, '$.block_ns_per_check') AS block_ns_per_check
FROM overlap_points AS p
JOIN results AS r ON r.job_id = p.job_id AND json_type(r.fields, '$.algorithm') IS NOT NULL;

-- One row per overlap point measured with the noise check: was the machine disturbed, how often was the
-- point re-run, what did its precision cost. The point record is a job's last record (crates/jobs/src/run.rs):
-- found through the primary key, so that reading it parses one record per job, not every timing.
CREATE VIEW overlap_measurements AS
SELECT
    p.job_id, p.l_star, p.w_star, p.r_star, p.precision,
    json_extract(p_params.params, '$.ci_target')                AS ci_target,
    json_extract(p_params.params, '$.time_cap_s')               AS time_cap_s,
    json_extract(r.fields, '$.repeats')                         AS repeats,
    json_extract(r.fields, '$.stop')                            AS stop,
    json_extract(r.fields, '$.timed_s')                         AS timed_s,
    json_extract(r.fields, '$.wall_s')                          AS wall_s,
    json_extract(r.fields, '$.disturbed')                       AS disturbed,
    json_extract(r.fields, '$.disturbance')                     AS disturbance,
    json_extract(r.fields, '$.reruns')                          AS reruns,
    json_extract(r.fields, '$.reference_compute_ns_before')     AS reference_compute_ns_before,
    json_extract(r.fields, '$.reference_compute_ns_after')      AS reference_compute_ns_after,
    json_extract(r.fields, '$.reference_compute_ns_baseline')   AS reference_compute_ns_baseline,
    json_extract(r.fields, '$.reference_stream_ns_before')      AS reference_stream_ns_before,
    json_extract(r.fields, '$.reference_stream_ns_after')       AS reference_stream_ns_after,
    r.worker_id,
    r.core_id
FROM overlap_points AS p
JOIN jobs AS p_params ON p_params.id = p.job_id
JOIN results AS r ON r.job_id = p.job_id
    AND r.row_index = (SELECT max(last.row_index) FROM results AS last WHERE last.job_id = p.job_id)
    AND json_type(r.fields, '$.algorithm') IS NULL AND json_type(r.fields, '$.disturbed') IS NOT NULL;
