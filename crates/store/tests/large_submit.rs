//! A submission larger than one of the store's JSON chunks is still one atomic write.

mod common;

use common::*;
use store::Error;

const JOBS: usize = 25_001; // three chunks

#[tokio::test]
async fn a_conflict_in_the_last_chunk_writes_nothing_of_the_first() {
    let (_dir, _path, store) = temp_store().await;
    let outcome = store
        .submit(&campaign("c"), &noop_jobs(0, JOBS), T0)
        .await
        .unwrap();
    assert_eq!((outcome.new_jobs, outcome.already_known), (JOBS as u64, 0));

    // In id order: two chunks of known jobs, then the changed one and ten new ones in the third.
    let mut again = noop_jobs(100_000, 100_010);
    let mut changed = noop_jobs(JOBS - 1, JOBS);
    changed[0].params_json = r#"{"index":-1,"duration_ms":0}"#.to_owned();
    again.extend(noop_jobs(0, JOBS - 1));
    again.extend(changed);
    let refused = store.submit(&campaign("d"), &again, T0 + 1.0).await;
    assert!(
        matches!(
            &refused,
            Err(Error::JobConflict {
                field: "params",
                ..
            })
        ),
        "{refused:?}"
    );
    assert_eq!(store.status(None).await.unwrap().total, JOBS as u64);
    assert_eq!(count(&store, "SELECT count(*) FROM campaigns").await, 1);
    assert_eq!(
        count(&store, "SELECT count(*) FROM campaign_jobs").await,
        JOBS as i64
    );

    // Leases come in id order, as they did when jobs were inserted in plan order.
    store.register_worker(&worker("w"), T0).await.unwrap();
    let leases = store
        .lease("w", 3, std::time::Duration::from_secs(60), T0, true)
        .await
        .unwrap();
    let ids: Vec<&str> = leases.iter().map(|l| l.job_id.as_str()).collect();
    assert_eq!(ids, ["noop-000000", "noop-000001", "noop-000002"]);
}
