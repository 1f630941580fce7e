//! Group commit through the public API: lease, heartbeat and complete calls that arrive together
//! share transactions, and each still gets exactly the answer it would get alone.

mod common;

use common::*;
use std::collections::HashSet;
use std::time::Duration;
use store::{CompleteOutcome, Error, LeaseRef};

const WORKERS: usize = 64;

#[tokio::test]
async fn concurrent_calls_share_transactions_and_keep_their_answers() {
    let names: Vec<String> = (0..WORKERS).map(|w| format!("w{w}")).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let (_dir, _path, store) = store_with(&refs, WORKERS * 2).await;
    let before = store.write_groups();
    let store = &store;

    // Every worker leases two jobs at once, and so does a caller that is not registered: its
    // failure is undone alone, inside the group.
    let callers = names.iter().map(String::as_str).chain(["nobody"]);
    let mut leases =
        futures(callers.map(|w| store.lease(w, 2, Duration::from_secs(60), T0, true))).await;
    let stranger = leases.pop().expect("the stranger's answer");
    assert!(
        matches!(stranger, Err(Error::UnknownWorker(_))),
        "{stranger:?}"
    );
    let leases: Vec<_> = leases.into_iter().map(|l| l.expect("lease")).collect();
    let mut seen = HashSet::new();
    for held in &leases {
        assert_eq!(held.len(), 2);
        for lease in held {
            assert!(
                seen.insert(lease.job_id.clone()),
                "{} leased twice",
                lease.job_id
            );
        }
    }

    // Heartbeats and completions of every worker, all at once.
    let beats = futures(names.iter().zip(&leases).map(|(w, held)| {
        let refs: Vec<LeaseRef> = held.iter().map(|l| l.reference()).collect();
        async move { store.heartbeat(w, &refs, T0 + 120.0, T0 + 1.0).await }
    }))
    .await;
    for (beat, held) in beats.into_iter().zip(&leases) {
        assert_eq!(beat.expect("heartbeat").len(), held.len());
    }
    let completions = futures(names.iter().zip(&leases).map(|(w, held)| async move {
        let mut outcomes = Vec::new();
        for lease in held {
            let records = [format!(r#"{{"worker":"{w}"}}"#)];
            outcomes.push(
                store
                    .complete(w, &lease.job_id, lease.token, Some(0), &records, T0 + 2.0)
                    .await,
            );
        }
        outcomes
    }))
    .await;
    assert!(
        completions
            .iter()
            .flatten()
            .all(|o| matches!(o, Ok(CompleteOutcome::Accepted)))
    );

    let status = store.status(None).await.unwrap();
    assert_eq!(
        (status.done, status.running, status.queued),
        ((WORKERS * 2) as u64, 0, 0)
    );
    assert_eq!(
        count(store, "SELECT count(*) FROM results").await,
        (WORKERS * 2) as i64
    );
    let after = store.write_groups();
    let (transactions, writes) = (
        after.transactions - before.transactions,
        after.writes - before.writes,
    );
    assert_eq!(writes, (WORKERS * 4 + 1) as u64, "every call is one write");
    assert!(
        transactions * 4 <= writes,
        "{writes} writes in {transactions} transactions: not grouped"
    );
}

/// Polls every future together (a plain join, without a futures dependency).
async fn futures<T>(all: impl IntoIterator<Item = impl std::future::Future<Output = T>>) -> Vec<T> {
    let mut pinned: Vec<_> = all.into_iter().map(Box::pin).collect();
    let mut results: Vec<Option<T>> = pinned.iter().map(|_| None).collect();
    std::future::poll_fn(|cx| {
        let mut pending = false;
        for (future, result) in pinned.iter_mut().zip(results.iter_mut()) {
            if result.is_none() {
                match future.as_mut().poll(cx) {
                    std::task::Poll::Ready(value) => *result = Some(value),
                    std::task::Poll::Pending => pending = true,
                }
            }
        }
        if pending {
            std::task::Poll::Pending
        } else {
            std::task::Poll::Ready(())
        }
    })
    .await;
    results
        .into_iter()
        .map(|r| r.expect("every future finished"))
        .collect()
}
