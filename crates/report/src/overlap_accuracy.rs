//! What accuracy costs in time, for the overlap kernels: each (algorithm, precision) by its
//! ns/check against the fraction of its verdicts that differ from the exact one, on checking sets
//! drawn apart from the timed ones (`verdict_check`, `crates/overlap/src/verdicts.rs`): the bulk
//! (drawn as the timed sets, the papers' benchmark) and a shell of near-touching configurations
//! at relative gaps spread over decades, which tells down to which gap a setting can be trusted.
//! [`crate::overlap_accuracy_render`] draws it.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::algorithm_rank;

/// One algorithm at one overlap point with a checking set (`sweep report accuracy` reads these
/// from the `overlap_verdicts` view).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VerdictRow {
    pub l_star: f64,
    pub w_star: f64,
    pub r_star: f64,
    pub precision: String,
    pub algorithm: String,
    pub ns_per_check: f64,
    pub bulk: u64,
    pub shell: u64,
    pub bulk_wrong: u64,
    pub shell_wrong: u64,
    /// Decade k of the shell holds relative gaps in [max·10⁻ᵏ⁻¹, max·10⁻ᵏ).
    pub shell_max_gap: f64,
    pub shell_by_decade: Vec<u64>,
    pub shell_wrong_by_decade: Vec<u64>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OverlapAccuracy {
    /// One per (algorithm, precision), in the papers' order of algorithms, f32 first.
    pub settings: Vec<PrecisionSetting>,
    /// The cheapest setting that gave no wrong verdict in the bulk (the papers' benchmark).
    pub recommended: Option<Recommended>,
    /// The shell's gaps per decade: decade k is `gap_edges[k]` to `gap_edges[k + 1]`.
    pub gap_edges: Vec<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Recommended {
    pub algorithm: String,
    pub precision: String,
    pub ns_per_check: f64,
    /// Below this relative gap its verdicts may be wrong (the upper edge of the widest decade
    /// where one was), `None` if none was.
    pub trusted_above_gap: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PrecisionSetting {
    pub algorithm: String,
    pub precision: String,
    pub points: usize,
    /// Geometric mean over the points of the mean ns/check.
    pub ns_per_check: f64,
    pub bulk: u64,
    pub bulk_wrong: u64,
    pub bulk_wrong_fraction: f64,
    pub shell: u64,
    pub shell_wrong: u64,
    pub shell_wrong_fraction: f64,
    /// Fraction wrong in each decade of the shell.
    pub shell_wrong_fraction_by_decade: Vec<f64>,
    /// See `Recommended::trusted_above_gap`.
    pub trusted_above_gap: Option<f64>,
    /// No wrong verdict in the bulk.
    pub safe: bool,
    /// Not beaten in both ns/check and shell errors by the other precision of its algorithm.
    pub pareto_in_algorithm: bool,
    /// ... nor by any other setting.
    pub pareto: bool,
}

/// The overlap family of the accuracy report; `None` when no point had a checking set.
pub fn overlap_accuracy(rows: &[VerdictRow]) -> Option<OverlapAccuracy> {
    let first = rows.first()?;
    let decades = first.shell_by_decade.len();
    let gap_edges = (0..=decades)
        .map(|k| first.shell_max_gap * 10f64.powi(-(k as i32)))
        .collect();
    let mut groups: BTreeMap<((usize, &str), &str), Vec<&VerdictRow>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.shell_by_decade.len() == decades) {
        groups
            .entry((algorithm_rank(&r.algorithm), &r.precision))
            .or_default()
            .push(r);
    }
    let mut settings: Vec<PrecisionSetting> = groups
        .into_iter()
        .map(|(((_, algorithm), precision), runs)| summarise(algorithm, precision, &runs, first))
        .collect();
    mark_pareto(&mut settings);
    let recommended = settings
        .iter()
        .filter(|s| s.safe)
        .min_by(|a, b| a.ns_per_check.total_cmp(&b.ns_per_check))
        .map(|s| Recommended {
            algorithm: s.algorithm.clone(),
            precision: s.precision.clone(),
            ns_per_check: s.ns_per_check,
            trusted_above_gap: s.trusted_above_gap,
        });
    Some(OverlapAccuracy {
        settings,
        recommended,
        gap_edges,
    })
}

fn fraction(part: u64, whole: u64) -> f64 {
    if whole == 0 {
        0.0
    } else {
        part as f64 / whole as f64
    }
}

fn summarise(
    algorithm: &str,
    precision: &str,
    runs: &[&VerdictRow],
    first: &VerdictRow,
) -> PrecisionSetting {
    let sum = |f: fn(&VerdictRow) -> u64| runs.iter().map(|r| f(r)).sum::<u64>();
    let decades = first.shell_by_decade.len();
    let per_decade = |k: usize| {
        let whole: u64 = runs.iter().map(|r| r.shell_by_decade[k]).sum();
        let wrong: u64 = runs.iter().map(|r| r.shell_wrong_by_decade[k]).sum();
        (wrong, whole)
    };
    let by_decade: Vec<f64> = (0..decades)
        .map(|k| {
            let (wrong, whole) = per_decade(k);
            fraction(wrong, whole)
        })
        .collect();
    // Decades run from the widest gap down: the first with a wrong verdict bounds the trust.
    let trusted_above_gap = (0..decades)
        .find(|&k| per_decade(k).0 > 0)
        .map(|k| first.shell_max_gap * 10f64.powi(-(k as i32)));
    let (bulk, bulk_wrong) = (sum(|r| r.bulk), sum(|r| r.bulk_wrong));
    let (shell, shell_wrong) = (sum(|r| r.shell), sum(|r| r.shell_wrong));
    let log_mean = runs
        .iter()
        .map(|r| r.ns_per_check.max(f64::MIN_POSITIVE).ln())
        .sum::<f64>()
        / runs.len().max(1) as f64;
    PrecisionSetting {
        algorithm: algorithm.to_owned(),
        precision: precision.to_owned(),
        points: runs.len(),
        ns_per_check: log_mean.exp(),
        bulk,
        bulk_wrong,
        bulk_wrong_fraction: fraction(bulk_wrong, bulk),
        shell,
        shell_wrong,
        shell_wrong_fraction: fraction(shell_wrong, shell),
        shell_wrong_fraction_by_decade: by_decade,
        trusted_above_gap,
        safe: bulk_wrong == 0,
        pareto_in_algorithm: false,
        pareto: false,
    }
}

fn dominates(a: &PrecisionSetting, b: &PrecisionSetting) -> bool {
    a.ns_per_check <= b.ns_per_check
        && a.shell_wrong_fraction <= b.shell_wrong_fraction
        && (a.ns_per_check < b.ns_per_check || a.shell_wrong_fraction < b.shell_wrong_fraction)
}

fn mark_pareto(settings: &mut [PrecisionSetting]) {
    let flags: Vec<(bool, bool)> = settings
        .iter()
        .map(|s| {
            let beaten_by = |same_algorithm: bool| {
                settings.iter().any(|o| {
                    (!same_algorithm || o.algorithm == s.algorithm) && o.safe && dominates(o, s)
                })
            };
            (s.safe && !beaten_by(true), s.safe && !beaten_by(false))
        })
        .collect();
    for (s, (in_algorithm, overall)) in settings.iter_mut().zip(flags) {
        s.pareto_in_algorithm = in_algorithm;
        s.pareto = overall;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::overlap_accuracy_render::overlap_markdown;

    fn row(
        algorithm: &str,
        precision: &str,
        ns: f64,
        bulk_wrong: u64,
        wrong: [u64; 3],
    ) -> VerdictRow {
        VerdictRow {
            l_star: 2.0,
            w_star: 3.0,
            r_star: 0.5,
            precision: precision.into(),
            algorithm: algorithm.into(),
            ns_per_check: ns,
            bulk: 1000,
            shell: 300,
            bulk_wrong,
            shell_wrong: wrong.iter().sum(),
            shell_max_gap: 1e-3,
            shell_by_decade: vec![100; 3],
            shell_wrong_by_decade: wrong.to_vec(),
        }
    }

    #[test]
    fn the_cheapest_setting_right_in_the_bulk_is_recommended() {
        let rows = vec![
            row("ocsi", "f32", 1.0, 0, [0, 0, 40]),
            row("ocsi", "f64", 1.5, 0, [0, 0, 2]),
            row("ocsi_batch", "f32", 0.3, 2, [0, 30, 50]),
            row("ocsi_batch", "f64", 0.6, 0, [0, 0, 0]),
            row("arvo", "f64", 3.0, 0, [0, 0, 0]),
        ];
        let report = overlap_accuracy(&rows).expect("rows with checks");
        let names: Vec<(&str, &str)> = report
            .settings
            .iter()
            .map(|s| (s.algorithm.as_str(), s.precision.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                ("arvo", "f64"),
                ("ocsi", "f32"),
                ("ocsi", "f64"),
                ("ocsi_batch", "f32"),
                ("ocsi_batch", "f64")
            ]
        );
        let batch_f32 = &report.settings[3];
        assert!(!batch_f32.safe && !batch_f32.pareto);
        assert_eq!(batch_f32.trusted_above_gap, Some(1e-4));
        assert!((batch_f32.shell_wrong_fraction - 80.0 / 300.0).abs() < 1e-12);
        let recommended = report.recommended.as_ref().expect("a safe setting");
        assert_eq!(
            (
                recommended.algorithm.as_str(),
                recommended.precision.as_str()
            ),
            ("ocsi_batch", "f64")
        );
        assert_eq!(recommended.trusted_above_gap, None);
        // ocsi_batch f64 is faster and never wrong: it dominates every other setting overall;
        // within OCSI, f32 is cheaper and f64 more accurate: both on the algorithm's front.
        assert!(report.settings[4].pareto);
        assert_eq!(report.settings.iter().filter(|s| s.pareto).count(), 1);
        assert!(report.settings[1].pareto_in_algorithm && report.settings[2].pareto_in_algorithm);
        for (edge, expected) in report.gap_edges.iter().zip([1e-3, 1e-4, 1e-5, 1e-6]) {
            assert!(
                (edge / expected - 1.0).abs() < 1e-12,
                "{:?}",
                report.gap_edges
            );
        }
        let mut text = String::new();
        overlap_markdown(&report, &mut text);
        assert!(
            text.contains("**Recommended: OCSI batch in f64**"),
            "{text}"
        );
        assert!(overlap_accuracy(&[]).is_none());
    }
}
