//! A read-only store neither creates nor modifies the database file and refuses every write.

mod common;

use common::*;
use std::time::Duration;
use store::{Error, Store};

fn digest(path: &std::path::Path) -> blake3::Hash {
    blake3::hash(&std::fs::read(path).unwrap())
}

#[tokio::test]
async fn read_only_open_does_not_create_a_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing.db");
    assert!(matches!(
        Store::open_read_only(&path).await,
        Err(Error::Open { .. })
    ));
    assert!(!path.exists());
}

#[tokio::test]
async fn read_only_open_refuses_a_foreign_database() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.db");
    std::fs::write(&path, b"").unwrap(); // an empty file is a valid, empty SQLite database
    assert!(matches!(
        Store::open_read_only(&path).await,
        Err(Error::SchemaOutdated { .. })
    ));
}

#[tokio::test]
async fn read_only_store_cannot_write_and_leaves_the_bytes_alone() {
    let (_dir, path, store) = store_with(&["w1"], 5).await;
    let lease = store
        .lease("w1", 1, Duration::from_secs(9), T0, true)
        .await
        .unwrap()
        .remove(0);
    store
        .complete(
            "w1",
            &lease.job_id,
            lease.token,
            Some(0),
            &[r#"{"x":1}"#.to_owned()],
            T0,
        )
        .await
        .unwrap();
    store.close().await;
    let before = digest(&path);

    let ro = Store::open_read_only(&path).await.unwrap();
    let other = path.with_file_name("other.db");
    let result = ro
        .query_read_only("SELECT id, state, exclusive, estimate_s FROM jobs ORDER BY id LIMIT 2")
        .await
        .unwrap();
    assert_eq!(result.columns, ["id", "state", "exclusive", "estimate_s"]);
    assert_eq!(
        result.rows[0],
        [
            serde_json::json!("noop-000000"),
            "done".into(),
            0.into(),
            0.5.into()
        ]
    );
    let empty = ro
        .query_read_only("SELECT id FROM jobs WHERE 0")
        .await
        .unwrap();
    assert_eq!((empty.columns.len(), empty.rows.len()), (1, 0));
    for sql in [
        "INSERT INTO campaigns (id, name, plan_text, created_at) VALUES ('x', 'x', '', 0)",
        "DELETE FROM results",
        "UPDATE jobs SET state = 'queued'",
        "CREATE TABLE t (x)",
        "DROP VIEW overlap_timings",
        "PRAGMA journal_mode = DELETE",
        &format!("ATTACH DATABASE '{}' AS other", other.display()),
        &format!("VACUUM INTO '{}'", other.display()),
    ] {
        assert!(ro.query_read_only(sql).await.is_err(), "{sql} must fail");
    }
    assert!(!other.exists(), "a read-only store created a file");
    // Writes that pass the statement filter are refused by SQLite's read-only connection.
    for sql in [
        "WITH x AS (SELECT 1) INSERT INTO campaigns (id, name, plan_text, created_at) VALUES ('x', 'x', '', 0)",
        "WITH x AS (SELECT 1) DELETE FROM results",
    ] {
        let err = ro.query_read_only(sql).await.unwrap_err();
        assert!(matches!(err, Error::Database(_)), "{sql}: {err}");
    }
    assert!(matches!(
        ro.submit(&campaign("d"), &noop_jobs(5, 6), T0).await,
        Err(Error::ReadOnly)
    ));
    assert!(matches!(
        ro.expire_leases(T0, 3).await,
        Err(Error::ReadOnly)
    ));
    assert_eq!(ro.status(None).await.unwrap().done, 1);
    assert_eq!(ro.export().await.unwrap().len(), 1);
    ro.close().await;

    assert_eq!(digest(&path), before, "the database file changed");
}

#[tokio::test]
async fn ad_hoc_queries_on_a_writable_store_are_read_only_too() {
    let (_dir, _path, store) = temp_store().await;
    store
        .submit(&campaign("c"), &noop_jobs(0, 2), T0)
        .await
        .unwrap();
    let err = store
        .query_read_only("WITH x AS (SELECT 1) DELETE FROM jobs")
        .await
        .unwrap_err();
    assert!(matches!(err, Error::Database(_)), "{err}");
    let result = store
        .query_read_only("SELECT count(*) AS n, x'00ff' AS b, NULL AS z, 1.5e0 AS r FROM jobs")
        .await
        .unwrap();
    assert_eq!(result.columns, ["n", "b", "z", "r"]);
    assert_eq!(
        result.rows,
        [[
            serde_json::json!(2),
            "00ff".into(),
            serde_json::Value::Null,
            1.5.into()
        ]]
    );
}

#[tokio::test]
async fn only_single_queries_are_accepted() {
    let (_dir, path, store) = temp_store().await;
    let copy = path.with_file_name("copy.db");
    for sql in [
        format!("VACUUM INTO '{}'", copy.display()),
        format!("SELECT 1; VACUUM INTO '{}'", copy.display()),
        "SELECT 1; DELETE FROM jobs".to_owned(),
        "PRAGMA table_info(jobs)".to_owned(),
        "/* SELECT */ DELETE FROM jobs".to_owned(),
        String::new(),
    ] {
        let err = store.query_read_only(&sql).await.unwrap_err();
        assert!(matches!(err, Error::NotAQuery(_)), "{sql:?}: {err}");
    }
    assert!(!copy.exists());
    for sql in [
        "select ';' AS x -- a comment; DELETE\n",
        "  WITH t(x) AS (VALUES (1)) SELECT x FROM t;  ;  /* done; */ ",
        "SELECT 'it''s; fine', \"name;\" FROM (SELECT 1 AS \"name;\")",
        "VALUES (1, 2)",
        "EXPLAIN QUERY PLAN SELECT * FROM jobs",
    ] {
        store
            .query_read_only(sql)
            .await
            .unwrap_or_else(|e| panic!("{sql:?}: {e}"));
    }
}
