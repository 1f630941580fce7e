//! `sweep`: the command line. Thin: parse, call the library crates, print.

mod args;
mod bench;
mod campaign;
mod database;
mod edmd_cmd;
mod local;
mod output;
mod overlap_cmd;
mod plan_cmd;
mod query;
mod remote;
mod report_cmd;
mod searching;
mod state_file;
mod status;
mod status_page;
mod system;
mod trajectory;

use clap::{Parser, Subcommand};

use crate::output::Format;

#[derive(Parser)]
#[command(
    name = "sweep",
    version,
    about = "Benchmark campaigns for hard-body collision algorithms"
)]
struct Cli {
    /// How results are printed: an aligned table, JSON, or CSV (export, query, report); logs go to stderr.
    #[arg(long, global = true, value_enum, default_value_t = Format::Table)]
    format: Format,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Time one point of a benchmark, without a database.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Verdict of every overlap algorithm and the minimum distance for each configuration of a CSV file.
    Overlap(overlap_cmd::OverlapArgs),
    /// One event-driven MD simulation of hard bodies, no database.
    Edmd(edmd_cmd::EdmdArgs),
    /// Validate a plan and print how many points it expands to, with an estimate of their cost.
    Plan(plan_cmd::PlanArgs),
    /// Local mode: run a plan on this machine, one job per core, resumable.
    Run(local::RunArgs),
    /// Job counts of a campaign: total, queued, running, done, failed.
    Status(status::StatusArgs),
    /// The papers' tables and figures from a result database.
    Report(report_cmd::ReportArgs),
    /// Read-only SQL over a result database.
    Query(query::QueryArgs),
    /// Every result record with its job, campaign, kind, attempt and worker.
    Export(query::ExportArgs),
    /// Serve campaigns to workers over gRPC, holding the result database.
    Coordinator(remote::CoordinatorArgs),
    /// Run jobs from a coordinator, one per pinned core.
    Worker(remote::WorkerArgs),
    /// Send a plan to a coordinator; prints the campaign id.
    Submit(remote::SubmitArgs),
    /// Cancel a campaign's queued points.
    Cancel(remote::CancelArgs),
    /// The workers a coordinator knows.
    Workers(remote::WorkersArgs),
    /// Internal: run one job (its spec as JSON on stdin) and write its records (a JSON array) on
    /// stdout; how a worker isolates a job that runs foreign code (`worker::child`).
    #[command(name = worker::child::RUN_JOB, hide = true)]
    RunJob {
        #[arg(long)]
        attempt: u32,
    },
}

fn main() -> std::process::ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version
        Err(e) => {
            // clap's first line names the flag and the cause; the usage hint after it is noise.
            let message = e.to_string();
            eprintln!(
                "{}",
                message.lines().next().unwrap_or("error: invalid arguments")
            );
            return std::process::ExitCode::from(2);
        }
    };
    if let Command::RunJob { attempt } = cli.command {
        // No logging set-up: stdout carries the records, stderr the error alone.
        return match worker::child::serve(&mut std::io::stdin(), &mut std::io::stdout(), attempt) {
            Ok(()) => std::process::ExitCode::SUCCESS,
            Err(error) => {
                eprintln!("{error}");
                std::process::ExitCode::FAILURE
            }
        };
    }
    system::init_logging();
    let result = match cli.command {
        Command::Bench(command) => bench::run(command, cli.format),
        Command::Overlap(args) => overlap_cmd::run(&args, cli.format),
        Command::Edmd(args) => edmd_cmd::run(&args, cli.format),
        Command::Plan(args) => plan_cmd::run(&args, cli.format),
        Command::Run(args) => local::run(&args, cli.format),
        Command::Status(args) => status::run(&args, cli.format),
        Command::Report(args) => report_cmd::run(&args, cli.format),
        Command::Query(args) => query::query(&args, cli.format),
        Command::Export(args) => query::export(&args, cli.format),
        Command::Coordinator(args) => remote::coordinator(&args),
        Command::Worker(args) => remote::worker(&args),
        Command::Submit(args) => remote::submit(&args, cli.format),
        Command::Cancel(args) => remote::cancel(&args, cli.format),
        Command::Workers(args) => remote::workers(&args, cli.format),
        Command::RunJob { .. } => Ok(()), // served above
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {}", one_line(&error));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The causes of `error` on one line, outermost first, each said once: a library error that
/// already quotes its source (sqlx's do, and so do errors that wrap them) is not followed by that
/// source again.
fn one_line(error: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in error.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("database error: {0}")]
    struct Quoting(#[source] std::io::Error);

    #[test]
    fn a_cause_already_quoted_is_said_once() {
        let io = std::io::Error::other("(code: 11) database disk image is malformed");
        let error = anyhow::Error::new(Quoting(io)).context("cannot open x.db");
        assert_eq!(
            one_line(&error),
            "cannot open x.db: database error: (code: 11) database disk image is malformed"
        );
        let plain = anyhow::anyhow!("no such table").context("report table1");
        assert_eq!(one_line(&plain), "report table1: no such table");
    }
}
