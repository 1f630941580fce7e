//! `sweep report NAME`: the papers' tables and figures from a result database. The rows come from
//! the `results` crate, the drawing and tabulating from `report`; this module picks the report,
//! its statistic or clock, and where it goes.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use report::{Clock, LengthUnit, ReportError, TableFormat};
use results::Statistic;

use crate::database;
use crate::output::{Format, print_json, print_text, write_json};

#[derive(Args)]
pub struct ReportArgs {
    /// table1 (f32), table2 (f64), fig2 (f32), fig3 (f64); EDMD: fig7 (τ_c against φ), fig8 (against X0, LL/NNL),
    /// fig9 (against ε_d), fig10 (against Δ_NNL), fig11 (Δ*_NNL), fig13 (superquadrics against p),
    /// accuracy (cost of each accuracy knob); peers (our EDMD spheres against a `[[command]]` program, per N);
    /// snapshot (a picture of a state file, --state); tune (the [[tune]] searches: the value found, its
    /// interval, the objective there, runs used, why it stopped).
    name: String,
    /// The result database (every report but snapshot).
    #[arg(long)]
    db: Option<PathBuf>,
    /// snapshot: the state file (`sweep edmd --save-state`) to draw.
    #[arg(long, value_name = "FILE")]
    state: Option<PathBuf>,
    /// snapshot: half the thickness of the slab drawn, in σ (default: the longest semi-axis).
    #[arg(long, value_name = "SIGMA")]
    slab: Option<f64>,
    /// Write here instead of stdout; the extension picks the format (.md .csv .tex .json .png .svg).
    /// Figures 2–3 print their points (estimate and 95 % interval) with `--format json` and no --out.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Lengths on EDMD axes (Δ_NNL, ε_d): semi-axis (the paper's unit, the smallest semi-axis) or sigma
    /// (the engine's and the plans' unit, the diameter of the sphere of equal volume).
    #[arg(long, default_value = "semi-axis")]
    length_unit: String,
    /// EDMD τ_c by the thread's CPU time (cpu, the paper's definition: other work on a shared core does not
    /// count) or by the wall clock (wall); records without a CPU τ_c (older ones) fall back to the wall clock.
    #[arg(long, default_value = "cpu")]
    clock: String,
    /// Figures 2–3: a circle in every cell, its size the point's 95 % CI half-width.
    #[arg(long)]
    ci: bool,
    /// Tables 1–2 and figures 2–3: each point's estimate from its timed blocks, `mean` (the papers'
    /// mean time per configuration set; the tables' default), `median`, or `p5` (the 5th
    /// percentile, the kernel's cost without the machine's noise; the figures' default).
    #[arg(long, value_parser = clap::builder::ValueParser::new(str::parse::<Statistic>))]
    statistic: Option<Statistic>,
    /// peers: the `[[command]]` label of the program compared (its runs print `tau_c_us`, and
    /// `tau_c_wall_us` for --clock wall).
    #[arg(long, default_value = "smallenburg-edmd")]
    label: String,
}

/// The reports of the overlap kernels: (name, table or figure, precision).
const OVERLAP: [(&str, bool, &str); 4] = [
    ("table1", true, "f32"),
    ("table2", true, "f64"),
    ("fig2", false, "f32"),
    ("fig3", false, "f64"),
];

/// The reports of the EDMD paper and the cost of accuracy.
const EDMD: [&str; 7] = [
    "fig7", "fig8", "fig9", "fig10", "fig11", "fig13", "accuracy",
];

pub fn run(args: &ReportArgs, format: Format) -> anyhow::Result<()> {
    let name = args.name.as_str();
    if name == "snapshot" {
        return snapshot_report(args);
    }
    if args.state.is_some() || args.slab.is_some() {
        bail!("--state and --slab apply to the snapshot report, not to {name}");
    }
    if let Some(&(_, table, precision)) = OVERLAP.iter().find(|(n, _, _)| *n == name) {
        return match table {
            true => table_report(args, precision, format),
            false => figure_report(args, precision, format),
        };
    }
    if name == "tune" {
        return tune_report(args, format);
    }
    if EDMD.contains(&name) {
        if args.statistic.is_some() {
            bail!("--statistic applies to table1, table2, fig2 and fig3, not to {name}");
        }
        return edmd_report(args, format);
    }
    if name == "peers" {
        return peers_report(args, format);
    }
    bail!(
        "report `{name}`: unknown or not available yet (available: table1, table2, fig2, fig3, fig7, fig8, fig9, fig10, fig11, fig13, accuracy, peers, snapshot, tune)"
    )
}

/// The database every report but the snapshot reads.
fn db(args: &ReportArgs) -> anyhow::Result<&Path> {
    args.db
        .as_deref()
        .with_context(|| format!("report {}: --db is required", args.name))
}

/// `sweep report snapshot --state F --out F.png|svg`: a slab of the state's bodies.
fn snapshot_report(args: &ReportArgs) -> anyhow::Result<()> {
    let state_path = args
        .state
        .as_deref()
        .context("report snapshot: --state FILE is required")?;
    let out = args
        .out
        .as_deref()
        .context("report snapshot: --out FILE.png|svg is required")?;
    let (state, _) = crate::state_file::load(state_path)?;
    let scene = state.scene();
    let semi_axes = scene.semi_axes();
    let longest = semi_axes.iter().copied().fold(0.0, f64::max);
    let slab = args.slab.unwrap_or(longest);
    if !(slab.is_finite() && slab > 0.0) {
        bail!("--slab must be positive, got {slab}");
    }
    let bodies: Vec<report::SnapshotBody> = state
        .bodies_now()
        .iter()
        .map(|b| report::SnapshotBody {
            centre: [b.r.x, b.r.y, b.r.z],
            axes: [0, 1, 2].map(|k| [b.rot[(k, 0)], b.rot[(k, 1)], b.rot[(k, 2)]]),
            semi_axes,
        })
        .collect();
    let picture = report::Snapshot {
        box_length: state.box_length(),
        bodies,
        slab,
        title: format!(
            "{:?} N = {}, φ = {}, X0 = {}, t = {:.3}: |z − L/2| < {slab:.2} σ, hue = long axis in the plane",
            scene.shape,
            scene.n,
            scene.phi,
            scene.x0,
            state.time()
        ),
        oriented: scene.shape != edmd::ShapeKind::Sphere,
    };
    report::snapshot(&picture, out)?;
    eprintln!(
        "{}: {} of {} bodies (the slab)",
        out.display(),
        picture.shown(),
        scene.n
    );
    Ok(())
}

/// Every overlap point, estimated by `--statistic` or else `default`; the campaigns that ran
/// slower than their machine's earlier ones are named on stderr, since a table mixes campaigns.
fn overlap_points(
    args: &ReportArgs,
    default: Statistic,
) -> anyhow::Result<Vec<report::OverlapPoint>> {
    let statistic = args.statistic.unwrap_or(default);
    let (points, shifts) = database::read(db(args)?, async |store| {
        let points = results::overlap_points(store, statistic).await?;
        Ok((points, results::machine_history(store).await?))
    })?;
    for shift in shifts {
        eprintln!("warning: {}", shift.message);
    }
    Ok(points)
}

/// Table 1 (or 2), estimated by the tables' statistic unless `--statistic` says otherwise.
fn table_report(args: &ReportArgs, precision: &str, format: Format) -> anyhow::Result<()> {
    let points = overlap_points(args, Statistic::FOR_TABLES)?;
    let table = report::table1(&points, precision);
    if table.is_empty() {
        bail!(
            "report {}: no {precision} overlap results in {}",
            args.name,
            db(args)?.display()
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

/// Figure 2 (or 3), estimated by the figures' statistic unless `--statistic` says otherwise:
/// drawn, or its points as JSON.
fn figure_report(args: &ReportArgs, precision: &str, format: Format) -> anyhow::Result<()> {
    let points = overlap_points(args, Statistic::FOR_SURFACES)?;
    let json_out = args.out.as_deref().filter(|o| {
        o.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
    });
    if json_out.is_some() || (args.out.is_none() && format == Format::Json) {
        return write_json(&report::fig2_points(&points, precision)?, json_out);
    }
    let out = args.out.as_deref().with_context(|| {
        format!(
            "report {}: give --out FILE.png, FILE.svg or FILE.json (or --format json)",
            args.name
        )
    })?;
    report::fig2(
        &points,
        precision,
        out,
        report::Fig2Options { show_ci: args.ci },
    )?;
    eprintln!("wrote {}", out.display());
    Ok(())
}

/// The EDMD figures and the accuracy report, with τ_c by `--clock`.
fn edmd_report(args: &ReportArgs, format: Format) -> anyhow::Result<()> {
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
    let (rows, failed, verdicts, searches) = database::read(db(args)?, async |store| {
        let rows = results::edmd_runs(store, clock).await?;
        match name {
            "accuracy" => {
                let failed = results::failed_edmd_runs(store).await?;
                Ok((
                    rows,
                    failed,
                    results::overlap_verdicts(store).await?,
                    Vec::new(),
                ))
            }
            "fig11" => Ok((
                rows,
                Vec::new(),
                Vec::new(),
                tune::report::rows(store).await?.0,
            )),
            _ => Ok((rows, Vec::new(), Vec::new(), Vec::new())),
        }
    })?;
    // Fig. 11 draws the Δ*_NNL that searches found minimising the τ_c of the same clock.
    let (searched, other_clock) = tune::report::fig11_minima(&searches, clock, unit);
    if other_clock > 0 {
        eprintln!(
            "note: {other_clock} search(es) of delta_nnl minimised the other clock's τ_c: not drawn with --clock {}",
            args.clock
        );
    }
    if clock == Clock::Cpu && rows.iter().any(|r| r.clock == Clock::Wall) {
        eprintln!(
            "note: some records have no CPU τ_c (written before it was kept): their wall-clock τ_c is used"
        );
    }
    if rows.is_empty() && verdicts.is_empty() && searched.is_empty() {
        bail!("report {name}: no EDMD results in {}", db(args)?.display());
    }
    match name {
        "fig7" => {
            let out = out.context("report fig7: give --out FILE.png or FILE.svg")?;
            report::fig7(&rows, out)?;
            eprintln!("wrote {}", out.display());
        }
        "fig8" => finish(report::fig8(&rows, out), json, out, |f| &f.missing)?,
        "fig9" => finish(report::fig9(&rows, unit, out), json, out, |f| &f.missing)?,
        "fig10" => finish(report::fig10(&rows, unit, out), json, out, |f| &f.missing)?,
        "fig11" => finish(report::fig11(&rows, &searched, unit, out), json, out, |f| {
            &f.missing
        })?,
        "fig13" => finish(report::fig13(&rows, out), json, out, |f| &f.missing)?,
        _ => accuracy(
            report::accuracy_report(&rows, &failed, &verdicts)?,
            json,
            out,
        )?,
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

/// The accuracy report as JSON, Markdown (on stdout, or `.md`) or a plot.
fn accuracy(study: report::AccuracyReport, json: bool, out: Option<&Path>) -> anyhow::Result<()> {
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

/// Our EDMD spheres against the program `--label`, per N and φ: τ_c of each by `--clock` (the
/// program's `tau_c_us` for CPU time, `tau_c_wall_us` for the wall clock), the ratio theirs /
/// ours and its 95 % interval (`report::peers`).
fn peers_report(args: &ReportArgs, format: Format) -> anyhow::Result<()> {
    let clock = match args.clock.as_str() {
        "cpu" => Clock::Cpu,
        "wall" => Clock::Wall,
        other => bail!("--clock {other}: expected cpu or wall"),
    };
    let db = db(args)?;
    let (ours, theirs) = database::read(db, async |store| {
        Ok((
            results::edmd_runs(store, clock).await?,
            results::command_runs(store).await?,
        ))
    })?;
    // The program's τ_c by the same clock as ours.
    let value = match clock {
        Clock::Cpu => "tau_c_us",
        Clock::Wall => "tau_c_wall_us",
    };
    let points = report::peers(&ours, &theirs, &args.label, value);
    if points.is_empty() {
        bail!(
            "report peers: no (N, φ) has both EDMD sphere runs and `{}` runs printing {value} in {}",
            args.label,
            db.display()
        );
    }
    match format {
        Format::Json => print_json(&points),
        _ => print_text(&report::peers_markdown(&points, &args.label)),
    }
}

/// `sweep report tune`: every `[[tune]]` search of the database's campaigns.
fn tune_report(args: &ReportArgs, format: Format) -> anyhow::Result<()> {
    let db = db(args)?;
    let (rows, unreadable) =
        database::read(db, async |store| Ok(tune::report::rows(store).await?))?;
    for u in &unreadable {
        eprintln!(
            "warning: campaign {}: a search this version cannot read ({}) is not shown",
            u.campaign, u.reason
        );
    }
    if rows.is_empty() {
        bail!("{}: no [[tune]] searches in its campaigns", db.display());
    }
    match (format, args.out.as_deref()) {
        (Format::Json, out) => write_json(&rows, out),
        (_, Some(out)) if out.extension().is_some_and(|e| e == "json") => {
            write_json(&rows, Some(out))
        }
        (_, Some(out)) if out.extension().is_some_and(|e| e == "png" || e == "svg") => {
            Ok(report::search_paths(&tune::report::paths(&rows), out)?)
        }
        (_, Some(out)) => std::fs::write(out, tune::report::table(&rows))
            .with_context(|| format!("--out {}", out.display())),
        (_, None) => print_text(&tune::report::table(&rows)),
    }
}
