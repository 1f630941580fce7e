//! Printing results: aligned tables for people, JSON for programs.

use std::io::{ErrorKind, Write};

use anyhow::Context;
use coordinator::autoalloc::Report;
use serde::Serialize;
use store::AllocationState;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Table,
    Json,
    Csv,
}

pub fn print_json(value: &impl Serialize) -> anyhow::Result<()> {
    print_text(&(serde_json::to_string_pretty(value)? + "\n"))
}

/// Writes `text` to stdout. A reader that closed the pipe (`sweep report … | head`) has what it
/// wanted: the process then ends quietly with status 0, where `print!` would panic.
pub fn print_text(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() == ErrorKind::BrokenPipe => std::process::exit(0),
        other => Ok(other?),
    }
}

/// Prints `rows` under `header` with every column as wide as its widest cell.
pub fn print_table(header: &[&str], rows: &[Vec<String>]) {
    let mut widths: Vec<usize> = header.iter().map(|h| h.len()).collect();
    for row in rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |cells: Vec<&str>| {
        let padded: Vec<String> = cells
            .iter()
            .zip(&widths)
            .map(|(c, w)| format!("{c:>w$}"))
            .collect();
        padded.join("  ").trim_end().to_owned() + "\n"
    };
    let mut text = line(header.to_vec());
    for row in rows {
        text += &line(row.iter().map(String::as_str).collect());
    }
    // Nothing on stdout is worth an error here but a closed pipe, which ends the process.
    let _ = print_text(&text);
}

/// CSV on stdout: a header row, then `rows`.
pub fn write_csv(
    columns: &[String],
    rows: impl Iterator<Item = Vec<String>>,
) -> anyhow::Result<()> {
    let quiet_on_closed_pipe = |e: csv::Error| match e.kind() {
        csv::ErrorKind::Io(io) if io.kind() == ErrorKind::BrokenPipe => std::process::exit(0),
        _ => e,
    };
    let mut writer = csv::Writer::from_writer(std::io::stdout().lock());
    writer.write_record(columns).map_err(quiet_on_closed_pipe)?;
    for row in rows {
        writer.write_record(&row).map_err(quiet_on_closed_pipe)?;
    }
    match writer.flush() {
        Err(e) if e.kind() == ErrorKind::BrokenPipe => std::process::exit(0),
        other => Ok(other?),
    }
}

/// Prints a campaign's counts and, where known, how its overlap points were measured
/// (`timing`: points with a noise check, flagged as disturbed, re-run).
pub fn print_status(
    campaign: &str,
    status: &store::Status,
    quality: Option<(&results::OverlapQuality, &[results::MachineShift])>,
    allocations: Option<&Report>,
    format: Format,
) -> anyhow::Result<()> {
    match format {
        Format::Json => {
            let mut out = serde_json::json!({ "campaign": campaign, "status": status });
            if let Some((quality, shifts)) = quality {
                out["timing"] = serde_json::to_value(quality)?;
                out["machine_history"] = serde_json::to_value(shifts)?;
            }
            if let Some(allocations) = allocations {
                out["allocations"] = serde_json::to_value(allocations)?;
            }
            print_json(&out)
        }
        _ => {
            println!(
                "campaign {campaign}: {} points: {} done, {} failed, {} queued, {} running, {} cancelled",
                status.total,
                status.done,
                status.failed,
                status.queued,
                status.running,
                status.cancelled
            );
            if let Some((q, shifts)) = quality {
                if q.checked > 0 {
                    println!(
                        "timing: {} overlap points checked for noise: {} re-run ({} re-runs), {} still disturbed (flagged); {:.0} s measuring, {:.0} s of it timed",
                        q.checked, q.rerun, q.reruns, q.disturbed, q.wall_s, q.timed_s
                    );
                }
                for shift in shifts {
                    println!("warning: {}", shift.message);
                }
            }
            if let Some(report) = allocations {
                print_allocation_summary(report);
            }
            Ok(())
        }
    }
}

/// Unix seconds now, for ages.
fn unix_now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// A span of seconds the way a person reads it: `42 s`, `7 min`, `2.5 h`.
fn span(seconds: f64) -> String {
    let s = seconds.max(0.0);
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

/// The allocations in a few lines: counts, the allocator's last decision, whether it is backing
/// off, and why the latest failures failed.
fn print_allocation_summary(report: &Report) {
    let now = unix_now();
    println!("allocations: {}", report.counts());
    if !report.note.is_empty() {
        let age = report
            .updated_at
            .map(|at| format!(" ({} ago)", span(now - at)))
            .unwrap_or_default();
        println!("allocator{age}: {}", report.note);
    }
    if let Some(at) = report.retry_at.filter(|&at| at > now) {
        println!(
            "backing off: {} failures in a row; next submission in {}",
            report.failures,
            span(at - now)
        );
    }
    for view in report
        .allocations
        .iter()
        .filter(|v| v.allocation.state == AllocationState::Failed)
        .take(3)
    {
        let a = &view.allocation;
        println!(
            "failed allocation {} ({} ago): {}",
            a.external_id.as_deref().unwrap_or("(not submitted)"),
            span(now - a.ended_at.unwrap_or(a.submitted_at)),
            a.reason
        );
    }
}

/// The allocations as a table, newest first: id, Slurm job, state, cores, when submitted and
/// started, how long it ran, workers, jobs done, reason.
pub fn print_allocations(report: &Report) {
    let now = unix_now();
    let rows: Vec<Vec<String>> = report
        .allocations
        .iter()
        .map(|view| {
            let a = &view.allocation;
            let ran = a
                .started_at
                .map(|start| span(a.ended_at.unwrap_or(now) - start))
                .unwrap_or_else(|| "-".into());
            vec![
                a.id.to_string(),
                a.external_id.clone().unwrap_or_else(|| "-".into()),
                a.state.as_str().to_owned(),
                format!("{}/{}", a.cores, a.nodes),
                format!("{} ago", span(now - a.submitted_at)),
                a.started_at
                    .map(|at| format!("{} ago", span(now - at)))
                    .unwrap_or_else(|| "-".into()),
                ran,
                view.workers.to_string(),
                view.jobs_done.map_or_else(|| "-".into(), |d| d.to_string()),
                a.reason.clone(),
            ]
        })
        .collect();
    print_table(
        &[
            "allocation",
            "slurm job",
            "state",
            "cores/nodes",
            "submitted",
            "started",
            "ran",
            "workers",
            "jobs done",
            "reason",
        ],
        &rows,
    );
}

/// Prints a serialisable value as JSON to stdout, or writes it to `out`.
pub fn write_json(value: &impl Serialize, out: Option<&std::path::Path>) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)? + "\n";
    match out {
        Some(out) => {
            std::fs::write(out, text).with_context(|| format!("cannot write {}", out.display()))?;
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        None => print_text(&text),
    }
}
