//! Figure 2 of the papers: run time over the (L*, W*) plane, one heat map per (algorithm, R*).

use std::collections::BTreeMap;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::render::{DrawResult, Drawing, FONT, render};
use crate::{OverlapRow, ReportError, algorithm_rank, algorithm_title};

const PANEL_WIDTH: u32 = 330;
const PANEL_HEIGHT: u32 = 290;
const COLOUR_BAR_WIDTH: u32 = 120;
const TITLE_HEIGHT: u32 = 50;
/// Cells with no measurement (a point not run yet) are drawn in this grey.
const MISSING: RGBColor = RGBColor(225, 225, 225);

/// Draws Figure 2 for `precision` into `path`: a PNG or an SVG by its extension. Panels are
/// laid out with one column per R* and one row per algorithm; each cell is a measured point's
/// mean run time (ms), on a colour scale shared by an algorithm's row (the bar on its right),
/// so that the R*-dependence the papers discuss is seen across a row.
pub fn fig2(rows: &[OverlapRow], precision: &str, path: &Path) -> Result<(), ReportError> {
    render(&Figure::new(rows, precision)?, path)
}

/// The measured grid: every distinct L*, W*, R* and algorithm of one precision.
struct Figure {
    precision: String,
    l_values: Vec<f64>,
    w_values: Vec<f64>,
    r_values: Vec<f64>,
    algorithms: Vec<String>,
    /// Mean ms by (algorithm, R*, L*, W*) indices; repeated rows of a point are averaged.
    cells: BTreeMap<[usize; 4], f64>,
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
        let title = format!(
            "Mean run time per point (ms) over the L*–W* plane, {}",
            self.precision
        );
        let body = root.titled(&title, (FONT, 24))?;
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
    fn new(rows: &[OverlapRow], precision: &str) -> Result<Self, ReportError> {
        let rows: Vec<&OverlapRow> = rows
            .iter()
            .filter(|r| r.precision == precision && r.mean_ms.is_finite())
            .collect();
        if rows.is_empty() {
            return Err(ReportError::NoRows {
                precision: precision.to_owned(),
            });
        }
        let l_values = distinct(rows.iter().map(|r| r.l_star));
        let w_values = distinct(rows.iter().map(|r| r.w_star));
        let r_values = distinct(rows.iter().map(|r| r.r_star));
        let mut algorithms: Vec<String> = rows.iter().map(|r| r.algorithm.clone()).collect();
        algorithms.sort_by(|a, b| algorithm_rank(a).cmp(&algorithm_rank(b)));
        algorithms.dedup();

        let mut sums: BTreeMap<[usize; 4], (f64, u32)> = BTreeMap::new();
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
        }
        let cells = sums
            .into_iter()
            .map(|(k, (sum, n))| (k, sum / f64::from(n)))
            .collect();
        Ok(Self {
            precision: precision.to_owned(),
            l_values,
            w_values,
            r_values,
            algorithms,
            cells,
        })
    }

    /// Smallest and largest value of an algorithm's row of panels (never an empty interval).
    fn scale(&self, algorithm: usize) -> (f64, f64) {
        let values = self
            .cells
            .iter()
            .filter(|(k, _)| k[0] == algorithm)
            .map(|(_, v)| *v);
        let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
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
                        Some(&v) => viridis((v - lo) / (hi - lo)),
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

    #[test]
    fn tick_decimals_follow_the_span() {
        assert_eq!(format_ms(12.345, 30.0), "12");
        assert_eq!(format_ms(1.2345, 2.0), "1.2");
        assert_eq!(format_ms(1.2346, 0.05), "1.235");
    }
}
