//! The report rows of overlap points: each visit re-estimated from its stored blocks, then a
//! point's visits pooled into one row.

use overlap::estimate::{Estimate, Statistic};
use report::OverlapPoint;
use store::Store;

use crate::error::Result;
use crate::overlap::{OverlapVisit, overlap_visits};

/// One row per (point, algorithm), estimated by `statistic`: what Tables 1–2 and Figs. 2–3 read.
pub async fn overlap_points(store: &Store, statistic: Statistic) -> Result<Vec<OverlapPoint>> {
    Ok(pool(overlap_visits(store).await?, statistic))
}

/// Each visit's estimate re-made from its stored blocks by `statistic` (`overlap::estimate`,
/// with its interval), or for jobs measured before blocks were kept the mean over repeats, with
/// Student's interval, whatever `statistic` asked for (the row's `statistic` says `mean`, and
/// so does the table's); then a point's visits pooled by `overlap::estimate::pool_visits` (one
/// visit: its row as it is). `visits` has the visits of a point next to each other, as
/// [`overlap_visits`] orders them.
pub fn pool(visits: Vec<OverlapVisit>, statistic: Statistic) -> Vec<OverlapPoint> {
    let visits: Vec<(OverlapPoint, Option<Estimate>, String)> = visits
        .into_iter()
        .map(|v| {
            let point = v.point.clone();
            let (row, estimate) = visit_row(v, statistic);
            (row, estimate, point)
        })
        .collect();
    visits
        .chunk_by(|a, b| a.2 == b.2 && a.0.algorithm == b.0.algorithm)
        .map(pool_point)
        .collect()
}

/// One visit's row, and its estimate (`None` where it has none).
fn visit_row(v: OverlapVisit, statistic: Statistic) -> (OverlapPoint, Option<Estimate>) {
    let checks_ms = v.configurations as f64 * 1e-6;
    let (estimate, ns_per_check, mean_ms, statistic) = if v.block_ns_per_check.is_empty() {
        let estimate = overlap::estimate::mean_interval(&v.repeat_ns_per_check);
        (estimate, v.ns_per_check, v.mean_ms, Statistic::Mean)
    } else {
        let estimate = overlap::estimate::estimate_with(statistic, &v.block_ns_per_check);
        let ns = estimate.map_or(v.ns_per_check, |e| e.value);
        (estimate, ns, ns * checks_ms, statistic)
    };
    let row = OverlapPoint {
        l_star: v.l_star,
        w_star: v.w_star,
        r_star: v.r_star,
        precision: v.precision,
        algorithm: v.algorithm,
        mean_ms,
        ns_per_check,
        acceptance: v.acceptance,
        repeats: v.repeats,
        disturbed: v.disturbed,
        reruns: v.reruns,
        statistic: statistic.name().to_owned(),
        visits: 1,
        ..OverlapPoint::default()
    };
    // ms per ns/check: the set's size, or for old rows the ratio the repeats' means give.
    let to_ms = if ns_per_check > 0.0 {
        mean_ms / ns_per_check
    } else {
        checks_ms
    };
    (with_interval(row, estimate, to_ms), estimate)
}

/// `row` with the 95 % interval of `estimate`, in ns/check and, times `to_ms`, in ms.
fn with_interval(row: OverlapPoint, estimate: Option<Estimate>, to_ms: f64) -> OverlapPoint {
    let finite = |x: f64| x.is_finite().then_some(x);
    let lo = estimate.and_then(|e| finite(e.lo));
    let hi = estimate.and_then(|e| finite(e.hi));
    OverlapPoint {
        ci95_lo_ns_per_check: lo,
        ci95_hi_ns_per_check: hi,
        ci95_lo_ms: lo.map(|x| x * to_ms),
        ci95_hi_ms: hi.map(|x| x * to_ms),
        ..row
    }
}

/// A point's visits (rows of one point and algorithm) as one row: the mean of their estimates
/// with the pooled interval; a visit without an interval takes part by its value alone.
fn pool_point(visits: &[(OverlapPoint, Option<Estimate>, String)]) -> OverlapPoint {
    let first = &visits[0].0;
    if let [(only, _, _)] = visits {
        return only.clone();
    }
    // Every visit of a point has the same set size, hence the same ms per ns/check.
    let to_ms = if first.ns_per_check > 0.0 {
        first.mean_ms / first.ns_per_check
    } else {
        0.0
    };
    let estimates: Vec<Estimate> = visits
        .iter()
        .map(|(row, estimate, _)| {
            estimate.unwrap_or(Estimate {
                value: row.ns_per_check,
                lo: f64::NAN,
                hi: f64::NAN,
                samples: 0,
                repeats: row.repeats as usize,
            })
        })
        .collect();
    let pooled = overlap::estimate::pool_visits(&estimates);
    let n = visits.len() as f64;
    let mean = |f: fn(&OverlapPoint) -> f64| visits.iter().map(|(r, _, _)| f(r)).sum::<f64>() / n;
    let any_flag = |f: fn(&OverlapPoint) -> Option<bool>| {
        visits
            .iter()
            .filter_map(|(r, _, _)| f(r))
            .reduce(|a, b| a || b)
    };
    let row = OverlapPoint {
        mean_ms: mean(|r| r.mean_ms),
        ns_per_check: pooled.map_or_else(|| mean(|r| r.ns_per_check), |e| e.value),
        acceptance: mean(|r| r.acceptance),
        repeats: visits.iter().map(|(r, _, _)| r.repeats).sum(),
        disturbed: any_flag(|r| r.disturbed),
        reruns: visits
            .iter()
            .filter_map(|(r, _, _)| r.reruns)
            .reduce(|a, b| a + b),
        statistic: report::join_statistics(visits.iter().map(|(r, _, _)| r.statistic.as_str())),
        visits: visits.len() as u32,
        ..first.clone()
    };
    with_interval(row, pooled, to_ms)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A visit of the point at `l_star`, visit `visit`: two sets of 50 blocks, every block
    /// `ns` ± 0.5 %.
    fn visit(l_star: f64, visit: u32, ns: f64) -> OverlapVisit {
        let set: Vec<f64> = (0..50)
            .map(|k| ns * if k % 2 == 0 { 1.005 } else { 0.995 })
            .collect();
        OverlapVisit {
            job_id: format!("{l_star}-{visit}"),
            l_star,
            w_star: 1.0,
            r_star: 5.0,
            acceptance_target: 0.4,
            configurations: 1_000_000,
            precision: "f32".into(),
            algorithm: "qri".into(),
            mean_ms: ns,
            ns_per_check: ns,
            acceptance: 0.4,
            repeats: 2,
            repeat_ns_per_check: vec![ns, ns],
            block_ns_per_check: vec![set.clone(), set],
            disturbed: Some(visit == 1),
            reruns: Some(visit),
            visit,
            point: format!(r#"{{"l_star":{l_star}}}"#),
        }
    }

    #[test]
    fn a_points_visits_pool_into_one_row_and_a_single_visit_is_left_alone() {
        let rows = vec![
            visit(1.0, 0, 10.0),
            visit(1.0, 1, 11.0),
            visit(1.0, 2, 12.0),
            visit(2.0, 0, 20.0),
        ];
        let single = visit_row(visit(2.0, 0, 20.0), Statistic::Mean).0;
        let report = pool(rows, Statistic::Mean);
        assert_eq!(report.len(), 2);
        let (pooled, alone) = (&report[0], &report[1]);
        assert_eq!(alone, &single);
        assert_eq!(alone.visits, 1);
        assert_eq!(pooled.visits, 3);
        assert!((pooled.ns_per_check - 11.0).abs() < 1e-9, "{pooled:?}");
        assert!((pooled.mean_ms - 11.0).abs() < 1e-9);
        // Between visits: t(2) · 1 / √3 (s = 1 for 10, 11, 12), far wider than any visit's own.
        let half = 4.303 / 3f64.sqrt();
        let (lo, hi) = (
            pooled.ci95_lo_ns_per_check.expect("lo"),
            pooled.ci95_hi_ns_per_check.expect("hi"),
        );
        assert!(
            (hi - 11.0 - half).abs() < 1e-6 && (11.0 - lo - half).abs() < 1e-6,
            "{lo} {hi}"
        );
        assert!(
            (pooled.ci95_hi_ms.expect("ms") - hi).abs() < 1e-9,
            "1 ms per ns/check here"
        );
        assert_eq!(
            (pooled.repeats, pooled.reruns, pooled.disturbed),
            (6, Some(3), Some(true))
        );
        assert_eq!(pooled.statistic, "mean");
    }
}
