//! Overlap records read back: over a campaign of the size of the paper's Table 1 / Figure 2
//! (20 × 20 (L*, W*) × 3 R* × 2 precisions = 2,400 points, × 6 algorithms × 3 repeats = 43,200
//! timing records), a point's visits, records that lack a timing, the verdict checks, and the
//! records `jobs::run` really writes.

mod common;

use std::time::{Duration, Instant};

use common::*;
use jobs::JobSpec;
use overlap::{Algorithm, PointSpec, Precision};

const REPEATS: usize = 3;

fn point(l_star: f64, w_star: f64, r_star: f64, precision: Precision) -> PointSpec {
    PointSpec {
        l_star,
        w_star,
        r_star,
        acceptance: 0.4,
        configurations: 2_000_000,
        repeats: REPEATS as u32,
        precision,
        algorithms: Algorithm::ALL.to_vec(),
        seed: 123,
        ci_target: None,
        time_cap_s: None,
        verdict_check: None,
        visit: None,
        plugins: Vec::new(),
    }
}

fn table1_points() -> Vec<JobSpec> {
    let mut specs = Vec::new();
    for precision in [Precision::F32, Precision::F64] {
        for r_star in [0.05, 0.5, 5.0] {
            for l in 1..=20 {
                for w in 1..=20 {
                    specs.push(JobSpec::Overlap(point(
                        f64::from(l),
                        f64::from(w),
                        r_star,
                        precision,
                    )));
                }
            }
        }
    }
    specs
}

/// Blocks of a 2·10⁶-configuration pass (16,384 configurations each).
const BLOCKS: usize = 123;

/// Timing of (algorithm a, repeat r): 1 + a + r/10 ms, so the mean over repeats is 1.1 + a;
/// each with its blocks (block k of repeat r of algorithm a: a + r + k/1000 ns/check), then
/// the point record with the noise check, as `jobs::run` writes them.
fn records() -> Vec<String> {
    let mut records = Vec::new();
    for (a, algorithm) in Algorithm::ALL.iter().enumerate() {
        for repeat in 0..REPEATS {
            let ms = 1.0 + a as f64 + repeat as f64 / 10.0;
            let blocks: Vec<f64> = (0..BLOCKS)
                .map(|k| (a + repeat) as f64 + k as f64 / 1000.0)
                .collect();
            records.push(
                serde_json::json!({"algorithm": algorithm.name(), "repeat": repeat, "ms": ms,
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

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_visits_and_quality_of_43200_timings() {
    let (_dir, path, store) = temp_store().await;
    let specs = table1_points();
    complete_all(&store, "table1", &specs, |_| Ok(records())).await;
    store
        .submit(
            &store::NewCampaign {
                id: "table1-again".into(),
                name: "again".into(),
                plan_text: String::new(),
                searches: Vec::new(),
            },
            &specs[..10].iter().map(new_job).collect::<Vec<_>>(),
            T0 + 1.0,
        )
        .await
        .unwrap();
    store.close().await;
    let store = store::Store::open_read_only(&path).await.unwrap();
    let quality = results::overlap_quality(&store, None).await.unwrap();
    assert_eq!(
        (
            quality.checked,
            quality.disturbed,
            quality.rerun,
            quality.reruns
        ),
        (2_400, 0, 2_400, 2_400)
    );
    let again = results::overlap_quality(&store, Some("table1-again"))
        .await
        .unwrap();
    assert_eq!(again.checked, 10);

    let started = Instant::now();
    let rows = results::overlap_visits(&store).await.unwrap();
    let elapsed = started.elapsed();
    println!(
        "overlap_visits: {} rows from 43,200 records in {elapsed:?}",
        rows.len()
    );
    // Not a benchmark: a guard against a read that went quadratic, which takes minutes here,
    // with room for a loaded CI machine (a linear one takes well under a second in release).
    let budget = Duration::from_secs(if cfg!(debug_assertions) { 30 } else { 10 });
    assert!(elapsed < budget, "overlap_visits took {elapsed:?}");

    assert_eq!(rows.len(), 2_400 * Algorithm::ALL.len());
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
        let a = Algorithm::ALL
            .iter()
            .position(|a| a.name() == row.algorithm)
            .unwrap() as f64;
        assert!((row.mean_ms - (1.1 + a)).abs() < 1e-9, "{row:?}");
        assert_eq!((row.disturbed, row.reruns), (Some(false), Some(1)));
        let mut firsts: Vec<f64> = row.block_ns_per_check.iter().map(|b| b[0]).collect();
        firsts.sort_by(f64::total_cmp);
        assert_eq!(firsts, [a, a + 1.0, a + 2.0], "every repeat's blocks");
        assert!(row.block_ns_per_check.iter().all(|b| b.len() == BLOCKS));
        assert!((row.ns_per_check - (1.1 + a) / 2.0).abs() < 1e-9);
        assert!((row.acceptance - 0.4).abs() < 1e-12 && row.acceptance_target == 0.4);
    }
    // Table 1's rows: one per point and algorithm, each estimated from its blocks.
    let points = results::overlap_points(&store, results::Statistic::Mean)
        .await
        .unwrap();
    assert_eq!(points.len(), rows.len());
    assert!(
        points
            .iter()
            .all(|p| p.visits == 1 && p.statistic == "mean")
    );
}

#[tokio::test]
async fn a_timing_record_without_its_time_is_an_error_naming_the_job() {
    let (_dir, _path, store) = temp_store().await;
    let spec = JobSpec::Overlap(point(1.0, 1.0, 5.0, Precision::F32));
    let record = r#"{"algorithm":"ocsi","repeat":0,"ns_per_check":1.0,"acceptance":0.4}"#;
    complete_all(&store, "c", std::slice::from_ref(&spec), |_| {
        Ok(vec![record.to_owned()])
    })
    .await;
    let error = results::overlap_visits(&store).await.unwrap_err();
    assert!(matches!(error, results::Error::Corrupt { .. }), "{error}");
    let message = error.to_string();
    assert!(
        message.contains(&spec.id()) && message.contains("ms, ns_per_check or acceptance"),
        "{message}"
    );
}

/// The visits of a point (`visit` absent for the first, then 1, 2, …; only the first with the
/// verdict check) come back with their visit and one `point` (the spec less `visit` and
/// `verdict_check`) that no other point shares, next to each other whatever their ids, and pool
/// into one row.
fn point_of(spec: &JobSpec) -> PointSpec {
    match spec {
        JobSpec::Overlap(point) => point.clone(),
        other => panic!("not an overlap point: {other:?}"),
    }
}

#[tokio::test]
async fn the_visits_of_a_point_come_together_and_pool_into_one_row() {
    let (_dir, _path, store) = temp_store().await;
    let visit = |l_star: f64, visit: Option<u32>| {
        JobSpec::Overlap(PointSpec {
            configurations: 1000,
            visit,
            ..point(l_star, 2.0, 5.0, Precision::F32)
        })
    };
    // As a plan writes them: only the first visit runs the verdict check.
    let specs = [
        JobSpec::Overlap(PointSpec {
            verdict_check: Some(1000),
            ..point_of(&visit(1.0, None))
        }),
        visit(1.0, Some(1)),
        visit(1.0, Some(2)),
        visit(3.0, None),
    ];
    complete_all(&store, "visits", &specs, |_| Ok(records())).await;
    let rows: Vec<_> = results::overlap_visits(&store)
        .await
        .unwrap()
        .into_iter()
        .filter(|r| r.algorithm == "qri")
        .collect();
    let seen: Vec<(&str, u32)> = rows.iter().map(|r| (r.job_id.as_str(), r.visit)).collect();
    let ids: Vec<String> = specs.iter().map(JobSpec::id).collect();
    assert_eq!(
        seen,
        [
            (ids[0].as_str(), 0),
            (ids[1].as_str(), 1),
            (ids[2].as_str(), 2),
            (ids[3].as_str(), 0)
        ]
    );
    assert!(
        rows[..3].iter().all(|r| r.point == rows[0].point),
        "{rows:?}"
    );
    assert!(
        !rows[0].point.contains("visit") && !rows[0].point.contains("verdict_check"),
        "{}",
        rows[0].point
    );
    assert_ne!(rows[3].point, rows[0].point);
    let points = results::overlap_points(&store, results::Statistic::Mean)
        .await
        .unwrap();
    let qri: Vec<_> = points.iter().filter(|p| p.algorithm == "qri").collect();
    assert_eq!(
        qri.iter().map(|p| (p.l_star, p.visits)).collect::<Vec<_>>(),
        [(1.0, 3), (3.0, 1)]
    );
}

/// Records as `jobs::run` writes them, read back: every algorithm of the point has its row,
/// with the blocks of every repeat, and the verdict check has a row per algorithm whose
/// ns/check is the mean of that algorithm's repeats.
#[tokio::test]
async fn the_records_jobs_run_writes_read_back() {
    let (_dir, _path, store) = temp_store().await;
    let spec = JobSpec::Overlap(PointSpec {
        configurations: 20_000,
        repeats: 2,
        algorithms: vec![Algorithm::Qri, Algorithm::OcsiBatch],
        verdict_check: Some(2_000),
        ..point(3.0, 2.0, 0.5, Precision::F64)
    });
    let mut written = Vec::new();
    complete_all(&store, "real", std::slice::from_ref(&spec), |spec| {
        let records = jobs::run(spec, 1).map_err(|e| e.to_string())?;
        let records: Vec<String> = records
            .into_iter()
            .map(|r| serde_json::Value::Object(r).to_string())
            .collect();
        Ok(records)
    })
    .await;
    for row in results::overlap_visits(&store).await.unwrap() {
        assert_eq!((row.precision.as_str(), row.repeats), ("f64", 2), "{row:?}");
        assert_eq!(row.block_ns_per_check.len(), 2, "{row:?}");
        assert!(row.ns_per_check > 0.0 && row.disturbed.is_some(), "{row:?}");
        written.push((row.algorithm.clone(), row.repeat_ns_per_check.clone()));
    }
    assert_eq!(
        written.iter().map(|(a, _)| a.as_str()).collect::<Vec<_>>(),
        ["ocsi_batch", "qri"]
    );
    let verdicts = results::overlap_verdicts(&store).await.unwrap();
    assert_eq!(verdicts.len(), 2, "{verdicts:?}");
    for v in &verdicts {
        let (_, repeats) = written.iter().find(|(a, _)| *a == v.algorithm).unwrap();
        assert_eq!(v.ns_per_check, repeats.iter().sum::<f64>() / 2.0);
        assert!(
            v.bulk + v.shell > 1_900 && v.bulk + v.shell <= 2_000,
            "{v:?}"
        );
        assert_eq!((v.l_star, v.w_star, v.r_star), (3.0, 2.0, 0.5));
    }
}
