//! Machine history: a campaign whose compute reference or plain read is slower than the same
//! machine's earlier campaigns is named, with the ratio; one within the tolerance is not, and
//! reads of sets of other sizes are not compared.

mod common;

use common::*;
use jobs::JobSpec;
use overlap::{Algorithm, PointSpec, Precision};

/// An overlap point of `configurations` (its arrays are 48 bytes per configuration in f32).
fn point(l_star: f64, configurations: u64, seed: u64) -> JobSpec {
    JobSpec::Overlap(PointSpec {
        l_star,
        w_star: 1.0,
        r_star: 0.5,
        acceptance: 0.4,
        configurations,
        repeats: 1,
        precision: Precision::F32,
        algorithms: vec![Algorithm::Qri],
        seed,
        ci_target: None,
        time_cap_s: None,
        verdict_check: None,
        visit: None,
        plugins: Vec::new(),
    })
}

/// A timing and a point record with these references.
fn records(spec: &JobSpec, compute_ns: f64, stream_ns: f64) -> Vec<String> {
    let JobSpec::Overlap(point) = spec else {
        panic!("an overlap point")
    };
    vec![
        serde_json::json!({"algorithm": "qri", "repeat": 0, "ms": 1.0, "ns_per_check": 10.0,
                           "acceptance": 0.4, "total_ms": 1.0, "block_ns_per_check": [10.0]})
        .to_string(),
        serde_json::json!({"arrays_bytes": point.configurations * 48, "disturbed": false,
                           "reruns": 0, "timed_s": 1.0, "wall_s": 2.0,
                           "reference_compute_ns_before": compute_ns,
                           "reference_compute_ns_after": compute_ns * 1.01,
                           "reference_stream_ns_before": stream_ns * 1.02,
                           "reference_stream_ns_after": stream_ns})
        .to_string(),
    ]
}

/// Campaign `name` made at `at`: three points of 10⁶ configurations (48 MB) and one of 10⁵
/// (4.8 MB), read at `small_stream` ns per configuration.
async fn campaign(
    store: &store::Store,
    name: &str,
    at: f64,
    compute_ns: f64,
    stream_ns: f64,
    small_stream: f64,
) {
    let seed = at as u64;
    let specs = [
        point(1.0, 1_000_000, seed),
        point(2.0, 1_000_000, seed),
        point(3.0, 1_000_000, seed),
        point(4.0, 100_000, seed),
    ];
    complete_all_at(store, name, at, &specs, |spec| {
        let JobSpec::Overlap(p) = spec else {
            unreachable!()
        };
        let stream = if p.configurations == 100_000 {
            small_stream
        } else {
            stream_ns
        };
        Ok(records(spec, compute_ns, stream))
    })
    .await;
}

#[tokio::test]
async fn a_campaign_slower_than_the_machines_earlier_ones_is_named() {
    let (_dir, _path, store) = temp_store().await;
    campaign(&store, "first", T0, 1.00, 1.30, 0.70).await;
    campaign(&store, "second", T0 + 100.0, 1.02, 1.35, 0.72).await;
    assert!(
        results::machine_history(&store).await.unwrap().is_empty(),
        "within the tolerance"
    );
    // A neighbour takes the memory bandwidth for a whole campaign; the core is as fast as ever,
    // and the small sets (in the cache) read as before.
    campaign(&store, "hogged", T0 + 200.0, 1.01, 2.6, 0.71).await;
    // Then the core runs 25 % slower, and the reads a little (within their tolerance).
    campaign(&store, "slow", T0 + 300.0, 1.25, 1.45, 0.75).await;
    let shifts = results::machine_history(&store).await.unwrap();
    let named: Vec<(&str, &str, Option<u64>)> = shifts
        .iter()
        .map(|s| (s.campaign.as_str(), s.reference, s.arrays_bytes))
        .collect();
    assert_eq!(
        named,
        [
            ("hogged", "memory", Some(1 << 25)),
            ("slow", "compute", None)
        ],
        "{shifts:#?}"
    );
    let hogged = &shifts[0];
    // 2.6 against the median of 1.30 and 1.35.
    assert!((hogged.ratio - 2.6 / 1.325).abs() < 1e-9, "{hogged:?}");
    assert_eq!(hogged.earlier_campaigns, 2);
    assert!(
        hogged.message.contains("1.96× slower")
            && hogged.message.contains("testhost (Test CPU)")
            && hogged.message.contains("32–64 MiB"),
        "{}",
        hogged.message
    );
    let slow = &shifts[1];
    assert_eq!(slow.earlier_campaigns, 3);
    // Against the median of the three earlier campaigns (1.00, 1.02, 1.01).
    assert!((slow.ratio - 1.25 / 1.01).abs() < 1e-9, "{slow:?}");
}
