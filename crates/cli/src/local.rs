//! `sweep run PLAN.toml`: local mode. The coordinator embedded in this process schedules the
//! plan's points to one worker slot per core; the database makes the run resumable.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use coordinator::{Config, Coordinator, Embedded, SystemClock};
use indicatif::{ProgressBar, ProgressStyle};
use worker::{Slots, WorkerOptions};

use crate::args::{AuthArgs, HttpArgs, TlsArgs};
use crate::campaign::{from_plan, read_plan_file};
use crate::output::{Format, print_json, print_status};
use crate::{database, searching, status_page, system};

#[derive(Args)]
pub struct RunArgs {
    plan: PathBuf,
    /// The result database (created if missing).
    #[arg(long, default_value = "sweep.db")]
    db: PathBuf,
    /// Cores to run on, e.g. `0,1` or `0-3` (default: every core available to this process).
    #[arg(long, value_parser = system::parse_core_list)]
    cores: Option<system::CoreList>,
    #[command(flatten)]
    http: HttpArgs,
    /// The token the status page asks for (off loopback, and to cancel).
    #[command(flatten)]
    auth: AuthArgs,
    /// The status page's certificate: with it, the page is served over HTTPS.
    #[command(flatten)]
    tls: TlsArgs,
}

/// Local leases are short: after a crash, a resumed run waits at most this long for the jobs
/// that were running.
const LOCAL_LEASE: Duration = Duration::from_secs(10);

pub fn run(args: &RunArgs, format: Format) -> anyhow::Result<()> {
    if args.tls.tls_cert.is_some() && args.http.http.is_none() {
        anyhow::bail!("--tls-cert: the certificate is the status page's; give --http ADDR too");
    }
    let (text, name) = read_plan_file(&args.plan)?;
    let campaign = from_plan(&text, &name, None)?;
    let cores = system::cores_or_all(&args.cores)?;
    system::start_thread_pool()?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let coordinator = runtime.block_on(async {
        let store = database::open(&args.db).await?;
        let config = Config {
            lease_for: LOCAL_LEASE,
            max_attempts: 3,
            ..Config::default()
        };
        anyhow::Ok(Coordinator::new(store, config, Arc::new(SystemClock))?)
    })?;
    let submitted = runtime.block_on(coordinator.submit(&campaign.campaign, &campaign.jobs))?;
    tracing::info!(
        campaign = %submitted.campaign_id,
        new = submitted.new_jobs,
        known = submitted.already_known,
        "submitted"
    );

    let prefix = format!("local:{}:", worker::provenance::hostname());
    let worker_id = format!("{prefix}{}", std::process::id());
    // An earlier local run on this host whose process is gone cannot finish its jobs: take them
    // back now rather than after its leases expire.
    runtime.block_on(async {
        for w in coordinator.store().workers().await? {
            let pid = w
                .info
                .id
                .strip_prefix(&prefix)
                .and_then(|p| p.parse::<u32>().ok());
            if w.running > 0 && pid.is_some_and(|pid| !system::process_alive(pid)) {
                let reclaimed = coordinator.reclaim(&w.info.id).await?;
                tracing::info!(
                    worker = %w.info.id,
                    reclaimed,
                    "took back the jobs of a dead local run"
                );
            }
        }
        anyhow::Ok(())
    })?;
    // Local mode runs what the user's own plan asks for, program jobs included.
    let info = worker::WorkerInfo {
        allow_commands: true,
        ..worker::provenance::worker_info(worker_id.clone(), &cores)
    };
    runtime.block_on(coordinator.register(&info))?;
    let reaper = {
        let _guard = runtime.enter();
        coordinator.spawn_reaper(Duration::from_secs(1))
    };
    let page = runtime.block_on(async {
        status_page::start(
            &args.http,
            &coordinator,
            args.auth.token()?,
            args.tls.read()?,
        )
        .await
    })?;
    if let Some((_, url)) = &page {
        eprintln!("status page on {url}");
    }
    let queue = Arc::new(Embedded {
        coordinator: coordinator.clone(),
        worker_id,
    });
    let options = WorkerOptions {
        cores,
        heartbeat_every: LOCAL_LEASE / 4,
        idle_poll: Duration::from_millis(50),
        lease_batch: None,
        lease_for: LOCAL_LEASE,
        deadline: None,
        idle_timeout: None,
        child_exe: Some(
            std::env::current_exe()
                .context("cannot find the sweep executable to run plugin points in")?,
        ),
    };
    let slots = Slots::start(queue, options, runtime.handle().clone())?;

    let bar = if format == Format::Json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(campaign.jobs.len() as u64)
    };
    bar.set_style(ProgressStyle::with_template(
        "{msg} [{bar:30}] {pos}/{len} points, {elapsed} elapsed, ETA {eta}",
    )?);
    bar.set_message(campaign.plan.name.clone());
    let id = submitted.campaign_id.clone();
    let mut halted = None;
    let searches = &campaign.plan.tunes;
    // The searches' step is taken afresh whenever a job has finished (and at the start).
    let mut finished_before = None;
    let mut searching = !searches.is_empty();
    let interrupted = runtime.block_on(async {
        let mut ticker = tokio::time::interval(Duration::from_millis(200));
        loop {
            tokio::select! {
                _ = tokio::signal::ctrl_c() => return Ok::<_, anyhow::Error>(true),
                reason = slots.halted() => {
                    halted = Some(reason);
                    return Ok(false);
                }
                _ = ticker.tick() => {
                    let status = coordinator.status(Some(&id)).await?;
                    let finished = status.done + status.failed + status.cancelled;
                    bar.set_position(finished);
                    if searching && finished_before != Some(finished) {
                        finished_before = Some(finished);
                        let issued = searching::step(&coordinator, &campaign.campaign, searches).await?;
                        if issued.new_jobs > 0 {
                            bar.inc_length(issued.new_jobs);
                            continue;
                        }
                        searching = !issued.all_done;
                        if searching && status.queued == 0 && status.running == 0 {
                            anyhow::bail!(
                                "[[tune]]: a search waits for evaluations that are neither queued nor running"
                            );
                        }
                    }
                    if status.queued == 0 && status.running == 0 && !searching {
                        return Ok(false);
                    }
                }
            }
        }
    })?;
    if interrupted {
        bar.suspend(|| {
            eprintln!("interrupted: finishing the jobs in hand, then stopping (rerun to resume)")
        });
    }
    slots.stop();
    slots.join();
    reaper.abort();
    if let Some((task, _)) = page {
        task.abort();
    }
    bar.finish_and_clear();
    let status = runtime.block_on(coordinator.status(Some(&id)))?;
    let quality = runtime.block_on(results::overlap_quality(coordinator.store(), Some(&id)))?;
    let shifts: Vec<_> = runtime
        .block_on(results::machine_history(coordinator.store()))?
        .into_iter()
        .filter(|s| s.campaign == id)
        .collect();
    let concluded = runtime.block_on(tune::drive::steps(coordinator.store(), searches))?;
    runtime.block_on(coordinator.store().close());
    match format {
        Format::Json => print_json(&serde_json::json!({
            "campaign": id,
            "new_jobs": submitted.new_jobs,
            "requeued": submitted.requeued,
            "already_known": submitted.already_known,
            "status": status,
            "timing": quality,
            "machine_history": shifts,
            "searches": concluded.iter().map(|s| s.step.clone()).filter_map(|step| match step {
                tune::Step::Done(c) => Some(c),
                _ => None,
            }).collect::<Vec<_>>(),
        }))?,
        _ => {
            println!(
                "{} new points, {} already known",
                submitted.new_jobs, submitted.already_known
            );
            print_status(&id, &status, Some((&quality, &shifts)), None, format)?;
            if !concluded.is_empty() {
                println!("{}", tune_summary(&concluded, &args.db));
            }
        }
    }
    if let Some(reason) = halted {
        anyhow::bail!(
            "the worker stopped ({reason}) with {} of {} points left",
            status.queued + status.running,
            status.total
        );
    }
    if interrupted {
        anyhow::bail!(
            "interrupted with {} of {} points left",
            status.queued + status.running,
            status.total
        );
    }
    if status.failed > 0 {
        anyhow::bail!(
            "{} points failed: see `sweep status --db {}`",
            status.failed,
            args.db.display()
        );
    }
    Ok(())
}

/// One line on the searches at the end of a run.
fn tune_summary(steps: &[tune::drive::SearchStep], db: &std::path::Path) -> String {
    let mut by_reason: std::collections::BTreeMap<&str, usize> = Default::default();
    for s in steps {
        let reason = match &s.step {
            tune::Step::Done(c) => c.stopped.as_str(),
            _ => "unfinished",
        };
        *by_reason.entry(reason).or_default() += 1;
    }
    let counts: Vec<String> = by_reason.iter().map(|(r, n)| format!("{n} {r}")).collect();
    format!(
        "tune: {} searches ({}); the values found: sweep report tune --db {}",
        steps.len(),
        counts.join(", "),
        db.display()
    )
}
