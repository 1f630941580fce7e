//! The queue contract's types on the wire and back, for both ends. An outcome a peer left
//! unspecified is an error of the peer, answered as `None`.

use queue::{CompleteOutcome, Completion, FailOutcome, Lease, LeaseRef, WorkerInfo};

use crate::v1 as pb;

impl From<WorkerInfo> for pb::WorkerInfo {
    fn from(info: WorkerInfo) -> Self {
        pb::WorkerInfo {
            id: info.id,
            hostname: info.hostname,
            cores: info.cores,
            cpu_model: info.cpu_model,
            cpu_flags: info.cpu_flags,
            rustc: info.rustc,
            git_commit: info.git_commit,
            profile: info.profile,
            allocation: info.allocation.unwrap_or_default(),
            allow_commands: info.allow_commands,
        }
    }
}

impl From<pb::WorkerInfo> for WorkerInfo {
    fn from(w: pb::WorkerInfo) -> Self {
        WorkerInfo {
            id: w.id,
            hostname: w.hostname,
            cores: w.cores,
            cpu_model: w.cpu_model,
            cpu_flags: w.cpu_flags,
            rustc: w.rustc,
            git_commit: w.git_commit,
            profile: w.profile,
            allocation: (!w.allocation.is_empty()).then_some(w.allocation),
            allow_commands: w.allow_commands,
        }
    }
}

impl From<Lease> for pb::Lease {
    fn from(l: Lease) -> Self {
        pb::Lease {
            job_id: l.job_id,
            kind: l.kind,
            params_json: l.params_json,
            attempt: l.attempt,
            token: l.token,
            exclusive: l.exclusive,
        }
    }
}

impl From<pb::Lease> for Lease {
    fn from(l: pb::Lease) -> Self {
        Lease {
            job_id: l.job_id,
            kind: l.kind,
            params_json: l.params_json,
            attempt: l.attempt,
            token: l.token,
            // Expiry is the coordinator's business; the worker knows the lease duration.
            expires_at: f64::NAN,
            exclusive: l.exclusive,
        }
    }
}

impl From<&LeaseRef> for pb::HeldLease {
    fn from(l: &LeaseRef) -> Self {
        pb::HeldLease {
            job_id: l.job_id.clone(),
            token: l.token,
        }
    }
}

impl From<pb::HeldLease> for LeaseRef {
    fn from(held: pb::HeldLease) -> Self {
        LeaseRef {
            job_id: held.job_id,
            token: held.token,
        }
    }
}

impl From<Completion> for pb::Completion {
    fn from(c: Completion) -> Self {
        pb::Completion {
            job_id: c.job_id,
            token: c.token,
            core_id: c.core_id.unwrap_or_default(),
            records_json: c.records,
        }
    }
}

impl From<pb::Completion> for Completion {
    fn from(c: pb::Completion) -> Self {
        Completion {
            job_id: c.job_id,
            token: c.token,
            core_id: Some(c.core_id),
            records: c.records_json,
        }
    }
}

pub fn complete_outcome_to_wire(outcome: CompleteOutcome) -> pb::complete_response::Outcome {
    use pb::complete_response::Outcome;
    match outcome {
        CompleteOutcome::Accepted => Outcome::Accepted,
        CompleteOutcome::Late => Outcome::Late,
        CompleteOutcome::AlreadyDone => Outcome::AlreadyDone,
    }
}

pub fn complete_outcome_from_wire(
    outcome: pb::complete_response::Outcome,
) -> Option<CompleteOutcome> {
    use pb::complete_response::Outcome;
    match outcome {
        Outcome::Accepted => Some(CompleteOutcome::Accepted),
        Outcome::Late => Some(CompleteOutcome::Late),
        Outcome::AlreadyDone => Some(CompleteOutcome::AlreadyDone),
        Outcome::Unspecified => None,
    }
}

pub fn fail_outcome_to_wire(outcome: FailOutcome) -> pb::fail_response::Outcome {
    use pb::fail_response::Outcome;
    match outcome {
        FailOutcome::Requeued => Outcome::Requeued,
        FailOutcome::Failed => Outcome::Failed,
        FailOutcome::Late => Outcome::Late,
    }
}

pub fn fail_outcome_from_wire(outcome: pb::fail_response::Outcome) -> Option<FailOutcome> {
    use pb::fail_response::Outcome;
    match outcome {
        Outcome::Requeued => Some(FailOutcome::Requeued),
        Outcome::Failed => Some(FailOutcome::Failed),
        Outcome::Late => Some(FailOutcome::Late),
        Outcome::Unspecified => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outcomes_survive_the_round_trip() {
        for o in [
            CompleteOutcome::Accepted,
            CompleteOutcome::Late,
            CompleteOutcome::AlreadyDone,
        ] {
            assert_eq!(
                complete_outcome_from_wire(complete_outcome_to_wire(o)),
                Some(o)
            );
        }
        for o in [
            FailOutcome::Requeued,
            FailOutcome::Failed,
            FailOutcome::Late,
        ] {
            assert_eq!(fail_outcome_from_wire(fail_outcome_to_wire(o)), Some(o));
        }
        assert_eq!(
            complete_outcome_from_wire(pb::complete_response::Outcome::Unspecified),
            None
        );
    }

    #[test]
    fn a_completion_keeps_its_records_and_core() {
        let c = Completion {
            job_id: "j".into(),
            token: 7,
            core_id: Some(3),
            records: vec!["{}".into()],
        };
        assert_eq!(Completion::from(pb::Completion::from(c.clone())), c);
    }
}
