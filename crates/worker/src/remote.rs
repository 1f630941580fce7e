//! A [`JobQueue`] over gRPC: the worker side of `sweep worker --coordinator URL`. The channel
//! connects lazily and reconnects by itself; the slots' backoff covers a coordinator that is away.

use std::collections::HashSet;
use std::time::Duration;

use queue::{
    CompleteOutcome, Completion, FailOutcome, Granted, JobQueue, LeaseRef, QueueError, WorkerInfo,
};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Certificate, Channel, ClientTlsConfig, Endpoint};
use wire::auth::{Token, WithToken};
use wire::convert::{complete_outcome_from_wire, fail_outcome_from_wire};
use wire::v1 as pb;
use wire::v1::worker_client::WorkerClient;

/// Every call carries this deadline: a hung coordinator must not hang a slot.
const DEADLINE: Duration = Duration::from_secs(10);

/// Leases per heartbeat or release message: a worker of many slots running short jobs holds tens
/// of thousands, more than one message may carry (gRPC's default limit is 4 MB, ~70 bytes each).
const LEASES_PER_CALL: usize = 4096;

pub struct Remote {
    client: WorkerClient<InterceptedService<Channel, WithToken>>,
    worker_id: String,
}

/// Sorts a failed call by whether retrying it can help (see the coordinator's `status`).
fn transport(status: tonic::Status) -> QueueError {
    use tonic::Code;
    let message = status.message().to_string();
    match status.code() {
        Code::Unauthenticated | Code::PermissionDenied => QueueError::Refused(message),
        Code::InvalidArgument
        | Code::NotFound
        | Code::AlreadyExists
        | Code::FailedPrecondition
        | Code::OutOfRange
        | Code::Unimplemented => QueueError::Rejected(message),
        code => QueueError::Transport(format!("{code:?}: {message}")),
    }
}

fn request<T>(message: T) -> tonic::Request<T> {
    let mut request = tonic::Request::new(message);
    request.set_timeout(DEADLINE);
    request
}

impl Remote {
    /// `url` like `http://host:port` or `https://…` (then `ca_pem` verifies the coordinator).
    pub fn new(
        url: &str,
        token: Option<Token>,
        ca_pem: Option<Vec<u8>>,
        worker_id: String,
    ) -> Result<Remote, QueueError> {
        let bad = |e: tonic::transport::Error| QueueError::Transport(format!("{url}: {e}"));
        let mut endpoint = Endpoint::from_shared(url.to_string())
            .map_err(bad)?
            .connect_timeout(Duration::from_secs(5))
            .tcp_nodelay(true);
        if let Some(ca) = ca_pem {
            endpoint = endpoint
                .tls_config(ClientTlsConfig::new().ca_certificate(Certificate::from_pem(ca)))
                .map_err(bad)?;
        }
        let channel = endpoint.connect_lazy();
        Ok(Remote {
            client: WorkerClient::with_interceptor(channel, WithToken::new(token)),
            worker_id,
        })
    }

    /// Registers this worker; answers the coordinator's lease duration.
    pub async fn register(&self, info: &WorkerInfo) -> Result<Duration, QueueError> {
        let response = self
            .client
            .clone()
            .register(request(pb::RegisterRequest {
                worker: Some(info.clone().into()),
            }))
            .await
            .map_err(transport)?
            .into_inner();
        Ok(Duration::from_millis(response.lease_ms))
    }
}

impl JobQueue for Remote {
    async fn lease(&self, max_jobs: u32, seconds_left: Option<f64>) -> Result<Granted, QueueError> {
        let message = pb::LeaseRequest {
            worker_id: self.worker_id.clone(),
            max_jobs,
            seconds_left,
        };
        let answer = self
            .client
            .clone()
            .lease(request(message))
            .await
            .map_err(transport)?
            .into_inner();
        Ok(Granted {
            leases: answer.leases.into_iter().map(Into::into).collect(),
            passed_over: answer.passed_over,
        })
    }

    async fn heartbeat(&self, leases: Vec<LeaseRef>) -> Result<Vec<LeaseRef>, QueueError> {
        let mut lost = HashSet::new();
        for chunk in leases.chunks(LEASES_PER_CALL) {
            let message = pb::HeartbeatRequest {
                worker_id: self.worker_id.clone(),
                leases: chunk.iter().map(Into::into).collect(),
            };
            let answer = self
                .client
                .clone()
                .heartbeat(request(message))
                .await
                .map_err(transport)?
                .into_inner();
            lost.extend(answer.lost.into_iter().map(LeaseRef::from));
        }
        Ok(leases.into_iter().filter(|l| !lost.contains(l)).collect())
    }

    async fn complete(
        &self,
        completions: Vec<Completion>,
    ) -> Result<Vec<CompleteOutcome>, QueueError> {
        let message = pb::CompleteRequest {
            worker_id: self.worker_id.clone(),
            completions: completions.into_iter().map(Into::into).collect(),
        };
        let response = self
            .client
            .clone()
            .complete(request(message))
            .await
            .map_err(transport)?
            .into_inner();
        response
            .outcomes()
            .map(|o| {
                complete_outcome_from_wire(o)
                    .ok_or_else(|| QueueError::Transport("complete: no outcome".into()))
            })
            .collect()
    }

    async fn fail(&self, lease: &LeaseRef, error: String) -> Result<FailOutcome, QueueError> {
        let message = pb::FailRequest {
            worker_id: self.worker_id.clone(),
            job_id: lease.job_id.clone(),
            token: lease.token,
            error,
        };
        let outcome = self
            .client
            .clone()
            .fail(request(message))
            .await
            .map_err(transport)?
            .into_inner()
            .outcome();
        fail_outcome_from_wire(outcome)
            .ok_or_else(|| QueueError::Transport("fail: no outcome".into()))
    }

    async fn release(&self, leases: Vec<LeaseRef>) -> Result<(), QueueError> {
        for chunk in leases.chunks(LEASES_PER_CALL) {
            let message = pb::ReleaseRequest {
                worker_id: self.worker_id.clone(),
                leases: chunk.iter().map(Into::into).collect(),
            };
            self.client
                .clone()
                .release(request(message))
                .await
                .map_err(transport)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_calls_that_may_pass_are_retried() {
        let sort = |code| transport(tonic::Status::new(code, "why"));
        for code in [
            tonic::Code::Unavailable,
            tonic::Code::DeadlineExceeded,
            tonic::Code::Internal,
            tonic::Code::Unknown,
        ] {
            assert!(sort(code).is_transient(), "{code:?}");
        }
        for code in [
            tonic::Code::InvalidArgument,
            tonic::Code::NotFound,
            tonic::Code::FailedPrecondition,
        ] {
            assert!(
                matches!(sort(code), QueueError::Rejected(m) if m == "why"),
                "{code:?}"
            );
        }
        assert!(matches!(
            sort(tonic::Code::Unauthenticated),
            QueueError::Refused(_)
        ));
        assert!(!sort(tonic::Code::PermissionDenied).is_transient());
    }
}
