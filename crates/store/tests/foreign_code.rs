//! Jobs that run foreign code reach only workers that allow it: never leased to the others, not
//! even in a time-limited grant, and a worker's registration can change its mind.

mod common;

use std::time::Duration;

use common::{T0, campaign, noop_jobs, temp_store, worker};
use store::{NewJob, Within};

fn foreign(i: usize) -> NewJob {
    NewJob {
        id: format!("cmd-{i:03}"),
        kind: "command".to_owned(),
        params_json: format!(r#"{{"index":{i}}}"#),
        estimate_s: 1.0,
        exclusive: false,
        pass: 0,
        foreign_code: true,
    }
}

const LEASE: Duration = Duration::from_secs(60);

#[tokio::test]
async fn foreign_code_is_leased_only_to_workers_that_allow_it() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("plain"), T0).await.unwrap();
    let mut allowed = worker("allowed");
    allowed.allow_commands = true;
    store.register_worker(&allowed, T0).await.unwrap();
    // Foreign jobs first in id order ("cmd-" < "noop-"), so a plain worker would meet them first.
    let mut jobs: Vec<NewJob> = (0..5).map(foreign).collect();
    jobs.extend(noop_jobs(0, 3));
    store.submit(&campaign("c"), &jobs, T0).await.unwrap();

    let plain = store.lease("plain", 100, LEASE, T0, true).await.unwrap();
    let kinds: Vec<&str> = plain.iter().map(|l| l.kind.as_str()).collect();
    assert_eq!(kinds, ["noop", "noop", "noop"]);
    // Nothing left it may run, though five jobs are queued; with a time limit too.
    assert!(
        store
            .lease("plain", 100, LEASE, T0, true)
            .await
            .unwrap()
            .is_empty()
    );
    let within = Within {
        seconds_left: 1e9,
        scale: Default::default(),
    };
    let granted = store
        .lease_within("plain", 100, LEASE, T0, true, Some(within))
        .await
        .unwrap();
    assert!(granted.leases.is_empty() && granted.passed_over == 0);

    let granted = store.lease("allowed", 100, LEASE, T0, true).await.unwrap();
    assert_eq!(granted.len(), 5);
    assert!(granted.iter().all(|l| l.kind == "command"));
    let workers = store.workers().await.unwrap();
    let allows: Vec<(String, bool)> = workers
        .iter()
        .map(|w| (w.info.id.clone(), w.info.allow_commands))
        .collect();
    assert_eq!(
        allows,
        // Same registration time: in id order.
        [("allowed".to_owned(), true), ("plain".to_owned(), false)]
    );
}

#[tokio::test]
async fn re_registering_without_the_flag_withdraws_it() {
    let (_dir, _path, store) = temp_store().await;
    let mut w = worker("w");
    w.allow_commands = true;
    store.register_worker(&w, T0).await.unwrap();
    w.allow_commands = false;
    store.register_worker(&w, T0 + 1.0).await.unwrap();
    store
        .submit(&campaign("c"), &[foreign(0)], T0)
        .await
        .unwrap();
    assert!(
        store
            .lease("w", 10, LEASE, T0 + 2.0, true)
            .await
            .unwrap()
            .is_empty()
    );
}
