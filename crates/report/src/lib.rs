//! Tables and figures of `sweep` campaigns, as pure functions over result rows.
//!
//! The store aggregates each overlap point into one [`OverlapRow`] per algorithm; this crate
//! never touches the database. It renders the papers' Tables 1–2 ([`table1`], then
//! [`render_table`] as Markdown, CSV, LaTeX or JSON) and Figure 2 ([`fig2`], PNG or SVG). Ours
//! compare a second precision, f64, where the papers compare a second language: Table 1 is
//! `table1(rows, "f32")`, Table 2 is `table1(rows, "f64")`. Figure 7 of the EDMD paper, τ_c
//! against φ, is [`fig7`] over [`EdmdRow`]s.
//!
//! Figures use the DejaVu Sans file shipped in `assets/fonts/` (compiled in), never system
//! fonts, so they render the same on a bare machine.

mod fig;
mod fig7;
mod render;
mod table;

use serde::{Deserialize, Serialize};

pub use fig::fig2;
pub use fig7::fig7;
pub use table::{Table1Row, TableFormat, render_table, table1};

/// One benchmark point's result for one algorithm: the mean over its repeats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OverlapRow {
    pub l_star: f64,
    pub w_star: f64,
    pub r_star: f64,
    pub precision: String,
    pub algorithm: String,
    pub mean_ms: f64,
    pub ns_per_check: f64,
    /// As measured: the fraction of configurations found not overlapping.
    pub acceptance: f64,
    pub repeats: u32,
}

/// One EDMD point: what tells its curve apart, its packing fraction and its time per collision.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdmdRow {
    pub shape: String,
    pub x0: f64,
    pub neighbours: String,
    pub delta_nnl: f64,
    pub n: u32,
    pub phi: f64,
    pub tau_c_us: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("no EDMD results to plot")]
    NoEdmdRows,
    #[error("no {precision} overlap results to plot")]
    NoRows { precision: String },
    #[error("cannot tell the format of `{path}` from its extension (expected {expected})")]
    Extension {
        path: String,
        expected: &'static str,
    },
    #[error("the bundled font assets/fonts/DejaVuSans.ttf is not a valid font")]
    Font,
    #[error("drawing {path}: {message}")]
    Draw { path: String, message: String },
    #[error("json: {0}")]
    Json(#[from] serde_json::Error),
}

/// The algorithms in the papers' order, with the names the papers print. Algorithms not listed
/// here (a future kernel) come after these, alphabetically, under their own name.
const ALGORITHMS: [(&str, &str); 6] = [
    ("arvo", "Arvo"),
    ("qri", "QRI"),
    ("qrf", "QRF"),
    ("sse", "SSE"),
    ("ocsi", "OCSI"),
    ("ocsi_batch", "OCSI batch"),
];

/// Sort key of an algorithm: its position in the papers' order, then its name.
fn algorithm_rank(name: &str) -> (usize, &str) {
    (
        ALGORITHMS
            .iter()
            .position(|(n, _)| *n == name)
            .unwrap_or(ALGORITHMS.len()),
        name,
    )
}

/// The printed name of an algorithm.
fn algorithm_title(name: &str) -> &str {
    ALGORITHMS
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(name, |(_, title)| title)
}
