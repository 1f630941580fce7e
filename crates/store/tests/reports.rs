//! Report queries over a campaign of the size of the paper's Table 1 / Figure 2:
//! 20 × 20 (L*, W*) × 3 R* × 2 precisions = 2,400 points, × 6 algorithms × 3 repeats = 43,200 rows.

mod common;

use common::*;
use std::time::{Duration, Instant};
use store::{NewJob, Store};

const ALGORITHMS: [&str; 6] = ["arvo", "qri", "qrf", "sse", "ocsi", "ocsi_batch"];
const REPEATS: usize = 3;

fn overlap_jobs() -> Vec<NewJob> {
    let mut jobs = Vec::new();
    for precision in ["f32", "f64"] {
        for r_star in [0.05, 0.5, 5.0] {
            for l in 1..=20 {
                for w in 1..=20 {
                    let params = serde_json::json!({
                        "l_star": f64::from(l), "w_star": f64::from(w), "r_star": r_star,
                        "acceptance": 0.4, "configurations": 2_000_000, "repeats": REPEATS,
                        "precision": precision, "algorithms": ALGORITHMS, "seed": 123,
                    });
                    jobs.push(NewJob {
                        id: format!("ov-{precision}-{r_star}-{l}-{w}"),
                        kind: "overlap".to_owned(),
                        params_json: params.to_string(),
                        estimate_s: 2.0,
                        exclusive: false,
                        pass: 0,
                    });
                }
            }
        }
    }
    jobs
}

/// Blocks of a 2·10⁶-configuration pass (16,384 configurations each).
const BLOCKS: usize = 123;

/// Timing of (algorithm a, repeat r): 1 + a + r/10 ms, so the mean over repeats is 1.1 + a;
/// each with its blocks (block k of repeat r of algorithm a: a + r + k/1000 ns/check), then
/// the point record with the noise check, as `jobs::run` writes them.
fn records() -> Vec<String> {
    let mut records = Vec::new();
    for (a, algorithm) in ALGORITHMS.iter().enumerate() {
        for repeat in 0..REPEATS {
            let ms = 1.0 + a as f64 + repeat as f64 / 10.0;
            let blocks: Vec<f64> = (0..BLOCKS)
                .map(|k| (a + repeat) as f64 + k as f64 / 1000.0)
                .collect();
            records.push(
                serde_json::json!({"algorithm": algorithm, "repeat": repeat, "ms": ms,
                                   "ns_per_check": ms / 2.0, "acceptance": 0.4, "total_ms": ms,
                                   "block_ns_per_check": blocks})
                .to_string(),
            );
        }
    }
    records.push(
        serde_json::json!({"stream_ns_per_config": 5.0, "repeats": REPEATS, "stop": "repeats",
                           "timed_s": 1.0, "wall_s": 2.0, "disturbed": false, "disturbance": null,
                           "reruns": 1, "reference_compute_ns_before": 1.6})
        .to_string(),
    );
    records
}

async fn filled_store() -> (tempfile::TempDir, std::path::PathBuf, Store) {
    let (dir, path, store) = temp_store().await;
    store.register_worker(&worker("w1"), T0).await.unwrap();
    let jobs = overlap_jobs();
    store.submit(&campaign("table1"), &jobs, T0).await.unwrap();
    store
        .submit(&campaign("table1-again"), &jobs[..10], T0 + 1.0)
        .await
        .unwrap();
    let records = records();
    loop {
        let leases = store
            .lease("w1", 256, Duration::from_secs(60), T0, true)
            .await
            .unwrap();
        if leases.is_empty() {
            break;
        }
        for lease in leases {
            store
                .complete("w1", &lease.job_id, lease.token, Some(2), &records, T0)
                .await
                .unwrap();
        }
    }
    (dir, path, store)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn overlap_rows_and_export_of_43200_results() {
    let (_dir, path, store) = filled_store().await;
    store.close().await;
    let store = Store::open_read_only(&path).await.unwrap();
    assert_eq!(
        count(&store, "SELECT count(*) FROM overlap_timings").await,
        43_200
    );
    let quality = store.overlap_quality(None).await.unwrap();
    assert_eq!(
        (
            quality.checked,
            quality.disturbed,
            quality.rerun,
            quality.reruns
        ),
        (2_400, 0, 2_400, 2_400)
    );
    assert_eq!(
        store
            .overlap_quality(Some("table1-again"))
            .await
            .unwrap()
            .checked,
        10
    );

    let started = Instant::now();
    let rows = store.overlap_rows().await.unwrap();
    let elapsed = started.elapsed();
    println!(
        "overlap_rows: {} rows from 43,200 results in {elapsed:?}",
        rows.len()
    );
    // Not a benchmark (that is `cargo bench -p cli --bench orchestrator`): a guard against a
    // query that went quadratic, which takes minutes here, with room for a loaded CI machine
    // (a linear one takes 0.3-0.5 s in release, 1.8 s while four builds shared the 2 cores).
    let budget = Duration::from_secs(if cfg!(debug_assertions) { 30 } else { 10 });
    assert!(elapsed < budget, "overlap_rows took {elapsed:?}");

    assert_eq!(rows.len(), 2_400 * ALGORITHMS.len());
    let first = &rows[0];
    assert_eq!(
        (
            first.precision.as_str(),
            first.r_star,
            first.l_star,
            first.w_star
        ),
        ("f32", 0.05, 1.0, 1.0)
    );
    assert_eq!(
        (
            first.algorithm.as_str(),
            first.repeats,
            first.configurations
        ),
        ("arvo", 3, 2_000_000)
    );
    for row in &rows {
        let a = ALGORITHMS.iter().position(|a| *a == row.algorithm).unwrap() as f64;
        assert!((row.mean_ms - (1.1 + a)).abs() < 1e-9, "{row:?}");
        assert_eq!((row.disturbed, row.reruns), (Some(false), Some(1)));
        let mut firsts: Vec<f64> = row.block_ns_per_check.iter().map(|b| b[0]).collect();
        firsts.sort_by(f64::total_cmp);
        assert_eq!(firsts, [a, a + 1.0, a + 2.0], "every repeat's blocks");
        assert!(row.block_ns_per_check.iter().all(|b| b.len() == BLOCKS));
        assert!((row.ns_per_check - (1.1 + a) / 2.0).abs() < 1e-9);
        assert!((row.acceptance - 0.4).abs() < 1e-12 && row.acceptance_target == 0.4);
    }

    let started = Instant::now();
    let export = store.export().await.unwrap();
    println!("export: {} rows in {:?}", export.len(), started.elapsed());
    assert_eq!(export.len(), 43_200 + 2_400);
    assert_eq!(export[0].campaign, "table1,table1-again");
    assert_eq!(export[0].fields["algorithm"], "arvo");
    assert_eq!(export.last().unwrap().campaign, "table1");
    assert!(
        export
            .iter()
            .all(|r| r.kind == "overlap" && r.attempt == 1 && r.worker == "w1")
    );
}

#[tokio::test]
async fn overlap_rows_refuse_a_record_without_timing() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w1"), T0).await.unwrap();
    store
        .submit(&campaign("c"), &overlap_jobs()[..1], T0)
        .await
        .unwrap();
    let lease = store
        .lease("w1", 1, Duration::from_secs(60), T0, true)
        .await
        .unwrap()
        .remove(0);
    let record =
        r#"{"algorithm":"ocsi","repeat":0,"ns_per_check":1.0,"acceptance":0.4}"#.to_owned();
    store
        .complete("w1", &lease.job_id, lease.token, None, &[record], T0)
        .await
        .unwrap();
    assert!(matches!(
        store.overlap_rows().await,
        Err(store::Error::Corrupt(_))
    ));
}

/// The visits of a point (`visit` absent for the first, then 1, 2, …) come back with their
/// visit and one `point` (the params less `visit`) that no other point shares, next to each
/// other whatever their ids.
#[tokio::test]
async fn overlap_rows_carry_the_visit_and_the_point() {
    let (_dir, _path, store) = temp_store().await;
    store.register_worker(&worker("w1"), T0).await.unwrap();
    let job = |id: &str, l_star: f64, visit: Option<u32>| {
        let mut params = serde_json::json!({
            "l_star": l_star, "w_star": 2.0, "r_star": 5.0, "acceptance": 0.4,
            "configurations": 1000, "repeats": REPEATS, "precision": "f32",
            "algorithms": ALGORITHMS, "seed": 1,
        });
        if let Some(visit) = visit {
            params["visit"] = visit.into();
        }
        NewJob {
            id: id.to_owned(),
            kind: "overlap".to_owned(),
            params_json: params.to_string(),
            estimate_s: 1.0,
            exclusive: false,
            pass: visit.unwrap_or(0),
        }
    };
    // Ids that sort against the visits.
    let jobs = [
        job("z-first", 1.0, None),
        job("a-second", 1.0, Some(1)),
        job("m-third", 1.0, Some(2)),
        job("b-other", 3.0, None),
    ];
    store.submit(&campaign("visits"), &jobs, T0).await.unwrap();
    let records = records();
    for lease in store
        .lease("w1", 8, Duration::from_secs(60), T0, true)
        .await
        .unwrap()
    {
        store
            .complete("w1", &lease.job_id, lease.token, Some(2), &records, T0)
            .await
            .unwrap();
    }
    let rows: Vec<_> = store
        .overlap_rows()
        .await
        .unwrap()
        .into_iter()
        .filter(|r| r.algorithm == "qri")
        .collect();
    let seen: Vec<(&str, u32)> = rows.iter().map(|r| (r.job_id.as_str(), r.visit)).collect();
    assert_eq!(
        seen,
        [
            ("z-first", 0),
            ("a-second", 1),
            ("m-third", 2),
            ("b-other", 0)
        ]
    );
    assert!(
        rows[..3].iter().all(|r| r.point == rows[0].point),
        "{rows:?}"
    );
    assert!(!rows[0].point.contains("visit"), "{}", rows[0].point);
    assert_ne!(rows[3].point, rows[0].point);
}
