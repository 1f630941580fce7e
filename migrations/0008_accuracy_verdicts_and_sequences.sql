-- sweep store, schema 8: what the accuracy report needs beyond schema 6.
--
-- EDMD: Eq. 73 split in time (tau_update_us: box and list rebuilds per collision, tau_predict_us:
-- the rest of tau_c_us, both wall clock; nnl_rebuild_s: the rebuilds' total) and the fingerprint of
-- the collision sequence (sequence_fingerprint: 8 hex digits per block of sequence_block
-- collisions, crates/edmd/src/sequence.rs). Records written before read as NULL.
--
-- Overlap: overlap_verdicts, one row per (point, algorithm) of the points run with `verdict_check`:
-- how many configurations of the checking set were judged (bulk: drawn as the timed sets; shell:
-- near the surface, by decade of the relative gap), how many verdicts differed from the exact one,
-- and the algorithm's mean ns/check at that point (from its timing records).
DROP VIEW edmd_runs;
CREATE VIEW edmd_runs AS
SELECT
    j.id                                              AS job_id,
    json_extract(j.params, '$.shape')                 AS shape,
    json_extract(j.params, '$.n')                     AS n,
    json_extract(j.params, '$.phi')                   AS phi,
    json_extract(j.params, '$.x0')                    AS x0,
    json_extract(j.params, '$.neighbours')            AS neighbours,
    json_extract(j.params, '$.eps_d')                 AS eps_d,
    json_extract(j.params, '$.delta_nnl')             AS delta_nnl,
    json_extract(j.params, '$.eps_nnl')               AS eps_nnl,
    json_extract(j.params, '$.nr_tol')                AS nr_tol,
    json_extract(j.params, '$.nr_max_iter')           AS nr_max_iter,
    json_extract(j.params, '$.nr_relax')              AS nr_relax,
    json_extract(j.params, '$.sd_max_iter')           AS sd_max_iter,
    json_extract(j.params, '$.sd_tol')                AS sd_tol,
    json_extract(j.params, '$.brent_tol')             AS brent_tol,
    json_extract(j.params, '$.seed')                  AS seed,
    json_extract(j.params, '$.equilibrate')           AS equilibrate,
    json_extract(r.fields, '$.collisions')            AS collisions,
    json_extract(r.fields, '$.tau_c_us')              AS tau_c_us,
    json_extract(r.fields, '$.tau_c_cpu_us')          AS tau_c_cpu_us,
    json_extract(r.fields, '$.pressure_z')            AS pressure_z,
    json_extract(r.fields, '$.pressure_z_err')        AS pressure_z_err,
    json_extract(r.fields, '$.temperature')           AS temperature,
    json_extract(r.fields, '$.energy_drift_rel')      AS energy_drift_rel,
    json_extract(r.fields, '$.momentum_drift')        AS momentum_drift,
    json_extract(r.fields, '$.overlaps')              AS overlaps,
    json_extract(r.fields, '$.solver_failures')       AS solver_failures,
    json_extract(r.fields, '$.contact_nr_fallbacks')  AS contact_nr_fallbacks,
    json_extract(r.fields, '$.nr_iterations_mean')    AS nr_iterations_mean,
    json_extract(r.fields, '$.distance_calls_per_collision') AS distance_calls_per_collision,
    json_extract(r.fields, '$.searches_per_collision') AS searches_per_collision,
    json_extract(r.fields, '$.nnl_rebuilds')          AS nnl_rebuilds,
    json_extract(r.fields, '$.cell_crossings')        AS cell_crossings,
    json_extract(r.fields, '$.init_s')                AS init_s,
    json_extract(r.fields, '$.wall_s')                AS wall_s,
    json_extract(r.fields, '$.cpu_s')                 AS cpu_s,
    json_extract(r.fields, '$.tau_update_us')         AS tau_update_us,
    json_extract(r.fields, '$.tau_predict_us')        AS tau_predict_us,
    json_extract(r.fields, '$.nnl_rebuild_s')         AS nnl_rebuild_s,
    json_extract(r.fields, '$.sequence_block')        AS sequence_block,
    json_extract(r.fields, '$.sequence_fingerprint')  AS sequence_fingerprint,
    r.worker_id,
    r.core_id
FROM jobs AS j
JOIN results AS r ON r.job_id = j.id
WHERE j.kind = 'edmd';

CREATE VIEW overlap_verdicts AS
SELECT
    p.job_id, p.l_star, p.w_star, p.r_star, p.acceptance_target, p.precision,
    json_extract(a.value, '$.algorithm')                          AS algorithm,
    (SELECT avg(t.ns_per_check) FROM overlap_timings AS t
     WHERE t.job_id = p.job_id AND t.algorithm = json_extract(a.value, '$.algorithm')) AS ns_per_check,
    json_extract(r.fields, '$.verdicts.bulk')                     AS bulk,
    json_extract(r.fields, '$.verdicts.shell')                    AS shell,
    json_extract(r.fields, '$.verdicts.undecided')                AS undecided,
    json_extract(r.fields, '$.verdicts.shell_by_decade')          AS shell_by_decade,
    json_extract(a.value, '$.bulk_wrong')                         AS bulk_wrong,
    json_extract(a.value, '$.shell_wrong')                        AS shell_wrong,
    json_extract(a.value, '$.shell_wrong_by_decade')              AS shell_wrong_by_decade
FROM overlap_points AS p
JOIN results AS r ON r.job_id = p.job_id AND json_type(r.fields, '$.verdicts') = 'object'
JOIN json_each(r.fields, '$.verdicts.algorithms') AS a;
