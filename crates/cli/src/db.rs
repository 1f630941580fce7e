//! Commands that read a result database: `status`, `report`, `query`, `export`.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use coordinator::Store;
use overlap::estimate::{Estimate, Statistic};
use report::{OverlapRow, TableFormat};

use crate::local::report_status;
use crate::output::{Format, print_json, print_table, print_text, write_csv};

pub(crate) fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    Ok(tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?)
}

/// Opens `db` read-only: reading never creates, migrates or changes the file.
pub(crate) async fn open_read_only(db: &Path) -> anyhow::Result<Store> {
    if !db.exists() {
        bail!("{}: no such database", db.display());
    }
    match Store::open_read_only(db).await {
        Err(error @ store::Error::SchemaOutdated { .. }) => bail!(
            "cannot open {}: {error}; `sweep run PLAN --db {}` or `sweep coordinator --db {}` migrates it",
            db.display(),
            db.display(),
            db.display()
        ),
        opened => opened.with_context(|| format!("cannot open {}", db.display())),
    }
}

#[derive(Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["db", "coordinator"])))]
pub struct StatusArgs {
    /// Read a result database directly.
    #[arg(long)]
    db: Option<PathBuf>,
    /// Ask a running coordinator.
    #[arg(long)]
    coordinator: Option<String>,
    #[command(flatten)]
    auth: crate::remote::AuthArgs,
    #[arg(long)]
    ca: Option<PathBuf>,
    /// One campaign (default: everything).
    #[arg(long)]
    campaign: Option<String>,
}

pub fn status(args: &StatusArgs, format: Format) -> anyhow::Result<()> {
    let campaign = args.campaign.as_deref();
    match (&args.db, &args.coordinator) {
        (Some(db), _) => runtime()?.block_on(async {
            let store = open_read_only(db).await?;
            let status = store.status(campaign).await?;
            let quality = store.overlap_quality(campaign).await?;
            report_status(campaign.unwrap_or("(all)"), &status, Some(&quality), format)
        }),
        (None, Some(url)) => {
            let client =
                crate::remote::ClientArgs::new(url.clone(), args.auth.clone(), args.ca.clone());
            crate::remote::remote_status(&client, campaign, format)
        }
        (None, None) => bail!("give --db FILE or --coordinator URL"),
    }
}

#[derive(Args)]
pub struct ReportArgs {
    /// table1 (f32), table2 (f64), fig2 (f32), fig3 (f64); EDMD: fig7 (τ_c against φ), fig8 (against X0, LL/NNL),
    /// fig9 (against ε_d), fig10 (against Δ_NNL), fig11 (Δ*_NNL), fig13 (superquadrics against p),
    /// accuracy (cost of each accuracy knob).
    pub(crate) name: String,
    #[arg(long)]
    pub(crate) db: PathBuf,
    /// Write here instead of stdout; the extension picks the format (.md .csv .tex .json .png .svg).
    /// Figures 2–3 print their points (estimate and 95 % interval) with `--format json` and no --out.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Lengths on EDMD axes (Δ_NNL, ε_d): semi-axis (the paper's unit, the smallest semi-axis) or sigma
    /// (the engine's and the plans' unit, the diameter of the sphere of equal volume).
    #[arg(long, default_value = "semi-axis")]
    pub(crate) length_unit: String,
    /// EDMD τ_c by the thread's CPU time (cpu, the paper's definition: other work on a shared core does not
    /// count) or by the wall clock (wall); records without a CPU τ_c (older ones) fall back to the wall clock.
    #[arg(long, default_value = "cpu")]
    pub(crate) clock: String,
    /// Figures 2–3: a circle in every cell, its size the point's 95 % CI half-width.
    #[arg(long)]
    pub(crate) ci: bool,
    /// Tables 1–2 and figures 2–3: each point's estimate from its timed blocks, `mean` (the papers'
    /// mean time per configuration set; the tables' default), `median`, or `p5` (the 5th
    /// percentile, the kernel's cost without the machine's noise; the figures' default).
    #[arg(long, value_parser = clap::builder::ValueParser::new(str::parse::<Statistic>))]
    pub(crate) statistic: Option<Statistic>,
}

/// Report rows from the store's, one per (point, algorithm): each visit's estimate re-made from
/// its stored blocks by `statistic` (`overlap::estimate`, with its interval), or for jobs
/// measured before blocks were kept the mean over repeats the store gave, with Student's
/// interval, whatever `statistic` asked for (the row's `statistic` says `mean`, and so does the
/// table's); then a point's visits pooled by `overlap::estimate::pool_visits` (one visit: its
/// row as it is). The store orders the visits of a point next to each other.
pub(crate) fn report_rows(rows: Vec<store::OverlapRow>, statistic: Statistic) -> Vec<OverlapRow> {
    let visits: Vec<(OverlapRow, Option<Estimate>, String)> = rows
        .into_iter()
        .map(|r| {
            let point = r.point.clone();
            let (row, estimate) = visit_row(r, statistic);
            (row, estimate, point)
        })
        .collect();
    visits
        .chunk_by(|a, b| a.2 == b.2 && a.0.algorithm == b.0.algorithm)
        .map(pool_point)
        .collect()
}

/// One visit's row, and its estimate (`None` where it has none).
fn visit_row(r: store::OverlapRow, statistic: Statistic) -> (OverlapRow, Option<Estimate>) {
    let checks_ms = r.configurations as f64 * 1e-6;
    let (estimate, ns_per_check, mean_ms, statistic) = if r.block_ns_per_check.is_empty() {
        let estimate = overlap::estimate::mean_interval(&r.repeat_ns_per_check);
        (estimate, r.ns_per_check, r.mean_ms, Statistic::Mean)
    } else {
        let estimate = overlap::estimate::estimate_with(statistic, &r.block_ns_per_check);
        let ns = estimate.map_or(r.ns_per_check, |e| e.value);
        (estimate, ns, ns * checks_ms, statistic)
    };
    let row = OverlapRow {
        l_star: r.l_star,
        w_star: r.w_star,
        r_star: r.r_star,
        precision: r.precision,
        algorithm: r.algorithm,
        mean_ms,
        ns_per_check,
        acceptance: r.acceptance,
        repeats: r.repeats,
        disturbed: r.disturbed,
        reruns: r.reruns,
        statistic: statistic.name().to_owned(),
        visits: 1,
        ..OverlapRow::default()
    };
    // ms per ns/check: the set's size, or for old rows the ratio the store averaged.
    let to_ms = if ns_per_check > 0.0 {
        mean_ms / ns_per_check
    } else {
        checks_ms
    };
    (with_interval(row, estimate, to_ms), estimate)
}

/// `row` with the 95 % interval of `estimate`, in ns/check and, times `to_ms`, in ms.
fn with_interval(row: OverlapRow, estimate: Option<Estimate>, to_ms: f64) -> OverlapRow {
    let finite = |x: f64| x.is_finite().then_some(x);
    let lo = estimate.and_then(|e| finite(e.lo));
    let hi = estimate.and_then(|e| finite(e.hi));
    OverlapRow {
        ci95_lo_ns_per_check: lo,
        ci95_hi_ns_per_check: hi,
        ci95_lo_ms: lo.map(|x| x * to_ms),
        ci95_hi_ms: hi.map(|x| x * to_ms),
        ..row
    }
}

/// A point's visits (rows of one point and algorithm) as one row: the mean of their estimates
/// with the pooled interval; a visit without an interval takes part by its value alone.
fn pool_point(visits: &[(OverlapRow, Option<Estimate>, String)]) -> OverlapRow {
    let first = &visits[0].0;
    if let [(only, _, _)] = visits {
        return only.clone();
    }
    // Every visit of a point has the same set size, hence the same ms per ns/check.
    let to_ms = if first.ns_per_check > 0.0 {
        first.mean_ms / first.ns_per_check
    } else {
        0.0
    };
    let estimates: Vec<Estimate> = visits
        .iter()
        .map(|(row, estimate, _)| {
            estimate.unwrap_or(Estimate {
                value: row.ns_per_check,
                lo: f64::NAN,
                hi: f64::NAN,
                samples: 0,
                repeats: row.repeats as usize,
            })
        })
        .collect();
    let pooled = overlap::estimate::pool_visits(&estimates);
    let n = visits.len() as f64;
    let mean = |f: fn(&OverlapRow) -> f64| visits.iter().map(|(r, _, _)| f(r)).sum::<f64>() / n;
    let any_flag = |f: fn(&OverlapRow) -> Option<bool>| {
        visits
            .iter()
            .filter_map(|(r, _, _)| f(r))
            .reduce(|a, b| a || b)
    };
    let row = OverlapRow {
        mean_ms: mean(|r| r.mean_ms),
        ns_per_check: pooled.map_or_else(|| mean(|r| r.ns_per_check), |e| e.value),
        acceptance: mean(|r| r.acceptance),
        repeats: visits.iter().map(|(r, _, _)| r.repeats).sum(),
        disturbed: any_flag(|r| r.disturbed),
        reruns: visits
            .iter()
            .filter_map(|(r, _, _)| r.reruns)
            .reduce(|a, b| a + b),
        statistic: report::join_statistics(visits.iter().map(|(r, _, _)| r.statistic.as_str())),
        visits: visits.len() as u32,
        ..first.clone()
    };
    with_interval(row, pooled, to_ms)
}

pub fn report(args: &ReportArgs, format: Format) -> anyhow::Result<()> {
    if crate::edmd_report::NAMES.contains(&args.name.as_str()) {
        if args.statistic.is_some() {
            bail!(
                "--statistic applies to table1, table2, fig2 and fig3, not to {}",
                args.name
            );
        }
        return crate::edmd_report::report(args, format);
    }
    let (kind, precision) = match args.name.as_str() {
        "table1" => ("table", "f32"),
        "table2" => ("table", "f64"),
        "fig2" => ("figure", "f32"),
        "fig3" => ("figure", "f64"),
        other => bail!(
            "report `{other}`: unknown or not available yet (available: table1, table2, fig2, fig3, fig7, fig8, fig9, fig10, fig11, fig13, accuracy)"
        ),
    };
    let statistic = args.statistic.unwrap_or(match kind {
        "table" => Statistic::FOR_TABLES,
        _ => Statistic::FOR_SURFACES,
    });
    let rows: Vec<OverlapRow> = runtime()?.block_on(async {
        let store = open_read_only(&args.db).await?;
        let rows = store.overlap_rows().await?;
        anyhow::Ok(report_rows(rows, statistic))
    })?;
    if kind == "figure" {
        let json_out = args.out.as_deref().filter(|o| {
            o.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        });
        if json_out.is_some() || (args.out.is_none() && format == Format::Json) {
            let points = report::fig2_points(&rows, precision)?;
            let text = serde_json::to_string_pretty(&points)? + "\n";
            match json_out {
                Some(out) => {
                    std::fs::write(out, text)
                        .with_context(|| format!("cannot write {}", out.display()))?;
                    eprintln!("wrote {}", out.display());
                }
                None => print_text(&text)?,
            }
            return Ok(());
        }
        let out = args.out.as_deref().with_context(|| {
            format!(
                "report {}: give --out FILE.png, FILE.svg or FILE.json (or --format json)",
                args.name
            )
        })?;
        report::fig2(
            &rows,
            precision,
            out,
            report::Fig2Options { show_ci: args.ci },
        )?;
        eprintln!("wrote {}", out.display());
        return Ok(());
    }
    let table = report::table1(&rows, precision);
    if table.is_empty() {
        bail!(
            "report {}: no {precision} overlap results in {}",
            args.name,
            args.db.display()
        );
    }
    match &args.out {
        Some(out) => {
            let text = report::render_table(&table, TableFormat::from_path(out)?)?;
            std::fs::write(out, text).with_context(|| format!("cannot write {}", out.display()))?;
            eprintln!("wrote {}", out.display());
        }
        None => {
            let format = match format {
                Format::Json => TableFormat::Json,
                Format::Csv => TableFormat::Csv,
                Format::Table => TableFormat::Markdown,
            };
            print_text(&report::render_table(&table, format)?)?;
        }
    }
    Ok(())
}

#[derive(Args)]
pub struct QueryArgs {
    /// SQL over the results, e.g. `SELECT algorithm, avg(ns_per_check) FROM overlap_timings GROUP BY 1`.
    sql: String,
    #[arg(long)]
    db: PathBuf,
}

fn cell(value: &serde_json::Value) -> String {
    match value {
        serde_json::Value::Null => String::new(),
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

pub fn query(args: &QueryArgs, format: Format) -> anyhow::Result<()> {
    let result = runtime()?.block_on(async {
        anyhow::Ok(
            open_read_only(&args.db)
                .await?
                .query_read_only(&args.sql)
                .await?,
        )
    })?;
    match format {
        Format::Json => {
            let objects: Vec<serde_json::Map<String, serde_json::Value>> = result
                .rows
                .iter()
                .map(|row| {
                    result
                        .columns
                        .iter()
                        .cloned()
                        .zip(row.iter().cloned())
                        .collect()
                })
                .collect();
            print_json(&objects)
        }
        Format::Csv => write_csv(
            &result.columns,
            result.rows.iter().map(|r| r.iter().map(cell).collect()),
        ),
        Format::Table => {
            let header: Vec<&str> = result.columns.iter().map(String::as_str).collect();
            let rows: Vec<Vec<String>> = result
                .rows
                .iter()
                .map(|r| r.iter().map(cell).collect())
                .collect();
            print_table(&header, &rows);
            Ok(())
        }
    }
}

#[derive(Args)]
pub struct ExportArgs {
    #[arg(long)]
    db: PathBuf,
}

/// One row per result record: the identifying columns first, then the union of all fields.
pub fn export(args: &ExportArgs, format: Format) -> anyhow::Result<()> {
    let rows = runtime()?
        .block_on(async { anyhow::Ok(open_read_only(&args.db).await?.export().await?) })?;
    let flat: Vec<serde_json::Map<String, serde_json::Value>> = rows
        .into_iter()
        .map(|row| {
            let mut out = serde_json::Map::new();
            out.insert("job_id".into(), row.job_id.into());
            out.insert("campaign".into(), row.campaign.into());
            out.insert("kind".into(), row.kind.into());
            out.insert("attempt".into(), row.attempt.into());
            out.insert("worker".into(), row.worker.into());
            out.insert("core_id".into(), row.core_id.into());
            out.extend(row.fields);
            out
        })
        .collect();
    match format {
        Format::Json => print_json(&flat),
        Format::Csv | Format::Table => {
            let fixed = ["job_id", "campaign", "kind", "attempt", "worker", "core_id"];
            let extra: BTreeSet<&String> = flat
                .iter()
                .flat_map(|r| r.keys())
                .filter(|k| !fixed.contains(&k.as_str()))
                .collect();
            let columns: Vec<String> = fixed
                .iter()
                .map(|s| s.to_string())
                .chain(extra.into_iter().cloned())
                .collect();
            let rows = flat.iter().map(|r| {
                columns
                    .iter()
                    .map(|c| r.get(c).map(cell).unwrap_or_default())
                    .collect()
            });
            write_csv(&columns, rows)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stored row of the point at `l_star`, visit `visit`: two sets of 50 blocks, every block
    /// `ns` ± 0.5 %.
    fn stored(l_star: f64, visit: u32, ns: f64) -> store::OverlapRow {
        let set: Vec<f64> = (0..50)
            .map(|k| ns * if k % 2 == 0 { 1.005 } else { 0.995 })
            .collect();
        store::OverlapRow {
            job_id: format!("{l_star}-{visit}"),
            l_star,
            w_star: 1.0,
            r_star: 5.0,
            acceptance_target: 0.4,
            configurations: 1_000_000,
            precision: "f32".into(),
            algorithm: "qri".into(),
            mean_ms: ns,
            ns_per_check: ns,
            acceptance: 0.4,
            repeats: 2,
            repeat_ns_per_check: vec![ns, ns],
            block_ns_per_check: vec![set.clone(), set],
            disturbed: Some(visit == 1),
            reruns: Some(visit),
            visit,
            point: format!(r#"{{"l_star":{l_star}}}"#),
        }
    }

    #[test]
    fn a_points_visits_pool_into_one_row_and_a_single_visit_is_left_alone() {
        let rows = vec![
            stored(1.0, 0, 10.0),
            stored(1.0, 1, 11.0),
            stored(1.0, 2, 12.0),
            stored(2.0, 0, 20.0),
        ];
        let single = visit_row(stored(2.0, 0, 20.0), Statistic::Mean).0;
        let report = report_rows(rows, Statistic::Mean);
        assert_eq!(report.len(), 2);
        let (pooled, alone) = (&report[0], &report[1]);
        assert_eq!(alone, &single);
        assert_eq!(alone.visits, 1);
        assert_eq!(pooled.visits, 3);
        assert!((pooled.ns_per_check - 11.0).abs() < 1e-9, "{pooled:?}");
        assert!((pooled.mean_ms - 11.0).abs() < 1e-9);
        // Between visits: t(2) · 1 / √3 (s = 1 for 10, 11, 12), far wider than any visit's own.
        let half = 4.303 / 3f64.sqrt();
        let (lo, hi) = (
            pooled.ci95_lo_ns_per_check.expect("lo"),
            pooled.ci95_hi_ns_per_check.expect("hi"),
        );
        assert!(
            (hi - 11.0 - half).abs() < 1e-6 && (11.0 - lo - half).abs() < 1e-6,
            "{lo} {hi}"
        );
        assert!(
            (pooled.ci95_hi_ms.expect("ms") - hi).abs() < 1e-9,
            "1 ms per ns/check here"
        );
        assert_eq!(
            (pooled.repeats, pooled.reruns, pooled.disturbed),
            (6, Some(3), Some(true))
        );
        assert_eq!(pooled.statistic, "mean");
    }
}
