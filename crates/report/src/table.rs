//! Tables 1–2 of the papers: mean run time over the (L*, W*) plane, per R* and algorithm, with
//! its 95 % confidence interval and how many of its points were measured on a disturbed machine.

use std::fmt::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::{
    OverlapPoint, ReportError, algorithm_rank, algorithm_title, join_statistics, quantile,
    statistic_caption,
};

/// One cell of Table 1: an algorithm's mean over every (L*, W*) point measured at one R*.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1Row {
    pub r_star: f64,
    pub precision: String,
    pub algorithm: String,
    pub mean_ms: f64,
    pub ns_per_check: f64,
    /// How many points (rows) the mean is over; 400 for the papers' 20 × 20 grid.
    pub points: u64,
    /// Half-width of the 95 % confidence interval of `mean_ms`, from the points' intervals
    /// (independent measurements); `None` if a point has no interval.
    pub ci95_ms: Option<f64>,
    /// The median over the points of their 95 % CI half-width relative to their estimate: how
    /// precisely a single point (a cell of Fig. 2) is known.
    pub point_ci95_rel: Option<f64>,
    /// Points measured on a disturbed machine even after their re-runs (flagged).
    pub disturbed: u64,
    /// Points re-run because the machine was disturbed.
    pub rerun: u64,
    /// The statistic of each point's blocks that the mean is over (`mean`, `median`, `p5`, or
    /// several joined by `+`; see [`OverlapPoint::statistic`]).
    pub statistic: String,
    /// The fewest visits any of the points was measured in ([`OverlapPoint::visits`]; 1 for a
    /// point measured once): with more, each point's interval includes how much its visits
    /// differ, and so does `ci95_ms`.
    #[serde(default)]
    pub visits: u32,
}

/// The 97.5 % quantile of the normal distribution: a 95 % interval is ±1.96 standard errors.
const Z95: f64 = 1.959_963_984_540_054;

/// Averages `rows` of one `precision` over the (L*, W*) plane for each (R*, algorithm), ordered
/// by R* then by the papers' algorithm order. Rows of other precisions are ignored. As in the
/// papers, every point weighs the same, whatever its shape.
pub fn table1(rows: &[OverlapPoint], precision: &str) -> Vec<Table1Row> {
    let mut selected: Vec<&OverlapPoint> =
        rows.iter().filter(|r| r.precision == precision).collect();
    selected.sort_by(|a, b| {
        a.r_star
            .total_cmp(&b.r_star)
            .then_with(|| algorithm_rank(&a.algorithm).cmp(&algorithm_rank(&b.algorithm)))
    });
    let mut out: Vec<Table1Row> = Vec::new();
    for group in selected.chunk_by(|a, b| a.r_star == b.r_star && a.algorithm == b.algorithm) {
        let n = group.len() as f64;
        // A point's standard error in ms from its interval; the mean's is √(Σ se²)/n.
        let se_ms: Option<Vec<f64>> = group
            .iter()
            .map(|r| Some((r.ci95_hi_ms? - r.ci95_lo_ms?) / (2.0 * Z95)))
            .collect();
        let relative: Vec<f64> = group.iter().filter_map(|r| r.relative_ci95()).collect();
        out.push(Table1Row {
            r_star: group[0].r_star,
            precision: precision.to_owned(),
            algorithm: group[0].algorithm.clone(),
            mean_ms: group.iter().map(|r| r.mean_ms).sum::<f64>() / n,
            ns_per_check: group.iter().map(|r| r.ns_per_check).sum::<f64>() / n,
            points: group.len() as u64,
            ci95_ms: se_ms
                .map(|se| Z95 * se.iter().map(|s| s * s).sum::<f64>().sqrt() / n)
                .filter(|h| h.is_finite()),
            point_ci95_rel: (relative.len() == group.len())
                .then(|| quantile(&relative, 0.5))
                .flatten(),
            disturbed: group.iter().filter(|r| r.disturbed == Some(true)).count() as u64,
            rerun: group
                .iter()
                .filter(|r| r.reruns.is_some_and(|n| n > 0))
                .count() as u64,
            statistic: join_statistics(group.iter().map(|r| r.statistic.as_str())),
            visits: group.iter().map(|r| r.visits.max(1)).min().unwrap_or(1),
        });
    }
    out
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TableFormat {
    /// A pipe table: rows R*, columns algorithms (ms), as the papers print it.
    Markdown,
    /// The same layout, comma-separated, header `r_star,<algorithm>…` (values in ms).
    Csv,
    /// A booktabs `tabular` (needs `\usepackage{booktabs}`), same layout.
    Latex,
    /// The rows themselves: a list of `{r_star, precision, algorithm, mean_ms, ns_per_check,
    /// points, ci95_ms, point_ci95_rel, disturbed, rerun, statistic}`.
    Json,
}

impl TableFormat {
    /// The format a file name asks for: `.md`, `.csv`, `.tex`, `.json`.
    pub fn from_path(path: &Path) -> Result<Self, ReportError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("md" | "markdown") => Ok(Self::Markdown),
            Some("csv") => Ok(Self::Csv),
            Some("tex") => Ok(Self::Latex),
            Some("json") => Ok(Self::Json),
            _ => Err(ReportError::Extension {
                path: path.display().to_string(),
                expected: ".md, .csv, .tex or .json",
            }),
        }
    }
}

/// Renders `rows` (from [`table1`]). Missing cells (an algorithm not run at some R*) are left
/// empty (`–` in Markdown, `--` in LaTeX).
pub fn render_table(rows: &[Table1Row], format: TableFormat) -> Result<String, ReportError> {
    Ok(match format {
        TableFormat::Markdown => Grid::new(rows).markdown(),
        TableFormat::Csv => Grid::new(rows).csv(),
        TableFormat::Latex => Grid::new(rows).latex(),
        TableFormat::Json => serde_json::to_string_pretty(rows)? + "\n",
    })
}

/// One cell of the grid: the mean (ms) and the half-width of its 95 % interval.
type Cell = (f64, Option<f64>);

/// Table 1 in the papers' layout: one line per R*, one column per algorithm.
struct Grid {
    algorithms: Vec<String>,
    lines: Vec<(f64, Vec<Option<Cell>>)>,
    /// What the footnote says: the median point's relative interval, and the points flagged and
    /// re-run (a point counts once per R*, whatever its algorithms).
    point_ci95_rel: Option<f64>,
    disturbed: u64,
    rerun: u64,
    /// The statistic of the points' blocks, over every row.
    statistic: String,
    /// The fewest and the most visits of a point, over every row.
    visits: (u32, u32),
}

impl Grid {
    fn new(rows: &[Table1Row]) -> Self {
        let mut algorithms: Vec<String> = rows.iter().map(|r| r.algorithm.clone()).collect();
        algorithms.sort_by(|a, b| algorithm_rank(a).cmp(&algorithm_rank(b)));
        algorithms.dedup();
        let lines = r_values_of(rows)
            .into_iter()
            .map(|r_star| {
                let cells = algorithms
                    .iter()
                    .map(|a| {
                        rows.iter()
                            .find(|row| row.r_star == r_star && &row.algorithm == a)
                            .map(|row| (row.mean_ms, row.ci95_ms))
                    })
                    .collect();
                (r_star, cells)
            })
            .collect();
        let relative: Vec<f64> = rows.iter().filter_map(|r| r.point_ci95_rel).collect();
        let per_r_star = |count: fn(&Table1Row) -> u64| -> u64 {
            r_values_of(rows)
                .iter()
                .map(|&r| {
                    rows.iter()
                        .filter(|row| row.r_star == r)
                        .map(count)
                        .max()
                        .unwrap_or(0)
                })
                .sum()
        };
        Self {
            algorithms,
            lines,
            point_ci95_rel: quantile(&relative, 0.5),
            disturbed: per_r_star(|r| r.disturbed),
            rerun: per_r_star(|r| r.rerun),
            statistic: join_statistics(rows.iter().map(|r| r.statistic.as_str())),
            visits: (
                rows.iter().map(|r| r.visits.max(1)).min().unwrap_or(1),
                rows.iter().map(|r| r.visits.max(1)).max().unwrap_or(1),
            ),
        }
    }

    /// Lines under the table: what each point's estimate is, what ± means and how the points
    /// were measured. Empty for rows that name no statistic and have no intervals or noise
    /// checks.
    fn footnote(&self) -> Vec<String> {
        let mut notes: Vec<String> = statistic_caption(&self.statistic).into_iter().collect();
        if self
            .lines
            .iter()
            .flat_map(|(_, cells)| cells)
            .any(|c| c.is_some_and(|(_, ci)| ci.is_some()))
        {
            notes.push("± is the 95 % confidence interval of the mean over the points.".to_owned());
        }
        if let Some(rel) = self.point_ci95_rel {
            notes.push(format!(
                "A single point is known to ±{:.2} % (median 95 % CI half-width).",
                rel * 100.0
            ));
        }
        if self.visits.1 > 1 {
            let (fewest, most) = self.visits;
            let count = if fewest == most {
                format!("{most}")
            } else {
                format!("{fewest}–{most}")
            };
            notes.push(format!(
                "Each point was measured in {count} visits spread over the campaign: its estimate is the mean of theirs, its interval includes how much they differ."
            ));
        }
        if self.disturbed + self.rerun > 0 {
            notes.push(format!(
                "{} point(s) were re-run because the machine was disturbed; {} are flagged (still disturbed after their re-runs).",
                self.rerun, self.disturbed
            ));
        }
        notes
    }

    fn markdown(&self) -> String {
        let mut out = String::from("| R* |");
        for a in &self.algorithms {
            let _ = write!(out, " {} (ms) |", algorithm_title(a));
        }
        out.push_str("\n|---:|");
        out.push_str(&"---:|".repeat(self.algorithms.len()));
        out.push('\n');
        for (r_star, cells) in &self.lines {
            let _ = write!(out, "| {r_star} |");
            for cell in cells {
                let _ = write!(
                    out,
                    " {} |",
                    cell.map_or_else(|| "–".to_owned(), |c| cell_text(c, " ± "))
                );
            }
            out.push('\n');
        }
        let notes = self.footnote();
        if !notes.is_empty() {
            out.push('\n');
            out.push_str(&notes.join(" "));
            out.push('\n');
        }
        out
    }

    fn csv(&self) -> String {
        // Algorithm names are identifiers (letters, digits, `_`): no quoting needed. The means
        // first, then the half-widths of their 95 % intervals (`<algorithm>_ci95`), then the
        // statistic of the points' blocks (`mean`, `median`, `p5`, joined by `+` if mixed).
        let mut out = String::from("r_star");
        for a in &self.algorithms {
            let _ = write!(out, ",{a}");
        }
        for a in &self.algorithms {
            let _ = write!(out, ",{a}_ci95");
        }
        out.push_str(",statistic\n");
        for (r_star, cells) in &self.lines {
            let _ = write!(out, "{r_star}");
            for cell in cells {
                let _ = write!(
                    out,
                    ",{}",
                    cell.map_or_else(String::new, |(mean, _)| ms(mean))
                );
            }
            for cell in cells {
                let _ = write!(
                    out,
                    ",{}",
                    cell.and_then(|(_, ci)| ci)
                        .map_or_else(String::new, two_digits)
                );
            }
            let _ = writeln!(out, ",{}", self.statistic);
        }
        out
    }

    fn latex(&self) -> String {
        let mut out = format!(
            "\\begin{{tabular}}{{r{}}}\n\\toprule\n$R^*$",
            "r".repeat(self.algorithms.len())
        );
        for a in &self.algorithms {
            let _ = write!(out, " & {} (ms)", latex_escape(algorithm_title(a)));
        }
        out.push_str(" \\\\\n\\midrule\n");
        for (r_star, cells) in &self.lines {
            let _ = write!(out, "{r_star}");
            for cell in cells {
                let _ = write!(
                    out,
                    " & {}",
                    cell.map_or_else(|| "--".to_owned(), |c| cell_text(c, " $\\pm$ "))
                );
            }
            out.push_str(" \\\\\n");
        }
        out.push_str("\\bottomrule\n\\end{tabular}\n");
        for note in self.footnote() {
            let _ = writeln!(out, "% {note}");
        }
        out
    }
}

/// The distinct R* of `rows`, in increasing order.
fn r_values_of(rows: &[Table1Row]) -> Vec<f64> {
    let mut r_values: Vec<f64> = rows.iter().map(|r| r.r_star).collect();
    r_values.sort_by(f64::total_cmp);
    r_values.dedup();
    r_values
}

/// A cell as text: the mean, and `± half-width` (two significant digits) when known.
fn cell_text(cell: Cell, plus_minus: &str) -> String {
    match cell {
        (mean, Some(ci)) => format!("{}{plus_minus}{}", ms(mean), two_digits(ci)),
        (mean, None) => ms(mean),
    }
}

/// Two significant digits, never in exponent form.
fn two_digits(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    // Rounded first, so that 0.0999… counts as 0.10, not as a value below 0.1.
    let rounded: f64 = format!("{x:.1e}").parse().unwrap_or(x);
    let decimals = (1 - rounded.abs().log10().floor() as i32).max(0) as usize;
    format!("{rounded:.decimals$}")
}

/// Milliseconds as the papers print them, with one more digit: modern kernels run in a few ms.
fn ms(value: f64) -> String {
    format!("{value:.2}")
}

fn latex_escape(text: &str) -> String {
    text.chars()
        .flat_map(|c| match c {
            '_' | '&' | '%' | '$' | '#' | '{' | '}' => vec!['\\', c],
            c => vec![c],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(l: f64, w: f64, r: f64, precision: &str, algorithm: &str, mean_ms: f64) -> OverlapPoint {
        OverlapPoint {
            l_star: l,
            w_star: w,
            r_star: r,
            precision: precision.into(),
            algorithm: algorithm.into(),
            mean_ms,
            ns_per_check: mean_ms * 500.0,
            acceptance: 0.4,
            repeats: 3,
            ..OverlapPoint::default()
        }
    }

    fn sample() -> Vec<OverlapPoint> {
        let mut rows = Vec::new();
        for (l, w) in [(1.0, 1.0), (1.0, 2.0), (2.0, 1.0), (2.0, 2.0)] {
            for r in [5.0, 0.05] {
                rows.push(row(l, w, r, "f32", "qri", 20.0 + l * w + r));
                rows.push(row(l, w, r, "f32", "ocsi", 10.0));
                rows.push(row(l, w, r, "f32", "my_kernel", 1.0));
                rows.push(row(l, w, r, "f64", "qri", 99.0));
            }
        }
        rows.push(row(1.0, 1.0, 0.5, "f32", "ocsi", 12.0));
        rows
    }

    #[test]
    fn means_over_the_plane_in_the_papers_order() {
        let t = table1(&sample(), "f32");
        let order: Vec<(f64, &str, u64)> = t
            .iter()
            .map(|r| (r.r_star, r.algorithm.as_str(), r.points))
            .collect();
        assert_eq!(
            order,
            [
                (0.05, "qri", 4),
                (0.05, "ocsi", 4),
                (0.05, "my_kernel", 4),
                (0.5, "ocsi", 1),
                (5.0, "qri", 4),
                (5.0, "ocsi", 4),
                (5.0, "my_kernel", 4)
            ]
        );
        // qri at R* = 5: mean of 20 + l·w + 5 over l·w ∈ {1, 2, 2, 4} = 27.25.
        assert!((t[4].mean_ms - 27.25).abs() < 1e-12);
        assert!((t[4].ns_per_check - 27.25 * 500.0).abs() < 1e-9);
        assert!(t.iter().all(|r| r.precision == "f32"));
        assert_eq!(table1(&sample(), "f64").len(), 2);
        assert!(table1(&sample(), "f16").is_empty());
    }

    #[test]
    fn visits_are_counted_and_said() {
        let t = table1(&sample(), "f32");
        assert!(
            t.iter().all(|r| r.visits == 1),
            "rows without visits count as one"
        );
        let md = render_table(&t, TableFormat::Markdown).expect("renders");
        assert!(!md.contains("visits"), "{md}");
        let visited: Vec<OverlapPoint> = sample()
            .into_iter()
            .map(|r| OverlapPoint {
                // A table row counts its least visited point.
                visits: if r.r_star == 5.0 || r.l_star == 2.0 {
                    5
                } else {
                    3
                },
                ..r
            })
            .collect();
        let t = table1(&visited, "f32");
        let visits: Vec<(f64, u32)> = t.iter().map(|r| (r.r_star, r.visits)).collect();
        assert_eq!(
            visits,
            [
                (0.05, 3),
                (0.05, 3),
                (0.05, 3),
                (0.5, 3),
                (5.0, 5),
                (5.0, 5),
                (5.0, 5)
            ]
        );
        let md = render_table(&t, TableFormat::Markdown).expect("renders");
        assert!(md.contains("measured in 3–5 visits"), "{md}");
        let json = render_table(&t, TableFormat::Json).expect("renders");
        assert!(json.contains(r#""visits": 3"#), "{json}");
    }

    #[test]
    fn renderers_use_the_papers_layout() {
        let t = table1(&sample(), "f32");
        let md = render_table(&t, TableFormat::Markdown).expect("renders");
        let lines: Vec<&str> = md.lines().collect();
        assert_eq!(lines[0], "| R* | QRI (ms) | OCSI (ms) | my_kernel (ms) |");
        assert_eq!(lines[1], "|---:|---:|---:|---:|");
        assert_eq!(lines[2], "| 0.05 | 22.30 | 10.00 | 1.00 |");
        assert_eq!(lines[3], "| 0.5 | – | 12.00 | – |");
        assert_eq!(lines.len(), 5);

        let csv = render_table(&t, TableFormat::Csv).expect("renders");
        assert_eq!(
            csv,
            "r_star,qri,ocsi,my_kernel,qri_ci95,ocsi_ci95,my_kernel_ci95,statistic\n0.05,22.30,10.00,1.00,,,,\n0.5,,12.00,,,,,\n5,27.25,10.00,1.00,,,,\n"
        );

        let tex = render_table(&t, TableFormat::Latex).expect("renders");
        assert!(tex.starts_with("\\begin{tabular}{rrrr}\n\\toprule\n$R^*$ & QRI (ms) & OCSI (ms) & my\\_kernel (ms) \\\\\n\\midrule\n"));
        assert!(tex.contains("\n0.5 & -- & 12.00 & -- \\\\\n"));
        assert!(tex.ends_with("\\bottomrule\n\\end{tabular}\n"));

        let json: serde_json::Value =
            serde_json::from_str(&render_table(&t, TableFormat::Json).expect("renders"))
                .expect("valid JSON");
        let first = json[0].as_object().expect("a list of objects");
        let mut keys: Vec<&str> = first.keys().map(String::as_str).collect();
        keys.sort_unstable();
        assert_eq!(
            keys,
            [
                "algorithm",
                "ci95_ms",
                "disturbed",
                "mean_ms",
                "ns_per_check",
                "point_ci95_rel",
                "points",
                "precision",
                "r_star",
                "rerun",
                "statistic",
                "visits"
            ]
        );
        assert_eq!(json[0]["points"], 4);
        assert!(
            json[0]["ci95_ms"].is_null(),
            "no interval without the points' intervals"
        );
    }

    /// Four points known to ±0.2 ms each (independent): the mean of four is known to ±0.1 ms;
    /// a flagged and a re-run point are counted, once per R* in the footnote.
    #[test]
    fn intervals_and_disturbances_reach_the_table() {
        let mut rows = Vec::new();
        for (k, (l, w)) in [(1.0, 1.0), (1.0, 2.0), (2.0, 1.0), (2.0, 2.0)]
            .into_iter()
            .enumerate()
        {
            for algorithm in ["qri", "ocsi"] {
                let mut r = row(l, w, 5.0, "f32", algorithm, 20.0);
                r.ci95_lo_ms = Some(19.8);
                r.ci95_hi_ms = Some(20.2);
                r.ci95_lo_ns_per_check = Some(r.ns_per_check * 0.99);
                r.ci95_hi_ns_per_check = Some(r.ns_per_check * 1.01);
                r.disturbed = Some(k == 0);
                r.reruns = Some(u32::from(k < 2));
                rows.push(r);
            }
        }
        let t = table1(&rows, "f32");
        assert!((t[0].ci95_ms.expect("an interval") - 0.1).abs() < 1e-12);
        assert!((t[0].point_ci95_rel.expect("points have intervals") - 0.01).abs() < 1e-12);
        assert_eq!((t[0].disturbed, t[0].rerun), (1, 2));
        let md = render_table(&t, TableFormat::Markdown).expect("renders");
        assert!(md.contains("| 5 | 20.00 ± 0.10 | 20.00 ± 0.10 |"), "{md}");
        assert!(md.contains("±1.00 % (median 95 % CI half-width)"), "{md}");
        assert!(
            md.contains("2 point(s) were re-run because the machine was disturbed; 1 are flagged"),
            "{md}"
        );
        let csv = render_table(&t, TableFormat::Csv).expect("renders");
        assert!(csv.ends_with("5,20.00,20.00,0.10,0.10,\n"), "{csv}");
        // A point without an interval leaves the mean without one.
        rows[0].ci95_lo_ms = None;
        assert_eq!(table1(&rows, "f32")[0].ci95_ms, None);
    }

    /// The statistic of the points reaches every format; points measured before blocks were
    /// kept (always the mean) mixed with re-estimated ones are named as a mix, not hidden.
    #[test]
    fn the_statistic_is_named_and_a_mix_is_told() {
        let mut rows = sample();
        for r in &mut rows {
            r.statistic = "median".into();
        }
        let t = table1(&rows, "f32");
        assert!(t.iter().all(|r| r.statistic == "median"));
        let md = render_table(&t, TableFormat::Markdown).expect("renders");
        assert!(
            md.contains("Each point's estimate (median): the median of its timed blocks."),
            "{md}"
        );
        let tex = render_table(&t, TableFormat::Latex).expect("renders");
        assert!(tex.contains("% Each point's estimate (median)"), "{tex}");
        rows[0].statistic = "mean".into();
        let t = table1(&rows, "f32");
        let first = t
            .iter()
            .find(|r| r.r_star == rows[0].r_star && r.algorithm == rows[0].algorithm)
            .expect("the cell of the old point");
        assert_eq!(first.statistic, "mean+median");
        assert!(t.iter().filter(|r| r.statistic == "median").count() == t.len() - 1);
        let md = render_table(&t, TableFormat::Markdown).expect("renders");
        assert!(md.contains("mixed statistics (mean+median)"), "{md}");
        let csv = render_table(&t, TableFormat::Csv).expect("renders");
        assert!(
            csv.lines().skip(1).all(|l| l.ends_with(",mean+median")),
            "{csv}"
        );
    }

    #[test]
    fn format_from_extension() {
        assert_eq!(
            TableFormat::from_path(Path::new("t.MD")).ok(),
            Some(TableFormat::Markdown)
        );
        assert_eq!(
            TableFormat::from_path(Path::new("a/t.tex")).ok(),
            Some(TableFormat::Latex)
        );
        assert!(TableFormat::from_path(Path::new("t.png")).is_err());
    }
}
