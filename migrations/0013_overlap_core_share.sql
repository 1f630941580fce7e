-- sweep store, schema 13: what the noise check of an overlap point measured since the check was
-- calibrated (crates/overlap/src/noise.rs): the share of its core the thread had during its timed
-- passes (core_share: its CPU time over their wall time; below 1 when another process ran on the
-- core), the fastest earlier plain read of sets of this size on the same thread
-- (reference_stream_ns_baseline), and the size of the set (arrays_bytes), by which those reads
-- and the machine history compare. Records written before read as NULL.
DROP VIEW overlap_measurements;
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
    json_extract(r.fields, '$.core_share')                      AS core_share,
    json_extract(r.fields, '$.arrays_bytes')                    AS arrays_bytes,
    json_extract(r.fields, '$.reference_compute_ns_before')     AS reference_compute_ns_before,
    json_extract(r.fields, '$.reference_compute_ns_after')      AS reference_compute_ns_after,
    json_extract(r.fields, '$.reference_compute_ns_baseline')   AS reference_compute_ns_baseline,
    json_extract(r.fields, '$.reference_stream_ns_before')      AS reference_stream_ns_before,
    json_extract(r.fields, '$.reference_stream_ns_after')       AS reference_stream_ns_after,
    json_extract(r.fields, '$.reference_stream_ns_baseline')    AS reference_stream_ns_baseline,
    r.worker_id,
    r.core_id
FROM overlap_points AS p
JOIN jobs AS p_params ON p_params.id = p.job_id
JOIN results AS r ON r.job_id = p.job_id
    AND r.row_index = (SELECT max(last.row_index) FROM results AS last WHERE last.job_id = p.job_id)
    AND json_type(r.fields, '$.algorithm') IS NULL AND json_type(r.fields, '$.disturbed') IS NOT NULL;
