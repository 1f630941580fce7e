//! Printing results: aligned tables for people, JSON for programs.

use std::io::{ErrorKind, Write};

use anyhow::Context;
use serde::Serialize;

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
    format: Format,
) -> anyhow::Result<()> {
    match format {
        Format::Json => {
            let mut out = serde_json::json!({ "campaign": campaign, "status": status });
            if let Some((quality, shifts)) = quality {
                out["timing"] = serde_json::to_value(quality)?;
                out["machine_history"] = serde_json::to_value(shifts)?;
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
            Ok(())
        }
    }
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
