-- sweep store, schema 3: the EDMD runs as a view, one row per done edmd job (its single record),
-- with the point's parameters next to its measured figures, for `sweep report fig7` and humans.
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
    json_extract(r.fields, '$.collisions')            AS collisions,
    json_extract(r.fields, '$.tau_c_us')              AS tau_c_us,
    json_extract(r.fields, '$.pressure_z')            AS pressure_z,
    json_extract(r.fields, '$.pressure_z_err')        AS pressure_z_err,
    json_extract(r.fields, '$.overlaps')              AS overlaps,
    json_extract(r.fields, '$.solver_failures')       AS solver_failures,
    r.worker_id,
    r.core_id
FROM jobs AS j
JOIN results AS r ON r.job_id = j.id
WHERE j.kind = 'edmd';
