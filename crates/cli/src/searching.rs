//! `[[tune]]` searches driven: after jobs finish, each search's next evaluations are submitted
//! into its campaign. Local mode calls [`step`] itself; a coordinator runs [`drive`] beside
//! its service. Nothing is kept in memory: the searches are read back as stored with their
//! campaigns and their evaluations from the jobs, so a restarted coordinator carries on where
//! it was.

use std::time::Duration;

use coordinator::{Coordinator, NewCampaign};
use jobs::TuneSearch;
use store::StoredSearch;

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
) -> anyhow::Result<Issued> {
    step_campaigns(coordinator, &[(campaign, searches)]).await
}

/// [`step`] for the searches of several campaigns, each one's evaluations into its own: the
/// EDMD jobs are read once for all of them.
async fn step_campaigns(
    coordinator: &Coordinator,
    campaigns: &[(&NewCampaign, &[TuneSearch])],
) -> anyhow::Result<Issued> {
    let all: Vec<TuneSearch> = campaigns
        .iter()
        .flat_map(|(_, s)| s.iter().cloned())
        .collect();
    let mut steps = tune::drive::steps(coordinator.store(), &all)
        .await?
        .into_iter();
    let mut issued = Issued {
        new_jobs: 0,
        all_done: true,
    };
    for &(campaign, searches) in campaigns {
        let mine: Vec<_> = steps.by_ref().take(searches.len()).collect();
        issued.all_done &= mine.iter().all(|s| matches!(s.step, tune::Step::Done(_)));
        let jobs: Vec<_> = mine
            .iter()
            .flat_map(|s| {
                s.jobs()
                    .into_iter()
                    .map(|spec| new_job(&spec, s.search.exclusive))
            })
            .collect();
        if jobs.is_empty() {
            continue;
        }
        let outcome = coordinator.submit(campaign, &jobs).await?;
        let new_jobs = outcome.new_jobs + outcome.requeued;
        if new_jobs > 0 {
            tracing::info!(campaign = %campaign.id, jobs = new_jobs, "[[tune]]: evaluations issued");
        }
        issued.new_jobs += new_jobs;
    }
    Ok(issued)
}

/// How often a coordinator looks whether jobs have finished since its last step.
const EVERY: Duration = Duration::from_secs(1);

/// The coordinator's driver: whenever jobs have finished or arrived, or searches were
/// submitted, a step of every search of every campaign that is not cancelled. A coordinator
/// without searches reads one small table a second and nothing else. A step that fails is
/// logged and tried again at the next change; it never stops the service.
pub async fn drive(coordinator: Coordinator) {
    let mut ticker = tokio::time::interval(EVERY);
    let mut seen_before = None;
    loop {
        ticker.tick().await;
        let stored = match coordinator.store().searches().await {
            Ok(stored) if stored.is_empty() => continue,
            Ok(stored) => stored,
            Err(e) => {
                tracing::warn!(error = %e, "[[tune]]: cannot read the searches");
                continue;
            }
        };
        let seen = match coordinator.status(None).await {
            Ok(s) => (s.done + s.failed + s.cancelled, s.total, stored.len()),
            Err(e) => {
                tracing::warn!(error = %e, "[[tune]]: cannot read the queue");
                continue;
            }
        };
        if seen_before == Some(seen) {
            continue;
        }
        match step_all(&coordinator, stored).await {
            Ok(()) => seen_before = Some(seen),
            Err(e) => tracing::warn!(error = %format!("{e:#}"), "[[tune]]: a step failed"),
        }
    }
}

async fn step_all(coordinator: &Coordinator, stored: Vec<StoredSearch>) -> anyhow::Result<()> {
    let mut campaigns: Vec<(NewCampaign, Vec<TuneSearch>)> = Vec::new();
    for s in stored.into_iter().filter(|s| !s.cancelled) {
        let search: TuneSearch = match serde_json::from_str(&s.search) {
            Ok(search) => search,
            Err(e) => {
                tracing::warn!(campaign = %s.campaign_id, error = %e, "[[tune]]: a stored search this version cannot read");
                continue;
            }
        };
        match campaigns.last_mut() {
            Some((c, searches)) if c.id == s.campaign_id => searches.push(search),
            _ => campaigns.push((
                // The campaign exists: submitting into it adds jobs and changes nothing else.
                NewCampaign {
                    id: s.campaign_id,
                    name: s.campaign_name,
                    plan_text: String::new(),
                    searches: Vec::new(),
                },
                vec![search],
            )),
        }
    }
    let campaigns: Vec<(&NewCampaign, &[TuneSearch])> =
        campaigns.iter().map(|(c, s)| (c, s.as_slice())).collect();
    step_campaigns(coordinator, &campaigns).await?;
    Ok(())
}
