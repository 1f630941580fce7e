//! Tables 1–2 of the papers: mean run time over the (L*, W*) plane, per R* and algorithm.

use std::fmt::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::{OverlapRow, ReportError, algorithm_rank, algorithm_title};

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
}

/// Averages `rows` of one `precision` over the (L*, W*) plane for each (R*, algorithm), ordered
/// by R* then by the papers' algorithm order. Rows of other precisions are ignored. As in the
/// papers, every point weighs the same, whatever its shape.
pub fn table1(rows: &[OverlapRow], precision: &str) -> Vec<Table1Row> {
    let mut selected: Vec<&OverlapRow> = rows.iter().filter(|r| r.precision == precision).collect();
    selected.sort_by(|a, b| {
        a.r_star
            .total_cmp(&b.r_star)
            .then_with(|| algorithm_rank(&a.algorithm).cmp(&algorithm_rank(&b.algorithm)))
    });
    let mut out: Vec<Table1Row> = Vec::new();
    for row in selected {
        match out.last_mut() {
            Some(last) if last.r_star == row.r_star && last.algorithm == row.algorithm => {
                // Running sums; divided once the group is complete.
                last.mean_ms += row.mean_ms;
                last.ns_per_check += row.ns_per_check;
                last.points += 1;
            }
            _ => out.push(Table1Row {
                r_star: row.r_star,
                precision: precision.to_owned(),
                algorithm: row.algorithm.clone(),
                mean_ms: row.mean_ms,
                ns_per_check: row.ns_per_check,
                points: 1,
            }),
        }
    }
    for row in &mut out {
        row.mean_ms /= row.points as f64;
        row.ns_per_check /= row.points as f64;
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
    /// The rows themselves: a list of `{r_star, precision, algorithm, mean_ms, ns_per_check, points}`.
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

/// Table 1 in the papers' layout: one line per R*, one column per algorithm.
struct Grid {
    algorithms: Vec<String>,
    lines: Vec<(f64, Vec<Option<f64>>)>,
}

impl Grid {
    fn new(rows: &[Table1Row]) -> Self {
        let mut algorithms: Vec<String> = rows.iter().map(|r| r.algorithm.clone()).collect();
        algorithms.sort_by(|a, b| algorithm_rank(a).cmp(&algorithm_rank(b)));
        algorithms.dedup();
        let mut r_values: Vec<f64> = rows.iter().map(|r| r.r_star).collect();
        r_values.sort_by(f64::total_cmp);
        r_values.dedup();
        let lines = r_values
            .into_iter()
            .map(|r_star| {
                let cells = algorithms
                    .iter()
                    .map(|a| {
                        rows.iter()
                            .find(|row| row.r_star == r_star && &row.algorithm == a)
                            .map(|row| row.mean_ms)
                    })
                    .collect();
                (r_star, cells)
            })
            .collect();
        Self { algorithms, lines }
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
                let _ = write!(out, " {} |", cell.map_or_else(|| "–".to_owned(), ms));
            }
            out.push('\n');
        }
        out
    }

    fn csv(&self) -> String {
        // Algorithm names are identifiers (letters, digits, `_`): no quoting needed.
        let mut out = String::from("r_star");
        for a in &self.algorithms {
            let _ = write!(out, ",{a}");
        }
        out.push('\n');
        for (r_star, cells) in &self.lines {
            let _ = write!(out, "{r_star}");
            for cell in cells {
                let _ = write!(out, ",{}", cell.map_or_else(String::new, ms));
            }
            out.push('\n');
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
                let _ = write!(out, " & {}", cell.map_or_else(|| "--".to_owned(), ms));
            }
            out.push_str(" \\\\\n");
        }
        out.push_str("\\bottomrule\n\\end{tabular}\n");
        out
    }
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

    fn row(l: f64, w: f64, r: f64, precision: &str, algorithm: &str, mean_ms: f64) -> OverlapRow {
        OverlapRow {
            l_star: l,
            w_star: w,
            r_star: r,
            precision: precision.into(),
            algorithm: algorithm.into(),
            mean_ms,
            ns_per_check: mean_ms * 500.0,
            acceptance: 0.4,
            repeats: 3,
        }
    }

    fn sample() -> Vec<OverlapRow> {
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
            "r_star,qri,ocsi,my_kernel\n0.05,22.30,10.00,1.00\n0.5,,12.00,\n5,27.25,10.00,1.00\n"
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
                "mean_ms",
                "ns_per_check",
                "points",
                "precision",
                "r_star"
            ]
        );
        assert_eq!(json[0]["points"], 4);
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
