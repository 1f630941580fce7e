-- sweep store, schema 6: the edmd_runs view keeps what the EDMD paper's Figures 7-11 and the
-- accuracy report need: every accuracy knob of the point (eps_d, eps_nnl, the solver tolerances,
-- the seed), and of its record the accuracy checks (energy drift, overlaps, Z and its error, solver
-- failures), the cost split (NR iterations, distance calls, contact searches, list rebuilds and cell
-- crossings: the terms of Eq. 73), the job's wall and CPU time and the initial state's time.
-- and tau_c from the thread's CPU time (the paper's definition) next to the wall-clock one.
-- Records written before these fields existed (tau_c_cpu_us, wall_s, cpu_s) read as NULL.
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
    r.worker_id,
    r.core_id
FROM jobs AS j
JOIN results AS r ON r.job_id = j.id
WHERE j.kind = 'edmd';
