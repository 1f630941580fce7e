//! `sweep report` for the EDMD paper's figures (7–11, 13) and the cost of accuracy: rows from the
//! store's `edmd_runs` view, drawn or printed by the `report` crate.

use std::path::Path;

use anyhow::{Context, bail};
use report::{Clock, EdmdRow, FailedRun, LengthUnit, ReportError, VerdictRow};

use crate::db::{ReportArgs, open_read_only, runtime};
use crate::output::{Format, print_json, print_text};

/// The reports this module makes.
pub const NAMES: [&str; 7] = [
    "fig7", "fig8", "fig9", "fig10", "fig11", "fig13", "accuracy",
];

/// Every EDMD run of the database, as the report crate reads them, with τ_c by `clock` where
/// the record has it.
fn rows(db: &Path, clock: Clock) -> anyhow::Result<Vec<EdmdRow>> {
    let runs = runtime()?.block_on(async {
        let store = open_read_only(db).await?;
        anyhow::Ok(store.edmd_runs().await?)
    })?;
    Ok(edmd_rows(runs, clock))
}

/// The EDMD points that failed for good, with the parameters the `edmd_runs` view would have
/// given them: the accuracy report counts them against their setting.
fn failed_runs(db: &Path) -> anyhow::Result<Vec<FailedRun>> {
    let jobs = runtime()?.block_on(async {
        let store = open_read_only(db).await?;
        anyhow::Ok(store.failed_jobs("edmd").await?)
    })?;
    jobs.into_iter().map(failed_run).collect()
}

/// A failed job's parameters as the `edmd_runs` view would have read them (the same keys).
fn failed_run(job: store::FailedJob) -> anyhow::Result<FailedRun> {
    let params: serde_json::Value = serde_json::from_str(&job.params_json)
        .with_context(|| format!("failed job {}: its parameters are not JSON", job.id))?;
    let field = |key: &str| {
        params
            .get(key)
            .with_context(|| format!("failed job {}: its parameters have no `{key}`", job.id))
    };
    let real = |key: &str| {
        field(key)?
            .as_f64()
            .with_context(|| format!("failed job {}: `{key}` is not a number", job.id))
    };
    let integer = |key: &str| {
        field(key)?.as_u64().with_context(|| {
            format!(
                "failed job {}: `{key}` is not a non-negative integer",
                job.id
            )
        })
    };
    let text = |key: &str| {
        field(key)?
            .as_str()
            .map(str::to_owned)
            .with_context(|| format!("failed job {}: `{key}` is not a string", job.id))
    };
    let small = |key: &str| {
        u32::try_from(integer(key)?)
            .with_context(|| format!("failed job {}: `{key}` is out of range", job.id))
    };
    let run = EdmdRow {
        shape: text("shape")?,
        x0: real("x0")?,
        neighbours: text("neighbours")?,
        delta_nnl: real("delta_nnl")?,
        n: small("n")?,
        phi: real("phi")?,
        tau_c_us: f64::NAN,
        eps_d: real("eps_d")?,
        eps_nnl: real("eps_nnl")?,
        nr_tol: real("nr_tol")?,
        nr_max_iter: small("nr_max_iter")?,
        nr_relax: real("nr_relax")?,
        sd_max_iter: small("sd_max_iter")?,
        sd_tol: real("sd_tol")?,
        brent_tol: real("brent_tol")?,
        seed: integer("seed")?,
        collisions: integer("collisions")?,
        exponents: match params.get("exponents") {
            None => None,
            Some(value) => Some(serde_json::from_value(value.clone()).with_context(|| {
                format!("failed job {}: `exponents` is not three numbers", job.id)
            })?),
        },
        ..EdmdRow::default()
    };
    Ok(FailedRun {
        run,
        reason: job.reason,
    })
}

/// Stored EDMD runs as the report crate reads them, with τ_c by `clock` where the record has it
/// (the status page draws with the same conversion).
pub(crate) fn edmd_rows(runs: Vec<store::EdmdRun>, clock: Clock) -> Vec<EdmdRow> {
    let count = |n: i64| u64::try_from(n).unwrap_or_default();
    runs.into_iter()
        .map(|r| {
            let (tau_c_us, clock) = match (clock, r.tau_c_cpu_us) {
                (Clock::Cpu, Some(cpu)) => (cpu, Clock::Cpu),
                _ => (r.tau_c_us, Clock::Wall),
            };
            EdmdRow {
                shape: r.shape,
                x0: r.x0,
                exponents: r.exponents,
                neighbours: r.neighbours,
                delta_nnl: r.delta_nnl,
                n: u32::try_from(r.n).unwrap_or(u32::MAX),
                phi: r.phi,
                tau_c_us,
                clock,
                eps_d: r.eps_d,
                eps_nnl: r.eps_nnl,
                nr_tol: r.nr_tol,
                nr_max_iter: u32::try_from(r.nr_max_iter).unwrap_or(u32::MAX),
                nr_relax: r.nr_relax,
                sd_max_iter: u32::try_from(r.sd_max_iter).unwrap_or(u32::MAX),
                sd_tol: r.sd_tol,
                brent_tol: r.brent_tol,
                seed: count(r.seed),
                collisions: count(r.collisions),
                pressure_z: r.pressure_z,
                pressure_z_err: r.pressure_z_err,
                energy_drift_rel: r.energy_drift_rel,
                overlaps: count(r.overlaps),
                solver_failures: count(r.solver_failures),
                contact_nr_fallbacks: count(r.contact_nr_fallbacks),
                nr_iterations_mean: r.nr_iterations_mean,
                nnl_rebuilds: count(r.nnl_rebuilds),
                init_s: r.init_s,
                wall_s: r.wall_s,
                cpu_s: r.cpu_s,
                tau_update_us: r.tau_update_us,
                tau_predict_us: r.tau_predict_us,
                sequence: r
                    .sequence_fingerprint
                    .as_deref()
                    .and_then(edmd::sequence::blocks_from_hex),
                sequence_block: r.sequence_block.and_then(|b| u32::try_from(b).ok()),
            }
        })
        .collect()
}

/// `sweep report NAME` for NAME in [`NAMES`].
pub fn report(args: &ReportArgs, format: Format) -> anyhow::Result<()> {
    let name = args.name.as_str();
    let unit = LengthUnit::parse(&args.length_unit).with_context(|| {
        format!(
            "--length-unit {}: expected semi-axis or sigma",
            args.length_unit
        )
    })?;
    let clock = match args.clock.as_str() {
        "cpu" => Clock::Cpu,
        "wall" => Clock::Wall,
        other => bail!("--clock {other}: expected cpu or wall"),
    };
    let json = format == Format::Json;
    let out = args.out.as_deref();
    if out.is_none() && !json && name != "accuracy" {
        bail!("report {name}: give --out FILE.png or FILE.svg, or --format json");
    }
    let rows = rows(&args.db, clock)?;
    let (verdicts, failed) = if name == "accuracy" {
        (verdict_rows(&args.db)?, failed_runs(&args.db)?)
    } else {
        (Vec::new(), Vec::new())
    };
    if clock == Clock::Cpu && rows.iter().any(|r| r.clock == Clock::Wall) {
        eprintln!(
            "note: some records have no CPU τ_c (written before it was kept): their wall-clock τ_c is used"
        );
    }
    if rows.is_empty() && verdicts.is_empty() {
        bail!("report {name}: no EDMD results in {}", args.db.display());
    }
    let wrote = |path: &Path| eprintln!("wrote {}", path.display());
    match name {
        "fig7" => {
            let out = out.context("report fig7: give --out FILE.png or FILE.svg")?;
            report::fig7(&rows, out)?;
            wrote(out);
        }
        "fig8" => finish(report::fig8(&rows, out), json, out, |f| &f.missing)?,
        "fig9" => finish(report::fig9(&rows, unit, out), json, out, |f| &f.missing)?,
        "fig10" => finish(report::fig10(&rows, unit, out), json, out, |f| &f.missing)?,
        "fig11" => finish(report::fig11(&rows, unit, out), json, out, |f| &f.missing)?,
        "fig13" => finish(report::fig13(&rows, out), json, out, |f| &f.missing)?,
        "accuracy" => accuracy(&rows, &failed, &verdicts, json, out)?,
        other => bail!("report `{other}` is not an EDMD report"),
    }
    Ok(())
}

/// Prints the figure's data as JSON when asked, says where it was drawn, and lists the paper's
/// points the database lacks.
fn finish<F: serde::Serialize>(
    figure: Result<F, ReportError>,
    json: bool,
    out: Option<&Path>,
    missing: impl Fn(&F) -> &Vec<String>,
) -> anyhow::Result<()> {
    let figure = figure?;
    for point in missing(&figure) {
        eprintln!("missing: {point}");
    }
    if json {
        print_json(&figure)?;
    }
    if let Some(out) = out {
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// The overlap points run with `verdict_check`, as the report crate reads them.
fn verdict_rows(db: &Path) -> anyhow::Result<Vec<VerdictRow>> {
    let rows = runtime()?.block_on(async {
        let store = open_read_only(db).await?;
        anyhow::Ok(store.overlap_verdicts().await?)
    })?;
    Ok(rows
        .into_iter()
        .map(|r| VerdictRow {
            l_star: r.l_star,
            w_star: r.w_star,
            r_star: r.r_star,
            precision: r.precision,
            algorithm: r.algorithm,
            ns_per_check: r.ns_per_check,
            bulk: r.bulk,
            shell: r.shell,
            bulk_wrong: r.bulk_wrong,
            shell_wrong: r.shell_wrong,
            shell_max_gap: r.shell_max_gap,
            shell_by_decade: r.shell_by_decade,
            shell_wrong_by_decade: r.shell_wrong_by_decade,
        })
        .collect())
}

fn accuracy(
    rows: &[EdmdRow],
    failed: &[FailedRun],
    verdicts: &[VerdictRow],
    json: bool,
    out: Option<&Path>,
) -> anyhow::Result<()> {
    let study = report::accuracy_report(rows, failed, verdicts)?;
    for point in &study.missing {
        eprintln!("missing: {point}");
    }
    if json {
        print_json(&study)?;
    }
    let Some(out) = out else {
        if !json {
            print_text(&report::accuracy_markdown(&study))?;
        }
        return Ok(());
    };
    match out.extension().and_then(|e| e.to_str()) {
        Some("md") => std::fs::write(out, report::accuracy_markdown(&study))
            .with_context(|| format!("cannot write {}", out.display()))?,
        _ => report::accuracy_plot(&study, out)?,
    }
    eprintln!("wrote {}", out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_job_is_read_with_the_keys_a_finished_one_has() {
        let scene = edmd::Scene::from_toml_str(
            "shape = \"ellipsoid\"\nn = 256\nphi = 0.3\nx0 = 0.5\nneighbours = \"nnl\"\n\
             delta_nnl = 0.06\nnr_tol = 1e-14\ncollisions = 20000\nseed = 3\n",
        )
        .expect("a valid scene");
        let spec = jobs::JobSpec::Edmd(scene.clone());
        let job = store::FailedJob {
            id: spec.id(),
            params_json: spec.canonical_json(),
            reason: "edmd: unresolved distance".into(),
        };
        let failed = failed_run(job).expect("readable parameters");
        let run = &failed.run;
        assert_eq!(
            (run.shape.as_str(), run.neighbours.as_str()),
            ("ellipsoid", "nnl")
        );
        assert_eq!(
            (run.n, run.phi, run.x0, run.delta_nnl),
            (256, 0.3, 0.5, 0.06)
        );
        assert_eq!(
            (run.nr_tol, run.eps_d, run.eps_nnl),
            (1e-14, scene.eps_d, scene.eps_nnl)
        );
        assert_eq!(
            (run.nr_max_iter, run.sd_max_iter),
            (scene.nr_max_iter, scene.sd_max_iter)
        );
        assert_eq!(
            (run.nr_relax, run.sd_tol, run.brent_tol),
            (scene.nr_relax, scene.sd_tol, scene.brent_tol)
        );
        assert_eq!((run.seed, run.collisions), (3, 20000));
        assert!(run.tau_c_us.is_nan(), "a failed run has no τ_c");
        assert_eq!(run.exponents, None);
        assert_eq!(failed.reason, "edmd: unresolved distance");

        let superquadric = edmd::Scene::from_toml_str(
            "shape = \"superquadric\"\nexponents = [2.0, 2.0, 4.0]\nn = 64\nphi = 0.256\nx0 = 2.0\n",
        )
        .expect("a valid superquadric scene");
        let spec = jobs::JobSpec::Edmd(superquadric);
        let job = store::FailedJob {
            id: spec.id(),
            params_json: spec.canonical_json(),
            reason: String::new(),
        };
        let run = failed_run(job).expect("readable parameters").run;
        assert_eq!(
            (run.shape.as_str(), run.exponents),
            ("superquadric", Some([2.0, 2.0, 4.0]))
        );

        let broken = store::FailedJob {
            id: "j1".into(),
            params_json: r#"{"kind":"edmd","shape":"ellipsoid"}"#.into(),
            reason: String::new(),
        };
        let err = format!("{:#}", failed_run(broken).expect_err("no x0"));
        assert!(
            err.contains("failed job j1") && err.contains("`x0`"),
            "{err}"
        );
    }
}
