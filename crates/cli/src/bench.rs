//! `sweep bench overlap`: one point of the papers' protocol, no database.

use anyhow::Context;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use overlap::kernels::batch::Isa;
use overlap::{Algorithm, OverlapError, PointSpec, Precision};
use serde::Serialize;

use crate::output::{Format, print_json, print_table, write_csv};
use crate::system;

#[derive(Subcommand)]
pub enum BenchCommand {
    /// Time every overlap algorithm over the same random configurations (papers' Sec. 3).
    Overlap(BenchOverlapArgs),
}

#[derive(Args)]
pub struct BenchOverlapArgs {
    /// Cuboid length in units of its thickness, L* = L/T.
    #[arg(long, allow_negative_numbers = true)]
    l_star: f64,
    /// Cuboid width in units of its thickness, W* = W/T.
    #[arg(long, allow_negative_numbers = true)]
    w_star: f64,
    /// Sphere radius in units of the cuboid thickness, R* = R/T.
    #[arg(long, allow_negative_numbers = true)]
    r_star: f64,
    /// Target fraction of non-overlapping configurations, in (0, 1).
    #[arg(long, default_value_t = 0.4, allow_negative_numbers = true)]
    acceptance: f64,
    /// Configurations per set, N_c.
    #[arg(long, default_value_t = 2_000_000)]
    configurations: u64,
    /// Independent configuration sets (at least; see --ci-target). Each algorithm's result is
    /// the 5th percentile of its timed blocks over every set.
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Measure more sets until every 95 % CI half-width is at most this fraction of its estimate.
    #[arg(long)]
    ci_target: Option<f64>,
    /// ... or until the measurement has taken this many seconds (default 60; needs --ci-target).
    #[arg(long)]
    time_cap_s: Option<f64>,
    #[arg(long, default_value = "f32", value_parser = parse_precision)]
    precision: Precision,
    /// Comma-separated subset of arvo, qri, qrf, sse, ocsi, ocsi_batch.
    #[arg(
        long,
        value_delimiter = ',',
        value_parser = parse_algorithm,
        default_value = "arvo,qri,qrf,sse,ocsi,ocsi_batch"
    )]
    algorithms: Vec<Algorithm>,
    /// Seed of the configuration sets.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Pin the timed loops to this core (generation still uses every core).
    #[arg(long)]
    core: Option<usize>,
}

fn parse_precision(s: &str) -> Result<Precision, String> {
    s.parse().map_err(|e: OverlapError| e.to_string())
}

fn parse_algorithm(s: &str) -> Result<Algorithm, String> {
    s.parse().map_err(|e: OverlapError| e.to_string())
}

/// The JSON of `sweep bench overlap` that users rely on (`results`, `stream_ns_per_config`), plus
/// what keeps the figures honest.
#[derive(Serialize)]
struct BenchReport {
    point: PointSpec,
    results: Vec<overlap::AlgorithmSummary>,
    stream_ns_per_config: f64,
    generation_ms: f64,
    timed_ms: f64,
    /// Wall time of the whole measurement, re-runs included: what the precision cost.
    wall_s: f64,
    repeats: u32,
    stop: overlap::Stop,
    block_configurations: u64,
    references: overlap::References,
    /// Why the result is not to be trusted (the machine was disturbed), or null.
    disturbance: Option<String>,
    reruns: u32,
    rerun_reasons: Vec<String>,
    /// Every pass with its blocks' ns/check, for re-estimating.
    timings: Vec<overlap::Timing>,
    arrays_bytes: u64,
    peak_rss_bytes: Option<u64>,
    isa: &'static str,
    rho: f64,
}

pub fn run(command: BenchCommand, format: Format) -> anyhow::Result<()> {
    match command {
        BenchCommand::Overlap(args) => bench_overlap(args, format),
    }
}

/// `l_star` → `--l-star`: errors name the flag the user typed.
fn flag_error(error: OverlapError) -> anyhow::Error {
    match error {
        OverlapError::Invalid { key, reason } => {
            anyhow::anyhow!("--{}: {reason}", key.replace('_', "-"))
        }
        other => anyhow::anyhow!(other),
    }
}

fn bench_overlap(args: BenchOverlapArgs, format: Format) -> anyhow::Result<()> {
    let spec = PointSpec {
        l_star: args.l_star,
        w_star: args.w_star,
        r_star: args.r_star,
        acceptance: args.acceptance,
        configurations: args.configurations,
        repeats: args.repeats,
        precision: args.precision,
        algorithms: args.algorithms,
        seed: args.seed,
        ci_target: args.ci_target,
        time_cap_s: args.time_cap_s,
        verdict_check: None,
        visit: None,
        plugins: Vec::new(),
    };
    spec.validate().map_err(flag_error)?;
    system::start_thread_pool()?;
    if let Some(core) = args.core {
        system::pin_current_thread(core)?;
    }
    let progress = if format == Format::Json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(spec.repeats as u64)
    };
    progress.set_style(ProgressStyle::with_template(
        "{msg} [{bar:30}] {pos}/{len} repeats, {elapsed}",
    )?);
    progress.set_message(format!(
        "L*={} W*={} R*={} {}",
        spec.l_star, spec.w_star, spec.r_star, spec.precision
    ));
    let mut calibration = overlap::Calibration::default();
    let report = overlap::run_point(&spec, &mut calibration, &mut |_| progress.inc(1))
        .map_err(flag_error)
        .context("benchmark failed")?;
    progress.finish_and_clear();

    let results = report.summary();
    let out = BenchReport {
        timed_ms: report.timed_s * 1e3,
        wall_s: report.wall_s,
        repeats: report.repeats,
        stop: report.stop,
        block_configurations: report.block_configurations,
        references: report.references,
        disturbance: report.disturbance.clone(),
        reruns: report.reruns,
        rerun_reasons: report.rerun_reasons.clone(),
        timings: report.timings.clone(),
        point: spec,
        results,
        stream_ns_per_config: report.stream_ns_per_config,
        generation_ms: report.generation_ms,
        arrays_bytes: report.arrays_bytes,
        peak_rss_bytes: system::peak_rss_bytes(),
        isa: Isa::best().name(),
        rho: report.rho,
    };
    match format {
        Format::Json => print_json(&out),
        Format::Csv => {
            let columns = [
                "algorithm",
                "mean_ms",
                "ns_per_check",
                "acceptance",
                "stream_ns_per_config",
                "ci95_lo_ns_per_check",
                "ci95_hi_ns_per_check",
                "plain_ns_per_check",
            ]
            .map(String::from);
            let rows = out.results.iter().map(|r| {
                vec![
                    r.algorithm.to_string(),
                    r.mean_ms.to_string(),
                    r.ns_per_check.to_string(),
                    r.acceptance.to_string(),
                    out.stream_ns_per_config.to_string(),
                    r.ci95_lo_ns_per_check.to_string(),
                    r.ci95_hi_ns_per_check.to_string(),
                    r.plain_ns_per_check.to_string(),
                ]
            });
            write_csv(&columns, rows)
        }
        Format::Table => {
            let rows: Vec<Vec<String>> = out
                .results
                .iter()
                .map(|r| {
                    vec![
                        r.algorithm.to_string(),
                        format!("{:.3}", r.mean_ms),
                        format!("{:.3}", r.ns_per_check),
                        format!(
                            "{:.2}",
                            (r.ci95_hi_ns_per_check - r.ci95_lo_ns_per_check)
                                / 2.0
                                / r.ns_per_check
                                * 100.0
                        ),
                        format!("{:.3}", r.plain_ns_per_check),
                        format!("{:.2}", r.ns_per_check / out.stream_ns_per_config),
                        format!("{:.4}", r.acceptance),
                    ]
                })
                .collect();
            print_table(
                &[
                    "algorithm",
                    "mean_ms",
                    "ns/check",
                    "±95% (%)",
                    "plain ns/check",
                    "x stream",
                    "acceptance",
                ],
                &rows,
            );
            println!(
                "stream {:.3} ns/config · generation {:.0} ms vs timed {:.0} ms · arrays {:.1} MB, peak RSS {} · {}",
                out.stream_ns_per_config,
                out.generation_ms,
                out.timed_ms,
                out.arrays_bytes as f64 / 1e6,
                out.peak_rss_bytes
                    .map_or("n/a".into(), |b| format!("{:.1} MB", b as f64 / 1e6)),
                out.isa
            );
            println!(
                "{} sets ({:?}) of {} configurations in blocks of {} · {:.2} s in all, {} re-run(s){}",
                out.repeats,
                out.stop,
                out.point.configurations,
                out.block_configurations,
                out.wall_s,
                out.reruns,
                out.disturbance
                    .as_deref()
                    .map_or(String::new(), |d| format!(" · DISTURBED: {d}"))
            );
            Ok(())
        }
    }
}
