//! What the EDMD curve figures share (Figs. 8–11 and 13): a curve's measured points, drawn with
//! the ones to distrust crossed out; the curve of τ_c against one knob at one state point
//! (Figs. 9–11); and the Δ_NNL curves with their located minima, which Fig. 10 draws and Fig. 11
//! collects.
//!
//! Each figure compares the runs that differ only in what it varies: every other accuracy knob
//! (and Δ_NNL, except in Figs. 10–11) is held at the campaign's baseline (see `selection`). The
//! paper's state points a figure is about are checked: those the database lacks are listed in
//! `missing`, and a figure with nothing to draw is [`crate::ReportError::MissingPoints`].

use std::collections::BTreeMap;

use serde::Serialize;

use crate::EdmdRow;
use crate::lines::{Series, Style};
use crate::minimum::{Minimum, locate_minimum};
use crate::selection::{Baseline, Key, mean_by_x, timed};
use crate::units::LengthUnit;

/// The elongations of Figs. 7, 9, 10 and the left panel of Fig. 11.
pub(crate) const PAPER_X0: [f64; 2] = [0.5, 2.0];

pub(crate) fn same(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

pub(crate) fn ellipsoids(rows: &[EdmdRow]) -> impl Iterator<Item = &EdmdRow> {
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
pub(crate) type State = (Key, Key, u32);

pub(crate) fn state(r: &EdmdRow) -> State {
    (Key(r.x0), Key(r.phi), r.n)
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

/// Every NNL ellipsoid state point with three or more Δ_NNL at the baseline knobs.
pub(crate) fn delta_curves(rows: &[EdmdRow], unit: LengthUnit) -> Vec<KnobCurve> {
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
pub(crate) fn unbracketed(curves: &[KnobCurve], unit: LengthUnit) -> Vec<String> {
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
