//! The accuracy report drawn (`accuracy` measures it): Markdown, the overlap kernels' section
//! first, and the plot of cost against what each setting loses.

use std::fmt::Write as _;
use std::path::Path;

use crate::ReportError;
use crate::accuracy::{AccuracyReport, COST_NOISE, MAX_ENERGY_DRIFT, MAX_Z_SIGMAS, SettingSummary};
use crate::lines::{LinePlot, Panel, Series, Style};
use crate::overlap_accuracy_render::{overlap_markdown, overlap_panels};
use crate::render::render;
use crate::selection::Key;

/// The report as Markdown: per knob, the summary table and the recommendation, then the runs of
/// each state point.
pub fn accuracy_markdown(report: &AccuracyReport) -> String {
    let mut out = String::from("# What accuracy costs in time\n\n");
    if let Some(overlap) = &report.overlap {
        overlap_markdown(overlap, &mut out);
    }
    if !report.knobs.is_empty() {
        out.push_str("## EDMD\n\n");
    }
    let _ = writeln!(
        out,
        "A setting is *safe* when every run of it finished (none failed for good) and its runs found no overlap and no solver failure, drifted in energy by at most {MAX_ENERGY_DRIFT:e} (relative), and kept Z within {MAX_Z_SIGMAS} combined standard errors of the tightest setting's run at the same state point. Cost is τ_c over τ_c at the tightest setting (geometric mean over state points). *Identical for* is how many collisions, from the first of the run, the event sequence stayed the same as the tightest setting's run from the same seed (to a block of 64; the fewest over the state points).\n"
    );
    for study in &report.knobs {
        let _ = writeln!(out, "### {} ({} is tighter)\n", study.knob, study.tighter);
        let _ = writeln!(
            out,
            "| {} | state points | cost (τ_c / τ_c,ref) | max \\|ΔZ\\|/Z | max \\|ΔZ\\|/σ | max energy drift | overlaps | solver failures | failed runs | NR fallbacks | identical for (collisions) | safe | Pareto |",
            study.knob
        );
        out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        for s in &study.settings {
            let _ = writeln!(
                out,
                "| {:e} | {} | {} | {:.2e} | {} | {:.1e} | {} | {} | {} | {} | {} | {} | {} |",
                s.value,
                s.state_points,
                s.cost_ratio.map_or("–".to_owned(), |c| format!("{c:.3}")),
                s.max_z_deviation_rel,
                s.max_z_deviation_sigmas
                    .map_or("–".to_owned(), |v| format!("{v:.2}")),
                s.max_energy_drift_rel,
                s.overlaps,
                s.solver_failures,
                s.failed_runs,
                s.contact_nr_fallbacks,
                s.min_identical_collisions
                    .map_or("–".to_owned(), |c| c.to_string()),
                if s.safe { "yes" } else { "**no**" },
                if s.pareto { "●" } else { "" },
            );
        }
        match study.recommended {
            Some(v) => {
                let _ = writeln!(
                    out,
                    "\n**Recommended: {} = {v:e}** — the tightest setting within {:.0} % of the cheapest one that lost nothing measurable, at the {} state point(s) it ran at.\n",
                    study.knob,
                    COST_NOISE * 100.0,
                    study
                        .settings
                        .iter()
                        .find(|s| Key(s.value) == Key(v))
                        .map_or(0, |s| s.state_points)
                );
            }
            None => {
                let _ = writeln!(out, "\nNo setting of {} was safe everywhere.\n", study.knob);
            }
        }
        let _ = writeln!(out, "#### {} by state point\n", study.knob);
        out.push_str("| state point | value | τ_c (µs) | cost | Z | ΔZ/σ | energy drift | overlaps | failures | NR iterations | identical for (of compared) | Δt_u share (Eq. 73) |\n");
        out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        for p in &study.state_points {
            let point = format!(
                "{}{} X0 = {}, φ = {}, N = {}, {}{}",
                p.shape,
                p.exponents
                    .map_or(String::new(), |[n, m, q]| format!(" [{n}, {m}, {q}]")),
                p.x0,
                p.phi,
                p.n,
                p.neighbours.to_uppercase(),
                if p.neighbours == "nnl" {
                    format!(" Δ = {}", p.delta_nnl)
                } else {
                    String::new()
                }
            );
            for r in &p.runs {
                let _ = writeln!(
                    out,
                    "| {point} | {:e}{} | {:.2} | {:.3} | {:.4} ± {} | {} | {:.1e} | {} | {} | {:.2} | {} | {} |",
                    r.value,
                    if Key(r.value) == Key(p.reference) {
                        " (ref)"
                    } else {
                        ""
                    },
                    r.tau_c_us,
                    r.cost_ratio,
                    r.pressure_z,
                    r.pressure_z_err
                        .map_or("–".to_owned(), |e| format!("{e:.4}")),
                    r.z_deviation_sigmas
                        .map_or("–".to_owned(), |v| format!("{v:.2}")),
                    r.energy_drift_rel,
                    r.overlaps,
                    r.solver_failures,
                    r.nr_iterations_mean,
                    match (r.identical_collisions, r.compared_collisions) {
                        (Some(same), Some(compared)) => format!("{same} of {compared}"),
                        _ => "–".to_owned(),
                    },
                    r.update_share
                        .map_or("–".to_owned(), |s| format!("{:.0} %", 100.0 * s)),
                );
            }
            for f in &p.failed {
                let _ = writeln!(
                    out,
                    "| {point} | {:e} | **failed**: {} | | | | | | | | | |",
                    f.value,
                    table_cell(&f.reason),
                );
            }
        }
        out.push('\n');
    }
    if !report.missing.is_empty() {
        out.push_str("## Missing points\n\n");
        for line in &report.missing {
            let _ = writeln!(out, "- {line}");
        }
        out.push('\n');
    }
    if !report.not_measured.is_empty() {
        out.push_str("## Not measured\n\n");
        for line in &report.not_measured {
            let _ = writeln!(out, "- {line}");
        }
    }
    out
}

/// `text` on one line of a Markdown table cell, at most 200 characters.
fn table_cell(text: &str) -> String {
    let line: String = text
        .chars()
        .map(|c| match c {
            '|' => '/',
            '\n' | '\r' => ' ',
            c => c,
        })
        .collect();
    match line.char_indices().nth(200) {
        Some((cut, _)) => format!("{}…", &line[..cut]),
        None => line,
    }
}

/// The overlap kernels' panels (`overlap_panels`), then cost against Z deviation,
/// one panel per knob: the Pareto front as a line, other safe settings as triangles, settings
/// that lost something as red crosses, each point labelled.
pub fn accuracy_plot(report: &AccuracyReport, path: &Path) -> Result<(), ReportError> {
    let mut panels: Vec<Panel> = report
        .overlap
        .as_ref()
        .map(overlap_panels)
        .unwrap_or_default();
    let knob_panels = report.knobs.iter().map(|study| {
        // A setting whose every run failed has no cost to place; the table lists it.
        let point = |s: &SettingSummary| Some((s.cost_ratio?, s.max_z_deviation_rel * 100.0));
        let points_of = |keep: fn(&SettingSummary) -> bool| -> Vec<(f64, f64)> {
            study
                .settings
                .iter()
                .filter(|s| keep(s))
                .filter_map(point)
                .collect()
        };
        let mut front = points_of(|s| s.pareto);
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        let others = points_of(|s| s.safe && !s.pareto);
        let lost = points_of(|s| !s.safe);
        let notes = study
            .settings
            .iter()
            .filter_map(|s| {
                let mark = if study.recommended.is_some_and(|v| Key(v) == Key(s.value)) {
                    " (recommended)"
                } else {
                    ""
                };
                Some((point(s)?, format!(" {:e}{mark}", s.value)))
            })
            .collect();
        let series = [
            ("Pareto front (safe)", front, Style::Measured),
            ("safe, dominated", others, Style::Located),
            (
                "lost accuracy (failed runs, overlaps, solver failures, drift or Z)",
                lost,
                Style::Flagged,
            ),
        ]
        .into_iter()
        .filter(|(_, points, _)| !points.is_empty())
        .map(|(label, points, style)| Series {
            label: label.into(),
            points,
            style,
            colour: 0,
        })
        .collect();
        Panel {
            title: format!("EDMD: {} ({} is tighter)", study.knob, study.tighter),
            x_desc: "cost: τ_c / τ_c at the tightest setting".into(),
            y_desc: "max |ΔZ| / Z (%)".into(),
            x_log: false,
            y_log: false,
            series,
            notes,
        }
    });
    panels.extend(knob_panels);
    render(
        &LinePlot {
            title: "What accuracy costs in time".into(),
            panels,
            columns: 2,
        },
        path,
    )
}
