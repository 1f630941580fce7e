//! Figure 2 of the papers: run time over the (L*, W*) plane, one heat map per (algorithm, R*).
//! Figure 3 is the same figure in f64 (`fig2(rows, "f64", …)`), as Table 2 is Table 1's.
//!
//! The colour scale of a row spans the 2nd to the 98th percentile of its cells, not their
//! extremes: one point measured on a disturbed machine (2–3× slow) would otherwise stretch the
//! scale and flatten the surface into one colour. Cells beyond are drawn in the end colours.
//! A point flagged as measured on a disturbed machine is crossed out in red; with
//! [`Fig2Options::show_ci`] every cell carries a circle whose diameter grows with its 95 % CI
//! half-width (the full cell at [`CI_FULL_CELL`]).

use std::collections::BTreeMap;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::render::{DrawResult, Drawing, FONT, render, render_svg};
use crate::{
    OverlapPoint, ReportError, algorithm_rank, algorithm_title, join_statistics, quantile,
};

const PANEL_WIDTH: u32 = 330;
const PANEL_HEIGHT: u32 = 290;
const COLOUR_BAR_WIDTH: u32 = 120;
const TITLE_HEIGHT: u32 = 50;
/// Cells with no measurement (a point not run yet) are drawn in this grey.
const MISSING: RGBColor = RGBColor(225, 225, 225);
/// The percentiles of a row's cells its colour scale spans.
const SCALE_PERCENTILES: (f64, f64) = (0.02, 0.98);
/// Relative 95 % CI half-width drawn as a circle filling the cell.
pub const CI_FULL_CELL: f64 = 0.05;

/// What Figure 2 shows besides the estimates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Fig2Options {
    /// A circle in every cell, its diameter proportional to the point's relative CI.
    pub show_ci: bool,
}

/// One cell: the estimate (ms), its relative 95 % CI half-width and whether it is flagged.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cell {
    ms: f64,
    relative_ci: Option<f64>,
    disturbed: bool,
}

/// Draws Figure 2 for `precision` into `path`: a PNG or an SVG by its extension. Panels are
/// laid out with one column per R* and one row per algorithm; each cell is a measured point's
/// run time (ms), on a colour scale shared by an algorithm's row (the bar on its right), so
/// that the R*-dependence the papers discuss is seen across a row.
pub fn fig2(
    rows: &[OverlapPoint],
    precision: &str,
    path: &Path,
    options: Fig2Options,
) -> Result<(), ReportError> {
    render(&Figure::new(rows, precision, options)?, path)
}

/// Figure 2 as [`fig2`] draws it, as an SVG document in memory.
pub fn fig2_svg(
    rows: &[OverlapPoint],
    precision: &str,
    options: Fig2Options,
) -> Result<String, ReportError> {
    render_svg(&Figure::new(rows, precision, options)?)
}

/// The points of Figure 2 for `precision`, each with its estimate and interval, ordered by
/// algorithm (the papers' order), R*, L* and W*: what `sweep report fig2 --format json` prints.
pub fn fig2_points(
    rows: &[OverlapPoint],
    precision: &str,
) -> Result<Vec<OverlapPoint>, ReportError> {
    let mut points: Vec<OverlapPoint> = rows
        .iter()
        .filter(|r| r.precision == precision)
        .cloned()
        .collect();
    if points.is_empty() {
        return Err(ReportError::NoRows {
            precision: precision.to_owned(),
        });
    }
    points.sort_by(|a, b| {
        algorithm_rank(&a.algorithm)
            .cmp(&algorithm_rank(&b.algorithm))
            .then(a.r_star.total_cmp(&b.r_star))
            .then(a.l_star.total_cmp(&b.l_star))
            .then(a.w_star.total_cmp(&b.w_star))
    });
    Ok(points)
}

/// The measured grid: every distinct L*, W*, R* and algorithm of one precision.
struct Figure {
    precision: String,
    l_values: Vec<f64>,
    w_values: Vec<f64>,
    r_values: Vec<f64>,
    algorithms: Vec<String>,
    /// By (algorithm, R*, L*, W*) indices; several rows of one cell (other acceptance targets
    /// or sizes) are averaged, their widest interval kept, flagged if any is.
    cells: BTreeMap<[usize; 4], Cell>,
    /// The statistic of the points' blocks (`mean`, `median`, `p5`), named in the title.
    statistic: String,
    options: Fig2Options,
}

/// Sorted distinct values.
fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// Index of `x` in the sorted distinct `values` it was taken from.
fn index_of(values: &[f64], x: f64) -> usize {
    values.partition_point(|v| v.total_cmp(&x).is_lt())
}

impl Drawing for Figure {
    fn size(&self) -> (u32, u32) {
        let columns = self.r_values.len() as u32;
        let rows = self.algorithms.len() as u32;
        (
            columns * PANEL_WIDTH + COLOUR_BAR_WIDTH,
            TITLE_HEIGHT + rows * PANEL_HEIGHT,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let statistic = match self.statistic.as_str() {
            "" => String::new(),
            name => format!(", {name} of the blocks"),
        };
        let mut title = format!(
            "Run time per point (ms{statistic}) over the L*–W* plane, {}",
            self.precision
        );
        if self.options.show_ci {
            title.push_str(&format!(
                " · circle: 95 % CI (full cell = ±{} %)",
                CI_FULL_CELL * 100.0
            ));
        }
        if self.cells.values().any(|c| c.disturbed) {
            title.push_str(" · ×: disturbed");
        }
        // A campaign with one R* makes a figure narrower than its title: shrink the title to fit
        // (DejaVu Sans averages about 0.56 em per character).
        let fits = f64::from(self.size().0) / (0.56 * title.chars().count() as f64);
        let body = root.titled(&title, (FONT, fits.min(24.0)))?;
        let (panels, bars) = body.split_horizontally(self.r_values.len() as u32 * PANEL_WIDTH);
        let panels = panels.split_evenly((self.algorithms.len(), self.r_values.len()));
        let bars = bars.split_evenly((self.algorithms.len(), 1));
        for (a, bar) in bars.iter().enumerate() {
            let scale = self.scale(a);
            for r in 0..self.r_values.len() {
                self.draw_panel(&panels[a * self.r_values.len() + r], a, r, scale)?;
            }
            draw_colour_bar(bar, scale)?;
        }
        Ok(())
    }
}

impl Figure {
    fn new(
        rows: &[OverlapPoint],
        precision: &str,
        options: Fig2Options,
    ) -> Result<Self, ReportError> {
        let rows: Vec<&OverlapPoint> = rows
            .iter()
            .filter(|r| r.precision == precision && r.mean_ms.is_finite())
            .collect();
        if rows.is_empty() {
            return Err(ReportError::NoRows {
                precision: precision.to_owned(),
            });
        }
        let statistic = join_statistics(rows.iter().map(|r| r.statistic.as_str()));
        let l_values = distinct(rows.iter().map(|r| r.l_star));
        let w_values = distinct(rows.iter().map(|r| r.w_star));
        let r_values = distinct(rows.iter().map(|r| r.r_star));
        let mut algorithms: Vec<String> = rows.iter().map(|r| r.algorithm.clone()).collect();
        algorithms.sort_by(|a, b| algorithm_rank(a).cmp(&algorithm_rank(b)));
        algorithms.dedup();

        let mut sums: BTreeMap<[usize; 4], (f64, u32, Option<f64>, bool)> = BTreeMap::new();
        for r in rows {
            let key = [
                algorithms
                    .iter()
                    .position(|a| *a == r.algorithm)
                    .unwrap_or_default(),
                index_of(&r_values, r.r_star),
                index_of(&l_values, r.l_star),
                index_of(&w_values, r.w_star),
            ];
            let entry = sums.entry(key).or_default();
            entry.0 += r.mean_ms;
            entry.1 += 1;
            entry.2 = match (entry.2, r.relative_ci95()) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
            entry.3 |= r.disturbed == Some(true);
        }
        let cells = sums
            .into_iter()
            .map(|(k, (sum, n, relative_ci, disturbed))| {
                (
                    k,
                    Cell {
                        ms: sum / f64::from(n),
                        relative_ci,
                        disturbed,
                    },
                )
            })
            .collect();
        Ok(Self {
            precision: precision.to_owned(),
            l_values,
            w_values,
            r_values,
            algorithms,
            cells,
            statistic,
            options,
        })
    }

    /// The colour scale of an algorithm's row of panels: the 2nd to 98th percentile of its
    /// cells (never an empty interval).
    fn scale(&self, algorithm: usize) -> (f64, f64) {
        let values: Vec<f64> = self
            .cells
            .iter()
            .filter(|(k, _)| k[0] == algorithm)
            .map(|(_, c)| c.ms)
            .collect();
        let lo = quantile(&values, SCALE_PERCENTILES.0).unwrap_or(0.0);
        let hi = quantile(&values, SCALE_PERCENTILES.1).unwrap_or(0.0);
        if hi > lo {
            (lo, hi)
        } else {
            let pad = (lo.abs() * 0.05).max(1e-3);
            (lo - pad, hi + pad)
        }
    }

    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        algorithm: usize,
        r: usize,
        (lo, hi): (f64, f64),
    ) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let caption = format!(
            "{}, R* = {}",
            algorithm_title(&self.algorithms[algorithm]),
            self.r_values[r]
        );
        let (nl, nw) = (self.l_values.len(), self.w_values.len());
        let mut chart = ChartBuilder::on(area)
            .caption(caption, (FONT, 17))
            .margin_top(4)
            .margin_right(12)
            .x_label_area_size(40)
            .y_label_area_size(46)
            // Integer coordinates include their end: 0..n−1 is n segments, one per value.
            .build_cartesian_2d((0..nl - 1).into_segmented(), (0..nw - 1).into_segmented())?;
        let l_label = |v: &SegmentValue<usize>| segment_label(&self.l_values, v);
        let w_label = |v: &SegmentValue<usize>| segment_label(&self.w_values, v);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("L*")
            .y_desc("W*")
            .x_labels(10)
            .y_labels(10)
            .x_label_formatter(&l_label)
            .y_label_formatter(&w_label)
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 15))
            .draw()?;
        chart.draw_series(
            (0..nl)
                .flat_map(|l| (0..nw).map(move |w| (l, w)))
                .map(|(l, w)| {
                    let colour = match self.cells.get(&[algorithm, r, l, w]) {
                        Some(cell) => viridis((cell.ms - lo) / (hi - lo)),
                        None => MISSING,
                    };
                    Rectangle::new(
                        [
                            (SegmentValue::Exact(l), SegmentValue::Exact(w)),
                            (SegmentValue::Exact(l + 1), SegmentValue::Exact(w + 1)),
                        ],
                        colour.filled(),
                    )
                }),
        )?;
        let (width, height) = chart.plotting_area().dim_in_pixel();
        let cell_px = (f64::from(width) / nl as f64).min(f64::from(height) / nw as f64);
        let here = |l: usize, w: usize| (SegmentValue::CenterOf(l), SegmentValue::CenterOf(w));
        let cells = || {
            self.cells
                .iter()
                .filter(move |(k, _)| k[0] == algorithm && k[1] == r)
                .map(|(k, c)| (k[2], k[3], *c))
        };
        if self.options.show_ci {
            chart.draw_series(cells().filter_map(|(l, w, c)| {
                let relative = c.relative_ci?;
                let radius = (relative / CI_FULL_CELL).clamp(0.0, 1.0) * cell_px / 2.0;
                Some(Circle::new(
                    here(l, w),
                    radius.max(1.0).round() as i32,
                    WHITE.stroke_width(1),
                ))
            }))?;
        }
        let red = RGBColor(220, 30, 30).stroke_width(2);
        chart.draw_series(
            cells()
                .filter(|(_, _, c)| c.disturbed)
                .map(|(l, w, _)| Cross::new(here(l, w), (cell_px / 3.0) as i32, red)),
        )?;
        Ok(())
    }
}

/// Tick label of a categorical axis: the value at the centre of a cell.
fn segment_label(values: &[f64], v: &SegmentValue<usize>) -> String {
    match v {
        SegmentValue::CenterOf(i) | SegmentValue::Exact(i) => {
            values.get(*i).map(f64::to_string).unwrap_or_default()
        }
        SegmentValue::Last => String::new(),
    }
}

/// A vertical colour bar for `[lo, hi]` ms, with its ticks on the right.
fn draw_colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (lo, hi): (f64, f64),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let mut chart = ChartBuilder::on(area)
        // Same vertical margins as a panel, so the bar spans the heat maps' height.
        .caption("ms", (FONT, 17))
        .margin_top(4)
        .margin_left(6)
        .margin_right(4)
        .x_label_area_size(40)
        .right_y_label_area_size(66)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|v| format_ms(*v, hi - lo))
        .label_style((FONT, 12))
        .draw()?;
    const STEPS: usize = 100;
    chart.draw_series((0..STEPS).map(|i| {
        let (a, b) = (i as f64 / STEPS as f64, (i + 1) as f64 / STEPS as f64);
        Rectangle::new(
            [(0.0, lo + a * (hi - lo)), (1.0, lo + b * (hi - lo))],
            viridis((a + b) / 2.0).filled(),
        )
    }))?;
    Ok(())
}

/// A tick value with as many decimals as the bar's span needs.
fn format_ms(v: f64, span: f64) -> String {
    let decimals = if span >= 10.0 {
        0
    } else if span >= 1.0 {
        1
    } else {
        (-span.log10()).ceil() as usize + 1
    };
    format!("{v:.decimals$}")
}

/// The viridis colour map (perceptually uniform, readable in grey and by colour-blind readers),
/// linearly interpolated between nine of its stops; `t` is clamped to [0, 1].
fn viridis(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let x = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mix = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * f).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_ends_and_clamps() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
    }

    /// One point 3× slow (a disturbed measurement) no longer sets the top of the scale.
    #[test]
    fn one_slow_point_does_not_stretch_the_scale() {
        let mut rows: Vec<OverlapPoint> = (1..=10)
            .flat_map(|l| (1..=10).map(move |w| (l, w)))
            .map(|(l, w)| OverlapPoint {
                l_star: f64::from(l),
                w_star: f64::from(w),
                r_star: 5.0,
                precision: "f32".into(),
                algorithm: "qri".into(),
                mean_ms: 20.0 + f64::from(l) * 0.1,
                ..OverlapPoint::default()
            })
            .collect();
        rows[17].mean_ms = 60.0;
        let figure = Figure::new(&rows, "f32", Fig2Options::default()).expect("rows");
        let (lo, hi) = figure.scale(0);
        assert!(lo >= 20.1 && hi <= 21.0, "scale {lo}..{hi}");
    }

    #[test]
    fn tick_decimals_follow_the_span() {
        assert_eq!(format_ms(12.345, 30.0), "12");
        assert_eq!(format_ms(1.2345, 2.0), "1.2");
        assert_eq!(format_ms(1.2346, 0.05), "1.235");
    }
}
