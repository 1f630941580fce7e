//! Tables and figures of `sweep` campaigns, as pure functions over result rows.
//!
//! The `results` crate reads each overlap point into one [`OverlapPoint`] per algorithm (its
//! visits pooled) and each EDMD run into an [`EdmdRow`]; this crate never touches the database. It renders the papers' Tables 1–2 and Figures 2–3 over
//! [`OverlapPoint`]s, and Figures 7–11 and 13 of the EDMD paper and the cost of accuracy over
//! [`EdmdRow`]s. Ours compare a second precision, f64, where the papers compare a second
//! language: Table 1 is `table1(rows, "f32")`, Table 2 is `table1(rows, "f64")`, and Figure 3
//! is Figure 2 in f64. Figures 8–11, Figure 13 and the cost of accuracy are data first
//! (serialisable, for `--format json`), drawn second; a figure that would be empty is
//! [`ReportError::MissingPoints`], naming what is missing.
//!
//! One file per report:
//!
//! - Tables 1–2, `table.rs`: [`table1`], then [`render_table`] as Markdown, CSV, LaTeX or JSON.
//! - Figures 2–3, `fig2.rs`: run time over the (L*, W*) plane, [`fig2()`] (PNG or SVG).
//! - Figure 7, `fig7.rs`: τ_c against φ, [`fig7()`].
//! - Figure 8, `fig8.rs`: τ_c against X0 with LL and NNL, and their ratio, [`fig8()`].
//! - Figure 9, `fig9.rs`: τ_c against ε_d, [`fig9()`].
//! - Figure 10, `fig10.rs`: τ_c against Δ_NNL and its minimum, [`fig10()`].
//! - Figure 11, `fig11.rs`: that minimum Δ*_NNL against φ and X0, [`fig11()`].
//! - Figure 13, `fig13.rs`: superquadrics against their exponent, [`fig13()`].
//! - The cost of accuracy, [`accuracy_report`]: the EDMD knobs in `accuracy.rs`, the overlap
//!   kernels in `overlap_accuracy.rs`; drawn as [`accuracy_markdown`] and [`accuracy_plot`] by
//!   `accuracy_render.rs` and `overlap_accuracy_render.rs`.
//! - A configuration's picture, [`snapshot()`] (`snapshot.rs`): a slab of bodies seen along z,
//!   coloured by orientation.
//!
//! What they share: the curves of Figures 8–13 (`curves.rs`), which runs a figure compares
//! (`selection.rs`), a curve's minimum (`minimum.rs`), the unit of lengths on an axis
//! (`units.rs`), line plots (`lines.rs`), and rendering with the bundled font (`render.rs`).
//!
//! Figures use the DejaVu Sans file shipped in `assets/fonts/` (compiled in), never system
//! fonts, so they render the same on a bare machine.

mod accuracy;
mod accuracy_render;
mod curves;
mod fig10;
mod fig11;
mod fig13;
mod fig2;
mod fig7;
mod fig8;
mod fig9;
mod lines;
mod minimum;
mod overlap_accuracy;
mod overlap_accuracy_render;
mod peers;
mod render;
mod search_paths;
mod selection;
mod snapshot;
mod table;
mod units;

use serde::{Deserialize, Serialize};

pub use accuracy::{AccuracyReport, FailedRun, accuracy, accuracy_report, safe_against};
pub use accuracy_render::{accuracy_markdown, accuracy_plot};
pub use fig2::{Fig2Options, fig2, fig2_points, fig2_svg};
pub use fig7::{fig7, fig7_svg};
pub use fig8::{Fig8, fig8};
pub use fig9::{Fig9, fig9};
pub use fig10::{Fig10, fig10};
pub use fig11::{Fig11, LocatedMinimum, fig11};
pub use fig13::{EllipsoidRatio, ExponentCurve, Fig13, fig13};
pub use minimum::{Minimum, MinimumMethod, locate_minimum};
pub use overlap_accuracy::{OverlapAccuracy, PrecisionSetting, VerdictRow, overlap_accuracy};
pub use peers::{CommandRow, PeerPoint, peers, peers_markdown};
pub use search_paths::{SearchPath, search_paths};
pub use snapshot::{Snapshot, SnapshotBody, snapshot};
pub use table::{Table1Row, TableFormat, render_table, table1};
pub use units::LengthUnit;

/// One benchmark point's result for one algorithm: its estimate (a statistic of its timed
/// blocks over every set, named in `statistic`, or for points measured before blocks were kept
/// the mean over its repeats) with the 95 % confidence interval, and whether the machine was
/// disturbed while it was measured.
/// `sweep report fig2 --format json` prints these.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OverlapPoint {
    pub l_star: f64,
    pub w_star: f64,
    pub r_star: f64,
    pub precision: String,
    pub algorithm: String,
    /// A set's run time by the estimate: `ns_per_check` × N_c.
    pub mean_ms: f64,
    pub ns_per_check: f64,
    /// As measured: the fraction of configurations found not overlapping.
    pub acceptance: f64,
    pub repeats: u32,
    /// The 95 % confidence interval of `ns_per_check` and of `mean_ms`; `None` where a point
    /// has no interval (one repeat of the protocol before blocks were kept).
    pub ci95_lo_ns_per_check: Option<f64>,
    pub ci95_hi_ns_per_check: Option<f64>,
    pub ci95_lo_ms: Option<f64>,
    pub ci95_hi_ms: Option<f64>,
    /// The machine was still disturbed after the point's re-runs (flagged); `None` for points
    /// measured without the noise check.
    pub disturbed: Option<bool>,
    /// Measurements of the point thrown away because the machine was disturbed.
    pub reruns: Option<u32>,
    /// The statistic of the blocks the estimate is (`mean`, `median`, `p5`; `overlap::estimate`);
    /// `mean` for points measured before blocks were kept, whatever was asked.
    pub statistic: String,
    /// Visits the point was measured in (the plan key `visits`; 0 in rows built without a
    /// store). With more than one, the estimate is the mean of the visits' estimates and the
    /// interval has a between-visit term (`overlap::estimate::pool_visits`: the larger of
    /// Student's t with visits − 1 degrees of freedom on the visits' estimates and the
    /// within-visit intervals combined); `repeats` and `reruns` are summed over the visits,
    /// `disturbed` is whether any visit was.
    #[serde(default)]
    pub visits: u32,
}

impl OverlapPoint {
    /// Half the 95 % interval relative to the estimate, if there is one.
    pub fn relative_ci95(&self) -> Option<f64> {
        let (lo, hi) = (self.ci95_lo_ns_per_check?, self.ci95_hi_ns_per_check?);
        (self.ns_per_check > 0.0).then(|| (hi - lo) / 2.0 / self.ns_per_check)
    }
}

/// The `q` quantile (0 ≤ q ≤ 1) of `values`, linearly interpolated; `None` if empty.
fn quantile(values: &[f64], q: f64) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let last = sorted.len().checked_sub(1)?;
    let at = q.clamp(0.0, 1.0) * last as f64;
    let i = at.floor() as usize;
    Some(match sorted.get(i + 1) {
        Some(next) => sorted[i] + at.fract() * (next - sorted[i]),
        None => sorted[i],
    })
}

/// The statistic rows were estimated by, from their `statistic` names: their common one
/// (`mean`, `median`, `p5`), or the distinct ones joined by `+` (names already joined are split)
/// when points measured before blocks were kept (always `mean`) mix with others; empty when no
/// row names one.
pub fn join_statistics<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let mut names: Vec<&str> = names
        .flat_map(|name| name.split('+'))
        .filter(|s| !s.is_empty())
        .collect();
    names.sort_unstable();
    names.dedup();
    names.join("+")
}

/// A sentence that says what each point's estimate is, for a caption; `None` without a
/// statistic.
fn statistic_caption(statistic: &str) -> Option<String> {
    let words = match statistic {
        "" => return None,
        "mean" => "the mean of its timed blocks (the papers' mean time per configuration set)",
        "median" => "the median of its timed blocks",
        "p5" => {
            "the 5th percentile of its timed blocks (the kernel's cost without the machine's noise)"
        }
        mixed => {
            return Some(format!(
                "Each point's estimate: mixed statistics ({mixed}); points measured before blocks were kept give the mean over their repeats."
            ));
        }
    };
    Some(format!("Each point's estimate ({statistic}): {words}."))
}

/// One EDMD run: the point's parameters (what tells its curve apart, its accuracy knobs) and
/// what it measured (its time per collision and the checks that say whether it was right).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EdmdRow {
    pub shape: String,
    pub x0: f64,
    /// A superquadric's exponents [n, m, p] of Eq. 77; `None` for other shapes.
    pub exponents: Option<[f64; 3]>,
    pub neighbours: String,
    /// In the engine's unit, σ (the diameter of the sphere of equal volume).
    pub delta_nnl: f64,
    pub n: u32,
    pub phi: f64,
    /// Time per collision (Eq. 69), by the clock `clock` says.
    pub tau_c_us: f64,
    pub clock: Clock,
    /// In σ, as `delta_nnl`.
    pub eps_d: f64,
    pub eps_nnl: f64,
    pub nr_tol: f64,
    pub nr_max_iter: u32,
    pub nr_relax: f64,
    pub sd_max_iter: u32,
    pub sd_tol: f64,
    pub brent_tol: f64,
    pub seed: u64,
    /// Collisions of the measured run.
    pub collisions: u64,
    pub pressure_z: f64,
    pub pressure_z_err: Option<f64>,
    pub energy_drift_rel: f64,
    pub overlaps: u64,
    pub solver_failures: u64,
    pub contact_nr_fallbacks: u64,
    pub nr_iterations_mean: f64,
    pub nnl_rebuilds: u64,
    pub init_s: Option<f64>,
    pub wall_s: Option<f64>,
    pub cpu_s: Option<f64>,
    /// Eq. 73 in time, wall clock: list updates (box and list rebuilds) and prediction per
    /// collision, in µs; `None` for records written before they were kept.
    pub tau_update_us: Option<f64>,
    pub tau_predict_us: Option<f64>,
    /// The collision sequence's fingerprint: one hash per block of `sequence_block` collisions,
    /// chained, from the run's first collision (`crates/edmd/src/sequence.rs`).
    pub sequence: Option<Vec<u32>>,
    pub sequence_block: Option<u32>,
}

impl EdmdRow {
    /// Δt_u / (Δt_u + Δt_coll) of Eq. 73, where the record has the split.
    pub fn update_share(&self) -> Option<f64> {
        let (update, predict) = (self.tau_update_us?, self.tau_predict_us?);
        (update + predict > 0.0).then(|| update / (update + predict))
    }
}

/// Which clock measured a τ_c: the thread's CPU time (the paper's "CPU time", unaffected by other
/// work on a shared core) or the wall clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Clock {
    Cpu,
    #[default]
    Wall,
}

/// The τ_c axis label of a figure over `rows`: it says which clock, or that they are mixed.
pub(crate) fn tau_label<'a>(rows: impl Iterator<Item = &'a EdmdRow>) -> String {
    let mut clocks = rows.map(|r| r.clock);
    let clock = match clocks.next() {
        Some(first) if clocks.all(|c| c == first) => match first {
            Clock::Cpu => "CPU time",
            Clock::Wall => "wall time",
        },
        _ => "CPU and wall time mixed",
    };
    format!("τ_c (µs, {clock})")
}

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("no EDMD results to plot")]
    NoEdmdRows,
    /// The database lacks the points a figure needs; each entry names one (or one group).
    #[error("{figure}: nothing to draw, the database lacks the points this report needs: {}; `sweep run deploy/plans/edmd-figures.toml` runs them", missing.join("; "))]
    MissingPoints {
        figure: &'static str,
        missing: Vec<String>,
    },
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
