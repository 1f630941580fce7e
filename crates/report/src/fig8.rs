//! Figure 8 of De Michele: τ_c against the elongation X0 at fixed φ with linked cells and
//! neighbour lists (a), and their ratio τ_c^LL/τ_c^NNL (b), with the paper's guides to the eye.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::curves::{CurvePoint, ellipsoids, points_of, same, xy};
use crate::lines::{LinePlot, Panel, Series, Style};
use crate::render::{drawn, render};
use crate::selection::{Baseline, Key};
use crate::{EdmdRow, ReportError, tau_label};

/// The paper's φ of Fig. 8 (and the X0 range of its runs).
const FIG8_PHI: [f64; 3] = [0.30, 0.40, 0.50];

/// Fig. 8: τ_c against X0 at fixed φ, LL and NNL (a), and τ_c^LL/τ_c^NNL (b).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fig8 {
    /// The τ_c axis: which clock measured it.
    pub tau_c: String,
    /// x of each point is X0.
    pub curves: Vec<X0Curve>,
    pub ratios: Vec<RatioCurve>,
    pub missing: Vec<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct X0Curve {
    pub phi: f64,
    pub n: u32,
    pub neighbours: String,
    /// Δ_NNL of the NNL runs, in σ (the baseline).
    pub delta_nnl_sigma: Option<f64>,
    pub points: Vec<CurvePoint>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RatioCurve {
    pub phi: f64,
    pub n: u32,
    pub points: Vec<RatioPoint>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RatioPoint {
    pub x0: f64,
    pub tau_ll_us: f64,
    pub tau_nnl_us: f64,
    pub ratio: f64,
}

impl Fig8 {
    pub fn new(rows: &[EdmdRow]) -> Result<Self, ReportError> {
        let baseline = Baseline::of(rows);
        let mut raw: BTreeMap<(Key, u32, String), Vec<(f64, f64)>> = BTreeMap::new();
        for r in ellipsoids(rows).filter(|r| baseline.at_baseline(r)) {
            raw.entry((Key(r.phi), r.n, r.neighbours.clone()))
                .or_default()
                .push((r.x0, r.tau_c_us));
        }
        let delta = baseline.of_shape("ellipsoid").and_then(|b| b.delta_nnl);
        let curves: Vec<X0Curve> = raw
            .into_iter()
            .map(|((phi, n, neighbours), points)| X0Curve {
                phi: phi.0,
                n,
                delta_nnl_sigma: (neighbours == "nnl").then_some(delta).flatten(),
                neighbours,
                points: points_of(points),
            })
            // Two X0 values are any sweep's corner (Fig. 7's state points): a curve of Fig. 8
            // is a sweep over X0.
            .filter(|c| c.points.len() >= 3)
            .collect();

        let mut missing = Vec::new();
        let mut ratios = Vec::new();
        for ll in curves.iter().filter(|c| c.neighbours == "ll") {
            let nnl = curves
                .iter()
                .find(|c| c.neighbours == "nnl" && c.n == ll.n && same(c.phi, ll.phi));
            let mut points = Vec::new();
            for p in &ll.points {
                match nnl.and_then(|c| c.points.iter().find(|q| same(q.x, p.x))) {
                    Some(q) => points.push(RatioPoint {
                        x0: p.x,
                        tau_ll_us: p.tau_c_us,
                        tau_nnl_us: q.tau_c_us,
                        ratio: p.tau_c_us / q.tau_c_us,
                    }),
                    None => missing.push(format!(
                        "ellipsoid NNL at φ = {}, X0 = {}, N = {} (the partner of an LL run, for panel b)",
                        ll.phi, p.x, ll.n
                    )),
                }
            }
            if !points.is_empty() {
                ratios.push(RatioCurve {
                    phi: ll.phi,
                    n: ll.n,
                    points,
                });
            }
        }
        for phi in FIG8_PHI {
            for method in ["ll", "nnl"] {
                if !curves
                    .iter()
                    .any(|c| c.neighbours == method && same(c.phi, phi))
                {
                    missing.push(format!(
                        "ellipsoid {} runs at φ = {phi} over three or more X0 (the paper: 0.25 to 4)",
                        method.to_uppercase()
                    ));
                }
            }
        }
        if !curves.iter().any(|c| c.neighbours == "ll") || ratios.is_empty() {
            return Err(ReportError::MissingPoints {
                figure: "fig8",
                missing,
            });
        }
        Ok(Self {
            tau_c: tau_label(ellipsoids(rows)),
            curves,
            ratios,
            missing,
        })
    }

    pub fn draw(&self, path: &Path) -> Result<(), ReportError> {
        let mut a = Vec::new();
        for (colour, c) in self.curves.iter().enumerate() {
            let method = match c.delta_nnl_sigma {
                Some(d) => format!("NNL (Δ = {d} σ)"),
                None => c.neighbours.to_uppercase(),
            };
            a.push(Series {
                label: format!("φ = {}, {method}, N = {}", c.phi, c.n),
                points: xy(&c.points),
                style: Style::Measured,
                colour,
            });
        }
        a.extend(self.guides());
        let b = self
            .ratios
            .iter()
            .enumerate()
            .map(|(colour, c)| Series {
                label: format!("φ = {}, N = {}", c.phi, c.n),
                points: c.points.iter().map(|p| (p.x0, p.ratio)).collect(),
                style: Style::Measured,
                colour,
            })
            .collect();
        let plot = LinePlot {
            title: "Fig. 8: τ_c against the elongation X0".into(),
            panels: vec![
                Panel {
                    title: "(a) τ_c with LL and NNL".into(),
                    x_desc: "X0 = a/b".into(),
                    y_desc: self.tau_c.clone(),
                    x_log: true,
                    y_log: true,
                    series: a,
                    notes: Vec::new(),
                },
                Panel {
                    title: "(b) τ_c^LL / τ_c^NNL".into(),
                    x_desc: "X0 = a/b".into(),
                    y_desc: "τ_c^LL / τ_c^NNL".into(),
                    x_log: true,
                    y_log: false,
                    series: b,
                    notes: Vec::new(),
                },
            ],
            columns: 2,
        };
        render(&plot, path)
    }

    /// The paper's guides to the eye, X0² (prolate) and 1/X0 (oblate), on the first LL curve:
    /// through its most elongated point on each side of X0 = 1, so that the slopes at large
    /// elongation compare.
    fn guides(&self) -> Vec<Series> {
        let Some(ll) = self.curves.iter().find(|c| c.neighbours == "ll") else {
            return Vec::new();
        };
        let xs = || ll.points.iter().map(|p| p.x);
        let guide = |side: &[f64], anchor: Option<&CurvePoint>, power: i32| -> Vec<(f64, f64)> {
            match anchor {
                Some(a) if side.len() >= 2 => side
                    .iter()
                    .map(|&x| (x, a.tau_c_us * (x / a.x).powi(power)))
                    .collect(),
                _ => Vec::new(),
            }
        };
        let prolate: Vec<f64> = xs().filter(|&x| x >= 1.0).collect();
        let oblate: Vec<f64> = xs().filter(|&x| x <= 1.0).collect();
        [
            (
                format!("guide ∝ X0² (prolate), φ = {}", ll.phi),
                guide(&prolate, ll.points.last().filter(|p| p.x > 1.0), 2),
            ),
            (
                format!("guide ∝ 1/X0 (oblate), φ = {}", ll.phi),
                guide(&oblate, ll.points.first().filter(|p| p.x < 1.0), -1),
            ),
        ]
        .into_iter()
        .filter(|(_, p)| !p.is_empty())
        .map(|(label, points)| Series {
            label,
            points,
            style: Style::Guide,
            colour: 0,
        })
        .collect()
    }
}

/// Fig. 8's data, drawn into `path` when one is given.
pub fn fig8(rows: &[EdmdRow], path: Option<&Path>) -> Result<Fig8, ReportError> {
    drawn(Fig8::new(rows)?, path, Fig8::draw)
}
