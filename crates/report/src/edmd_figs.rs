//! Figures 8–11 of De Michele, as data first (what `--format json` prints) and drawings second:
//! τ_c against X0 with LL and NNL and their ratio (Fig. 8), against ε_d (Fig. 9), against
//! Δ_NNL with its located minimum (Fig. 10), and that minimum Δ*_NNL against φ and X0 (Fig. 11).
//!
//! Each figure compares the runs that differ only in what it varies: every other accuracy knob
//! (and Δ_NNL, except in Figs. 10–11) is held at the campaign's baseline (see `selection`). The
//! paper's state points a figure is about are checked: those the database lacks are listed in
//! `missing`, and a figure with nothing to draw is [`ReportError::MissingPoints`].

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::lines::{LinePlot, Panel, Series, Style};
use crate::minimum::{Minimum, locate_minimum};
use crate::render::{drawn, render};
use crate::selection::{Baseline, EPS_D, Key, mean_by_x, timed};
use crate::units::LengthUnit;
use crate::{EdmdRow, ReportError, tau_label};

/// The paper's φ of Fig. 8 (and the X0 range of its runs).
const FIG8_PHI: [f64; 3] = [0.30, 0.40, 0.50];
/// The elongations of Figs. 7, 9, 10 and the left panel of Fig. 11.
const PAPER_X0: [f64; 2] = [0.5, 2.0];
const FIG10_PHI: [f64; 2] = [0.45, 0.57];
const FIG11_PHI: [f64; 2] = [0.40, 0.55];

pub(crate) fn same(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

fn ellipsoids(rows: &[EdmdRow]) -> impl Iterator<Item = &EdmdRow> {
    rows.iter().filter(|r| r.shape == "ellipsoid" && timed(r))
}

/// One measured point of a curve: x (in the figure's unit), τ_c averaged over `runs` runs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CurvePoint {
    pub x: f64,
    pub tau_c_us: f64,
    pub runs: u32,
}

pub(crate) fn points_of(raw: Vec<(f64, f64)>) -> Vec<CurvePoint> {
    mean_by_x(raw.into_iter())
        .into_iter()
        .map(|(x, tau_c_us, runs)| CurvePoint { x, tau_c_us, runs })
        .collect()
}

pub(crate) fn xy(points: &[CurvePoint]) -> Vec<(f64, f64)> {
    points.iter().map(|p| (p.x, p.tau_c_us)).collect()
}

/// A measured curve, and its points at the x in `flagged` crossed out under their own label.
pub(crate) fn curve_series(
    label: String,
    points: &[CurvePoint],
    (flagged, flagged_label): (&[f64], String),
    colour: usize,
) -> Vec<Series> {
    let crossed: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| flagged.iter().any(|&x| same(x, p.x)))
        .map(|p| (p.x, p.tau_c_us))
        .collect();
    let mut series = vec![Series {
        label,
        points: xy(points),
        style: Style::Measured,
        colour,
    }];
    if !crossed.is_empty() {
        series.push(Series {
            label: flagged_label,
            points: crossed,
            style: Style::Flagged,
            colour,
        });
    }
    series
}

/// τ_c against one knob at one NNL ellipsoid state point, the other knobs at the baseline: ε_d
/// in Fig. 9, Δ_NNL in Figs. 10–11. Each figure fills its own part, and its JSON has only that
/// part's fields.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KnobCurve {
    pub x0: f64,
    pub phi: f64,
    pub n: u32,
    /// x of each point is the knob in `length_unit`.
    pub points: Vec<CurvePoint>,
    /// Fig. 9: ε_d (in `length_unit`) of the points whose runs found overlapping pairs; `None`
    /// in Fig. 10, whose JSON has no such field.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overlapping: Option<Vec<f64>>,
    /// Figs. 10–11: where τ_c is least over Δ_NNL, and Eq. 73 along the curve, its fields
    /// printed beside the others; `None` in Fig. 9, whose JSON has none of them.
    #[serde(flatten)]
    pub optimum: Option<Optimum>,
}

/// The minimum of a curve over Δ_NNL, and the list updates' share of τ_c along it (Fig. 11
/// reads the share at the minimum).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Optimum {
    /// Δ*_NNL in `length_unit` (x) and the fitted τ_c there (y); `method` says whether the grid
    /// brackets it.
    pub minimum: Option<Minimum>,
    /// Δ*_NNL in σ, the value to put in a plan.
    pub minimum_sigma: Option<f64>,
    /// Eq. 73 in time at each Δ_NNL of `points` that has it: the list updates' share.
    pub split: Vec<SplitPoint>,
}

/// A state point (X0, φ, N) of the ellipsoid runs.
type State = (Key, Key, u32);

fn state(r: &EdmdRow) -> State {
    (Key(r.x0), Key(r.phi), r.n)
}

// ---------------------------------------------------------------------------------- Fig. 8

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

// ---------------------------------------------------------------------------------- Fig. 9

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

// --------------------------------------------------------------------------------- Fig. 10

/// Fig. 10: τ_c against Δ_NNL per state point, with the minimum located by a parabola in log Δ.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Fig10 {
    pub length_unit: LengthUnit,
    pub tau_c: String,
    pub curves: Vec<KnobCurve>,
    pub missing: Vec<String>,
}

/// Eq. 73 split in time at one x: Δt_u (box and list rebuilds) and Δt_coll (the rest, the
/// prediction) per collision, wall clock, averaged over `runs`; `update_share` = Δt_u / τ_c.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SplitPoint {
    pub x: f64,
    pub tau_update_us: f64,
    pub tau_predict_us: f64,
    pub update_share: f64,
    pub runs: u32,
}

fn split_of(raw: &[(f64, f64, f64)]) -> Vec<SplitPoint> {
    let updates = mean_by_x(raw.iter().map(|&(x, u, _)| (x, u)));
    let predictions = mean_by_x(raw.iter().map(|&(x, _, p)| (x, p)));
    updates
        .into_iter()
        .zip(predictions)
        .map(|((x, u, runs), (_, p, _))| SplitPoint {
            x,
            tau_update_us: u,
            tau_predict_us: p,
            update_share: if u + p > 0.0 { u / (u + p) } else { 0.0 },
            runs,
        })
        .collect()
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

/// Every NNL ellipsoid state point with three or more Δ_NNL at the baseline knobs.
fn delta_curves(rows: &[EdmdRow], unit: LengthUnit) -> Vec<KnobCurve> {
    let baseline = Baseline::of(rows);
    let mut raw: BTreeMap<State, Vec<(f64, f64)>> = BTreeMap::new();
    let mut splits: BTreeMap<State, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for r in ellipsoids(rows).filter(|r| r.neighbours == "nnl" && baseline.knobs_match(r, None)) {
        let x = unit.convert(r.delta_nnl, r.x0);
        raw.entry(state(r)).or_default().push((x, r.tau_c_us));
        if let (Some(update), Some(predict)) = (r.tau_update_us, r.tau_predict_us) {
            splits
                .entry(state(r))
                .or_default()
                .push((x, update, predict));
        }
    }
    raw.into_iter()
        .map(|(key, points)| {
            let (x0, phi, n) = key;
            let split = splits.get(&key).map_or_else(Vec::new, |s| split_of(s));
            let points = points_of(points);
            let minimum = locate_minimum(&xy(&points));
            let optimum = Optimum {
                minimum_sigma: minimum.map(|m| m.x / unit.convert(1.0, x0.0)),
                minimum,
                split,
            };
            KnobCurve {
                x0: x0.0,
                phi: phi.0,
                n,
                points,
                overlapping: None,
                optimum: Some(optimum),
            }
        })
        .filter(|c| c.points.len() >= 3)
        .collect()
}

/// The state points whose Δ grid does not bracket the minimum, as missing points.
fn unbracketed(curves: &[KnobCurve], unit: LengthUnit) -> Vec<String> {
    curves
        .iter()
        .filter_map(|c| {
            let m = c.optimum.as_ref()?.minimum?;
            if m.bracketed() {
                return None;
            }
            let at_low = c.points.first().is_some_and(|p| same(p.x, m.x));
            Some(format!(
                "ellipsoid NNL at X0 = {}, φ = {}: the Δ_NNL grid does not bracket the minimum (smallest τ_c at its {} end, Δ = {} {}); add {} Δ_NNL",
                c.x0,
                c.phi,
                if at_low { "lower" } else { "upper" },
                m.x,
                unit.symbol(),
                if at_low { "smaller" } else { "larger" }
            ))
        })
        .collect()
}

// --------------------------------------------------------------------------------- Fig. 11

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
    pub delta_star_sigma: f64,
    pub tau_c_us: f64,
    /// False when the grid's edge is the smallest value: `delta_star` is then only a bound.
    pub bracketed: bool,
    pub method: crate::MinimumMethod,
    /// The Δ_NNL grid's ends, in `length_unit`.
    pub grid: [f64; 2],
    /// Eq. 73 at the grid point nearest Δ*: the share of τ_c spent on list updates.
    pub update_share: Option<f64>,
}

impl Fig11 {
    pub fn new(rows: &[EdmdRow], unit: LengthUnit) -> Result<Self, ReportError> {
        let curves = delta_curves(rows, unit);
        let minima: Vec<LocatedMinimum> = curves
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
        let located = |keep: &dyn Fn(&LocatedMinimum) -> bool| {
            minima.iter().filter(|m| m.bracketed && keep(m)).count()
        };
        let mut missing = Vec::new();
        for x0 in PAPER_X0 {
            if located(&|m| same(m.x0, x0)) < 2 {
                missing.push(format!(
                    "located Δ*_NNL at X0 = {x0} for two or more φ (the paper: 0.25 to 0.55): NNL runs over a Δ_NNL grid bracketing the minimum"
                ));
            }
        }
        for phi in FIG11_PHI {
            if located(&|m| same(m.phi, phi)) < 2 {
                missing.push(format!(
                    "located Δ*_NNL at φ = {phi} for two or more X0: NNL runs over a Δ_NNL grid bracketing the minimum"
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
            let mut located: Vec<(f64, f64)> = minima
                .iter()
                .filter(|m| m.bracketed)
                .map(|m| (x(m), m.delta_star))
                .collect();
            located.sort_by(|a, b| a.0.total_cmp(&b.0));
            let bounds: Vec<(f64, f64)> = minima
                .iter()
                .filter(|m| !m.bracketed)
                .map(|m| (x(m), m.delta_star))
                .collect();
            series.push(Series {
                label: label(key),
                points: located,
                style: Style::Measured,
                colour,
            });
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

/// Fig. 8's data, drawn into `path` when one is given.
pub fn fig8(rows: &[EdmdRow], path: Option<&Path>) -> Result<Fig8, ReportError> {
    drawn(Fig8::new(rows)?, path, Fig8::draw)
}

/// Fig. 9's data, drawn into `path` when one is given.
pub fn fig9(rows: &[EdmdRow], unit: LengthUnit, path: Option<&Path>) -> Result<Fig9, ReportError> {
    drawn(Fig9::new(rows, unit)?, path, Fig9::draw)
}

/// Fig. 10's data, drawn into `path` when one is given.
pub fn fig10(
    rows: &[EdmdRow],
    unit: LengthUnit,
    path: Option<&Path>,
) -> Result<Fig10, ReportError> {
    drawn(Fig10::new(rows, unit)?, path, Fig10::draw)
}

/// Fig. 11's data, drawn into `path` when one is given.
pub fn fig11(
    rows: &[EdmdRow],
    unit: LengthUnit,
    path: Option<&Path>,
) -> Result<Fig11, ReportError> {
    drawn(Fig11::new(rows, unit)?, path, Fig11::draw)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Figs. 9 and 10 print the fields their curves always had, in the same order, even where
    /// the part is empty.
    #[test]
    fn a_knob_curve_prints_only_its_figure_s_part() {
        let curve = |overlapping, optimum| KnobCurve {
            x0: 2.0,
            phi: 0.5,
            n: 256,
            points: Vec::new(),
            overlapping,
            optimum,
        };
        let json = |c: KnobCurve| serde_json::to_string(&c).expect("serialisable");
        assert_eq!(
            json(curve(Some(Vec::new()), None)),
            r#"{"x0":2.0,"phi":0.5,"n":256,"points":[],"overlapping":[]}"#
        );
        let optimum = Optimum {
            minimum: None,
            minimum_sigma: None,
            split: Vec::new(),
        };
        assert_eq!(
            json(curve(None, Some(optimum))),
            r#"{"x0":2.0,"phi":0.5,"n":256,"points":[],"minimum":null,"minimum_sigma":null,"split":[]}"#
        );
    }
}
