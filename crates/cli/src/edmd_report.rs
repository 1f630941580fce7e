//! `sweep report` for the EDMD paper's figures (7–11, 13) and the cost of accuracy: rows from the
//! store's `edmd_runs` view, drawn or printed by the `report` crate.

use std::path::Path;

use anyhow::{Context, bail};
use report::{Clock, EdmdRow, LengthUnit, ReportError, VerdictRow};

use crate::db::{ReportArgs, open_read_only, runtime};
use crate::output::{Format, print_json, print_text};

/// The reports this module makes.
pub const NAMES: [&str; 7] = ["fig7", "fig8", "fig9", "fig10", "fig11", "fig13", "accuracy"];

/// Every EDMD run of the database, as the report crate reads them, with τ_c by `clock` where
/// the record has it.
fn rows(db: &Path, clock: Clock) -> anyhow::Result<Vec<EdmdRow>> {
    let runs = runtime()?.block_on(async {
        let store = open_read_only(db).await?;
        anyhow::Ok(store.edmd_runs().await?)
    })?;
    Ok(edmd_rows(runs, clock))
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
    let verdicts = if name == "accuracy" {
        verdict_rows(&args.db)?
    } else {
        Vec::new()
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
        "accuracy" => accuracy(&rows, &verdicts, json, out)?,
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
    verdicts: &[VerdictRow],
    json: bool,
    out: Option<&Path>,
) -> anyhow::Result<()> {
    let study = report::accuracy_report(rows, verdicts)?;
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
