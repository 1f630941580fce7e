//! Figure 13 of De Michele: the time per collision τ_c of superquadrics (Eq. 77 with n = m = 2
//! and b = c) against their exponent p, at X0 = 0.5 and 2, φ = 0.256, N = 512, with linked cells
//! (left panel) and neighbour lists (right panel); and how much slower a superquadric run is than
//! the hard-ellipsoid run of the same body (p = 2) and state point, against the paper's "at least
//! 5–6 times slower" (Sec. 5.2).
//!
//! Runs are compared as in Figs. 8–11 (`selection`): every accuracy knob and Δ_NNL at its
//! shape's baseline, and a hard-ellipsoid reference only with the knobs and Δ_NNL of the
//! superquadric run it is compared with.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::curves::{CurvePoint, curve_series, points_of, same};
use crate::lines::{LinePlot, Panel, Series, Style};
use crate::render::{drawn, render, render_svg};
use crate::selection::{Baseline, Key, knobs, timed};
use crate::{EdmdRow, ReportError, tau_label};

/// The paper's state point of Fig. 13 and the exponents our plan runs there (the paper went to
/// p = 8 with LL and p = 4 with NNL).
const PHI: f64 = 0.256;
const N: u32 = 512;
const X0: [f64; 2] = [0.5, 2.0];
const P_GRID: [f64; 6] = [2.0, 3.0, 4.0, 6.0, 8.0, 10.0];
/// "the SQs simulations (see p = 2, i.e. HEs) are at least 5-6 times slower than the HEs ones".
const PAPER_RATIO: [f64; 2] = [5.0, 6.0];

/// Fig. 13's data, as `sweep report fig13 --format json` prints it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fig13 {
    /// The τ_c axis: which clock measured it.
    pub tau_c: String,
    /// One curve per (X0, φ, N, neighbour method); x of each point is p.
    pub curves: Vec<ExponentCurve>,
    /// τ_c(superquadric, p = 2) / τ_c(hard ellipsoid) at each state point that has both.
    pub ellipsoid_ratios: Vec<EllipsoidRatio>,
    /// The paper's "at least 5–6 times slower", as its two numbers.
    pub paper_ratio: [f64; 2],
    pub missing: Vec<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExponentCurve {
    pub x0: f64,
    pub phi: f64,
    pub n: u32,
    pub neighbours: String,
    /// Δ_NNL of the NNL runs, in σ (the baseline).
    pub delta_nnl_sigma: Option<f64>,
    pub points: Vec<CurvePoint>,
    /// The p whose runs found overlapping pairs or had solver failures: not to be trusted.
    pub flagged: Vec<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EllipsoidRatio {
    pub x0: f64,
    pub phi: f64,
    pub n: u32,
    pub neighbours: String,
    pub tau_superquadric_us: f64,
    pub tau_ellipsoid_us: f64,
    pub ratio: f64,
    /// Runs averaged on each side.
    pub superquadric_runs: u32,
    pub ellipsoid_runs: u32,
}

/// p of a superquadric of the paper's family (n = m = 2), if `r` is one.
fn paper_exponent(r: &EdmdRow) -> Option<f64> {
    match r.exponents {
        Some([n, m, p]) if r.shape == "superquadric" && n == 2.0 && m == 2.0 => Some(p),
        _ => None,
    }
}

/// (X0, φ, N, neighbour method): what tells one curve of the figure from another.
type StatePoint = (Key, Key, u32, String);

fn state_point(r: &EdmdRow) -> StatePoint {
    (Key(r.x0), Key(r.phi), r.n, r.neighbours.clone())
}

/// "superquadric LL at X0 = 0.5, φ = 0.256, N = 512".
fn describe(shape: &str, (x0, phi, n, neighbours): &StatePoint) -> String {
    format!(
        "{shape} {} at X0 = {}, φ = {}, N = {n}",
        neighbours.to_uppercase(),
        x0.0,
        phi.0
    )
}

impl Fig13 {
    pub fn new(rows: &[EdmdRow]) -> Result<Self, ReportError> {
        let baseline = Baseline::of(rows);
        let superquadrics: Vec<(&EdmdRow, f64)> = rows
            .iter()
            .filter(|r| timed(r) && baseline.at_baseline(r))
            .filter_map(|r| Some((r, paper_exponent(r)?)))
            .collect();
        // Per curve: (p, τ_c) of every run, and the p of runs with overlaps or solver failures.
        type Runs = (Vec<(f64, f64)>, Vec<f64>);
        let mut raw: BTreeMap<StatePoint, Runs> = BTreeMap::new();
        for &(r, p) in &superquadrics {
            let entry = raw.entry(state_point(r)).or_default();
            entry.0.push((p, r.tau_c_us));
            if r.overlaps > 0 || r.solver_failures > 0 {
                entry.1.push(p);
            }
        }
        let delta = baseline.of_shape("superquadric").and_then(|b| b.delta_nnl);
        let curves: Vec<ExponentCurve> = raw
            .into_iter()
            .map(|((x0, phi, n, neighbours), (points, mut flagged))| {
                flagged.sort_by(f64::total_cmp);
                flagged.dedup();
                ExponentCurve {
                    x0: x0.0,
                    phi: phi.0,
                    n,
                    delta_nnl_sigma: (neighbours == "nnl").then_some(delta).flatten(),
                    neighbours,
                    points: points_of(points),
                    flagged,
                }
            })
            .collect();

        let mut missing = Vec::new();
        for x0 in X0 {
            for method in ["ll", "nnl"] {
                let key = (Key(x0), Key(PHI), N, method.to_owned());
                let curve = curves.iter().find(|c| {
                    same(c.x0, x0) && same(c.phi, PHI) && c.n == N && c.neighbours == method
                });
                let absent: Vec<String> = P_GRID
                    .iter()
                    .filter(|&&p| !curve.is_some_and(|c| c.points.iter().any(|q| same(q.x, p))))
                    .map(|p| p.to_string())
                    .collect();
                if !absent.is_empty() {
                    missing.push(format!(
                        "{} with exponents [2, 2, p] for p = {}",
                        describe("superquadric", &key),
                        absent.join(", ")
                    ));
                }
            }
        }
        let ellipsoid_ratios = ellipsoid_ratios(rows, &superquadrics, &mut missing);
        if curves.is_empty() {
            return Err(ReportError::MissingPoints {
                figure: "fig13",
                missing,
            });
        }
        Ok(Self {
            tau_c: tau_label(superquadrics.iter().map(|(r, _)| *r)),
            curves,
            ellipsoid_ratios,
            paper_ratio: PAPER_RATIO,
            missing,
        })
    }

    pub fn draw(&self, path: &Path) -> Result<(), ReportError> {
        render(&self.plot(), path)
    }

    /// The figure as [`Fig13::draw`] draws it, as an SVG document in memory (the status page's).
    pub fn svg(&self) -> Result<String, ReportError> {
        render_svg(&self.plot())
    }

    fn plot(&self) -> LinePlot {
        let panels = [
            ("ll", "linked cells (LL)"),
            ("nnl", "neighbour lists (NNL)"),
        ]
        .into_iter()
        .filter(|(method, _)| self.curves.iter().any(|c| c.neighbours == *method))
        .map(|(method, title)| self.panel(method, title))
        .collect();
        let [low, high] = self.paper_ratio;
        LinePlot {
            title: format!(
                "Fig. 13: superquadrics, τ_c against p (triangles: hard ellipsoids; the paper: superquadrics at p = 2 at least {low}–{high} times slower)"
            ),
            panels,
            columns: 2,
        }
    }

    fn panel(&self, method: &str, title: &str) -> Panel {
        let mut series = Vec::new();
        for (colour, c) in self
            .curves
            .iter()
            .filter(|c| c.neighbours == method)
            .enumerate()
        {
            let delta = c
                .delta_nnl_sigma
                .map(|d| format!(", Δ = {d} σ"))
                .unwrap_or_default();
            series.extend(curve_series(
                format!("X0 = {}, φ = {}, N = {}{delta}", c.x0, c.phi, c.n),
                &c.points,
                (
                    &c.flagged,
                    format!("overlaps or solver failures (X0 = {})", c.x0),
                ),
                colour,
            ));
            let reference = self.ellipsoid_ratios.iter().find(|r| {
                r.neighbours == method && same(r.x0, c.x0) && same(r.phi, c.phi) && r.n == c.n
            });
            if let Some(r) = reference {
                series.push(Series {
                    label: format!(
                        "hard ellipsoid X0 = {}: τ_c(p = 2)/τ_c(HE) = {:.2}",
                        r.x0, r.ratio
                    ),
                    points: vec![(2.0, r.tau_ellipsoid_us)],
                    style: Style::Located,
                    colour,
                });
            }
        }
        // The p axis spans the plan's grid even where only part of it is measured.
        if let Some(&(_, y)) = series.first().and_then(|s| s.points.first()) {
            series.push(Series {
                label: String::new(),
                points: vec![(P_GRID[0], y), (P_GRID[P_GRID.len() - 1], y)],
                style: Style::Frame,
                colour: 0,
            });
        }
        Panel {
            title: title.to_owned(),
            x_desc: "p, the exponent of |z/c|^p in Eq. 77 (n = m = 2)".into(),
            y_desc: self.tau_c.clone(),
            x_log: false,
            y_log: true,
            series,
            notes: Vec::new(),
        }
    }
}

/// τ_c(superquadric, p = 2) / τ_c(hard ellipsoid) per state point: the ellipsoid runs with the
/// same X0, φ, N, neighbour method, Δ_NNL (NNL) and accuracy knobs as the superquadric ones.
/// State points of the paper's figure without a reference are added to `missing`.
fn ellipsoid_ratios(
    rows: &[EdmdRow],
    superquadrics: &[(&EdmdRow, f64)],
    missing: &mut Vec<String>,
) -> Vec<EllipsoidRatio> {
    let mut at_p2: BTreeMap<StatePoint, Vec<&EdmdRow>> = BTreeMap::new();
    for &(r, p) in superquadrics {
        if p == 2.0 {
            at_p2.entry(state_point(r)).or_default().push(r);
        }
    }
    let mut ratios = Vec::new();
    for (key, sq) in at_p2 {
        let like = |e: &&EdmdRow| {
            sq.iter().any(|s| {
                knobs(s) == knobs(e) && (s.neighbours != "nnl" || s.delta_nnl == e.delta_nnl)
            })
        };
        let ellipsoids: Vec<&EdmdRow> = rows
            .iter()
            .filter(|e| e.shape == "ellipsoid" && timed(e) && state_point(e) == key)
            .filter(like)
            .collect();
        let mean = |runs: &[&EdmdRow]| {
            let count = u32::try_from(runs.len()).ok().filter(|&n| n > 0)?;
            Some((
                runs.iter().map(|r| r.tau_c_us).sum::<f64>() / f64::from(count),
                count,
            ))
        };
        match (mean(&sq), mean(&ellipsoids)) {
            (Some((tau_sq, sq_runs)), Some((tau_he, he_runs))) => ratios.push(EllipsoidRatio {
                x0: key.0.0,
                phi: key.1.0,
                n: key.2,
                neighbours: key.3,
                tau_superquadric_us: tau_sq,
                tau_ellipsoid_us: tau_he,
                ratio: tau_sq / tau_he,
                superquadric_runs: sq_runs,
                ellipsoid_runs: he_runs,
            }),
            _ if same(key.1.0, PHI) && key.2 == N && X0.iter().any(|&x| same(x, key.0.0)) => {
                missing.push(format!(
                    "{} with the knobs of its superquadric runs (the reference of τ_c(p = 2)/τ_c(HE))",
                    describe("ellipsoid", &key)
                ));
            }
            _ => {}
        }
    }
    ratios
}

/// Fig. 13's data, drawn into `path` when one is given.
pub fn fig13(rows: &[EdmdRow], path: Option<&Path>) -> Result<Fig13, ReportError> {
    drawn(Fig13::new(rows)?, path, Fig13::draw)
}
