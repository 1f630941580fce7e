//! What the store returns of results, without looking inside them: the records of a kind of job
//! in the order they were written, and read-only SQL with bound values.

mod common;

use std::time::Duration;

use common::*;
use store::NewJob;

fn job(id: &str, kind: &str) -> NewJob {
    NewJob {
        id: id.to_owned(),
        kind: kind.to_owned(),
        params_json: format!(r#"{{"name":"{id}"}}"#),
        estimate_s: 1.0,
        exclusive: false,
        pass: 0,
        foreign_code: false,
    }
}

#[tokio::test]
async fn results_of_a_kind_come_per_job_in_the_order_written() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w1"), T0).await.unwrap();
    let jobs = [
        job("c-other", "edmd"),
        job("d-unfinished", "overlap"),
        job("b-first", "overlap"),
    ];
    store.submit(&campaign("c"), &jobs, T0).await.unwrap();
    // Submitted later, though its id sorts first.
    let later = [job("a-second", "overlap")];
    store
        .submit(&campaign("d"), &later, T0 + 1.0)
        .await
        .unwrap();
    let leases = store
        .lease("w1", 8, Duration::from_secs(60), T0, true)
        .await
        .unwrap();
    for lease in leases.iter().filter(|l| l.job_id != "d-unfinished") {
        // Twelve records, so that their order cannot come from sorting their text.
        let records: Vec<String> = (0..12)
            .map(|i| format!(r#"{{"job":"{}","i":{i}}}"#, lease.job_id))
            .collect();
        store
            .complete("w1", &lease.job_id, lease.token, None, &records, T0)
            .await
            .unwrap();
    }
    let overlap = store.results_of("overlap").await.unwrap();
    let ids: Vec<&str> = overlap.iter().map(|j| j.job_id.as_str()).collect();
    assert_eq!(ids, ["b-first", "a-second"], "submission order");
    for job in &overlap {
        assert_eq!(job.params_json, format!(r#"{{"name":"{}"}}"#, job.job_id));
        let order: Vec<u64> = job
            .records
            .iter()
            .map(|r| {
                serde_json::from_str::<serde_json::Value>(r).unwrap()["i"]
                    .as_u64()
                    .unwrap()
            })
            .collect();
        assert_eq!(order, (0..12).collect::<Vec<_>>());
    }
    assert_eq!(store.results_of("edmd").await.unwrap().len(), 1);
    assert!(store.results_of("noop").await.unwrap().is_empty());
}

#[tokio::test]
async fn read_only_sql_takes_bound_values() {
    let (_dir, _path, store) = store_with(&["w1"], 3).await;
    let sql = "SELECT count(*) FROM jobs WHERE ?1 IS NULL OR id = ?1";
    let all = store
        .query_read_only_with(sql, &[serde_json::Value::Null])
        .await
        .unwrap();
    assert_eq!(all.rows[0][0], 3);
    let one = store
        .query_read_only_with(sql, &["noop-000001".into()])
        .await
        .unwrap();
    assert_eq!(one.rows[0][0], 1);
    let numbers = store
        .query_read_only_with("SELECT ?1 + ?2", &[2.into(), 0.5.into()])
        .await
        .unwrap();
    assert_eq!(numbers.rows[0][0], 2.5);
    // Binding does not open a way around the single read-only statement.
    assert!(
        store
            .query_read_only_with("DELETE FROM jobs WHERE id = ?1", &["noop-000001".into()])
            .await
            .is_err()
    );
}
