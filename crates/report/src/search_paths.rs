//! The paths of `[[tune]]` searches: one panel per search, the values it ran against what they
//! gave, and the value it found with its interval.

use std::path::Path;

use crate::ReportError;
use crate::lines::{LinePlot, Panel, Series, Style};
use crate::render::render;

/// One search as drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct SearchPath {
    /// The state point, e.g. "ellipsoid N = 256, φ = 0.45, X0 = 2".
    pub title: String,
    pub knob: String,
    /// The field minimised (the y axis), or `None` for a loosest-safe search (safe 1, unsafe 0).
    pub objective: Option<String>,
    /// Every run: the knob's value and what it gave (`None`: the run failed for good).
    pub runs: Vec<(f64, Option<f64>)>,
    pub found: Option<f64>,
    pub interval: Option<[f64; 2]>,
}

/// Draws the searches into `path` (.png or .svg), two panels to a row.
pub fn search_paths(searches: &[SearchPath], path: &Path) -> Result<(), ReportError> {
    let panels = searches.iter().map(panel).collect();
    render(
        &LinePlot {
            title: "[[tune]] searches: the runs, the value found and its interval".into(),
            panels,
            columns: 2,
        },
        path,
    )
}

fn panel(search: &SearchPath) -> Panel {
    let mut runs: Vec<(f64, f64)> = search
        .runs
        .iter()
        .filter_map(|&(x, v)| v.map(|v| (x, v)))
        .collect();
    runs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let floor = runs.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
    let floor = if floor.is_finite() { floor } else { 0.0 };
    let mut series = vec![Series {
        label: "runs".into(),
        points: runs.clone(),
        style: if search.objective.is_some() {
            Style::Measured
        } else {
            Style::Flagged
        },
        colour: 0,
    }];
    let failed: Vec<(f64, f64)> = search
        .runs
        .iter()
        .filter(|r| r.1.is_none())
        .map(|r| (r.0, floor))
        .collect();
    if !failed.is_empty() {
        series.push(Series {
            label: "failed for good".into(),
            points: failed,
            style: Style::Flagged,
            colour: 1,
        });
    }
    if let Some([lo, hi]) = search.interval {
        series.push(Series {
            label: "interval".into(),
            points: vec![(lo, floor), (hi, floor)],
            style: Style::Guide,
            colour: 2,
        });
    }
    if let Some(found) = search.found {
        // At the value the nearest run gave: the value found itself may not have been run.
        let nearest = runs
            .iter()
            .min_by(|a, b| {
                (a.0 / found)
                    .ln()
                    .abs()
                    .total_cmp(&(b.0 / found).ln().abs())
            })
            .map_or(floor, |r| r.1);
        series.push(Series {
            label: "value found".into(),
            points: vec![(found, nearest)],
            style: Style::Located,
            colour: 2,
        });
    }
    Panel {
        title: search.title.clone(),
        x_desc: search.knob.clone(),
        y_desc: search
            .objective
            .clone()
            .unwrap_or_else(|| "safe (1) or not (0)".into()),
        x_log: true,
        y_log: false,
        series,
        notes: Vec::new(),
    }
}
