//! `sweep`: the command line. Thin: parse, call the library crates, print.

mod bench;
mod output;
mod overlap_cmd;
mod system;

use clap::{Parser, Subcommand};

use crate::output::Format;

#[derive(Parser)]
#[command(name = "sweep", version, about = "Benchmark campaigns for hard-body collision algorithms")]
struct Cli {
    /// How results are printed: an aligned table, or JSON on stdout (logs stay on stderr).
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
}

fn main() -> std::process::ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version
        Err(e) => {
            // clap's first line names the flag and the cause; the usage hint after it is noise.
            let message = e.to_string();
            eprintln!("{}", message.lines().next().unwrap_or("error: invalid arguments"));
            return std::process::ExitCode::from(2);
        }
    };
    system::init_logging();
    let result = match cli.command {
        Command::Bench(command) => bench::run(command, cli.format),
        Command::Overlap(args) => overlap_cmd::run(&args, cli.format),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            // One line: the causes joined, outermost first.
            eprintln!("error: {error:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
