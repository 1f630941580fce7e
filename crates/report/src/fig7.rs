//! Figure 7 of De Michele: the time per collision τ_c against the packing fraction φ, one curve
//! per (shape, X0, neighbour method), on a logarithmic τ_c axis so that spheres (≈ 1 µs) and
//! ellipsoids (tens of µs) share the plot.

use std::collections::BTreeMap;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::render::{DrawResult, Drawing, FONT, render};
use crate::{EdmdRow, ReportError};

const WIDTH: u32 = 900;
const HEIGHT: u32 = 620;

/// Draws Figure 7 into `path` (PNG or SVG by its extension). Points of a curve that differ in
/// anything but φ (N, Δ_NNL) are separate curves, so a curve never mixes two kinds of run.
pub fn fig7(rows: &[EdmdRow], path: &Path) -> Result<(), ReportError> {
    render(&Figure::new(rows)?, path)
}

/// Curves by their label, each a list of (φ, τ_c in µs) sorted by φ.
struct Figure {
    curves: BTreeMap<String, Vec<(f64, f64)>>,
}

impl Figure {
    fn new(rows: &[EdmdRow]) -> Result<Self, ReportError> {
        let mut curves: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for r in rows
            .iter()
            .filter(|r| r.tau_c_us > 0.0 && r.tau_c_us.is_finite())
        {
            curves
                .entry(label(r))
                .or_default()
                .push((r.phi, r.tau_c_us));
        }
        if curves.is_empty() {
            return Err(ReportError::NoEdmdRows);
        }
        for points in curves.values_mut() {
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            *points = mean_per_phi(points);
        }
        Ok(Figure { curves })
    }

    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let points = || self.curves.values().flatten();
        let fold = |f: fn(&(f64, f64)) -> f64| {
            points()
                .map(f)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        let (phi_lo, phi_hi) = fold(|p| p.0);
        let (tau_lo, tau_hi) = fold(|p| p.1);
        let pad = ((phi_hi - phi_lo) * 0.05).max(0.01);
        // Room above the curves for the legend (a decade on the logarithmic axis).
        ((phi_lo - pad, phi_hi + pad), (tau_lo / 1.5, tau_hi * 12.0))
    }
}

/// Points sorted by φ with repeated φ (e.g. seeds, or a Δ_NNL that LL ignores) averaged.
fn mean_per_phi(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut merged: Vec<(f64, f64, u32)> = Vec::new();
    for &(phi, tau) in points {
        match merged.last_mut() {
            Some(last) if last.0 == phi => {
                last.1 += tau;
                last.2 += 1;
            }
            _ => merged.push((phi, tau, 1)),
        }
    }
    merged
        .into_iter()
        .map(|(phi, sum, count)| (phi, sum / f64::from(count)))
        .collect()
}

/// "ellipsoid X0 = 2, NNL (Δ = 0.08), N = 256": what distinguishes one kind of run from another.
fn label(r: &EdmdRow) -> String {
    let method = if r.neighbours == "nnl" {
        format!("NNL (Δ = {})", r.delta_nnl)
    } else {
        "LL".to_owned()
    };
    let body = if r.shape == "sphere" {
        "sphere".to_owned()
    } else {
        format!("{} X0 = {}", r.shape, r.x0)
    };
    format!("{body}, {method}, N = {}", r.n)
}

impl Drawing for Figure {
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let ((phi_lo, phi_hi), (tau_lo, tau_hi)) = self.ranges();
        let mut chart = ChartBuilder::on(root)
            .caption("Time per collision τ_c against φ (Eq. 69)", (FONT, 24))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(phi_lo..phi_hi, (tau_lo..tau_hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("φ")
            .y_desc("τ_c (µs)")
            .label_style((FONT, 16))
            .axis_desc_style((FONT, 18))
            .draw()?;
        for (index, (name, points)) in self.curves.iter().enumerate() {
            let colour = Palette99::pick(index).to_rgba();
            chart
                .draw_series(LineSeries::new(
                    points.iter().copied(),
                    colour.stroke_width(2),
                ))?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FONT, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_points_are_averaged_per_phi() {
        let merged = mean_per_phi(&[(0.3, 1.0), (0.3, 3.0), (0.4, 5.0)]);
        assert_eq!(merged, vec![(0.3, 2.0), (0.4, 5.0)]);
    }
}
