//! Line plots of measured curves, in one or more panels, on linear or logarithmic axes: the
//! drawing every EDMD figure shares.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;

use crate::render::{DrawResult, Drawing, FONT};

const PANEL_WIDTH: u32 = 900;
const PANEL_HEIGHT: u32 = 620;
const TITLE_HEIGHT: u32 = 40;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Style {
    /// Measured points joined by a line.
    Measured,
    /// A guide to the eye (a power law): a dashed grey line, no markers.
    Guide,
    /// Points without a line, drawn as crosses: flagged measurements (overlaps found, a
    /// minimum not bracketed).
    Flagged,
    /// Points without a line, drawn as large diamonds: located minima.
    Located,
    /// Not drawn: points the axes must reach (a figure's whole x grid while some of it is
    /// not measured yet).
    Frame,
}

pub(crate) struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
    /// Series with the same colour index share a colour (a curve and its located minimum).
    pub colour: usize,
}

pub(crate) struct Panel {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub x_log: bool,
    pub y_log: bool,
    pub series: Vec<Series>,
    /// Text next to points (e.g. the value of the setting a point measured).
    pub notes: Vec<((f64, f64), String)>,
}

/// Panels side by side, `columns` to a row, under one title.
pub(crate) struct LinePlot {
    pub title: String,
    pub panels: Vec<Panel>,
    pub columns: usize,
}

impl LinePlot {
    /// A figure of one panel, titled by the panel's title.
    pub fn single(panel: Panel) -> Self {
        Self {
            title: String::new(),
            panels: vec![panel],
            columns: 1,
        }
    }

    fn grid(&self) -> (u32, u32) {
        let columns = self.columns.clamp(1, self.panels.len().max(1));
        let rows = self.panels.len().div_ceil(columns).max(1);
        (columns as u32, rows as u32)
    }

    fn title_height(&self) -> u32 {
        if self.title.is_empty() {
            0
        } else {
            TITLE_HEIGHT
        }
    }
}

impl Drawing for LinePlot {
    fn size(&self) -> (u32, u32) {
        let (columns, rows) = self.grid();
        (
            columns * PANEL_WIDTH,
            self.title_height() + rows * PANEL_HEIGHT,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let body = if self.title.is_empty() {
            root.clone()
        } else {
            root.titled(&self.title, (FONT, 24))?
        };
        let (columns, rows) = self.grid();
        let areas = body.split_evenly((rows as usize, columns as usize));
        for (panel, area) in self.panels.iter().zip(&areas) {
            let ((x_lo, x_hi), (y_lo, y_hi)) = panel.ranges();
            // A logarithmic axis shorter than a decade would show no tick label at all.
            let x_log = panel.x_log && x_hi / x_lo > 10.0;
            let y_log = panel.y_log && y_hi / y_lo > 10.0;
            let log = |lo: f64, hi: f64, labelled: Option<Vec<f64>>| {
                let (bold, light) = log_ticks(lo, hi);
                (lo..hi)
                    .log_scale()
                    .with_key_points(labelled.unwrap_or(bold))
                    .with_light_points(light)
            };
            let x_log_range = || log(x_lo, x_hi, panel.swept_x());
            match (x_log, y_log) {
                (false, false) => panel.draw_on(area, x_lo..x_hi, y_lo..y_hi)?,
                (true, false) => panel.draw_on(area, x_log_range(), y_lo..y_hi)?,
                (false, true) => panel.draw_on(area, x_lo..x_hi, log(y_lo, y_hi, None))?,
                (true, true) => panel.draw_on(area, x_log_range(), log(y_lo, y_hi, None))?,
            }
        }
        Ok(())
    }
}

/// Smallest and largest of `values` (positive ones only on a logarithmic axis), padded, with
/// room above for the legend.
fn padded(values: impl Iterator<Item = f64>, log: bool, legend_room: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let span = (hi / lo).max(1.5);
        (lo / span.powf(0.05), hi * span.powf(0.05 + legend_room))
    } else {
        let span = if hi > lo {
            hi - lo
        } else {
            lo.abs().max(1.0) * 0.1
        };
        (lo - 0.05 * span, hi + (0.05 + legend_room) * span)
    }
}

/// Ticks of a logarithmic axis on [lo, hi]: labelled ones at the decades (and at 2 and 5 times
/// them on an axis of at most two decades, which would otherwise carry two or three labels), grid
/// lines at every m·10^k (only the decades beyond three). Plotters' own choice for a span of a
/// decade or two labels some values twice and crowds sub-decade grid lines into one band.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let decades = (hi / lo).log10();
    let in_range = |v: &f64| (lo..=hi).contains(v);
    let ticks = |mantissas: &[f64]| -> Vec<f64> {
        (lo.log10().floor() as i32..=hi.log10().ceil() as i32)
            // 1/10^|k|, not 10^k, for negative k: 0.1 exactly as the label's value.
            .map(|k| {
                if k < 0 {
                    1.0 / 10f64.powi(-k)
                } else {
                    10f64.powi(k)
                }
            })
            .flat_map(|decade| mantissas.iter().map(move |m| m * decade))
            .filter(in_range)
            .collect()
    };
    let bold = ticks(if decades <= 2.0 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    });
    let light = if decades <= 3.0 {
        ticks(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    } else {
        ticks(&[1.0])
    };
    (bold, light)
}

/// A tick label short enough for any axis: 0.001 as 1e-3, 12345 as 1.2e4.
fn tick(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".to_owned()
    } else if !(1e-2..1e4).contains(&a) {
        let text = format!("{v:.1e}");
        text.replace(".0e", "e")
    } else {
        let text = format!("{v:.3}");
        text.trim_end_matches('0').trim_end_matches('.').to_owned()
    }
}

/// A sweep over at most this many x values has them labelled on a logarithmic x axis.
const SWEPT_LABELS: usize = 8;

impl Panel {
    /// The x values of the series where they are a sweep over a few points ([`SWEPT_LABELS`]),
    /// each at least a quarter more than the one before and labelled differently, within two
    /// decades: a logarithmic x axis labels them instead of its decades and their 2s and 5s,
    /// which left Fig. 8's X0 = 0.25 and 4 unlabelled. Wider sweeps keep the decades (Fig. 9's
    /// ε_d, 3.2·10⁻⁷ to 3.2·10⁻³, reads better on 10⁻⁶ … 10⁻³).
    fn swept_x(&self) -> Option<Vec<f64>> {
        let mut xs: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0))
            .filter(|x| x.is_finite() && *x > 0.0)
            .collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let apart = xs
            .windows(2)
            .all(|w| w[1] >= 1.25 * w[0] && tick(w[0]) != tick(w[1]));
        let within = xs
            .first()
            .zip(xs.last())
            .is_some_and(|(lo, hi)| hi / lo <= 100.0);
        ((2..=SWEPT_LABELS).contains(&xs.len()) && apart && within).then_some(xs)
    }

    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let points = || self.series.iter().flat_map(|s| s.points.iter());
        let x = padded(points().map(|p| p.0), self.x_log, 0.0);
        // The legend takes the top of the panel: about a third for a full legend.
        let room = 0.08 * self.series.iter().filter(|s| !s.label.is_empty()).count() as f64;
        let y = padded(points().map(|p| p.1), self.y_log, room.min(0.8));
        (x, y)
    }

    fn draw_on<DB, X, Y>(&self, area: &DrawingArea<DB, Shift>, x: X, y: Y) -> DrawResult
    where
        DB: DrawingBackend,
        DB::ErrorType: 'static,
        X: AsRangedCoord<Value = f64>,
        Y: AsRangedCoord<Value = f64>,
        X::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, (FONT, 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x, y)?;
        chart
            .configure_mesh()
            .x_desc(self.x_desc.as_str())
            .y_desc(self.y_desc.as_str())
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()?;
        for series in &self.series {
            let colour = match series.style {
                Style::Guide => RGBAColor(110, 110, 110, 1.0),
                _ => Palette99::pick(series.colour).to_rgba(),
            };
            let points = series.points.iter().copied();
            let drawn = match series.style {
                Style::Measured => {
                    chart
                        .draw_series(points.clone().map(|p| Circle::new(p, 4, colour.filled())))?;
                    chart.draw_series(LineSeries::new(points, colour.stroke_width(2)))?
                }
                Style::Guide => chart.draw_series(DashedLineSeries::new(
                    points,
                    8,
                    6,
                    colour.stroke_width(2),
                ))?,
                Style::Flagged => {
                    chart.draw_series(points.map(|p| Cross::new(p, 7, RED.stroke_width(3))))?
                }
                Style::Located => {
                    chart.draw_series(points.map(|p| TriangleMarker::new(p, 9, colour.filled())))?
                }
                Style::Frame => continue,
            };
            if series.label.is_empty() {
                continue;
            }
            let style = series.style;
            drawn
                .label(&series.label)
                .legend(move |(x, y)| match style {
                    Style::Flagged => Cross::new((x + 10, y), 5, RED.stroke_width(2)).into_dyn(),
                    Style::Located => {
                        TriangleMarker::new((x + 10, y), 6, colour.filled()).into_dyn()
                    }
                    _ => PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                        .into_dyn(),
                });
        }
        chart.draw_series(self.notes.iter().map(|(at, text)| {
            Text::new(text.clone(), *at, (FONT, 13).into_font().color(&BLACK))
        }))?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axes_label_each_value_once() {
        // Fig. 13's NNL panel: 85 to 2700 µs.
        let (bold, light) = log_ticks(85.0, 2700.0);
        assert_eq!(bold, [100.0, 200.0, 500.0, 1000.0, 2000.0]);
        assert_eq!(light.len(), 1 + 9 + 2);
        assert!(light.windows(2).all(|w| w[0] < w[1]));
        let labels: Vec<String> = bold.iter().map(|&v| tick(v)).collect();
        let mut unique = labels.clone();
        unique.dedup();
        assert_eq!(labels, unique);
        // Four decades: decades only.
        let (bold, light) = log_ticks(0.05, 800.0);
        assert_eq!(bold, [0.1, 1.0, 10.0, 100.0]);
        assert_eq!(light, bold);
    }

    /// Fig. 8's sweep over X0 is labelled at each X0; many values, values too close to read
    /// apart, or spread over more than two decades keep the decades.
    #[test]
    fn a_sweep_over_a_few_values_labels_each_one() {
        let panel = |xs: &[f64]| Panel {
            title: String::new(),
            x_desc: String::new(),
            y_desc: String::new(),
            x_log: true,
            y_log: true,
            series: vec![
                Series {
                    label: "LL".into(),
                    points: xs.iter().map(|&x| (x, 1.0 + x)).collect(),
                    style: Style::Measured,
                    colour: 0,
                },
                Series {
                    label: "NNL".into(),
                    points: xs.iter().rev().map(|&x| (x, 2.0 + x)).collect(),
                    style: Style::Measured,
                    colour: 1,
                },
            ],
            notes: Vec::new(),
        };
        assert_eq!(
            panel(&[4.0, 0.25, 0.5, 1.0, 2.0]).swept_x(),
            Some(vec![0.25, 0.5, 1.0, 2.0, 4.0])
        );
        let many: Vec<f64> = (0..12).map(|k| 1.5f64.powi(k)).collect();
        assert_eq!(panel(&many).swept_x(), None);
        assert_eq!(panel(&[1.0, 1.1, 4.0]).swept_x(), None);
        assert_eq!(panel(&[3.2e-7, 3.2e-5, 3.2e-3]).swept_x(), None);
        assert_eq!(
            panel(&[0.1, 1.0, 10.0]).swept_x(),
            Some(vec![0.1, 1.0, 10.0])
        );
        assert_eq!(panel(&[2.0]).swept_x(), None);
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(0.001), "1e-3");
        assert_eq!(tick(1e-7), "1e-7");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(40.0), "40");
        assert_eq!(tick(12345.0), "1.2e4");
    }

    #[test]
    fn ranges_leave_room_and_respect_log_axes() {
        let (lo, hi) = padded([1.0, 100.0, -3.0].into_iter(), true, 0.0);
        assert!(
            lo < 1.0 && lo > 0.5 && hi > 100.0 && hi < 200.0,
            "{lo} {hi}"
        );
        let (lo, hi) = padded([2.0, 2.0].into_iter(), false, 0.0);
        assert!(lo < 2.0 && hi > 2.0);
    }
}
