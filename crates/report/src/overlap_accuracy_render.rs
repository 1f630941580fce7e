//! The overlap kernels' part of the accuracy report drawn (`overlap_accuracy` measures it): its
//! Markdown section and its two panels of the accuracy plot.

use std::fmt::Write as _;

use crate::algorithm_title;
use crate::lines::{Panel, Series, Style};
use crate::overlap_accuracy::{OverlapAccuracy, PrecisionSetting};

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
