//! Figure 9 of De Michele: τ_c against the distance tolerance ε_d with neighbour lists, one
//! curve per (X0, φ), the points whose runs found overlapping pairs crossed out.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::curves::{KnobCurve, PAPER_X0, State, curve_series, ellipsoids, points_of, same, state};
use crate::lines::{LinePlot, Panel};
use crate::render::{drawn, render};
use crate::selection::{Baseline, EPS_D};
use crate::units::LengthUnit;
use crate::{EdmdRow, ReportError, tau_label};

/// Fig. 9: τ_c against ε_d with NNL, one curve per (X0, φ); points whose run found overlaps
/// are flagged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fig9 {
    pub length_unit: LengthUnit,
    pub tau_c: String,
    pub curves: Vec<KnobCurve>,
    pub missing: Vec<String>,
}

impl Fig9 {
    pub fn new(rows: &[EdmdRow], unit: LengthUnit) -> Result<Self, ReportError> {
        let baseline = Baseline::of(rows);
        // Per state point: (ε_d, τ_c) of every run, and the ε_d of runs that found overlaps.
        type Runs = (Vec<(f64, f64)>, Vec<f64>);
        let mut raw: BTreeMap<State, Runs> = BTreeMap::new();
        for r in ellipsoids(rows).filter(|r| {
            r.neighbours == "nnl"
                && baseline.delta_matches(r)
                && baseline.knobs_match(r, Some(EPS_D))
        }) {
            let entry = raw.entry(state(r)).or_default();
            let eps = unit.convert(r.eps_d, r.x0);
            entry.0.push((eps, r.tau_c_us));
            if r.overlaps > 0 {
                entry.1.push(eps);
            }
        }
        let curves: Vec<KnobCurve> = raw
            .into_iter()
            .map(|((x0, phi, n), (points, mut overlapping))| {
                overlapping.sort_by(f64::total_cmp);
                overlapping.dedup();
                KnobCurve {
                    x0: x0.0,
                    phi: phi.0,
                    n,
                    points: points_of(points),
                    overlapping: Some(overlapping),
                    optimum: None,
                }
            })
            .filter(|c| c.points.len() >= 2)
            .collect();
        let missing: Vec<String> = PAPER_X0
            .iter()
            .filter(|&&x0| !curves.iter().any(|c| same(c.x0, x0)))
            .map(|x0| {
                format!(
                    "ellipsoid NNL runs at X0 = {x0} over two or more ε_d (the paper: 1e-7 to 1e-2) at φ from 0.30 to 0.55"
                )
            })
            .collect();
        if curves.is_empty() {
            return Err(ReportError::MissingPoints {
                figure: "fig9",
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
        let mut x0s: Vec<f64> = self.curves.iter().map(|c| c.x0).collect();
        x0s.dedup_by(|a, b| same(*a, *b));
        let panels = x0s
            .iter()
            .map(|&x0| {
                let mut series = Vec::new();
                for (colour, c) in self.curves.iter().filter(|c| same(c.x0, x0)).enumerate() {
                    series.extend(curve_series(
                        format!("φ = {}, N = {}", c.phi, c.n),
                        &c.points,
                        (
                            c.overlapping.as_deref().unwrap_or_default(),
                            format!("overlaps found (φ = {})", c.phi),
                        ),
                        colour,
                    ));
                }
                Panel {
                    title: format!("X0 = {x0}, NNL"),
                    x_desc: format!("ε_d (unit: {})", self.length_unit.symbol()),
                    y_desc: self.tau_c.clone(),
                    x_log: true,
                    y_log: true,
                    series,
                    notes: Vec::new(),
                }
            })
            .collect();
        render(
            &LinePlot {
                title: "Fig. 9: τ_c against ε_d".into(),
                panels,
                columns: 2,
            },
            path,
        )
    }
}

/// Fig. 9's data, drawn into `path` when one is given.
pub fn fig9(rows: &[EdmdRow], unit: LengthUnit, path: Option<&Path>) -> Result<Fig9, ReportError> {
    drawn(Fig9::new(rows, unit)?, path, Fig9::draw)
}
