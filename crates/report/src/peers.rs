//! Peers side by side: τ_c of our EDMD spheres against another program's (a `[[command]]`
//! family, e.g. Smallenburg's published hard-sphere code) at the same N and φ.
//!
//! Each side's runs of a point are its repeats (seeds, visits). The ratio is theirs / ours
//! (above 1: ours is faster), estimated as the ratio of geometric means, with a 95 % interval
//! from Welch's t on the logarithms: exp(d ± t_ν·√(s₁²/n₁ + s₂²/n₂)), ν by Welch–Satterthwaite.
//! Times per collision are positive and their noise multiplicative (a disturbed run is slower
//! by a factor), so logarithms are the natural scale; with fewer than two runs on a side the
//! interval is absent.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::EdmdRow;

/// One done program job: its parameters and the values it printed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CommandRow {
    pub job_id: String,
    pub label: String,
    pub params: BTreeMap<String, serde_json::Value>,
    pub program_hash: String,
    pub wall_s: f64,
    pub cpu_s: f64,
    pub values: BTreeMap<String, f64>,
}

impl CommandRow {
    /// A numeric parameter.
    pub fn param(&self, name: &str) -> Option<f64> {
        self.params.get(name).and_then(serde_json::Value::as_f64)
    }
}

/// One (N, φ) of the comparison.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PeerPoint {
    pub n: u32,
    pub phi: f64,
    /// Geometric means of τ_c (µs per collision) and the runs behind them.
    pub ours_tau_c_us: f64,
    pub ours_runs: usize,
    pub theirs_tau_c_us: f64,
    pub theirs_runs: usize,
    /// theirs / ours: above 1, ours is faster.
    pub ratio: f64,
    /// 95 % interval of the ratio; `None` with fewer than two runs on a side.
    pub ratio_ci95: Option<(f64, f64)>,
}

/// The comparison: every (N, φ) that both sides measured, by N then φ. `label` picks the
/// program; its runs must print the value `value` (τ_c in µs by the same clock as `ours`:
/// `tau_c_us` for CPU time, `tau_c_wall_us` for the wall clock) and have parameters `n` and
/// `phi`. Only sphere runs of ours count.
pub fn peers(ours: &[EdmdRow], theirs: &[CommandRow], label: &str, value: &str) -> Vec<PeerPoint> {
    let key = |n: u32, phi: f64| (n, (phi * 1e9).round() as i64);
    let mut sides: BTreeMap<(u32, i64), Sides> = BTreeMap::new();
    for row in ours.iter().filter(|r| r.shape == "sphere") {
        if row.tau_c_us > 0.0 {
            let entry = sides
                .entry(key(row.n, row.phi))
                .or_insert((row.phi, vec![], vec![]));
            entry.1.push(row.tau_c_us.ln());
        }
    }
    for row in theirs.iter().filter(|r| r.label == label) {
        let (Some(n), Some(phi), Some(&tau)) =
            (row.param("n"), row.param("phi"), row.values.get(value))
        else {
            continue;
        };
        if tau > 0.0 && n >= 0.0 && n <= f64::from(u32::MAX) {
            let entry = sides
                .entry(key(n as u32, phi))
                .or_insert((phi, vec![], vec![]));
            entry.2.push(tau.ln());
        }
    }
    sides
        .into_iter()
        .filter(|(_, (_, a, b))| !a.is_empty() && !b.is_empty())
        .map(|((n, _), (phi, ours, theirs))| {
            let (m1, v1) = mean_var(&ours);
            let (m2, v2) = mean_var(&theirs);
            let d = m2 - m1;
            let ratio_ci95 = (ours.len() > 1 && theirs.len() > 1).then(|| {
                let (a, b) = (v1 / ours.len() as f64, v2 / theirs.len() as f64);
                let se = (a + b).sqrt();
                let df = if se > 0.0 {
                    (a + b).powi(2)
                        / (a * a / (ours.len() - 1) as f64 + b * b / (theirs.len() - 1) as f64)
                } else {
                    f64::INFINITY
                };
                let t = t975(df);
                ((d - t * se).exp(), (d + t * se).exp())
            });
            PeerPoint {
                n,
                phi,
                ours_tau_c_us: m1.exp(),
                ours_runs: ours.len(),
                theirs_tau_c_us: m2.exp(),
                theirs_runs: theirs.len(),
                ratio: d.exp(),
                ratio_ci95,
            }
        })
        .collect()
}

/// A point's φ, and the logarithms of τ_c of our runs and of theirs.
type Sides = (f64, Vec<f64>, Vec<f64>);

/// Mean and sample variance (0 for one value).
fn mean_var(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = if xs.len() > 1 {
        xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    (mean, var)
}

/// Student's t 0.975 quantile for `df` degrees of freedom (real df rounded down; 1.96 beyond 30).
fn t975(df: f64) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    if !df.is_finite() || df > 30.0 {
        return 1.96;
    }
    let i = (df.floor() as usize).clamp(1, 30);
    T[i - 1]
}

/// The comparison as a Markdown table.
pub fn peers_markdown(points: &[PeerPoint], label: &str) -> String {
    let mut out = format!(
        "| N | φ | ours τ_c (µs) | runs | {label} τ_c (µs) | runs | ratio theirs/ours | 95 % interval |\n|---|---|---|---|---|---|---|---|\n"
    );
    for p in points {
        let ci = p
            .ratio_ci95
            .map_or_else(|| "—".to_owned(), |(lo, hi)| format!("{lo:.3} – {hi:.3}"));
        out.push_str(&format!(
            "| {} | {} | {:.4} | {} | {:.4} | {} | {:.3} | {} |\n",
            p.n, p.phi, p.ours_tau_c_us, p.ours_runs, p.theirs_tau_c_us, p.theirs_runs, p.ratio, ci
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ours(n: u32, tau: f64) -> EdmdRow {
        EdmdRow {
            shape: "sphere".into(),
            n,
            phi: 0.45,
            tau_c_us: tau,
            ..EdmdRow::default()
        }
    }

    fn theirs(n: u32, tau: f64) -> CommandRow {
        CommandRow {
            label: "peer".into(),
            params: [
                ("n".to_owned(), serde_json::json!(n)),
                ("phi".to_owned(), serde_json::json!(0.45)),
            ]
            .into(),
            values: [("tau_c_us".to_owned(), tau)].into(),
            ..CommandRow::default()
        }
    }

    #[test]
    fn ratio_of_geometric_means_with_a_welch_interval() {
        let points = peers(
            &[ours(256, 1.0), ours(256, 4.0), ours(512, 1.0)],
            &[
                theirs(256, 2.0),
                theirs(256, 8.0),
                theirs(512, 3.0),
                theirs(1024, 1.0),
            ],
            "peer",
            "tau_c_us",
        );
        assert_eq!(points.len(), 2, "1024 has no run of ours");
        let p = &points[0];
        assert!((p.ours_tau_c_us - 2.0).abs() < 1e-12 && (p.theirs_tau_c_us - 4.0).abs() < 1e-12);
        assert!((p.ratio - 2.0).abs() < 1e-12);
        let (lo, hi) = p.ratio_ci95.expect("two runs a side");
        // Equal spreads (ln 4 apart), df = 2: half-width t·√(2·(ln 4)²/2 / 2) = 4.303·ln4/√2.
        let half = 4.303 * 4f64.ln() / 2f64.sqrt();
        assert!((hi.ln() - (2f64.ln() + half)).abs() < 1e-9, "{hi}");
        assert!((lo * hi - 4.0).abs() < 1e-9, "symmetric in logs around 2");
        assert_eq!(points[1].ratio_ci95, None, "one run a side");
        assert!(peers_markdown(&points, "peer").contains("| 256 | 0.45 |"));
    }
}
