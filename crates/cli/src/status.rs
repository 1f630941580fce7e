//! `sweep status`: a campaign's counts, from a database or from a running coordinator.

use std::path::PathBuf;

use clap::Args;
use coordinator::autoalloc::Report;

use crate::args::{AuthArgs, ClientArgs};
use crate::database;
use crate::output::{Format, print_status};

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
    auth: AuthArgs,
    #[arg(long)]
    ca: Option<PathBuf>,
    /// One campaign (default: everything).
    #[arg(long)]
    campaign: Option<String>,
}

/// A worker seen within this many seconds counts as connected.
const ALLOWING_WORKER_RECENT_S: f64 = 60.0;

pub fn run(args: &StatusArgs, format: Format) -> anyhow::Result<()> {
    let campaign = args.campaign.as_deref();
    let shown = campaign.unwrap_or("(all)");
    match (&args.db, &args.coordinator) {
        (Some(db), _) => {
            let (status, quality, shifts, allocations, waiting) =
                database::read(db, async |store| {
                    let status = store.status(campaign).await?;
                    let now = std::time::SystemTime::now()
                        .duration_since(std::time::UNIX_EPOCH)
                        .map_or(0.0, |d| d.as_secs_f64());
                    let waiting = store
                        .foreign_code_waiting(campaign, now - ALLOWING_WORKER_RECENT_S)
                        .await?;
                    let quality = results::overlap_quality(store, campaign).await?;
                    let shifts = results::machine_history(store).await?;
                    let allocations = Report::read(store, None, None).await?;
                    Ok((status, quality, shifts, allocations, waiting))
                })?;
            if waiting > 0 {
                // On stderr: the counts on stdout keep their shape.
                eprintln!(
                    "warning: {waiting} program job(s) queued and no worker started with --allow-commands seen in the last {ALLOWING_WORKER_RECENT_S:.0} s: no other worker will ever be given them"
                );
            }
            let shifts: Vec<_> = shifts
                .into_iter()
                .filter(|s| campaign.is_none_or(|c| c == s.campaign))
                .collect();
            let allocations = shown_allocations(allocations);
            print_status(
                shown,
                &status,
                Some((&quality, &shifts)),
                allocations.as_ref(),
                format,
            )
        }
        (None, Some(url)) => {
            let client = ClientArgs {
                coordinator: url.clone(),
                auth: args.auth.clone(),
                ca: args.ca.clone(),
            };
            let status = crate::remote::status(&client, campaign)?;
            let allocations =
                crate::remote::allocations(&client, false)?.and_then(shown_allocations);
            print_status(shown, &status, None, allocations.as_ref(), format)
        }
        (None, None) => anyhow::bail!("give --db FILE or --coordinator URL"),
    }
}

/// The allocations, where there is anything to say about them: a coordinator that allocates, or
/// a database one did.
fn shown_allocations(report: Report) -> Option<Report> {
    (report.configured || !report.allocations.is_empty()).then_some(report)
}
