//! What accuracy costs in time, for the overlap kernels: each (algorithm, precision) by its
//! ns/check against the fraction of its verdicts that differ from the exact one, on checking sets
//! drawn apart from the timed ones (`verdict_check`, `crates/overlap/src/verdicts.rs`): the bulk
//! (drawn as the timed sets, the papers' benchmark) and a shell of near-touching configurations
//! at relative gaps spread over decades, which tells down to which gap a setting can be trusted.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::lines::{Panel, Series, Style};
use crate::{algorithm_rank, algorithm_title};

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
    /// The shell's gaps per decade: decade k is [`gap_edges`][k] to [`gap_edges`][k + 1].
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
    /// See [`Recommended::trusted_above_gap`].
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

fn gap(x: Option<f64>) -> String {
    x.map_or("all gaps".to_owned(), |g| format!("{g:.0e}"))
}

/// The overlap section of the accuracy report in Markdown.
pub fn overlap_markdown(report: &OverlapAccuracy, out: &mut String) {
    out.push_str("## Overlap kernels: f32 against f64\n\n");
    let decades = report.gap_edges.len().saturating_sub(1);
    let _ = writeln!(
        out,
        "Verdicts judged against Eq. 2 evaluated exactly, on checking sets drawn apart from the timed ones: the *bulk* is drawn as the timed sets are (the papers' benchmark), the *shell* holds near-touching configurations at relative gaps from {:.0e} to {:.0e} ({decades} decades). A setting is *safe* with no wrong verdict in the bulk; *trusted above* is the widest gap at which a verdict was wrong. ns/check is the geometric mean over the points.\n",
        report.gap_edges.last().copied().unwrap_or(f64::NAN),
        report.gap_edges.first().copied().unwrap_or(f64::NAN),
    );
    out.push_str("| algorithm | precision | points | ns/check | bulk wrong | shell wrong | trusted above gap | safe | Pareto (algorithm) | Pareto (all) |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for s in &report.settings {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.2} | {} / {} ({:.1e}) | {} / {} ({:.2} %) | {} | {} | {} | {} |",
            algorithm_title(&s.algorithm),
            s.precision,
            s.points,
            s.ns_per_check,
            s.bulk_wrong,
            s.bulk,
            s.bulk_wrong_fraction,
            s.shell_wrong,
            s.shell,
            100.0 * s.shell_wrong_fraction,
            gap(s.trusted_above_gap),
            if s.safe { "yes" } else { "**no**" },
            if s.pareto_in_algorithm { "●" } else { "" },
            if s.pareto { "●" } else { "" },
        );
    }
    match &report.recommended {
        Some(r) => {
            let _ = writeln!(
                out,
                "\n**Recommended: {} in {}** ({:.2} ns/check), the cheapest setting with no wrong verdict in the bulk; its verdicts can be wrong only for spheres within a relative gap of {} of touching. Where closer contacts matter, take the cheapest f64 setting of the table.\n",
                algorithm_title(&r.algorithm),
                r.precision,
                r.ns_per_check,
                gap(r.trusted_above_gap)
            );
        }
        None => out.push_str("\nNo setting was free of wrong verdicts in the bulk.\n\n"),
    }
}

/// Two panels: ns/check against the shell's wrong fraction (the Pareto front as a line), and the
/// wrong fraction per decade of gap, worst algorithm of each precision.
pub(crate) fn overlap_panels(report: &OverlapAccuracy) -> Vec<Panel> {
    let point = |s: &PrecisionSetting| (s.ns_per_check, 100.0 * s.shell_wrong_fraction);
    let mut front: Vec<(f64, f64)> = report
        .settings
        .iter()
        .filter(|s| s.pareto)
        .map(point)
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut series = vec![Series {
        label: "Pareto front".into(),
        points: front,
        style: Style::Measured,
        colour: 0,
    }];
    for (colour, precision) in ["f32", "f64"].into_iter().enumerate() {
        let points: Vec<(f64, f64)> = report
            .settings
            .iter()
            .filter(|s| s.precision == precision)
            .map(point)
            .collect();
        if !points.is_empty() {
            series.push(Series {
                label: precision.into(),
                points,
                style: Style::Located,
                colour: colour + 1,
            });
        }
    }
    let notes = report
        .settings
        .iter()
        .map(|s| {
            let mark = match &report.recommended {
                Some(r) if r.algorithm == s.algorithm && r.precision == s.precision => {
                    " (recommended)"
                }
                _ => "",
            };
            (
                point(s),
                format!(" {} {}{mark}", algorithm_title(&s.algorithm), s.precision),
            )
        })
        .collect();
    let cost = Panel {
        title: "Overlap kernels: cost against wrong verdicts near contact".into(),
        x_desc: "ns/check (geometric mean over points)".into(),
        y_desc: "wrong verdicts in the near-contact shell (%)".into(),
        x_log: true,
        y_log: false,
        series,
        notes,
    };
    let mids: Vec<f64> = report
        .gap_edges
        .windows(2)
        .map(|w| (w[0] * w[1]).sqrt())
        .collect();
    let by_gap = ["f32", "f64"]
        .into_iter()
        .enumerate()
        .filter_map(|(colour, precision)| {
            let settings: Vec<&PrecisionSetting> = report
                .settings
                .iter()
                .filter(|s| s.precision == precision)
                .collect();
            (!settings.is_empty()).then(|| Series {
                label: format!("{precision}, worst algorithm"),
                points: mids
                    .iter()
                    .enumerate()
                    .map(|(k, &x)| {
                        let worst = settings
                            .iter()
                            .map(|s| {
                                s.shell_wrong_fraction_by_decade
                                    .get(k)
                                    .copied()
                                    .unwrap_or(0.0)
                            })
                            .fold(0.0, f64::max);
                        (x, 100.0 * worst)
                    })
                    .collect(),
                style: Style::Measured,
                colour: colour + 1,
            })
        })
        .collect();
    let gaps = Panel {
        title: "Overlap kernels: wrong verdicts by distance from contact".into(),
        x_desc: "relative gap |d − R| / R (decade's centre)".into(),
        y_desc: "wrong verdicts (%)".into(),
        x_log: true,
        y_log: false,
        series: by_gap,
        notes: Vec::new(),
    };
    vec![cost, gaps]
}

#[cfg(test)]
mod tests {
    use super::*;

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
