//! `[[tune]]` searches driven: after jobs finish, each search's next evaluations are submitted
//! into its campaign. Local mode calls [`step`] itself; a coordinator runs [`drive`] beside
//! its service. Nothing is kept in memory: the searches are re-read from the campaigns' plans
//! and their evaluations from the jobs, so a restarted coordinator carries on where it was.

use std::time::Duration;

use coordinator::{Coordinator, NewCampaign};
use jobs::{Plan, TuneSearch};

use crate::campaign::new_job;

pub struct Issued {
    /// Jobs queued by this step (new, or failed ones asked for again).
    pub new_jobs: u64,
    pub all_done: bool,
}

/// Submits the evaluations the searches ask for next into `campaign`.
pub async fn step(
    coordinator: &Coordinator,
    campaign: &NewCampaign,
    searches: &[TuneSearch],
    exclusive: bool,
) -> anyhow::Result<Issued> {
    let steps = tune::drive::steps(coordinator.store(), searches).await?;
    let jobs: Vec<_> = steps
        .iter()
        .flat_map(|s| s.jobs())
        .map(|spec| new_job(&spec, exclusive))
        .collect();
    let new_jobs = if jobs.is_empty() {
        0
    } else {
        let outcome = coordinator.submit(campaign, &jobs).await?;
        outcome.new_jobs + outcome.requeued
    };
    Ok(Issued {
        new_jobs,
        all_done: steps.iter().all(|s| matches!(s.step, tune::Step::Done(_))),
    })
}

/// How often a coordinator looks whether jobs have finished since its last step.
const EVERY: Duration = Duration::from_secs(1);

/// The coordinator's driver: whenever jobs have finished, a step of every search of every
/// campaign that is not cancelled. A step that fails is logged and tried again at the next
/// finished job; it never stops the service.
pub async fn drive(coordinator: Coordinator) {
    let mut ticker = tokio::time::interval(EVERY);
    let mut seen_before = None;
    loop {
        ticker.tick().await;
        // A step is due when a job has finished or been added, or a campaign submitted.
        let seen = match changes(&coordinator).await {
            Ok(seen) => seen,
            Err(e) => {
                tracing::warn!(error = %format!("{e:#}"), "[[tune]]: cannot read the queue");
                continue;
            }
        };
        if seen_before == Some(seen) {
            continue;
        }
        match step_all(&coordinator).await {
            Ok(()) => seen_before = Some(seen),
            Err(e) => tracing::warn!(error = %format!("{e:#}"), "[[tune]]: a step failed"),
        }
    }
}

/// What changes when a step may be due: jobs finished, jobs in all, campaigns.
async fn changes(coordinator: &Coordinator) -> anyhow::Result<(u64, u64, usize)> {
    let status = coordinator.status(None).await?;
    let campaigns = coordinator
        .store()
        .query_read_only_with("SELECT count(*) FROM campaigns", &[])
        .await?;
    let count = campaigns.rows.len();
    let campaigns = campaigns
        .rows
        .first()
        .and_then(|r| r.first())
        .and_then(serde_json::Value::as_u64)
        .unwrap_or(count as u64) as usize;
    Ok((
        status.done + status.failed + status.cancelled,
        status.total,
        campaigns,
    ))
}

async fn step_all(coordinator: &Coordinator) -> anyhow::Result<()> {
    let campaigns = coordinator
        .store()
        .query_read_only_with(
            "SELECT id, name, plan_text FROM campaigns
             WHERE cancelled_at IS NULL AND plan_text LIKE '%tune%' ORDER BY created_at, id",
            &[],
        )
        .await?;
    for row in &campaigns.rows {
        let [id, name, text] = row.as_slice() else {
            continue;
        };
        let (Some(id), Some(name), Some(text)) = (id.as_str(), name.as_str(), text.as_str()) else {
            continue;
        };
        // Read as a coordinator reads a submitted plan: plugins are never opened here.
        let plan = match Plan::parse_in(text, name, std::path::Path::new(".")) {
            Ok(plan) => plan,
            Err(e) => {
                tracing::warn!(campaign = id, error = %e, "[[tune]]: the campaign's plan does not parse any more");
                continue;
            }
        };
        if plan.tunes.is_empty() {
            continue;
        }
        let campaign = NewCampaign {
            id: id.to_owned(),
            name: name.to_owned(),
            plan_text: text.to_owned(),
        };
        let issued = step(coordinator, &campaign, &plan.tunes, plan.exclusive_timing).await?;
        if issued.new_jobs > 0 {
            tracing::info!(
                campaign = id,
                jobs = issued.new_jobs,
                "[[tune]]: evaluations issued"
            );
        }
    }
    Ok(())
}
