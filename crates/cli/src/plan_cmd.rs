//! `sweep plan PLAN.toml`: what a plan expands to, before anything runs.

use std::collections::BTreeMap;
use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::campaign::{from_plan, read_plan_file};
use crate::output::{Format, print_json};

#[derive(Args)]
pub struct PlanArgs {
    plan: PathBuf,
}

#[derive(Serialize)]
struct PlanSummary {
    name: String,
    campaign: String,
    points: usize,
    /// `[[tune]]` searches (one per state point), whose points come as they go.
    searches: usize,
    by_kind: BTreeMap<String, usize>,
    exclusive: bool,
    estimate_s: f64,
}

pub fn run(args: &PlanArgs, format: Format) -> anyhow::Result<()> {
    let (text, name) = read_plan_file(&args.plan)?;
    let campaign = from_plan(&text, &name, None)?;
    let mut by_kind = BTreeMap::new();
    for job in &campaign.jobs {
        *by_kind.entry(job.kind.clone()).or_insert(0) += 1;
    }
    let summary = PlanSummary {
        name: campaign.plan.name.clone(),
        campaign: campaign.campaign.id.clone(),
        points: campaign.jobs.len(),
        searches: campaign.plan.tunes.len(),
        by_kind,
        exclusive: campaign.plan.exclusive_timing,
        // An empty sum is −0.
        estimate_s: campaign.plan.estimate_seconds() + 0.0,
    };
    match format {
        Format::Json => print_json(&summary),
        _ => {
            let kinds: Vec<String> = summary
                .by_kind
                .iter()
                .map(|(k, n)| format!("{n} {k}"))
                .collect();
            let searches = match summary.searches {
                0 => String::new(),
                n => format!(" and {n} [[tune]] searches"),
            };
            let kinds = match kinds.is_empty() {
                true => String::new(),
                false => format!(" ({})", kinds.join(", ")),
            };
            println!(
                "{}: {} points{kinds}{searches}, campaign {}, estimated {:.0} s of job time{}",
                summary.name,
                summary.points,
                summary.campaign,
                summary.estimate_s,
                if summary.exclusive {
                    ", exclusive timing"
                } else {
                    ""
                }
            );
            Ok(())
        }
    }
}
