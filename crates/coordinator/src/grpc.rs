//! The gRPC face of the [`Coordinator`]: the `sweep.v1` Worker and Admin services. Each call is
//! one coordinator operation, hence one write of a committed SQLite transaction (shared with the
//! calls that arrived with it: group commit, in the store), before it is answered.
//! What a plan means is not known here: the application injects an [`ExpandPlan`] function.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use tonic::transport::{Identity, Server, ServerTlsConfig};
use tonic::{Request, Response, Status};
use wire::auth::{RequireToken, Token};
use wire::v1 as pb;
use wire::v1::admin_server::{Admin, AdminServer};
use wire::v1::worker_server::{Worker, WorkerServer};

use wire::convert::{complete_outcome_to_wire, fail_outcome_to_wire};

use crate::autoalloc::Report;
use crate::{Completion, Coordinator, Error, LeaseRef, NewCampaign, NewJob};

/// Plan text, file name and the plan's folder on the submitter's machine (empty: the file
/// name's) → the campaign and its jobs, or the one-line error a user sees.
pub type ExpandPlan =
    Arc<dyn Fn(&str, &str, &str) -> Result<(NewCampaign, Vec<NewJob>), String> + Send + Sync>;

#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error(
        "refusing to listen on {0} without a token: set --token-file or SWEEP_TOKEN, or listen on loopback"
    )]
    NoTokenOffLoopback(SocketAddr),
    #[error("TLS: {0}")]
    Tls(String),
    #[error("serving: {0}")]
    Transport(#[from] tonic::transport::Error),
}

/// The status code tells a worker whether to retry: `internal` may pass, the others will recur.
fn status(error: Error) -> Status {
    use store::Error as E;
    match &error {
        Error::Store(
            E::InvalidRecord { .. }
            | E::DuplicateCompletion(_)
            | E::InvalidParams { .. }
            | E::InvalidEstimate { .. }
            | E::JobConflict { .. }
            | E::WorkerConflict { .. }
            | E::NotAQuery(_),
        ) => Status::invalid_argument(error.to_string()),
        Error::Store(E::UnknownWorker(_) | E::UnknownJob(_) | E::UnknownCampaign(_)) => {
            Status::not_found(error.to_string())
        }
        Error::Store(E::ReadOnly) => Status::failed_precondition(error.to_string()),
        _ => {
            tracing::error!(%error, "coordinator operation failed");
            Status::internal(error.to_string())
        }
    }
}

/// Conversions of the admin messages, used by both ends (the queue contract's are in
/// [`wire::convert`]).
pub mod convert {
    use super::pb;
    use crate::Status;
    use crate::autoalloc::{AllocationView, Report};
    use store::{Allocation, AllocationState};

    pub fn status_to_wire(s: &Status) -> pb::StatusResponse {
        pb::StatusResponse {
            total: s.total,
            queued: s.queued,
            running: s.running,
            done: s.done,
            failed: s.failed,
            cancelled: s.cancelled,
            estimate_s_remaining: s.estimate_s_remaining,
        }
    }

    pub fn allocations_to_wire(report: &Report) -> pb::AllocationsResponse {
        pb::AllocationsResponse {
            configured: report.configured,
            failures: report.failures,
            retry_at: report.retry_at.unwrap_or(0.0),
            note: report.note.clone(),
            updated_at: report.updated_at.unwrap_or(0.0),
            allocations: report
                .allocations
                .iter()
                .map(|view| {
                    let a = &view.allocation;
                    pb::allocations_response::Allocation {
                        id: a.id,
                        manager: a.manager.clone(),
                        external_id: a.external_id.clone().unwrap_or_default(),
                        state: a.state.as_str().to_owned(),
                        nodes: a.nodes,
                        cores: a.cores,
                        time_limit_s: a.time_limit_s,
                        submitted_at: a.submitted_at,
                        started_at: a.started_at,
                        ended_at: a.ended_at,
                        reason: a.reason.clone(),
                        workers: view.workers,
                        jobs_done: view.jobs_done,
                    }
                })
                .collect(),
        }
    }

    /// The report as sent; an allocation in a state this side does not know is an error of the
    /// peer, named.
    pub fn allocations_from_wire(r: &pb::AllocationsResponse) -> Result<Report, String> {
        let allocations = r
            .allocations
            .iter()
            .map(|a| {
                let state = AllocationState::parse(&a.state).ok_or_else(|| {
                    format!("allocation {} has an unknown state {:?}", a.id, a.state)
                })?;
                Ok(AllocationView {
                    allocation: Allocation {
                        id: a.id,
                        manager: a.manager.clone(),
                        external_id: (!a.external_id.is_empty()).then(|| a.external_id.clone()),
                        state,
                        nodes: a.nodes,
                        cores: a.cores,
                        time_limit_s: a.time_limit_s,
                        submitted_at: a.submitted_at,
                        started_at: a.started_at,
                        ended_at: a.ended_at,
                        reason: a.reason.clone(),
                    },
                    workers: a.workers,
                    jobs_done: a.jobs_done,
                })
            })
            .collect::<Result<_, String>>()?;
        Ok(Report {
            configured: r.configured,
            failures: r.failures,
            retry_at: (r.retry_at > 0.0).then_some(r.retry_at),
            note: r.note.clone(),
            updated_at: (r.updated_at > 0.0).then_some(r.updated_at),
            allocations,
        })
    }

    pub fn status_from_wire(s: &pb::StatusResponse) -> Status {
        Status {
            total: s.total,
            queued: s.queued,
            running: s.running,
            done: s.done,
            failed: s.failed,
            cancelled: s.cancelled,
            estimate_s_remaining: s.estimate_s_remaining,
        }
    }
}

#[derive(Clone)]
struct Services {
    coordinator: Coordinator,
    expand: ExpandPlan,
}

#[tonic::async_trait]
impl Worker for Services {
    async fn register(
        &self,
        request: Request<pb::RegisterRequest>,
    ) -> Result<Response<pb::RegisterResponse>, Status> {
        let w = request
            .into_inner()
            .worker
            .ok_or_else(|| Status::invalid_argument("register: no worker"))?;
        if w.id.is_empty() {
            return Err(Status::invalid_argument("register: empty worker id"));
        }
        self.coordinator.register(&w.into()).await.map_err(status)?;
        let lease_ms = self.coordinator.config().lease_for.as_millis() as u64;
        Ok(Response::new(pb::RegisterResponse {
            heartbeat_interval_ms: lease_ms / 4,
            lease_ms,
        }))
    }

    async fn lease(
        &self,
        request: Request<pb::LeaseRequest>,
    ) -> Result<Response<pb::LeaseResponse>, Status> {
        let r = request.into_inner();
        let granted = self
            .coordinator
            .lease_within(&r.worker_id, r.max_jobs, true, r.seconds_left)
            .await
            .map_err(status)?;
        Ok(Response::new(pb::LeaseResponse {
            leases: granted.leases.into_iter().map(Into::into).collect(),
            passed_over: granted.passed_over,
        }))
    }

    async fn heartbeat(
        &self,
        request: Request<pb::HeartbeatRequest>,
    ) -> Result<Response<pb::HeartbeatResponse>, Status> {
        let r = request.into_inner();
        let held: Vec<LeaseRef> = r.leases.into_iter().map(Into::into).collect();
        let valid = self
            .coordinator
            .heartbeat(&r.worker_id, &held)
            .await
            .map_err(status)?;
        let lost = held
            .iter()
            .filter(|l| !valid.contains(l))
            .map(Into::into)
            .collect();
        Ok(Response::new(pb::HeartbeatResponse { lost }))
    }

    async fn complete(
        &self,
        request: Request<pb::CompleteRequest>,
    ) -> Result<Response<pb::CompleteResponse>, Status> {
        let r = request.into_inner();
        let completions: Vec<Completion> = r.completions.into_iter().map(Into::into).collect();
        let outcomes = self
            .coordinator
            .complete_batch(&r.worker_id, &completions)
            .await
            .map_err(status)?;
        let outcomes = outcomes
            .into_iter()
            .map(|o| complete_outcome_to_wire(o) as i32)
            .collect();
        Ok(Response::new(pb::CompleteResponse { outcomes }))
    }

    async fn fail(
        &self,
        request: Request<pb::FailRequest>,
    ) -> Result<Response<pb::FailResponse>, Status> {
        let r = request.into_inner();
        let outcome = self
            .coordinator
            .fail(&r.worker_id, &r.job_id, r.token, &r.error)
            .await
            .map_err(status)?;
        Ok(Response::new(pb::FailResponse {
            outcome: fail_outcome_to_wire(outcome) as i32,
        }))
    }

    async fn release(
        &self,
        request: Request<pb::ReleaseRequest>,
    ) -> Result<Response<pb::ReleaseResponse>, Status> {
        let r = request.into_inner();
        let held: Vec<LeaseRef> = r.leases.into_iter().map(Into::into).collect();
        self.coordinator
            .release(&r.worker_id, &held)
            .await
            .map_err(status)?;
        Ok(Response::new(pb::ReleaseResponse {}))
    }
}

#[tonic::async_trait]
impl Admin for Services {
    async fn submit(
        &self,
        request: Request<pb::SubmitRequest>,
    ) -> Result<Response<pb::SubmitResponse>, Status> {
        let r = request.into_inner();
        // A bad plan is refused before anything is written, with the message `sweep run` gives.
        let (campaign, jobs) = (self.expand)(&r.plan_toml, &r.file_name, &r.plan_dir)
            .map_err(Status::invalid_argument)?;
        let outcome = self
            .coordinator
            .submit(&campaign, &jobs)
            .await
            .map_err(status)?;
        Ok(Response::new(pb::SubmitResponse {
            campaign_id: outcome.campaign_id,
            new_jobs: outcome.new_jobs + outcome.requeued,
            already_known: outcome.already_known,
        }))
    }

    async fn status(
        &self,
        request: Request<pb::StatusRequest>,
    ) -> Result<Response<pb::StatusResponse>, Status> {
        let campaign = request.into_inner().campaign_id;
        let campaign = (!campaign.is_empty()).then_some(campaign);
        let s = self
            .coordinator
            .status(campaign.as_deref())
            .await
            .map_err(status)?;
        Ok(Response::new(convert::status_to_wire(&s)))
    }

    async fn cancel(
        &self,
        request: Request<pb::CancelRequest>,
    ) -> Result<Response<pb::CancelResponse>, Status> {
        let cancelled = self
            .coordinator
            .cancel(&request.into_inner().campaign_id)
            .await
            .map_err(status)?;
        Ok(Response::new(pb::CancelResponse { cancelled }))
    }

    async fn workers(
        &self,
        _: Request<pb::WorkersRequest>,
    ) -> Result<Response<pb::WorkersResponse>, Status> {
        let workers = self
            .coordinator
            .store()
            .workers()
            .await
            .map_err(|e| status(e.into()))?;
        let workers = workers
            .into_iter()
            .map(|w| pb::workers_response::Entry {
                worker: Some(w.info.into()),
                last_seen_at: w.last_seen_at,
                running: w.running,
            })
            .collect();
        Ok(Response::new(pb::WorkersResponse { workers }))
    }

    async fn allocations(
        &self,
        request: Request<pb::AllocationsRequest>,
    ) -> Result<Response<pb::AllocationsResponse>, Status> {
        let store = self.coordinator.store();
        let fail = |e: store::Error| status(e.into());
        let done = match request.into_inner().jobs_done {
            true => Some(store.allocation_jobs_done().await.map_err(fail)?),
            false => None,
        };
        let report = Report::read(store, Some(self.coordinator.allocating()), done.as_ref())
            .await
            .map_err(fail)?;
        Ok(Response::new(convert::allocations_to_wire(&report)))
    }
}

/// Where and how to listen.
pub struct ServeOptions {
    pub listen: SocketAddr,
    pub token: Option<Token>,
    /// PEM certificate chain and key: serve TLS.
    pub tls: Option<(Vec<u8>, Vec<u8>)>,
}

/// Serves both services until `shutdown` resolves, reaping expired leases meanwhile. A
/// non-loopback address without a token is refused: anyone on the network could submit work.
pub async fn serve(
    coordinator: Coordinator,
    expand: ExpandPlan,
    options: ServeOptions,
    listener: tokio::net::TcpListener,
    shutdown: impl std::future::Future<Output = ()> + Send,
) -> Result<(), ServeError> {
    if options.token.is_none() && !options.listen.ip().is_loopback() {
        return Err(ServeError::NoTokenOffLoopback(options.listen));
    }
    let reaper =
        coordinator.spawn_reaper(Duration::from_secs(1).min(coordinator.config().lease_for / 4));
    let services = Services {
        coordinator,
        expand,
    };
    let auth = RequireToken::new(options.token);
    // Workers' calls carry their own 10 s deadline; this bounds the others. Submitting a plan of
    // a million points takes tens of seconds.
    let mut server = Server::builder().timeout(Duration::from_secs(600));
    if let Some((cert, key)) = options.tls {
        server = server
            .tls_config(ServerTlsConfig::new().identity(Identity::from_pem(cert, key)))
            .map_err(|e| ServeError::Tls(e.to_string()))?;
    }
    // Without TCP_NODELAY on the accepted sockets, Nagle's algorithm and delayed ACKs add ~40 ms
    // to every small response (the builder's own setting does not reach a listener passed in).
    let incoming = tonic::transport::server::TcpIncoming::from(listener).with_nodelay(Some(true));
    let result = server
        .add_service(WorkerServer::with_interceptor(
            services.clone(),
            auth.clone(),
        ))
        .add_service(AdminServer::with_interceptor(services, auth))
        .serve_with_incoming_shutdown(incoming, shutdown)
        .await;
    reaper.abort();
    Ok(result?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_that_will_recur_are_not_internal() {
        let code = |e: store::Error| status(Error::Store(e)).code();
        let record = store::Error::InvalidRecord {
            job_id: "j".into(),
            index: 0,
            reason: "an array".into(),
        };
        assert_eq!(code(record), tonic::Code::InvalidArgument);
        assert_eq!(
            code(store::Error::DuplicateCompletion("j".into())),
            tonic::Code::InvalidArgument
        );
        assert_eq!(
            code(store::Error::UnknownJob("j".into())),
            tonic::Code::NotFound
        );
        assert_eq!(
            code(store::Error::UnknownWorker("w".into())),
            tonic::Code::NotFound
        );
        assert_eq!(
            code(store::Error::ReadOnly),
            tonic::Code::FailedPrecondition
        );
        // A busy database may pass: the worker retries what comes as `internal`.
        let busy = || store::Error::Database(sqlx::Error::PoolTimedOut);
        assert!(Error::Store(busy()).is_transient());
        assert!(!Error::Store(store::Error::ReadOnly).is_transient());
        assert_eq!(code(busy()), tonic::Code::Internal);
    }
}
