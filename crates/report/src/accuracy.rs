//! What accuracy costs in time, for the EDMD engine: for each accuracy knob (ε_d, ε_d^nnl, the
//! Newton–Raphson, steepest-descent and Brent tolerances) that a campaign swept, τ_c against
//! what the looser settings lose — overlaps, solver failures, energy drift, and Z's deviation
//! from the run at the tightest setting of the same state point — with the Pareto front and the
//! cheapest setting that loses nothing measurable.
//!
//! A state point is everything but the knob: shape, X0, φ, N, neighbour method, Δ_NNL, seed
//! and run length; the other knobs are held at the campaign's baseline. Two runs at different
//! settings start from initial states prepared with those settings, so Z's deviation is judged
//! against the two runs' combined standard error.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::lines::{LinePlot, Panel, Series, Style};
use crate::render::render;
use crate::selection::{Baseline, KNOBS, Key, Tighter, knobs, timed};
use crate::{EdmdRow, ReportError};

/// A setting loses nothing measurable when its runs found no overlap and no solver failure,
/// kept the energy to this relative drift, and kept Z within this many combined standard errors
/// of the tightest run's.
pub const MAX_ENERGY_DRIFT: f64 = 1e-9;
pub const MAX_Z_SIGMAS: f64 = 3.0;
/// Costs closer than this (relative) are not told apart: one run's τ_c on a shared machine
/// varies by a few per cent, so the recommendation is the tightest safe setting whose cost is
/// within this of the cheapest safe one.
pub const COST_NOISE: f64 = 0.05;

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AccuracyReport {
    pub knobs: Vec<KnobStudy>,
    /// What the report could not measure, said rather than left out silently.
    pub not_measured: Vec<String>,
}

/// One knob swept at one or more state points.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KnobStudy {
    pub knob: String,
    /// "smaller" or "larger": the direction of the more careful setting.
    pub tighter: &'static str,
    /// One per value of the knob, tightest first, summarised over its state points.
    pub settings: Vec<SettingSummary>,
    pub state_points: Vec<StatePointStudy>,
    /// The tightest value that lost nothing at any state point it ran at and costs no more
    /// than [`COST_NOISE`] above the cheapest such value.
    pub recommended: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettingSummary {
    pub value: f64,
    pub state_points: usize,
    /// Geometric mean over state points of τ_c / τ_c at the tightest setting.
    pub cost_ratio: f64,
    /// Largest |Z − Z_ref| / Z_ref.
    pub max_z_deviation_rel: f64,
    /// Largest |Z − Z_ref| / √(err² + err_ref²); `None` where no error was measured.
    pub max_z_deviation_sigmas: Option<f64>,
    pub max_energy_drift_rel: f64,
    pub overlaps: u64,
    pub solver_failures: u64,
    pub contact_nr_fallbacks: u64,
    pub safe: bool,
    /// Not beaten in both cost and Z deviation by a safe setting.
    pub pareto: bool,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StatePointStudy {
    pub shape: String,
    pub x0: f64,
    pub phi: f64,
    pub n: u32,
    pub neighbours: String,
    pub delta_nnl: f64,
    pub seed: u64,
    pub collisions: u64,
    /// The tightest value, the reference of this state point.
    pub reference: f64,
    pub runs: Vec<SettingRun>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettingRun {
    pub value: f64,
    pub tau_c_us: f64,
    pub cost_ratio: f64,
    pub pressure_z: f64,
    pub pressure_z_err: Option<f64>,
    pub z_deviation_rel: f64,
    pub z_deviation_sigmas: Option<f64>,
    pub energy_drift_rel: f64,
    pub overlaps: u64,
    pub solver_failures: u64,
    pub contact_nr_fallbacks: u64,
    pub nr_iterations_mean: f64,
}

impl SettingRun {
    fn safe(&self) -> bool {
        self.overlaps == 0
            && self.solver_failures == 0
            && self.energy_drift_rel <= MAX_ENERGY_DRIFT
            && self.z_deviation_sigmas.is_none_or(|s| s <= MAX_Z_SIGMAS)
    }
}

/// The accuracy report over every EDMD run; [`ReportError::MissingPoints`] when no state
/// point was run at two values of any knob.
pub fn accuracy(rows: &[EdmdRow]) -> Result<AccuracyReport, ReportError> {
    let baseline = Baseline::of(rows);
    let studies: Vec<KnobStudy> = (0..KNOBS.len())
        .filter_map(|k| study(rows, &baseline, k))
        .collect();
    if studies.is_empty() {
        return Err(ReportError::MissingPoints {
            figure: "accuracy",
            missing: vec![format!(
                "runs of one state point at two or more values of an accuracy knob ({}), the others at the campaign's baseline",
                KNOBS.map(|(name, _)| name).join(", ")
            )],
        });
    }
    Ok(AccuracyReport {
        knobs: studies,
        not_measured: vec![
            "how long (in collisions) the event sequence stays identical to the reference run: the engine does not record the sequence".into(),
            "the overlap kernels' f32 against f64 verdicts against the exact answer: not part of the campaign records yet".into(),
        ],
    })
}

type PointKey = (String, Key, Key, u32, String, Key, u64, u64);

fn study(rows: &[EdmdRow], baseline: &Baseline, k: usize) -> Option<KnobStudy> {
    let (name, tighter) = KNOBS[k];
    let mut points: BTreeMap<PointKey, BTreeMap<Key, Vec<&EdmdRow>>> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| timed(r) && baseline.knobs_match(r, Some(k)))
    {
        let key = (
            r.shape.clone(),
            Key(r.x0),
            Key(r.phi),
            r.n,
            r.neighbours.clone(),
            Key(r.delta_nnl),
            r.seed,
            r.collisions,
        );
        points
            .entry(key)
            .or_default()
            .entry(Key(knobs(r)[k]))
            .or_default()
            .push(r);
    }
    let tightest_first = |a: &f64, b: &f64| match tighter {
        Tighter::Smaller => a.total_cmp(b),
        Tighter::Larger => b.total_cmp(a),
    };
    let mut state_points = Vec::new();
    for ((shape, x0, phi, n, neighbours, delta_nnl, seed, collisions), by_value) in points {
        if by_value.len() < 2 {
            continue;
        }
        let mut settings: Vec<(f64, Averaged)> = by_value
            .into_iter()
            .map(|(value, runs)| (value.0, Averaged::of(&runs)))
            .collect();
        settings.sort_by(|a, b| tightest_first(&a.0, &b.0));
        let reference = settings[0].clone();
        let runs = settings
            .iter()
            .map(|(value, a)| a.against(*value, &reference.1))
            .collect();
        state_points.push(StatePointStudy {
            shape,
            x0: x0.0,
            phi: phi.0,
            n,
            neighbours,
            delta_nnl: delta_nnl.0,
            seed,
            collisions,
            reference: reference.0,
            runs,
        });
    }
    if state_points.is_empty() {
        return None;
    }
    let mut values: Vec<f64> = state_points
        .iter()
        .flat_map(|p| p.runs.iter().map(|r| r.value))
        .collect();
    values.sort_by(tightest_first);
    values.dedup_by(|a, b| Key(*a) == Key(*b));
    let mut settings: Vec<SettingSummary> = values
        .iter()
        .map(|&value| summarise(value, &state_points))
        .collect();
    mark_pareto(&mut settings);
    let cheapest = settings
        .iter()
        .filter(|s| s.safe)
        .map(|s| s.cost_ratio)
        .fold(f64::INFINITY, f64::min);
    // Settings are tightest first: the first safe one within the noise of the cheapest.
    let recommended = settings
        .iter()
        .find(|s| s.safe && s.cost_ratio <= cheapest * (1.0 + COST_NOISE))
        .map(|s| s.value);
    Some(KnobStudy {
        knob: name.to_owned(),
        tighter: match tighter {
            Tighter::Smaller => "smaller",
            Tighter::Larger => "larger",
        },
        settings,
        state_points,
        recommended,
    })
}

/// The runs of one setting at one state point (several when repeated), averaged; counts summed.
#[derive(Clone, Debug)]
struct Averaged {
    tau_c_us: f64,
    z: f64,
    z_err: Option<f64>,
    energy_drift_rel: f64,
    overlaps: u64,
    solver_failures: u64,
    contact_nr_fallbacks: u64,
    nr_iterations_mean: f64,
}

impl Averaged {
    fn of(runs: &[&EdmdRow]) -> Self {
        let n = runs.len() as f64;
        let mean = |f: fn(&EdmdRow) -> f64| runs.iter().map(|r| f(r)).sum::<f64>() / n;
        // The standard error of a mean of independent runs.
        let z_err = runs
            .iter()
            .map(|r| r.pressure_z_err.map(|e| e * e))
            .sum::<Option<f64>>()
            .map(|v| v.sqrt() / n);
        Self {
            tau_c_us: mean(|r| r.tau_c_us),
            z: mean(|r| r.pressure_z),
            z_err,
            energy_drift_rel: runs.iter().map(|r| r.energy_drift_rel).fold(0.0, f64::max),
            overlaps: runs.iter().map(|r| r.overlaps).sum(),
            solver_failures: runs.iter().map(|r| r.solver_failures).sum(),
            contact_nr_fallbacks: runs.iter().map(|r| r.contact_nr_fallbacks).sum(),
            nr_iterations_mean: mean(|r| r.nr_iterations_mean),
        }
    }

    fn against(&self, value: f64, reference: &Averaged) -> SettingRun {
        let deviation = (self.z - reference.z).abs();
        let sigmas = match (self.z_err, reference.z_err) {
            (Some(a), Some(b)) if a * a + b * b > 0.0 => Some(deviation / (a * a + b * b).sqrt()),
            _ => None,
        };
        SettingRun {
            value,
            tau_c_us: self.tau_c_us,
            cost_ratio: self.tau_c_us / reference.tau_c_us,
            pressure_z: self.z,
            pressure_z_err: self.z_err,
            z_deviation_rel: deviation / reference.z.abs(),
            z_deviation_sigmas: sigmas,
            energy_drift_rel: self.energy_drift_rel,
            overlaps: self.overlaps,
            solver_failures: self.solver_failures,
            contact_nr_fallbacks: self.contact_nr_fallbacks,
            nr_iterations_mean: self.nr_iterations_mean,
        }
    }
}

fn summarise(value: f64, state_points: &[StatePointStudy]) -> SettingSummary {
    let runs: Vec<&SettingRun> = state_points
        .iter()
        .flat_map(|p| p.runs.iter().filter(|r| Key(r.value) == Key(value)))
        .collect();
    let count = runs.len().max(1) as f64;
    let sigmas: Vec<f64> = runs.iter().filter_map(|r| r.z_deviation_sigmas).collect();
    SettingSummary {
        value,
        state_points: runs.len(),
        cost_ratio: (runs.iter().map(|r| r.cost_ratio.ln()).sum::<f64>() / count).exp(),
        max_z_deviation_rel: runs.iter().map(|r| r.z_deviation_rel).fold(0.0, f64::max),
        max_z_deviation_sigmas: (!sigmas.is_empty())
            .then(|| sigmas.iter().copied().fold(0.0, f64::max)),
        max_energy_drift_rel: runs.iter().map(|r| r.energy_drift_rel).fold(0.0, f64::max),
        overlaps: runs.iter().map(|r| r.overlaps).sum(),
        solver_failures: runs.iter().map(|r| r.solver_failures).sum(),
        contact_nr_fallbacks: runs.iter().map(|r| r.contact_nr_fallbacks).sum(),
        safe: runs.iter().all(|r| r.safe()),
        pareto: false,
    }
}

/// A safe setting is on the front when no other safe setting is at least as cheap and as
/// accurate, and strictly better in one of the two.
fn mark_pareto(settings: &mut [SettingSummary]) {
    let objectives: Vec<(f64, f64, bool)> = settings
        .iter()
        .map(|s| (s.cost_ratio, s.max_z_deviation_rel, s.safe))
        .collect();
    for (i, s) in settings.iter_mut().enumerate() {
        let (cost, error, safe) = objectives[i];
        s.pareto = safe
            && !objectives.iter().enumerate().any(|(j, &(c, e, ok))| {
                j != i && ok && c <= cost && e <= error && (c < cost || e < error)
            });
    }
}

/// The report as Markdown: per knob, the summary table and the recommendation, then the runs of
/// each state point.
pub fn accuracy_markdown(report: &AccuracyReport) -> String {
    let mut out = String::from("# What accuracy costs in time (EDMD)\n\n");
    let _ = writeln!(
        out,
        "A setting is *safe* when its runs found no overlap and no solver failure, drifted in energy by at most {MAX_ENERGY_DRIFT:e} (relative), and kept Z within {MAX_Z_SIGMAS} combined standard errors of the tightest setting's run at the same state point. Cost is τ_c over τ_c at the tightest setting (geometric mean over state points).\n"
    );
    for study in &report.knobs {
        let _ = writeln!(out, "## {} ({} is tighter)\n", study.knob, study.tighter);
        let _ = writeln!(
            out,
            "| {} | state points | cost (τ_c / τ_c,ref) | max \\|ΔZ\\|/Z | max \\|ΔZ\\|/σ | max energy drift | overlaps | solver failures | NR fallbacks | safe | Pareto |",
            study.knob
        );
        out.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
        for s in &study.settings {
            let _ = writeln!(
                out,
                "| {:e} | {} | {:.3} | {:.2e} | {} | {:.1e} | {} | {} | {} | {} | {} |",
                s.value,
                s.state_points,
                s.cost_ratio,
                s.max_z_deviation_rel,
                s.max_z_deviation_sigmas
                    .map_or("–".to_owned(), |v| format!("{v:.2}")),
                s.max_energy_drift_rel,
                s.overlaps,
                s.solver_failures,
                s.contact_nr_fallbacks,
                if s.safe { "yes" } else { "**no**" },
                if s.pareto { "●" } else { "" },
            );
        }
        match study.recommended {
            Some(v) => {
                let _ = writeln!(
                    out,
                    "\n**Recommended: {} = {v:e}** — the tightest setting within {:.0} % of the cheapest one that lost nothing measurable, at the {} state point(s) it ran at.\n",
                    study.knob,
                    COST_NOISE * 100.0,
                    study
                        .settings
                        .iter()
                        .find(|s| Key(s.value) == Key(v))
                        .map_or(0, |s| s.state_points)
                );
            }
            None => {
                let _ = writeln!(out, "\nNo setting of {} was safe everywhere.\n", study.knob);
            }
        }
        let _ = writeln!(out, "### {} by state point\n", study.knob);
        out.push_str("| state point | value | τ_c (µs) | cost | Z | ΔZ/σ | energy drift | overlaps | failures | NR iterations |\n");
        out.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
        for p in &study.state_points {
            let point = format!(
                "{} X0 = {}, φ = {}, N = {}, {}{}",
                p.shape,
                p.x0,
                p.phi,
                p.n,
                p.neighbours.to_uppercase(),
                if p.neighbours == "nnl" {
                    format!(" Δ = {}", p.delta_nnl)
                } else {
                    String::new()
                }
            );
            for r in &p.runs {
                let _ = writeln!(
                    out,
                    "| {point} | {:e}{} | {:.2} | {:.3} | {:.4} ± {} | {} | {:.1e} | {} | {} | {:.2} |",
                    r.value,
                    if Key(r.value) == Key(p.reference) {
                        " (ref)"
                    } else {
                        ""
                    },
                    r.tau_c_us,
                    r.cost_ratio,
                    r.pressure_z,
                    r.pressure_z_err
                        .map_or("–".to_owned(), |e| format!("{e:.4}")),
                    r.z_deviation_sigmas
                        .map_or("–".to_owned(), |v| format!("{v:.2}")),
                    r.energy_drift_rel,
                    r.overlaps,
                    r.solver_failures,
                    r.nr_iterations_mean,
                );
            }
        }
        out.push('\n');
    }
    out.push_str("## Not measured\n\n");
    for line in &report.not_measured {
        let _ = writeln!(out, "- {line}");
    }
    out
}

/// Cost against Z deviation, one panel per knob: the Pareto front as a line, other safe
/// settings as triangles, settings that lost something as red crosses, each point labelled.
pub fn accuracy_plot(report: &AccuracyReport, path: &Path) -> Result<(), ReportError> {
    let panels = report
        .knobs
        .iter()
        .map(|study| {
            let point = |s: &SettingSummary| (s.cost_ratio, s.max_z_deviation_rel * 100.0);
            let mut front: Vec<(f64, f64)> = study
                .settings
                .iter()
                .filter(|s| s.pareto)
                .map(point)
                .collect();
            front.sort_by(|a, b| a.0.total_cmp(&b.0));
            let others: Vec<(f64, f64)> = study
                .settings
                .iter()
                .filter(|s| s.safe && !s.pareto)
                .map(point)
                .collect();
            let lost: Vec<(f64, f64)> = study
                .settings
                .iter()
                .filter(|s| !s.safe)
                .map(point)
                .collect();
            let notes = study
                .settings
                .iter()
                .map(|s| {
                    let mark = if study.recommended.is_some_and(|v| Key(v) == Key(s.value)) {
                        " (recommended)"
                    } else {
                        ""
                    };
                    (point(s), format!(" {:e}{mark}", s.value))
                })
                .collect();
            let series = [
                ("Pareto front (safe)", front, Style::Measured),
                ("safe, dominated", others, Style::Located),
                (
                    "lost accuracy (overlaps, failures, drift or Z)",
                    lost,
                    Style::Flagged,
                ),
            ]
            .into_iter()
            .filter(|(_, points, _)| !points.is_empty())
            .map(|(label, points, style)| Series {
                label: label.into(),
                points,
                style,
                colour: 0,
            })
            .collect();
            Panel {
                title: format!("{} ({} is tighter)", study.knob, study.tighter),
                x_desc: "cost: τ_c / τ_c at the tightest setting".into(),
                y_desc: "max |ΔZ| / Z (%)".into(),
                x_log: false,
                y_log: false,
                series,
                notes,
            }
        })
        .collect();
    render(
        &LinePlot {
            title: "What accuracy costs in time (EDMD)".into(),
            panels,
            columns: 2,
        },
        path,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(eps_d: f64, tau_c_us: f64, z: f64, overlaps: u64) -> EdmdRow {
        EdmdRow {
            shape: "ellipsoid".into(),
            x0: 2.0,
            neighbours: "nnl".into(),
            delta_nnl: 0.06,
            n: 256,
            phi: 0.5,
            tau_c_us,
            eps_d,
            nr_tol: 1e-10,
            collisions: 1000,
            pressure_z: z,
            pressure_z_err: Some(0.05),
            overlaps,
            ..Default::default()
        }
    }

    #[test]
    fn the_cheapest_safe_setting_is_recommended() {
        let rows = vec![
            run(1e-7, 50.0, 10.0, 0),
            run(1e-5, 45.0, 10.02, 0),
            run(1e-3, 40.0, 10.05, 0),
            // Fastest, but it found overlaps.
            run(1e-2, 30.0, 10.01, 2),
            // Another state point, only at the tightest and one loose setting: Z drifted.
            EdmdRow {
                phi: 0.4,
                ..run(1e-7, 40.0, 7.0, 0)
            },
            EdmdRow {
                phi: 0.4,
                ..run(1e-5, 36.0, 7.5, 0)
            },
        ];
        let report = accuracy(&rows).expect("an ε_d study");
        assert_eq!(report.knobs.len(), 1);
        let study = &report.knobs[0];
        assert_eq!(study.knob, "eps_d");
        assert_eq!(study.state_points.len(), 2);
        let values: Vec<f64> = study.settings.iter().map(|s| s.value).collect();
        assert_eq!(values, vec![1e-7, 1e-5, 1e-3, 1e-2]);
        // 1e-5 lost 0.5/√0.005 ≈ 7 σ of Z at φ = 0.4; 1e-2 found overlaps; 1e-3 is the cheapest
        // safe one.
        assert!(!study.settings[1].safe && !study.settings[3].safe);
        assert_eq!(study.recommended, Some(1e-3));
        assert!(study.settings[2].pareto && study.settings[0].pareto);
        assert!((study.settings[2].cost_ratio - 0.8).abs() < 1e-12);
        let text = accuracy_markdown(&report);
        assert!(text.contains("**Recommended: eps_d = 1e-3**"), "{text}");
    }

    #[test]
    fn no_swept_knob_is_missing_points() {
        let rows = vec![
            run(1e-5, 45.0, 10.0, 0),
            EdmdRow {
                phi: 0.4,
                ..run(1e-5, 40.0, 7.0, 0)
            },
        ];
        match accuracy(&rows) {
            Err(ReportError::MissingPoints { figure, missing }) => {
                assert_eq!(figure, "accuracy");
                assert!(missing[0].contains("eps_d"), "{missing:?}");
            }
            other => panic!("{other:?}"),
        }
    }
}
