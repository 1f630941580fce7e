//! Figure 10 of De Michele: τ_c against the neighbour lists' Δ_NNL per state point, with the
//! minimum located by a parabola in log Δ (the curves are `curves::delta_curves`, which Fig. 11
//! reads too).

use std::path::Path;

use serde::Serialize;

use crate::curves::{KnobCurve, PAPER_X0, delta_curves, ellipsoids, same, unbracketed, xy};
use crate::lines::{LinePlot, Panel, Series, Style};
use crate::render::{drawn, render};
use crate::units::LengthUnit;
use crate::{EdmdRow, ReportError, tau_label};

const FIG10_PHI: [f64; 2] = [0.45, 0.57];

/// Fig. 10: τ_c against Δ_NNL per state point, with the minimum located by a parabola in log Δ.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fig10 {
    pub length_unit: LengthUnit,
    pub tau_c: String,
    pub curves: Vec<KnobCurve>,
    pub missing: Vec<String>,
}

impl Fig10 {
    pub fn new(rows: &[EdmdRow], unit: LengthUnit) -> Result<Self, ReportError> {
        let curves = delta_curves(rows, unit);
        let mut missing = Vec::new();
        for x0 in PAPER_X0 {
            for phi in FIG10_PHI {
                if !curves.iter().any(|c| same(c.x0, x0) && same(c.phi, phi)) {
                    missing.push(format!(
                        "ellipsoid NNL runs at X0 = {x0}, φ = {phi} over three or more Δ_NNL around the minimum"
                    ));
                }
            }
        }
        missing.extend(unbracketed(&curves, unit));
        if curves.is_empty() {
            return Err(ReportError::MissingPoints {
                figure: "fig10",
                missing,
            });
        }
        Ok(Self {
            length_unit: unit,
            tau_c: tau_label(ellipsoids(rows)),
            curves,
            missing,
        })
    }

    pub fn draw(&self, path: &Path) -> Result<(), ReportError> {
        let mut phis: Vec<f64> = self.curves.iter().map(|c| c.phi).collect();
        phis.sort_by(f64::total_cmp);
        phis.dedup_by(|a, b| same(*a, *b));
        let panels = phis
            .iter()
            .map(|&phi| {
                let mut series = Vec::new();
                for (colour, c) in self.curves.iter().filter(|c| same(c.phi, phi)).enumerate() {
                    series.push(Series {
                        label: format!("X0 = {}, N = {}", c.x0, c.n),
                        points: xy(&c.points),
                        style: Style::Measured,
                        colour,
                    });
                    if let Some(m) = c.optimum.as_ref().and_then(|o| o.minimum) {
                        let located = m.bracketed();
                        series.push(Series {
                            label: if located {
                                format!("Δ* = {:.3} (fit), X0 = {}", m.x, c.x0)
                            } else {
                                format!("minimum not bracketed, X0 = {}", c.x0)
                            },
                            points: vec![(m.x, m.y)],
                            style: if located {
                                Style::Located
                            } else {
                                Style::Flagged
                            },
                            colour,
                        });
                    }
                }
                Panel {
                    title: format!("φ = {phi}, NNL"),
                    x_desc: format!("Δ_NNL (unit: {})", self.length_unit.symbol()),
                    y_desc: self.tau_c.clone(),
                    x_log: true,
                    y_log: false,
                    series,
                    notes: Vec::new(),
                }
            })
            .collect();
        render(
            &LinePlot {
                title: "Fig. 10: τ_c against Δ_NNL, minimum by a parabola in log Δ".into(),
                panels,
                columns: 2,
            },
            path,
        )
    }
}

/// Fig. 10's data, drawn into `path` when one is given.
pub fn fig10(
    rows: &[EdmdRow],
    unit: LengthUnit,
    path: Option<&Path>,
) -> Result<Fig10, ReportError> {
    drawn(Fig10::new(rows, unit)?, path, Fig10::draw)
}
