//! The distributed commands: `coordinator`, `worker`, `submit`, `status --coordinator`,
//! `cancel`, `workers`. Every one that talks to a coordinator takes `--token-file` or
//! `SWEEP_TOKEN`.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, bail};
use clap::Args;
use coordinator::autoalloc::config::AllocConfig;
use coordinator::autoalloc::slurm::Slurm;
use coordinator::autoalloc::{self, Allocator, Launch, Report};
use coordinator::grpc::{ExpandPlan, ServeOptions};
use coordinator::{Config, Coordinator, Status, SystemClock};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Certificate, Channel, ClientTlsConfig, Endpoint};
use wire::auth::WithToken;
use wire::v1 as pb;
use wire::v1::admin_client::AdminClient;
use worker::remote::Remote;
use worker::{Slots, WorkerOptions};

use crate::args::{AuthArgs, ClientArgs, HttpArgs, TlsArgs};
use crate::campaign::{from_plan, read_plan_file};
use crate::output::{Format, print_allocations, print_json, print_table};
use crate::searching;
use crate::{database, status_page, system};

/// An admin client of the coordinator `client` names, whose calls give up after `timeout`.
async fn admin(
    client: &ClientArgs,
    timeout: Duration,
) -> anyhow::Result<AdminClient<InterceptedService<Channel, WithToken>>> {
    let mut endpoint = Endpoint::from_shared(client.coordinator.clone())
        .with_context(|| format!("--coordinator {}", client.coordinator))?
        .connect_timeout(Duration::from_secs(5))
        .timeout(timeout);
    if let Some(ca) = client.ca_pem()? {
        endpoint = endpoint
            .tls_config(ClientTlsConfig::new().ca_certificate(Certificate::from_pem(ca)))?;
    }
    let channel = endpoint
        .connect()
        .await
        .with_context(|| format!("cannot reach {}", client.coordinator))?;
    Ok(AdminClient::with_interceptor(
        channel,
        WithToken::new(client.auth.token()?),
    ))
}

/// How long an admin call may take, but a submission.
const ADMIN_TIMEOUT: Duration = Duration::from_secs(60);
/// Expanding and storing a plan of a million points takes tens of seconds.
const SUBMIT_TIMEOUT: Duration = Duration::from_secs(600);

/// A refused call as one line: the server's message, not tonic's wrapping.
fn rpc_error(status: tonic::Status) -> anyhow::Error {
    match status.code() {
        tonic::Code::InvalidArgument => anyhow::anyhow!("{}", status.message()),
        tonic::Code::Unauthenticated => {
            anyhow::anyhow!("refused by the coordinator: {}", status.message())
        }
        code => anyhow::anyhow!("coordinator: {code:?}: {}", status.message()),
    }
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    Ok(tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?)
}

#[derive(Args)]
pub struct CoordinatorArgs {
    /// Address to listen on, e.g. 127.0.0.1:7070 or 0.0.0.0:7070 (the latter needs a token).
    #[arg(long)]
    listen: SocketAddr,
    #[arg(long)]
    db: PathBuf,
    #[command(flatten)]
    auth: AuthArgs,
    #[command(flatten)]
    tls: TlsArgs,
    /// Seconds a lease lasts without a heartbeat.
    #[arg(long, default_value_t = 30)]
    lease_secs: u64,
    /// Attempts (failures or lost leases) before a job is failed.
    #[arg(long, default_value_t = 3)]
    max_attempts: u32,
    #[command(flatten)]
    http: HttpArgs,
    /// Submit Slurm allocations of workers while work is queued, as this file says (TOML:
    /// time_limit, cores, nodes, max_in_flight, idle_timeout_s, partition, account, …; see
    /// deploy/README.md).
    #[arg(long, value_name = "FILE")]
    slurm_alloc: Option<PathBuf>,
}

/// deploy/slurm/sweep.sbatch, what an allocation runs unless the allocation file names a script.
const SWEEP_SBATCH: &str = include_str!("../../../deploy/slurm/sweep.sbatch");

pub fn coordinator(args: &CoordinatorArgs) -> anyhow::Result<()> {
    let token = args.auth.token()?;
    let tls = args.tls.read()?;
    if token.is_none() && !args.listen.ip().is_loopback() {
        bail!(
            "--listen {}: refusing a non-loopback address without a token (--token-file or SWEEP_TOKEN)",
            args.listen
        );
    }
    // The allocation file and Slurm's commands are checked before the database is touched.
    let allocating = match &args.slurm_alloc {
        Some(file) => {
            let config = AllocConfig::read(file).context("--slurm-alloc")?;
            let slurm = Slurm::default();
            let missing = slurm.missing();
            if !missing.is_empty() {
                bail!(
                    "--slurm-alloc {}: cannot find {} on PATH (is this a Slurm submit host?)",
                    file.display(),
                    missing.join(", ")
                );
            }
            let script = autoalloc::write_script(&config, SWEEP_SBATCH).with_context(|| {
                format!(
                    "--slurm-alloc {}: cannot write the allocations' script into {}",
                    file.display(),
                    config.directory.display()
                )
            })?;
            Some((config, slurm, script))
        }
        None => None,
    };
    let expand: ExpandPlan = Arc::new(|text: &str, file: &str, dir: &str| {
        from_plan(
            text,
            file,
            (!dir.is_empty()).then_some(std::path::Path::new(dir)),
        )
        .map(|c| (c.campaign, c.jobs))
        .map_err(|e| e.to_string())
    });
    runtime()?.block_on(async {
        let store = database::open(&args.db).await?;
        let config = Config {
            lease_for: Duration::from_secs(args.lease_secs.max(1)),
            max_attempts: args.max_attempts,
            ..Config::default()
        };
        let coordinator = Coordinator::new(store, config, Arc::new(SystemClock))?;
        let listener = tokio::net::TcpListener::bind(args.listen)
            .await
            .with_context(|| format!("--listen {}", args.listen))?;
        // The bound address (port 0 picks a free one) on stdout: scripts and tests read it.
        println!("listening on {}", listener.local_addr()?);
        let allocator = match allocating {
            Some((config, slurm, script)) => {
                let bound = listener.local_addr()?;
                let launch = Launch {
                    script,
                    coordinator_url: config
                        .coordinator_url
                        .clone()
                        .unwrap_or_else(|| default_url(bound, tls.is_some())),
                    export: allocation_env(&config, &args.auth)?,
                };
                tracing::info!(url = %launch.coordinator_url, directory = %config.directory.display(), "allocating Slurm workers");
                let allocator = Allocator::new(config, launch, coordinator.clone(), slurm).await?;
                Some(allocator.spawn())
            }
            None => None,
        };
        let searches = tokio::spawn(searching::drive(coordinator.clone()));
        let page = status_page::start(&args.http, &coordinator, token.clone(), tls.clone()).await?;
        if let Some((_, url)) = &page {
            println!("status page on {url}");
        }
        let options = ServeOptions {
            listen: args.listen,
            token,
            tls,
        };
        let served = coordinator::grpc::serve(
            coordinator.clone(),
            expand,
            options,
            listener,
            shutdown_signal(),
        )
        .await;
        searches.abort();
        if let Some((task, _)) = page {
            task.abort();
        }
        if let Some(task) = allocator {
            // Allocations in flight keep running; their workers end them (idle timeout,
            // deadline), and a coordinator started again on this database follows them.
            task.abort();
        }
        served?;
        let writes = coordinator.store().write_groups();
        tracing::info!(
            transactions = writes.transactions,
            writes = writes.writes,
            abandoned = writes.abandoned,
            "database writes since start (group commit)"
        );
        coordinator.store().close().await;
        anyhow::Ok(())
    })
}

/// How the nodes reach a coordinator bound to `bound` when the allocation file does not say:
/// this host's name for a wildcard address, the address itself otherwise.
fn default_url(bound: SocketAddr, tls: bool) -> String {
    let scheme = if tls { "https" } else { "http" };
    let host = if bound.ip().is_unspecified() {
        worker::provenance::hostname()
    } else {
        match bound {
            SocketAddr::V4(v4) => v4.ip().to_string(),
            SocketAddr::V6(v6) => format!("[{}]", v6.ip()),
        }
    };
    format!("{scheme}://{host}:{}", bound.port())
}

/// What an allocation's script needs besides the submitting environment: the binary, and the
/// token file (a token from SWEEP_TOKEN reaches it through the environment itself).
fn allocation_env(config: &AllocConfig, auth: &AuthArgs) -> anyhow::Result<Vec<(String, String)>> {
    let sweep = match &config.sweep {
        Some(sweep) => sweep.clone(),
        None => std::env::current_exe().context("cannot tell where this sweep binary is")?,
    };
    let mut export = vec![("SWEEP".to_owned(), sweep.display().to_string())];
    if let Some(file) = auth.token_file() {
        let file = std::path::absolute(file)
            .with_context(|| format!("--token-file {}", file.display()))?;
        export.push(("SWEEP_TOKEN_FILE".to_owned(), file.display().to_string()));
    }
    Ok(export)
}

/// SIGINT or SIGTERM.
async fn shutdown_signal() {
    let mut term = match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
        Ok(term) => term,
        Err(error) => {
            tracing::warn!(%error, "cannot listen for SIGTERM; only Ctrl-C stops this process");
            let _ = tokio::signal::ctrl_c().await;
            return;
        }
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term.recv() => {}
    }
}

#[derive(Args)]
pub struct WorkerArgs {
    #[command(flatten)]
    client: ClientArgs,
    /// Cores to run on, e.g. `0,1` or `0-3` (default: every core available to this process).
    #[arg(long, value_parser = system::parse_core_list)]
    cores: Option<system::CoreList>,
    /// Run on the first N cores available to this process, for a scheduler that gives a count
    /// (Slurm's SLURM_CPUS_ON_NODE, a Kubernetes CPU limit) rather than a list.
    #[arg(
        long,
        value_name = "N",
        conflicts_with = "cores",
        value_parser = clap::value_parser!(u32).range(1..)
    )]
    core_count: Option<u32>,
    /// Jobs leased per call, instead of as many as fit 100 ms of the observed run time (one at a
    /// time for long jobs, up to 512 for short ones).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    lease_batch: Option<u32>,
    /// Unix time by which every job must be done (an allocation's end less a margin): only jobs
    /// expected to finish by then are leased; the worker stops then, or as soon as nothing
    /// queued fits in what is left.
    #[arg(long, value_name = "UNIX_SECONDS")]
    deadline: Option<f64>,
    /// Stop after this many seconds without a job (the coordinator has nothing queued), or
    /// without reaching the coordinator at the start.
    #[arg(long, value_name = "SECONDS", value_parser = clap::value_parser!(u64).range(1..))]
    idle_timeout: Option<u64>,
    /// The batch system's id of the allocation this worker runs in, shown with the allocation.
    #[arg(long, value_name = "ID", env = "SLURM_JOB_ID")]
    allocation: Option<String>,
    /// Run program jobs (`[[command]]`: foreign code). Without it the coordinator never leases
    /// this worker one, so a leaked token does not become code execution on every worker.
    #[arg(long)]
    allow_commands: bool,
}

pub fn worker(args: &WorkerArgs) -> anyhow::Result<()> {
    let cores = match args.core_count {
        Some(count) => system::first_cores(&system::available_cores()?, count as usize)?,
        None => system::cores_or_all(&args.cores)?,
    };
    system::start_thread_pool()?;
    let runtime = runtime()?;
    if let Some(deadline) = args.deadline
        && !deadline.is_finite()
    {
        bail!("--deadline {deadline}: not a time");
    }
    let worker_id = format!("{}:{}", worker::provenance::hostname(), std::process::id());
    let info = worker::WorkerInfo {
        allocation: args.allocation.clone().filter(|a| !a.is_empty()),
        allow_commands: args.allow_commands,
        ..worker::provenance::worker_info(worker_id.clone(), &cores)
    };
    let idle_timeout = args.idle_timeout.map(Duration::from_secs);
    let remote = {
        let _guard = runtime.enter();
        Remote::new(
            &args.client.coordinator,
            args.client.auth.token()?,
            args.client.ca_pem()?,
            worker_id,
        )?
    };
    // Register with backoff: a worker may start before its coordinator. One with an idle
    // timeout gives up after it (an allocation that cannot reach its coordinator ends, saying
    // why, instead of idling to its time limit).
    let lease_for = runtime.block_on(async {
        let mut wait = Duration::from_millis(100);
        let started = std::time::Instant::now();
        loop {
            match remote.register(&info).await {
                Ok(lease_for) => return anyhow::Ok(lease_for),
                Err(error @ worker::QueueError::Refused(_)) => bail!("{error}"),
                Err(error) if idle_timeout.is_some_and(|t| started.elapsed() >= t) => bail!(
                    "cannot register with {} within the idle timeout: {error}",
                    args.client.coordinator
                ),
                Err(error) => {
                    tracing::warn!(%error, "coordinator not reachable; retrying");
                    tokio::time::sleep(wait).await;
                    wait = (wait * 2).min(Duration::from_secs(5));
                }
            }
        }
    })?;
    let options = WorkerOptions {
        cores,
        heartbeat_every: (lease_for / 4).max(Duration::from_millis(100)),
        idle_poll: Duration::from_millis(200),
        lease_batch: args.lease_batch,
        lease_for,
        deadline: args.deadline,
        idle_timeout,
        child_exe: Some(
            std::env::current_exe()
                .context("cannot find the sweep executable to run plugin points in")?,
        ),
    };
    let slots = Slots::start(Arc::new(remote), options, runtime.handle().clone())?;
    let halted = runtime.block_on(async {
        tokio::select! {
            _ = shutdown_signal() => None,
            reason = slots.halted() => Some(reason),
            reason = slots.finished() => {
                // Printed on stderr whatever RUST_LOG says: an allocation's output tells why it ended.
                eprintln!("sweep worker: stopping: {reason}");
                None
            }
        }
    });
    tracing::info!("stopping: finishing the jobs in hand, returning the rest");
    slots.stop();
    slots.join();
    match halted {
        Some(reason) => bail!("the worker stopped: {reason}"),
        None => Ok(()),
    }
}

#[derive(Args)]
pub struct SubmitArgs {
    plan: PathBuf,
    #[command(flatten)]
    client: ClientArgs,
}

pub fn submit(args: &SubmitArgs, format: Format) -> anyhow::Result<()> {
    let (text, name) = read_plan_file(&args.plan)?;
    let response = runtime()?.block_on(async {
        let mut admin = admin(&args.client, SUBMIT_TIMEOUT).await?;
        let request = pb::SubmitRequest {
            plan_toml: text,
            file_name: name,
            plan_dir: plan_dir(&args.plan)?,
        };
        anyhow::Ok(admin.submit(request).await.map_err(rpc_error)?.into_inner())
    })?;
    match format {
        Format::Json => print_json(&serde_json::json!({
            "campaign": response.campaign_id,
            "new_jobs": response.new_jobs,
            "already_known": response.already_known,
        })),
        _ => {
            println!("{}", response.campaign_id);
            eprintln!(
                "{} new points, {} already known",
                response.new_jobs, response.already_known
            );
            Ok(())
        }
    }
}

/// A campaign's counts (or the whole store's) as the coordinator `client` names has them.
pub fn status(client: &ClientArgs, campaign: Option<&str>) -> anyhow::Result<Status> {
    let s = runtime()?.block_on(async {
        let mut admin = admin(client, ADMIN_TIMEOUT).await?;
        let request = pb::StatusRequest {
            campaign_id: campaign.unwrap_or_default().to_string(),
        };
        anyhow::Ok(admin.status(request).await.map_err(rpc_error)?.into_inner())
    })?;
    Ok(coordinator::grpc::convert::status_from_wire(&s))
}

/// The allocations of the coordinator `client` names (with the jobs each did if `jobs_done`:
/// that reads every done job); `None` from a coordinator too old to tell.
pub fn allocations(client: &ClientArgs, jobs_done: bool) -> anyhow::Result<Option<Report>> {
    let response = runtime()?.block_on(async {
        let mut admin = admin(client, ADMIN_TIMEOUT).await?;
        match admin
            .allocations(pb::AllocationsRequest { jobs_done })
            .await
        {
            Ok(response) => anyhow::Ok(Some(response.into_inner())),
            Err(status) if status.code() == tonic::Code::Unimplemented => Ok(None),
            Err(status) => Err(rpc_error(status)),
        }
    })?;
    response
        .map(|r| {
            coordinator::grpc::convert::allocations_from_wire(&r)
                .map_err(|e| anyhow::anyhow!("coordinator: {e}"))
        })
        .transpose()
}

#[derive(Args)]
pub struct CancelArgs {
    campaign: String,
    #[command(flatten)]
    client: ClientArgs,
}

pub fn cancel(args: &CancelArgs, format: Format) -> anyhow::Result<()> {
    let cancelled = runtime()?.block_on(async {
        let mut admin = admin(&args.client, ADMIN_TIMEOUT).await?;
        let request = pb::CancelRequest {
            campaign_id: args.campaign.clone(),
        };
        anyhow::Ok(
            admin
                .cancel(request)
                .await
                .map_err(rpc_error)?
                .into_inner()
                .cancelled,
        )
    })?;
    match format {
        Format::Json => {
            print_json(&serde_json::json!({ "campaign": args.campaign, "cancelled": cancelled }))
        }
        _ => {
            println!("cancelled {cancelled} queued points of {}", args.campaign);
            Ok(())
        }
    }
}

#[derive(Args)]
pub struct WorkersArgs {
    #[command(flatten)]
    client: ClientArgs,
}

pub fn workers(args: &WorkersArgs, format: Format) -> anyhow::Result<()> {
    let workers = runtime()?.block_on(async {
        let mut admin = admin(&args.client, ADMIN_TIMEOUT).await?;
        anyhow::Ok(
            admin
                .workers(pb::WorkersRequest {})
                .await
                .map_err(rpc_error)?
                .into_inner()
                .workers,
        )
    })?;
    let rows: Vec<serde_json::Value> = workers
        .iter()
        .map(|e| {
            let w = e.worker.clone().unwrap_or_default();
            serde_json::json!({
                "id": w.id, "hostname": w.hostname, "cores": w.cores, "cpu_model": w.cpu_model,
                "git_commit": w.git_commit, "running": e.running, "last_seen_at": e.last_seen_at,
                "allocation": (!w.allocation.is_empty()).then_some(&w.allocation),
            })
        })
        .collect();
    match format {
        Format::Json => print_json(&rows),
        _ => {
            let table: Vec<Vec<String>> = workers
                .iter()
                .map(|e| {
                    let w = e.worker.clone().unwrap_or_default();
                    let cores: Vec<String> = w.cores.iter().map(u32::to_string).collect();
                    vec![
                        w.id,
                        cores.join(","),
                        e.running.to_string(),
                        if w.allocation.is_empty() {
                            "-".to_owned()
                        } else {
                            w.allocation
                        },
                        w.cpu_model,
                        w.git_commit,
                    ]
                })
                .collect();
            print_table(
                &["worker", "cores", "running", "allocation", "cpu", "commit"],
                &table,
            );
            if let Some(report) = allocations(&args.client, true)?
                && (report.configured || !report.allocations.is_empty())
            {
                println!();
                print_allocations(&report);
                if !report.note.is_empty() {
                    println!("allocator: {}", report.note);
                }
            }
            Ok(())
        }
    }
}

/// The plan file's folder, absolute: the coordinator resolves the plan's program paths in it.
fn plan_dir(plan: &std::path::Path) -> anyhow::Result<String> {
    let dir = plan
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let dir = dir
        .canonicalize()
        .with_context(|| format!("cannot resolve the folder of {}", plan.display()))?;
    Ok(dir.display().to_string())
}
