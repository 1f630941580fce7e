//! The blocked protocol measures the same thing as whole passes, keeps every block, and stops
//! as its goal says.

use overlap::batch::{verdict, verdict_words};
use overlap::protocol::{block_configurations, count_overlaps};
use overlap::sampler::generate;
use overlap::{
    Algorithm, Calibration, Cuboid, OverlapError, PointSpec, Precision, Stop, run_point,
};

fn spec(configurations: u64, repeats: u32) -> PointSpec {
    PointSpec {
        l_star: 4.0,
        w_star: 8.0,
        r_star: 5.0,
        acceptance: 0.4,
        configurations,
        repeats,
        precision: Precision::F32,
        algorithms: vec![Algorithm::Qri, Algorithm::Ocsi, Algorithm::OcsiBatch],
        seed: 9,
        ci_target: None,
        time_cap_s: None,
        verdict_check: None,
        visit: None,
        plugins: Vec::new(),
    }
}

/// Counting block by block gives the whole set's count and, for the batched kernel, the same
/// verdict bits, including a last block that is not a multiple of 16 or 64.
#[test]
fn blocks_count_what_the_whole_pass_counts() {
    let n = 10_007;
    let point = spec(n as u64, 1);
    let batch = generate::<f32>(&point.spherocuboid(), n, 3);
    let cuboid = Cuboid::<f32>::from_reduced(point.l_star, point.w_star);
    let block = block_configurations(n);
    assert_eq!(block % 64, 0);
    for algorithm in Algorithm::ALL {
        let mut whole_bits = vec![0u64; verdict_words(n)];
        let whole = count_overlaps(algorithm, batch.view(), &cuboid, 5.0, &mut whole_bits);
        let mut bits = vec![0u64; verdict_words(n)];
        let blocked: u64 = (0..n)
            .step_by(block)
            .map(|start| {
                let range = start..(start + block).min(n);
                let words = &mut bits[start / 64..][..verdict_words(range.len())];
                count_overlaps(algorithm, batch.view().range(range), &cuboid, 5.0, words)
            })
            .sum();
        assert_eq!(blocked, whole, "{algorithm}");
        if algorithm == Algorithm::OcsiBatch {
            assert!((0..n).all(|i| verdict(&bits, i) == verdict(&whole_bits, i)));
            assert_eq!(bits, whole_bits, "no bit past the last configuration");
        }
    }
}

#[test]
fn block_sizes() {
    assert_eq!(block_configurations(2_000_000), 16_384);
    assert_eq!(block_configurations(200_000), 3_136);
    assert_eq!(block_configurations(1000), 1024);
}

/// Every pass keeps its blocks; they tile it (their times add up to the pass); the summary's
/// interval holds its estimate; the references are measured.
#[test]
fn a_point_keeps_its_blocks() {
    let point = spec(20_000, 2);
    let report = run_point(&point, &mut Calibration::default(), &mut |_| {}).expect("runs");
    assert_eq!(report.timings.len(), 2 * 3);
    assert_eq!((report.repeats, report.stop), (2, Stop::Repeats));
    let blocks = 20_000usize.div_ceil(report.block_configurations as usize);
    for t in &report.timings {
        assert_eq!(t.block_ns_per_check.len(), blocks);
        // Σ ns/check × checks of each block = the pass; the last block is the short one.
        let sizes = (0..blocks).map(|b| {
            (20_000 - b * report.block_configurations as usize)
                .min(report.block_configurations as usize)
        });
        let sum_ms: f64 = t
            .block_ns_per_check
            .iter()
            .zip(sizes)
            .map(|(ns, k)| ns * k as f64 * 1e-6)
            .sum();
        assert!(
            (sum_ms / t.total_ms - 1.0).abs() < 1e-9,
            "{sum_ms} vs {}",
            t.total_ms
        );
        assert!((t.acceptance - 0.4).abs() < 0.03);
    }
    for s in report.summary() {
        assert!(
            s.ci95_lo_ns_per_check <= s.ns_per_check && s.ns_per_check <= s.ci95_hi_ns_per_check,
            "{s:?}"
        );
        assert!((s.mean_ms / (s.ns_per_check * 20_000.0 * 1e-6) - 1.0).abs() < 1e-12);
    }
    let r = report.references;
    assert!(
        r.compute_ns_before > 0.0
            && r.compute_ns_after > 0.0
            && r.stream_ns_before > 0.0
            && r.stream_ns_after > 0.0
    );
    assert!(report.wall_s >= report.timed_s && report.timed_s > 0.0);
}

/// With a target no measurement can reach, the cap stops it, after the sets asked for; with a
/// target any measurement reaches, it stops as precise.
#[test]
fn ci_target_and_time_cap() {
    let easy = PointSpec {
        ci_target: Some(0.9),
        ..spec(20_000, 2)
    };
    let report = run_point(&easy, &mut Calibration::default(), &mut |_| {}).expect("runs");
    // Usually after the two sets asked for; a test machine busy with other tests may need more.
    assert_eq!(report.stop, Stop::Precise);
    assert!(report.repeats >= 2);

    let impossible = PointSpec {
        ci_target: Some(1e-9),
        time_cap_s: Some(0.05),
        ..spec(20_000, 2)
    };
    let report = run_point(&impossible, &mut Calibration::default(), &mut |_| {}).expect("runs");
    assert_eq!(report.stop, Stop::TimeCap);
    assert!(report.repeats >= 2);
}

#[test]
fn precision_keys_are_checked() {
    let key = |p: PointSpec| match p.validate() {
        Err(OverlapError::Invalid { key, .. }) => Some(key),
        Err(other) => panic!("{other}"),
        Ok(()) => None,
    };
    assert_eq!(
        key(PointSpec {
            ci_target: Some(0.0),
            ..spec(100, 1)
        }),
        Some("ci_target")
    );
    assert_eq!(
        key(PointSpec {
            ci_target: Some(1.5),
            ..spec(100, 1)
        }),
        Some("ci_target")
    );
    assert_eq!(
        key(PointSpec {
            time_cap_s: Some(10.0),
            ..spec(100, 1)
        }),
        Some("time_cap_s")
    );
    assert_eq!(
        key(PointSpec {
            ci_target: Some(0.01),
            time_cap_s: Some(-1.0),
            ..spec(100, 1)
        }),
        Some("time_cap_s")
    );
    assert_eq!(
        key(PointSpec {
            ci_target: Some(0.01),
            time_cap_s: Some(10.0),
            ..spec(100, 1)
        }),
        None
    );
}
