//! Figure 11 of De Michele: the optimal Δ*_NNL, the minimum of each curve of Fig. 10, against φ
//! per X0 and against X0 per φ; a minimum the Δ_NNL grid does not bracket is drawn as a bound.
//! Minima found by `[[tune]]` searches (given as [`LocatedMinimum`]s with
//! [`MinimumMethod::Search`]) are drawn beside those of grids, as curves of their own.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::curves::{PAPER_X0, delta_curves, same, unbracketed};
use crate::lines::{LinePlot, Panel, Series, Style};
use crate::minimum::MinimumMethod;
use crate::render::{drawn, render};
use crate::selection::Key;
use crate::units::LengthUnit;
use crate::{EdmdRow, ReportError};

const FIG11_PHI: [f64; 2] = [0.40, 0.55];

/// Fig. 11: Δ*_NNL against φ per X0 (left) and against X0 per φ (right).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fig11 {
    pub length_unit: LengthUnit,
    pub minima: Vec<LocatedMinimum>,
    pub missing: Vec<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LocatedMinimum {
    pub x0: f64,
    pub phi: f64,
    pub n: u32,
    /// Δ*_NNL in `length_unit`.
    pub delta_star: f64,
    /// Δ*_NNL in σ (the equal-volume sphere's diameter), whatever `length_unit` is.
    pub delta_star_sigma: f64,
    /// A search's: where the runs could not tell the τ_c from the minimum's, in `length_unit`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interval: Option<[f64; 2]>,
    pub tau_c_us: f64,
    /// False when the grid's edge (a search's range end) is the smallest value: `delta_star` is
    /// then only a bound.
    pub bracketed: bool,
    pub method: MinimumMethod,
    /// The Δ_NNL grid's (a search's range's) ends, in `length_unit`.
    pub grid: [f64; 2],
    /// Eq. 73 at the grid point nearest Δ*: the share of τ_c spent on list updates.
    pub update_share: Option<f64>,
}

impl Fig11 {
    /// The minima of the grids in `rows` and those `searched` (in `unit` already).
    pub fn new(
        rows: &[EdmdRow],
        searched: &[LocatedMinimum],
        unit: LengthUnit,
    ) -> Result<Self, ReportError> {
        let curves = delta_curves(rows, unit);
        let mut minima: Vec<LocatedMinimum> = curves
            .iter()
            .filter_map(|c| {
                let optimum = c.optimum.as_ref()?;
                let m = optimum.minimum?;
                Some(LocatedMinimum {
                    x0: c.x0,
                    phi: c.phi,
                    n: c.n,
                    delta_star: m.x,
                    delta_star_sigma: optimum.minimum_sigma?,
                    interval: None,
                    tau_c_us: m.y,
                    bracketed: m.bracketed(),
                    method: m.method,
                    grid: [c.points.first()?.x, c.points.last()?.x],
                    update_share: optimum
                        .split
                        .iter()
                        .min_by(|a, b| (a.x / m.x).ln().abs().total_cmp(&(b.x / m.x).ln().abs()))
                        .map(|s| s.update_share),
                })
            })
            .collect();
        minima.extend_from_slice(searched);
        let located = |keep: &dyn Fn(&LocatedMinimum) -> bool| {
            minima.iter().filter(|m| m.bracketed && keep(m)).count()
        };
        let mut missing = Vec::new();
        for x0 in PAPER_X0 {
            if located(&|m| same(m.x0, x0)) < 2 {
                missing.push(format!(
                    "located Δ*_NNL at X0 = {x0} for two or more φ (the paper: 0.25 to 0.55): NNL runs over a Δ_NNL grid bracketing the minimum, or a [[tune]] search of delta_nnl"
                ));
            }
        }
        for phi in FIG11_PHI {
            if located(&|m| same(m.phi, phi)) < 2 {
                missing.push(format!(
                    "located Δ*_NNL at φ = {phi} for two or more X0: NNL runs over a Δ_NNL grid bracketing the minimum, or a [[tune]] search of delta_nnl"
                ));
            }
        }
        missing.extend(unbracketed(&curves, unit));
        if located(&|_| true) == 0 {
            return Err(ReportError::MissingPoints {
                figure: "fig11",
                missing,
            });
        }
        Ok(Self {
            length_unit: unit,
            minima,
            missing,
        })
    }

    pub fn draw(&self, path: &Path) -> Result<(), ReportError> {
        let unit = self.length_unit.symbol();
        let left = self.panel(
            |m| (Key(m.x0), m.n),
            |m| m.phi,
            |(x0, n)| format!("X0 = {}, N = {n}", x0.0),
            format!("Δ*_NNL against φ (unit: {unit})"),
            "φ",
            false,
        );
        let right = self.panel(
            |m| (Key(m.phi), m.n),
            |m| m.x0,
            |(phi, n)| format!("φ = {}, N = {n}", phi.0),
            format!("Δ*_NNL against X0 (unit: {unit})"),
            "X0 = a/b",
            true,
        );
        render(
            &LinePlot {
                title: "Fig. 11: the optimal Δ*_NNL (crosses: minimum not bracketed, a bound)"
                    .into(),
                panels: vec![left, right],
                columns: 2,
            },
            path,
        )
    }

    /// One curve per `group` of Δ* against `x`.
    fn panel(
        &self,
        group: impl Fn(&LocatedMinimum) -> (Key, u32),
        x: impl Fn(&LocatedMinimum) -> f64,
        label: impl Fn((Key, u32)) -> String,
        title: String,
        x_desc: &str,
        x_log: bool,
    ) -> Panel {
        let mut groups: BTreeMap<(Key, u32), Vec<&LocatedMinimum>> = BTreeMap::new();
        for m in &self.minima {
            groups.entry(group(m)).or_default().push(m);
        }
        let mut series = Vec::new();
        for (colour, (key, minima)) in groups.into_iter().enumerate() {
            let located = |searched: bool| {
                let mut points: Vec<(f64, f64)> = minima
                    .iter()
                    .filter(|m| m.bracketed && (m.method == MinimumMethod::Search) == searched)
                    .map(|m| (x(m), m.delta_star))
                    .collect();
                points.sort_by(|a, b| a.0.total_cmp(&b.0));
                points
            };
            let (from_grids, from_searches) = (located(false), located(true));
            // A search's minima are diamonds over the grids' curve of the same state points
            // (where its runs are a grid of their own, the two agree), or the curve itself.
            let search_style = if from_grids.is_empty() {
                Style::Measured
            } else {
                Style::Located
            };
            for (points, suffix, style) in [
                (from_grids, "", Style::Measured),
                (from_searches, " (search)", search_style),
            ] {
                if !points.is_empty() {
                    series.push(Series {
                        label: format!("{}{suffix}", label(key)),
                        points,
                        style,
                        colour,
                    });
                }
            }
            let bounds: Vec<(f64, f64)> = minima
                .iter()
                .filter(|m| !m.bracketed)
                .map(|m| (x(m), m.delta_star))
                .collect();
            if !bounds.is_empty() {
                series.push(Series {
                    label: String::new(),
                    points: bounds,
                    style: Style::Flagged,
                    colour,
                });
            }
        }
        Panel {
            title,
            x_desc: x_desc.into(),
            y_desc: format!("Δ*_NNL ({})", self.length_unit.symbol()),
            x_log,
            y_log: false,
            series,
            notes: Vec::new(),
        }
    }
}

/// Fig. 11's data from grids and searches, drawn into `path` when one is given.
pub fn fig11(
    rows: &[EdmdRow],
    searched: &[LocatedMinimum],
    unit: LengthUnit,
    path: Option<&Path>,
) -> Result<Fig11, ReportError> {
    drawn(Fig11::new(rows, searched, unit)?, path, Fig11::draw)
}
