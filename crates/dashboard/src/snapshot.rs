//! The sampler: one task reads the store into a [`Snapshot`] every few seconds, and every request
//! is answered from the latest one, so a hundred open pages cost what one does.
//!
//! Cost: a sample is O(jobs) (the counts group every job of every campaign by state; jobs done
//! per worker read the done jobs through the state index, and jobs done per allocation are
//! summed from them) plus O(running) for the jobs in hand, O(20) for the failures and O(50) for
//! the allocations; with `[[tune]]` searches, O(EDMD jobs) more to say where each stands. The next sample starts [`MIN_PERIOD`] or ten times the last
//! sample's duration after it, whichever is longer: whatever the campaign's size, sampling keeps
//! at most a tenth of one core busy, on the read-only connections (never the writer). Each
//! snapshot says what its sample cost (`sample_s`) and when the next is due.

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use coordinator::autoalloc::Report;
use coordinator::{Coordinator, Status};
use results::OverlapQuality;

use crate::figures::FigureLink;
use serde::Serialize;
use store::{FailureRecord, JobInHand};
use tokio::sync::{Notify, watch};
use tune::drive::DriveError;
use tune::report::SearchRow;

/// The shortest time between two samples.
pub const MIN_PERIOD: Duration = Duration::from_secs(1);
/// A sample may keep the reader busy for this fraction of the time.
const DUTY: u32 = 10;
/// Jobs per second are measured over this much of the past.
const RATE_WINDOW_S: f64 = 60.0;
/// Failures listed.
const FAILURES: u32 = 20;

/// One campaign as the page shows it. The first fields are those of `sweep status --format json`
/// (`campaign`, `status`, `timing`); the rest extend it.
#[derive(Clone, Debug, Serialize)]
pub struct CampaignView {
    pub campaign: String,
    pub status: Status,
    pub timing: OverlapQuality,
    pub name: String,
    pub created_at: f64,
    pub cancelled_at: Option<f64>,
    /// Finished jobs (done, failed or cancelled) over all jobs, 0 to 1.
    pub progress: f64,
    /// Jobs finished per second over the last minute (or since the page's server started);
    /// `None` until two samples apart in time have seen the campaign.
    pub jobs_per_s: Option<f64>,
    /// Seconds until the queued and running jobs are done, `None` if nothing tells.
    pub remaining_s: Option<f64>,
    /// How `remaining_s` was computed, in words.
    pub remaining_how: String,
}

/// One worker as the page shows it. The fields of `sweep workers --format json` (`id`,
/// `hostname`, `cores`, `cpu_model`, `git_commit`, `running`, `last_seen_at`, `allocation`) and
/// more.
#[derive(Clone, Debug, Serialize)]
pub struct WorkerView {
    pub id: String,
    pub hostname: String,
    pub cores: Vec<u32>,
    pub cpu_model: String,
    pub git_commit: String,
    pub running: u32,
    pub last_seen_at: f64,
    pub rustc: String,
    pub profile: String,
    pub registered_at: f64,
    /// Seconds since the worker last called (lease, heartbeat or report), at the sample.
    pub heartbeat_age_s: f64,
    /// No call for more than half a lease: two heartbeats missed.
    pub stale: bool,
    pub jobs_done: u64,
    pub in_hand: Vec<JobInHand>,
    /// The Slurm job id of the allocation it runs in, if any.
    pub allocation: Option<String>,
}

/// Everything the page shows, as of `taken_at`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Snapshot {
    /// Unix seconds.
    pub taken_at: f64,
    /// How long the sample took, and when the next one is due after it (seconds).
    pub sample_s: f64,
    pub next_sample_in_s: f64,
    /// Done jobs in the whole store: the figures' cache key.
    pub done_total: u64,
    pub campaigns: Vec<CampaignView>,
    pub workers: Vec<WorkerView>,
    pub failures: Vec<FailureRecord>,
    pub figures: Vec<FigureLink>,
    /// The allocations of `--slurm-alloc` (empty, `configured: false`, without an allocator).
    pub allocations: Report,
    /// Why the page draws nothing, or nothing for some kind of done job.
    pub figures_absent: Vec<String>,
    /// The `[[tune]]` searches of the campaigns, running and concluded, as `sweep report tune
    /// --format json` gives them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub searches: Vec<SearchRow>,
    /// Done jobs by kind (which figures can be drawn).
    #[serde(skip)]
    pub done_by_kind: Vec<(String, u64)>,
}

fn unix_now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Finished jobs of each campaign at past samples, for the rate.
#[derive(Default)]
struct History {
    finished: HashMap<String, VecDeque<(f64, u64)>>,
}

impl History {
    /// Records `finished` at `now` and returns jobs per second over the window.
    fn rate(&mut self, campaign: &str, now: f64, finished: u64) -> Option<f64> {
        let samples = self.finished.entry(campaign.to_owned()).or_default();
        samples.push_back((now, finished));
        // Keep the newest sample older than the window as the baseline.
        while samples.len() > 2 && samples[1].0 <= now - RATE_WINDOW_S {
            samples.pop_front();
        }
        let &(then, before) = samples.front()?;
        let elapsed = now - then;
        (elapsed >= 0.5).then(|| finished.saturating_sub(before) as f64 / elapsed)
    }
}

/// The remaining time and how it was estimated. `rate` is measured; without it the plan's
/// estimate of each job's CPU time is spread over the cores of the live workers.
pub fn remaining(status: &Status, rate: Option<f64>, live_cores: usize) -> (Option<f64>, String) {
    let left = status.queued + status.running;
    if left == 0 {
        return (Some(0.0), "finished".into());
    }
    match rate {
        Some(rate) if rate > 0.0 => (
            Some(left as f64 / rate),
            format!(
                "{left} jobs left (queued + running) ÷ {rate:.3} jobs/s, the rate of the last {RATE_WINDOW_S:.0} s"
            ),
        ),
        _ if live_cores > 0 && status.estimate_s_remaining > 0.0 => (
            Some(status.estimate_s_remaining / live_cores as f64),
            format!(
                "no job finished lately: the plan's estimate, {:.0} CPU-seconds left ÷ {live_cores} cores of live workers",
                status.estimate_s_remaining
            ),
        ),
        _ => (
            None,
            "unknown: no job finished lately and no live worker".into(),
        ),
    }
}

/// What `sample` reads.
async fn sample(coordinator: &Coordinator, history: &mut History) -> results::Result<Snapshot> {
    let store = coordinator.store();
    let now = unix_now();
    let stale_after = coordinator.config().lease_for.as_secs_f64() / 2.0;
    let records = store.workers().await?;
    let mut activity = store.worker_activity().await?;
    let workers: Vec<WorkerView> = records
        .into_iter()
        .map(|w| {
            let mine = activity.remove(&w.info.id).unwrap_or_default();
            let age = (now - w.last_seen_at).max(0.0);
            WorkerView {
                id: w.info.id,
                hostname: w.info.hostname,
                cores: w.info.cores,
                cpu_model: w.info.cpu_model,
                git_commit: w.info.git_commit,
                running: w.running,
                last_seen_at: w.last_seen_at,
                rustc: w.info.rustc,
                profile: w.info.profile,
                registered_at: w.registered_at,
                heartbeat_age_s: age,
                stale: age > stale_after,
                jobs_done: mine.jobs_done,
                in_hand: mine.in_hand,
                allocation: w.info.allocation,
            }
        })
        .collect();
    // Jobs done per allocation, from what was just read per worker (no second pass over jobs).
    let mut done_by_allocation: HashMap<String, u64> = HashMap::new();
    for w in &workers {
        if let Some(allocation) = &w.allocation {
            *done_by_allocation.entry(allocation.clone()).or_default() += w.jobs_done;
        }
    }
    let allocations = Report::read(
        store,
        Some(coordinator.allocating()),
        Some(&done_by_allocation),
    )
    .await?;
    let live_cores = workers
        .iter()
        .filter(|w| !w.stale)
        .map(|w| w.cores.len())
        .sum();
    let mut campaigns = Vec::new();
    for c in store.campaigns().await? {
        let s = c.status;
        let finished = s.done + s.failed + s.cancelled;
        let rate = history.rate(&c.id, now, finished);
        let (remaining_s, remaining_how) = remaining(&s, rate, live_cores);
        campaigns.push(CampaignView {
            timing: results::overlap_quality(store, Some(&c.id)).await?,
            progress: if s.total == 0 {
                1.0
            } else {
                finished as f64 / s.total as f64
            },
            jobs_per_s: rate,
            remaining_s,
            remaining_how,
            campaign: c.id,
            status: s,
            name: c.name,
            created_at: c.created_at,
            cancelled_at: c.cancelled_at,
        });
    }
    let done_by_kind = store.done_by_kind().await?;
    let searches = match tune::report::rows(store).await {
        Ok((rows, _)) => rows,
        Err(DriveError::Results(e)) => return Err(e),
        // A stored search this version cannot drive is reported by `sweep report tune`; the
        // page shows the others.
        Err(error) => {
            tracing::warn!(%error, "status page: the searches cannot be shown");
            Vec::new()
        }
    };
    let figures = crate::figures::BY_KIND
        .iter()
        .filter(|(kind, _)| done_by_kind.iter().any(|(k, _)| k == kind))
        .flat_map(|(_, figures)| figures.iter().map(|f| f.link()))
        .collect();
    Ok(Snapshot {
        taken_at: now,
        sample_s: 0.0,
        next_sample_in_s: 0.0,
        done_total: store.status(None).await?.done,
        campaigns,
        workers,
        failures: store.recent_failures(FAILURES).await?,
        figures,
        allocations,
        figures_absent: crate::figures::absent(&done_by_kind),
        done_by_kind,
        searches,
    })
}

/// The latest snapshot, and a way to ask for a fresh one now (after a cancel).
#[derive(Clone)]
pub struct Sampler {
    latest: watch::Receiver<Arc<Snapshot>>,
    poke: Arc<Notify>,
}

impl Sampler {
    /// Takes a first sample, then keeps sampling in a task until the returned handle is aborted
    /// (or dropped with the runtime).
    pub async fn start(
        coordinator: Coordinator,
    ) -> results::Result<(Sampler, tokio::task::JoinHandle<()>)> {
        let mut history = History::default();
        let first = sample(&coordinator, &mut history).await?;
        let (tx, rx) = watch::channel(Arc::new(first));
        let poke = Arc::new(Notify::new());
        let sampler = Sampler {
            latest: rx,
            poke: poke.clone(),
        };
        let task = tokio::spawn(async move {
            let mut wait = MIN_PERIOD;
            loop {
                tokio::select! {
                    _ = tokio::time::sleep(wait) => {}
                    _ = poke.notified() => {}
                }
                let started = Instant::now();
                match sample(&coordinator, &mut history).await {
                    Ok(mut snapshot) => {
                        let cost = started.elapsed();
                        wait = MIN_PERIOD.max(cost * DUTY);
                        snapshot.sample_s = cost.as_secs_f64();
                        snapshot.next_sample_in_s = wait.as_secs_f64();
                        tx.send_replace(Arc::new(snapshot));
                    }
                    Err(error) => {
                        tracing::warn!(%error, "status page: sampling the store failed; keeping the last sample");
                        wait = MIN_PERIOD.max(started.elapsed() * DUTY);
                    }
                }
            }
        });
        Ok((sampler, task))
    }

    pub fn latest(&self) -> Arc<Snapshot> {
        self.latest.borrow().clone()
    }

    /// Asks for a sample now rather than at the next period.
    pub fn refresh(&self) {
        self.poke.notify_one();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(queued: u64, running: u64, done: u64, estimate: f64) -> Status {
        Status {
            total: queued + running + done,
            queued,
            running,
            done,
            estimate_s_remaining: estimate,
            ..Status::default()
        }
    }

    #[test]
    fn rate_over_the_window() {
        let mut h = History::default();
        assert_eq!(h.rate("c", 100.0, 0), None, "one sample tells no rate");
        assert_eq!(h.rate("c", 110.0, 50), Some(5.0));
        assert_eq!(h.rate("c", 120.0, 150), Some(7.5));
        // Samples older than the window are dropped but the last one before it stays the baseline.
        for t in 13..=20 {
            h.rate("c", f64::from(t) * 10.0, 150 + 10 * (t as u64 - 12));
        }
        // At t = 210 the baseline is the sample at 150 (180 finished).
        let r = h.rate("c", 210.0, 240).unwrap();
        assert!((r - (240.0 - 180.0) / 60.0).abs() < 1e-9, "rate {r}");
    }

    #[test]
    fn remaining_time_and_how() {
        let (s, how) = remaining(&status(90, 10, 0, 0.0), Some(4.0), 2);
        assert_eq!(s, Some(25.0));
        assert!(how.contains("100 jobs left"), "{how}");
        let (s, how) = remaining(&status(10, 0, 5, 300.0), None, 3);
        assert_eq!(s, Some(100.0));
        assert!(how.contains("plan's estimate"), "{how}");
        assert_eq!(remaining(&status(10, 0, 5, 300.0), Some(0.0), 0).0, None);
        assert_eq!(
            remaining(&status(0, 0, 5, 0.0), None, 0),
            (Some(0.0), "finished".into())
        );
    }
}
