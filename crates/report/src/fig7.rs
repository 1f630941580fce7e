//! Figure 7 of De Michele: the time per collision τ_c against the packing fraction φ, one curve
//! per (shape, X0, neighbour method), on a logarithmic τ_c axis so that spheres (≈ 1 µs) and
//! ellipsoids (tens of µs) share the plot.

use std::collections::BTreeMap;
use std::path::Path;

use crate::lines::{LinePlot, Panel, Series, Style};
use crate::render::{render, render_svg};
use crate::selection::{Baseline, mean_by_x, timed};
use crate::{EdmdRow, ReportError, tau_label};

/// Draws Figure 7 into `path` (PNG or SVG by its extension). Points of a curve that differ in
/// anything but φ (N, Δ_NNL) are separate curves, so a curve never mixes two kinds of run; runs
/// off the campaign's baseline accuracy knobs and Δ_NNL (the sweeps of Figs. 9–11) are left out.
pub fn fig7(rows: &[EdmdRow], path: &Path) -> Result<(), ReportError> {
    render(&plot(rows)?, path)
}

/// Figure 7 as [`fig7`] draws it, as an SVG document in memory.
pub fn fig7_svg(rows: &[EdmdRow]) -> Result<String, ReportError> {
    render_svg(&plot(rows)?)
}

fn plot(rows: &[EdmdRow]) -> Result<LinePlot, ReportError> {
    let baseline = Baseline::of(rows);
    let mut curves: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows.iter().filter(|r| timed(r) && baseline.at_baseline(r)) {
        curves
            .entry(label(r))
            .or_default()
            .push((r.phi, r.tau_c_us));
    }
    if curves.is_empty() {
        return Err(ReportError::NoEdmdRows);
    }
    let series = curves
        .into_iter()
        .enumerate()
        .map(|(colour, (label, points))| Series {
            label,
            points: mean_by_x(points.into_iter())
                .into_iter()
                .map(|(x, y, _)| (x, y))
                .collect(),
            style: Style::Measured,
            colour,
        })
        .collect();
    let panel = Panel {
        title: "Time per collision τ_c against φ (Eq. 69)".into(),
        x_desc: "φ".into(),
        y_desc: tau_label(rows.iter()),
        x_log: false,
        y_log: true,
        series,
        notes: Vec::new(),
    };
    Ok(LinePlot::single(panel))
}

/// "ellipsoid X0 = 2, NNL (Δ = 0.08), N = 256": what distinguishes one kind of run from another.
fn label(r: &EdmdRow) -> String {
    let method = if r.neighbours == "nnl" {
        format!("NNL (Δ = {})", r.delta_nnl)
    } else {
        "LL".to_owned()
    };
    let body = match (r.shape.as_str(), r.exponents) {
        ("sphere", _) => "sphere".to_owned(),
        // Superquadrics of other exponents are other bodies: never one curve.
        (shape, Some([n, m, p])) => format!("{shape} X0 = {}, exponents [{n}, {m}, {p}]", r.x0),
        (shape, None) => format!("{shape} X0 = {}", r.x0),
    };
    format!("{body}, {method}, N = {}", r.n)
}
