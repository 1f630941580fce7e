//! The allocator of `sweep coordinator --slurm-alloc FILE`: workers that come when there is work.
//! While jobs are queued it submits Slurm allocations of `deploy/slurm/sweep.sbatch` in its
//! workers-only form (`--coordinator URL --idle-timeout S --stop-margin M`), as many as the work
//! needs and never more than `max_in_flight`, follows them with `squeue`, and records each in the
//! store (`allocations`, migration 0014) with its state and, when it failed, why.
//!
//! One [`Allocator::tick`] (every `check_every_s`, and at once when a submission queues jobs):
//!
//! 1. **Follow.** `squeue` reports on the allocations in flight; one that left the queue without
//!    a worker ever registering from it (`sweep worker --allocation`, SLURM_JOB_ID) is `failed`,
//!    with the last line of its output file as the reason; one that ran is `ended`, with
//!    Slurm's final state (COMPLETED: its workers went idle or had no time left for what is
//!    queued; TIMEOUT: the time limit).
//! 2. **Size.** The work is the queued jobs' expected CPU-seconds: a job's estimate times what
//!    its kind has been observed to take per second of estimate ([`crate::Durations`], the
//!    estimate the status page starts from), from the first [`HEAD`] queued jobs in lease order (a
//!    fixed shuffle of each plan, so a fair sample) scaled to the queue's length. Jobs expected to
//!    take longer than an allocation's usable time (time limit less the stop margin) can never
//!    run in one and are left out (and said so). The allocations in flight supply their cores
//!    times their usable time left; new allocations are submitted until the supply covers the
//!    work, and never beyond `max_in_flight`. As no job that fits takes longer than the usable
//!    time, that is never more allocations than the jobs keep busy (⌈jobs ÷ cores⌉). At least
//!    one is in flight while anything that fits is queued; none is submitted when nothing is,
//!    and allocations still pending then are cancelled.
//! 3. **Back off.** A failed `sbatch`, or an allocation that ended without a worker, counts a
//!    failure; after `n` failures in a row nothing is submitted for
//!    min([`BACKOFF_FIRST_S`] · 2ⁿ⁻¹, [`BACKOFF_MAX_S`]) seconds. A worker registering from one of
//!    the allocations resets the count. So a broken argument costs one `sbatch` a minute at
//!    first, then fewer, never a loop, and the reason is shown meanwhile.
//!
//! Cost per tick: one `squeue` over the allocations in flight; the queue's length (the state
//! index, no row) and [`HEAD`] rows; O(in flight) writes. Nothing is O(jobs) beyond the count.
//!
//! The workers themselves end their allocation: `--idle-timeout` (no job for that long) and
//! `--deadline` (the allocation's end less the stop margin: no job is leased that is not
//! expected to finish by then, see [`crate::Coordinator::lease_within`]).

pub mod config;
pub mod slurm;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use store::{Allocation, AllocationState, AllocatorState};
use tokio::task::JoinHandle;

use crate::Coordinator;
use crate::autoalloc::config::AllocConfig;
use crate::autoalloc::slurm::{Batch, JobStatus, one_line};

/// Queued jobs sampled per tick for their expected durations.
pub const HEAD: u32 = 4096;
/// The pause after the first failure; it doubles with each failure in a row.
pub const BACKOFF_FIRST_S: f64 = 60.0;
/// The longest pause.
pub const BACKOFF_MAX_S: f64 = 3600.0;

/// How a submitted allocation starts its workers.
#[derive(Debug, Clone, PartialEq)]
pub struct Launch {
    /// The script sbatch runs (see [`write_script`]).
    pub script: PathBuf,
    /// How the workers reach this coordinator.
    pub coordinator_url: String,
    /// Environment the allocation gets besides the submitting one's (`--export=ALL,K=V`): the
    /// binary (`SWEEP`) and the token file (`SWEEP_TOKEN_FILE`).
    pub export: Vec<(String, String)>,
}

/// Writes the script the allocations run into `config.directory` (creating it): the file the
/// allocation file names, or `builtin` (deploy/slurm/sweep.sbatch, built into the binary). The
/// allocator asks for `cores` CPUs itself, so the script's `#SBATCH --exclusive` line (whole
/// nodes, for the hand-submitted form) is left out; `sbatch_args = ["--exclusive"]` asks for
/// whole nodes again. Answers the path written.
pub fn write_script(config: &AllocConfig, builtin: &str) -> std::io::Result<PathBuf> {
    let text = match &config.script {
        Some(path) => std::fs::read_to_string(path)?,
        None => builtin.to_owned(),
    };
    std::fs::create_dir_all(&config.directory)?;
    let path = config.directory.join("sweep-workers.sbatch");
    std::fs::write(&path, without_exclusive(&text))?;
    Ok(path)
}

/// `text` without its `#SBATCH --exclusive` directives.
pub fn without_exclusive(text: &str) -> String {
    text.lines()
        .filter(|line| {
            let words: Vec<&str> = line.split_whitespace().collect();
            !(words.first() == Some(&"#SBATCH")
                && words.get(1).is_some_and(|w| w.starts_with("--exclusive")))
        })
        .map(|line| format!("{line}\n"))
        .collect()
}

/// Errors of the allocator: the store's (a tick that cannot read or write the store does
/// nothing and is retried at the next).
pub type Error = crate::Error;

/// What one tick did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tick {
    /// Slurm ids of the allocations submitted.
    pub submitted: Vec<String>,
    /// sbatch calls that failed.
    pub refused: u32,
    /// Pending allocations cancelled because nothing is queued.
    pub cancelled: Vec<String>,
    /// The decision, in words (also the allocator's `note`).
    pub note: String,
}

/// The allocator: its configuration, the batch system, and the allocations in flight.
pub struct Allocator<B: Batch> {
    config: AllocConfig,
    launch: Launch,
    coordinator: Coordinator,
    batch: B,
    /// Pending or running, oldest first.
    open: Vec<Allocation>,
    /// Seconds left of each running allocation at the last `squeue`, by id.
    left_s: HashMap<i64, f64>,
    /// Allocations a worker has registered from (each counts as a success once).
    with_worker: HashSet<i64>,
    state: AllocatorState,
    /// The state as last written.
    saved: Option<AllocatorState>,
}

/// The allocator's state is written when it changes, and at least this often (seconds).
pub const STATE_EVERY_S: f64 = 60.0;

impl<B: Batch> Allocator<B> {
    /// An allocator that takes over the allocations a previous coordinator on the same
    /// database left in flight, and its failure count.
    pub async fn new(
        config: AllocConfig,
        launch: Launch,
        coordinator: Coordinator,
        batch: B,
    ) -> Result<Self, Error> {
        coordinator.set_allocating();
        let store = coordinator.store();
        let open = store.open_allocations().await?;
        let state = store.allocator_state().await?.unwrap_or_default();
        Ok(Allocator {
            config,
            launch,
            coordinator,
            batch,
            open,
            left_s: HashMap::new(),
            with_worker: HashSet::new(),
            state,
            saved: None,
        })
    }

    pub fn config(&self) -> &AllocConfig {
        &self.config
    }

    /// The pending and running allocations.
    pub fn open(&self) -> &[Allocation] {
        &self.open
    }

    /// The sbatch arguments of one allocation.
    pub fn sbatch_args(&self) -> Vec<String> {
        let c = &self.config;
        let dir = c.directory.display();
        let mut args = vec![
            "--parsable".to_owned(),
            "--job-name=sweep-workers".to_owned(),
            format!("--chdir={dir}"),
            format!("--output={dir}/slurm-%j.out"),
            format!("--time={}", c.time_limit),
            format!("--nodes={}", c.nodes),
            "--ntasks-per-node=1".to_owned(),
            format!("--cpus-per-task={}", c.cores_per_node()),
            format!("--signal=B:USR1@{}", c.stop_margin_s),
        ];
        if let Some(partition) = &c.partition {
            args.push(format!("--partition={partition}"));
        }
        if let Some(account) = &c.account {
            args.push(format!("--account={account}"));
        }
        let mut export = String::from("--export=ALL");
        for (key, value) in &self.launch.export {
            export.push_str(&format!(",{key}={value}"));
        }
        args.push(export);
        args.extend(c.sbatch_args.iter().cloned());
        args.push(self.launch.script.display().to_string());
        args.extend([
            "--coordinator".to_owned(),
            self.launch.coordinator_url.clone(),
            "--idle-timeout".to_owned(),
            c.idle_timeout_s.to_string(),
            "--stop-margin".to_owned(),
            c.stop_margin_s.to_string(),
        ]);
        if !c.worker_args.is_empty() {
            args.push("--".to_owned());
            args.extend(c.worker_args.iter().cloned());
        }
        args
    }

    /// Follows the allocations in flight, then submits or cancels as the work asks (see the
    /// module's documentation).
    pub async fn tick(&mut self) -> Result<Tick, Error> {
        let mut tick = Tick::default();
        let followed = self.follow().await?;
        let now = self.coordinator.now();
        let sample = self.coordinator.store().queue_sample(HEAD).await?;
        let durations = self.coordinator.durations().await?;
        let usable_s = self.config.usable_s();
        let cores = f64::from(self.config.cores);

        // The work: what fits in an allocation, scaled from the head of the queue to all of it.
        let expected: Vec<f64> = sample
            .head
            .iter()
            .map(|(kind, estimate)| durations.expected_s(kind, *estimate))
            .collect();
        let fitting: Vec<f64> = expected
            .iter()
            .copied()
            .filter(|&e| e <= usable_s)
            .collect();
        let scale_up = if expected.is_empty() {
            0.0
        } else {
            sample.queued as f64 / expected.len() as f64
        };
        let fitting_jobs = (fitting.len() as f64 * scale_up).round() as u64;
        let too_long = sample.queued.saturating_sub(fitting_jobs);
        let work_s = fitting.iter().sum::<f64>() * scale_up + 0.0; // an empty sum is -0

        // The supply: what the allocations in flight can still run.
        let supply_s: f64 = self
            .open
            .iter()
            .map(|a| {
                let left = match a.state {
                    AllocationState::Running => self
                        .left_s
                        .get(&a.id)
                        .map_or(usable_s, |left| left - self.config.stop_margin_s as f64),
                    _ => usable_s,
                };
                f64::from(a.cores) * left.clamp(0.0, usable_s)
            })
            .sum::<f64>()
            + 0.0; // an empty sum is -0
        let in_flight = self.open.len() as u32;

        let mut words = if sample.queued == 0 {
            String::new()
        } else {
            format!(
                "{} jobs queued ({fitting_jobs} fit an allocation, ≈ {work_s:.0} CPU-s expected) \
                 against {supply_s:.0} CPU-s left in the allocations in flight",
                sample.queued
            )
        };
        if too_long > 0 {
            if !words.is_empty() {
                words.push_str("; ");
            }
            words.push_str(&format!(
                "{too_long} queued jobs are expected to take longer than an allocation's {usable_s:.0} s \
                 (time limit less the stop margin): no allocation can run them"
            ));
        }
        let decision = if sample.queued == 0 {
            // Only what squeue just said is pending: one that started meanwhile may hold jobs.
            let pending = self
                .open
                .iter_mut()
                .filter(|a| followed.is_ok() && a.state == AllocationState::Pending);
            for allocation in pending {
                let Some(id) = allocation.external_id.clone() else {
                    continue;
                };
                match self.batch.cancel(&id).await {
                    Ok(()) => {
                        allocation.state = AllocationState::Cancelled;
                        allocation.ended_at = Some(now);
                        allocation.reason = "cancelled while pending: nothing queued".into();
                        self.coordinator
                            .store()
                            .update_allocation(allocation)
                            .await?;
                        tick.cancelled.push(id);
                    }
                    Err(error) => {
                        tracing::warn!(allocation = %id, %error, "cannot cancel a pending allocation")
                    }
                }
            }
            self.open.retain(|a| a.state.is_open());
            if tick.cancelled.is_empty() {
                "nothing queued: nothing to submit".to_owned()
            } else {
                format!(
                    "nothing queued: cancelled pending allocations {}",
                    tick.cancelled.join(", ")
                )
            }
        } else if fitting_jobs == 0 {
            "nothing queued fits an allocation: nothing to submit".to_owned()
        } else if let Err(error) = &followed {
            format!("not submitting while the allocations in flight are unknown: squeue: {error}")
        } else if let Some(retry_at) = self.state.retry_at.filter(|&at| at > now) {
            format!(
                "backing off after {} failures in a row: next submission in {:.0} s",
                self.state.failures,
                retry_at - now
            )
        } else {
            let per_allocation_s = cores * usable_s;
            let mut wanted = ((work_s - supply_s) / per_allocation_s).ceil().max(0.0) as u64;
            if in_flight == 0 {
                wanted = wanted.max(1);
            }
            // No more than the jobs keep busy: each fitting job takes at most `usable_s`, so
            // `wanted` never exceeds ⌈fitting jobs ÷ cores⌉.
            let room = u64::from(self.config.max_in_flight.saturating_sub(in_flight));
            let new = wanted.min(room);
            for _ in 0..new {
                if !self.submit(now, &mut tick).await? {
                    break;
                }
            }
            match (new, tick.refused) {
                (0, _) if room == 0 => format!(
                    "at the limit of {} allocations in flight",
                    self.config.max_in_flight
                ),
                (0, _) => "the allocations in flight cover the work".to_owned(),
                (_, 0) => format!("submitted {}", tick.submitted.join(", ")),
                _ => format!(
                    "sbatch failed ({} failures in a row): next submission in {:.0} s",
                    self.state.failures,
                    self.state.retry_at.map_or(0.0, |at| at - now)
                ),
            }
        };
        let (pending, running) = self.open.iter().fold((0, 0), |(p, r), a| match a.state {
            AllocationState::Running => (p, r + 1),
            _ => (p + 1, r),
        });
        if !words.is_empty() {
            words.push_str(". ");
        }
        tick.note = format!("{decision}. {words}In flight: {pending} pending, {running} running.");
        self.save_state(now, &tick.note).await?;
        Ok(tick)
    }

    /// Asks Slurm about the allocations in flight and records what changed. Answers whether
    /// squeue answered (the tick still goes on: an allocation's end is seen at a later tick).
    async fn follow(&mut self) -> Result<Result<(), String>, Error> {
        if self.open.is_empty() {
            return Ok(Ok(()));
        }
        let ids: Vec<String> = self
            .open
            .iter()
            .filter_map(|a| a.external_id.clone())
            .collect();
        let statuses = match self.batch.query(&ids).await {
            Ok(statuses) => statuses,
            Err(error) => {
                tracing::warn!(%error, "squeue failed");
                return Ok(Err(error));
            }
        };
        let store = self.coordinator.store().clone();
        let workers = store.allocation_workers(&ids).await?;
        let now = self.coordinator.now();
        let mut open = std::mem::take(&mut self.open);
        for allocation in &mut open {
            let Some(id) = allocation.external_id.clone() else {
                continue;
            };
            let registered = workers.get(&id).copied().unwrap_or(0);
            if registered > 0 && self.with_worker.insert(allocation.id) {
                // A worker came: submissions and allocations work again.
                self.state.failures = 0;
                self.state.retry_at = None;
            }
            let before = allocation.clone();
            match statuses.get(&id) {
                Some(status) if status.is_pending() => {
                    allocation.reason = status.reason.clone();
                }
                Some(status) if status.is_running() => {
                    if allocation.state != AllocationState::Running {
                        allocation.state = AllocationState::Running;
                        allocation.started_at = Some(match status.left_s {
                            Some(left) => now - (allocation.time_limit_s - left).max(0.0),
                            None => now,
                        });
                    }
                    allocation.reason = if registered == 0 {
                        "running; no worker registered yet".to_owned()
                    } else {
                        String::new()
                    };
                    if let Some(left) = status.left_s {
                        self.left_s.insert(allocation.id, left);
                    }
                }
                ended => self.end(allocation, ended, registered, now),
            }
            if *allocation != before {
                store.update_allocation(allocation).await?;
            }
        }
        open.retain(|a| a.state.is_open());
        self.left_s.retain(|id, _| open.iter().any(|a| a.id == *id));
        self.open = open;
        Ok(Ok(()))
    }

    /// Records the end of `allocation`: `ended` if a worker ever registered from it, else
    /// `failed` with what its output file says last (and a failure for the back-off).
    fn end(
        &mut self,
        allocation: &mut Allocation,
        status: Option<&JobStatus>,
        registered: u32,
        now: f64,
    ) {
        let how = match status {
            Some(s) if s.reason.is_empty() => s.state.clone(),
            Some(s) => format!("{} ({})", s.state, s.reason),
            None => "gone from squeue".to_owned(),
        };
        allocation.ended_at = Some(now);
        if registered > 0 || self.with_worker.contains(&allocation.id) {
            allocation.state = AllocationState::Ended;
            allocation.reason = how;
            return;
        }
        allocation.state = AllocationState::Failed;
        let id = allocation.external_id.as_deref().unwrap_or("?");
        let output = self.config.directory.join(format!("slurm-{id}.out"));
        allocation.reason = match last_line(&output) {
            Some(line) => format!(
                "ended ({how}) without starting a worker; {} says: {line}",
                output.display()
            ),
            None => format!(
                "ended ({how}) without starting a worker; nothing in {}",
                output.display()
            ),
        };
        tracing::error!(allocation = %id, reason = %allocation.reason, "allocation failed");
        self.failed(now);
    }

    /// Counts a failure and sets when the next submission may be.
    fn failed(&mut self, now: f64) {
        self.state.failures += 1;
        let pause = backoff_s(self.state.failures);
        self.state.retry_at = Some(now + pause);
    }

    /// Submits one allocation; answers whether sbatch took it.
    async fn submit(&mut self, now: f64, tick: &mut Tick) -> Result<bool, Error> {
        let mut allocation = Allocation {
            id: 0,
            manager: "slurm".to_owned(),
            external_id: None,
            state: AllocationState::Pending,
            nodes: self.config.nodes,
            cores: self.config.cores,
            time_limit_s: self.config.time_limit_s,
            submitted_at: now,
            started_at: None,
            ended_at: None,
            reason: String::new(),
        };
        let accepted = match self.batch.submit(&self.sbatch_args()).await {
            Ok(id) => {
                tracing::info!(allocation = %id, cores = self.config.cores, "allocation submitted");
                allocation.external_id = Some(id.clone());
                allocation.reason = "submitted".to_owned();
                tick.submitted.push(id);
                true
            }
            Err(error) => {
                tracing::error!(%error, "sbatch failed");
                allocation.state = AllocationState::Failed;
                allocation.ended_at = Some(now);
                allocation.reason = format!("sbatch failed: {}", one_line(&error));
                tick.refused += 1;
                self.failed(now);
                false
            }
        };
        allocation.id = self
            .coordinator
            .store()
            .insert_allocation(&allocation)
            .await?;
        if accepted {
            self.open.push(allocation);
        }
        Ok(accepted)
    }

    /// Records the allocator's state when it changed, and at least every [`STATE_EVERY_S`] (its
    /// `updated_at` tells the allocator is alive): not a write per tick.
    async fn save_state(&mut self, now: f64, note: &str) -> Result<(), Error> {
        let changed = self.state.note != note || self.saved.as_ref() != Some(&self.state);
        let due = self
            .saved
            .as_ref()
            .is_none_or(|saved| now - saved.updated_at >= STATE_EVERY_S);
        self.state.note = note.to_owned();
        if !(changed || due) {
            return Ok(());
        }
        self.state.updated_at = now;
        self.coordinator
            .store()
            .set_allocator_state(&self.state)
            .await?;
        self.saved = Some(self.state.clone());
        Ok(())
    }

    /// Ticks every `check_every_s` and whenever a submission queues jobs, until the task is
    /// aborted. A tick that fails (the store busy) is logged and the next one tries again.
    pub fn spawn(mut self) -> JoinHandle<()> {
        let every = Duration::from_secs(self.config.check_every_s);
        let woken = self.coordinator.queue_grew();
        tokio::spawn(async move {
            loop {
                match self.tick().await {
                    Ok(tick) => tracing::debug!(note = %tick.note, "allocator"),
                    Err(error) => tracing::warn!(%error, "allocator tick failed"),
                }
                tokio::select! {
                    _ = tokio::time::sleep(every) => {}
                    _ = woken.notified() => {}
                }
            }
        })
    }
}

/// What every view of the allocations shows (`sweep workers`, `sweep status`, the status page):
/// the allocator's state and the latest allocations, newest first.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Report {
    /// An allocator runs (or, read from a database, has ever run) on this coordinator.
    pub configured: bool,
    /// Failed submissions or allocations in a row, and when submitting may resume.
    pub failures: u32,
    pub retry_at: Option<f64>,
    /// The allocator's last decision, in words, and when it was taken.
    pub note: String,
    pub updated_at: Option<f64>,
    pub allocations: Vec<AllocationView>,
}

/// One allocation with what its workers did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AllocationView {
    #[serde(flatten)]
    pub allocation: Allocation,
    /// Workers that registered from it.
    pub workers: u32,
    /// Jobs its workers have done (`None` where not counted).
    pub jobs_done: Option<u64>,
}

/// How many ended allocations a report lists besides those in flight.
pub const RECENT: u32 = 50;

impl Report {
    /// The report of `store`: its allocator state and the allocations in flight and the
    /// [`RECENT`] latest; `jobs_done` maps an allocation's Slurm id to the jobs its workers did
    /// (the caller counts them: it costs a read of every done job). `configured`: whether an
    /// allocator runs; `None` reads it as "one has run on this database".
    pub async fn read(
        store: &store::Store,
        configured: Option<bool>,
        jobs_done: Option<&HashMap<String, u64>>,
    ) -> Result<Report, store::Error> {
        let allocations = store.allocations(RECENT).await?;
        let ids: Vec<String> = allocations
            .iter()
            .filter_map(|a| a.external_id.clone())
            .collect();
        let workers = store.allocation_workers(&ids).await?;
        let state = store.allocator_state().await?;
        let allocations = allocations
            .into_iter()
            .map(|allocation| {
                let id = allocation.external_id.as_deref().unwrap_or_default();
                AllocationView {
                    workers: workers.get(id).copied().unwrap_or(0),
                    jobs_done: jobs_done.map(|done| done.get(id).copied().unwrap_or(0)),
                    allocation,
                }
            })
            .collect();
        Ok(Report {
            configured: configured.unwrap_or(state.is_some()),
            failures: state.as_ref().map_or(0, |s| s.failures),
            retry_at: state.as_ref().and_then(|s| s.retry_at),
            note: state.as_ref().map(|s| s.note.clone()).unwrap_or_default(),
            updated_at: state.as_ref().map(|s| s.updated_at),
            allocations,
        })
    }

    /// Allocations by state, e.g. `1 pending, 2 running, 5 ended, 1 failed` (states with none
    /// left out; `none` when there is none).
    pub fn counts(&self) -> String {
        let states = [
            AllocationState::Pending,
            AllocationState::Running,
            AllocationState::Ended,
            AllocationState::Failed,
            AllocationState::Cancelled,
        ];
        let parts: Vec<String> = states
            .iter()
            .filter_map(|&state| {
                let n = self
                    .allocations
                    .iter()
                    .filter(|a| a.allocation.state == state)
                    .count();
                (n > 0).then(|| format!("{n} {}", state.as_str()))
            })
            .collect();
        if parts.is_empty() {
            "none".to_owned()
        } else {
            parts.join(", ")
        }
    }
}

/// The pause after `failures` failures in a row.
pub fn backoff_s(failures: u32) -> f64 {
    let doublings = failures.saturating_sub(1).min(16);
    (BACKOFF_FIRST_S * f64::from(1u32 << doublings)).min(BACKOFF_MAX_S)
}

/// The last non-empty line of a file, if it can be read.
fn last_line(path: &Path) -> Option<String> {
    let text = std::fs::read_to_string(path).ok()?;
    text.lines()
        .map(str::trim)
        .rfind(|l| !l.is_empty())
        .map(str::to_owned)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pause_doubles_up_to_an_hour() {
        assert_eq!(backoff_s(1), 60.0);
        assert_eq!(backoff_s(2), 120.0);
        assert_eq!(backoff_s(6), 1920.0);
        assert_eq!(backoff_s(7), 3600.0);
        assert_eq!(backoff_s(1000), 3600.0);
    }

    #[test]
    fn the_script_loses_only_its_exclusive_directive() {
        let script =
            "#!/bin/bash\n#SBATCH --exclusive\n#SBATCH --time=04:00:00\necho --exclusive\n";
        assert_eq!(
            without_exclusive(script),
            "#!/bin/bash\n#SBATCH --time=04:00:00\necho --exclusive\n"
        );
    }
}
