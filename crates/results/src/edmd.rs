//! EDMD jobs read back: every done run as the report crate's [`EdmdRow`], and the runs that
//! failed for good as [`FailedRun`]s, each from its parameters (the [`edmd::Scene`] it was
//! submitted as) and, when done, its one record (`jobs::run`: the fields of
//! [`edmd::RunReport`] plus the job's `wall_s`, `cpu_s` and collision-sequence fingerprint).

use edmd::Scene;
use jobs::JobSpec;
use report::{Clock, EdmdRow, FailedRun};
use serde::Deserialize;
use store::Store;

use crate::error::{Result, corrupt};

/// The fields of an EDMD record that reports read. Those written only by later versions of
/// the engine may be absent (older databases stay readable); every other one must be there.
#[derive(Deserialize)]
struct EdmdRecord {
    collisions: u64,
    tau_c_us: f64,
    tau_c_cpu_us: Option<f64>,
    pressure_z: f64,
    /// NaN (one block) is written as JSON null.
    pressure_z_err: Option<f64>,
    energy_drift_rel: f64,
    overlaps: u64,
    solver_failures: u64,
    contact_nr_fallbacks: u64,
    nr_iterations_mean: f64,
    nnl_rebuilds: u64,
    init_s: Option<f64>,
    wall_s: Option<f64>,
    cpu_s: Option<f64>,
    tau_update_us: Option<f64>,
    tau_predict_us: Option<f64>,
    sequence_fingerprint: Option<String>,
    sequence_block: Option<u32>,
}

/// The scene a stored EDMD job was submitted as.
fn scene(job_id: &str, params_json: &str) -> Result<Scene> {
    match serde_json::from_str(params_json) {
        Ok(JobSpec::Edmd(scene)) => Ok(scene),
        Ok(other) => Err(corrupt(
            "edmd",
            job_id,
            format!("its parameters are a {} job's", other.kind()),
        )),
        Err(e) => Err(corrupt(
            "edmd",
            job_id,
            format!("unreadable parameters: {e}"),
        )),
    }
}

/// The name `value` (a unit enum variant) is serialised as: the scene's own spelling of its
/// shape and neighbour method.
fn name_of(value: impl serde::Serialize) -> String {
    match serde_json::to_value(value) {
        Ok(serde_json::Value::String(name)) => name,
        _ => String::new(),
    }
}

/// The row of a point with `scene`'s parameters and no result yet (τ_c NaN).
fn row_of(job_id: &str, scene: &Scene) -> Result<EdmdRow> {
    let small = |key: &str, value: u64| {
        u32::try_from(value)
            .map_err(|_| corrupt("edmd", job_id, format!("`{key}` = {value} is out of range")))
    };
    Ok(EdmdRow {
        // A mixture is not a point of its first species' one-size curves (nor of the peers'
        // sphere comparison): its rows carry a shape of their own.
        shape: if scene.is_mixture() {
            format!("{}-mixture", name_of(scene.shape))
        } else {
            name_of(scene.shape)
        },
        x0: scene.x0,
        exponents: scene.exponents,
        neighbours: name_of(scene.neighbours),
        delta_nnl: scene.delta_nnl,
        n: small("n", scene.n as u64)?,
        phi: scene.phi,
        tau_c_us: f64::NAN,
        eps_d: scene.eps_d,
        eps_nnl: scene.eps_nnl,
        nr_tol: scene.nr_tol,
        nr_max_iter: scene.nr_max_iter,
        nr_relax: scene.nr_relax,
        sd_max_iter: scene.sd_max_iter,
        sd_tol: scene.sd_tol,
        brent_tol: scene.brent_tol,
        seed: scene.seed,
        collisions: scene.collisions,
        ..EdmdRow::default()
    })
}

/// Every done EDMD point with τ_c by `clock` where its record has it (records written before
/// the CPU τ_c was kept give the wall clock's, and say so in `clock`), ordered by shape, X0,
/// neighbour method, N, Δ_NNL, φ, ε_d, nr_tol, seed and the superquadric exponent p (then in
/// submission order). A record lacking a field the engine always writes is an error.
pub async fn edmd_runs(store: &Store, clock: Clock) -> Result<Vec<EdmdRow>> {
    let mut rows: Vec<EdmdRow> = edmd_scenes(store, clock)
        .await?
        .into_iter()
        .map(|(_, row)| row)
        .collect();
    let p = |r: &EdmdRow| r.exponents.map(|e| e[2]);
    rows.sort_by(|a, b| {
        a.shape
            .cmp(&b.shape)
            .then(a.x0.total_cmp(&b.x0))
            .then_with(|| a.neighbours.cmp(&b.neighbours))
            .then(a.n.cmp(&b.n))
            .then(a.delta_nnl.total_cmp(&b.delta_nnl))
            .then(a.phi.total_cmp(&b.phi))
            .then(a.eps_d.total_cmp(&b.eps_d))
            .then(a.nr_tol.total_cmp(&b.nr_tol))
            .then(a.seed.cmp(&b.seed))
            .then_with(|| match (p(a), p(b)) {
                (Some(x), Some(y)) => x.total_cmp(&y),
                (x, y) => x.is_some().cmp(&y.is_some()),
            })
    });
    Ok(rows)
}

/// Every done EDMD point as the scene it was submitted as and its row (as [`edmd_runs`]), in
/// submission order: for searches, which match scenes, not rows.
pub async fn edmd_scenes(store: &Store, clock: Clock) -> Result<Vec<(Scene, EdmdRow)>> {
    let mut rows = Vec::new();
    for job in store.results_of("edmd").await? {
        let scene = scene(&job.job_id, &job.params_json)?;
        let [record] = job.records.as_slice() else {
            return Err(corrupt(
                "edmd",
                &job.job_id,
                format!("{} records where a run writes one", job.records.len()),
            ));
        };
        let r: EdmdRecord = serde_json::from_str(record)
            .map_err(|e| corrupt("edmd", &job.job_id, format!("malformed record: {e}")))?;
        let (tau_c_us, clock) = match (clock, r.tau_c_cpu_us) {
            (Clock::Cpu, Some(cpu)) => (cpu, Clock::Cpu),
            _ => (r.tau_c_us, Clock::Wall),
        };
        let row = EdmdRow {
            tau_c_us,
            clock,
            collisions: r.collisions,
            pressure_z: r.pressure_z,
            pressure_z_err: r.pressure_z_err,
            energy_drift_rel: r.energy_drift_rel,
            overlaps: r.overlaps,
            solver_failures: r.solver_failures,
            contact_nr_fallbacks: r.contact_nr_fallbacks,
            nr_iterations_mean: r.nr_iterations_mean,
            nnl_rebuilds: r.nnl_rebuilds,
            init_s: r.init_s,
            wall_s: r.wall_s,
            cpu_s: r.cpu_s,
            tau_update_us: r.tau_update_us,
            tau_predict_us: r.tau_predict_us,
            sequence: r
                .sequence_fingerprint
                .as_deref()
                .and_then(edmd::sequence::blocks_from_hex),
            sequence_block: r.sequence_block,
            ..row_of(&job.job_id, &scene)?
        };
        rows.push((scene, row));
    }
    Ok(rows)
}

/// The scenes of the EDMD points that failed for good (a search counts them against their
/// value) and of those queued or running (a search's evaluations in flight).
pub async fn edmd_unfinished_scenes(store: &Store) -> Result<(Vec<Scene>, Vec<Scene>)> {
    let failed = store
        .failed_jobs("edmd")
        .await?
        .into_iter()
        .map(|job| scene(&job.id, &job.params_json))
        .collect::<Result<Vec<_>>>()?;
    let pending = store
        .query_read_only_with(
            "SELECT id, params FROM jobs WHERE kind = 'edmd' AND state IN ('queued', 'running')",
            &[],
        )
        .await?
        .rows
        .iter()
        .map(|row| match row.as_slice() {
            [
                serde_json::Value::String(id),
                serde_json::Value::String(params),
            ] => scene(id, params),
            _ => Err(corrupt(
                "edmd",
                "?",
                "a job row without id and parameters".to_owned(),
            )),
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((failed, pending))
}

/// The EDMD points that failed for good, with their parameters as a done run's row has them
/// and the reason of their last attempt: the accuracy report counts them against their setting.
pub async fn failed_edmd_runs(store: &Store) -> Result<Vec<FailedRun>> {
    store
        .failed_jobs("edmd")
        .await?
        .into_iter()
        .map(|job| {
            Ok(FailedRun {
                run: row_of(&job.id, &scene(&job.id, &job.params_json)?)?,
                reason: job.reason,
            })
        })
        .collect()
}
