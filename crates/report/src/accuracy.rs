//! What accuracy costs in time, for the EDMD engine: for each accuracy knob (ε_d, ε_d^nnl, the
//! Newton–Raphson, steepest-descent and Brent tolerances) that a campaign swept, τ_c against
//! what the looser settings lose — overlaps, solver failures, energy drift, Z's deviation from
//! the run at the tightest setting of the same state point, and how many collisions the event
//! sequence stays identical to that run's — with the Pareto front and the cheapest setting that
//! loses nothing measurable. A run that failed (the engine stopped on an unresolved distance or
//! contact, say) has no result but counts against its setting: a setting is safe only where
//! every run of it finished clean. The overlap kernels' family (f32 against f64) is
//! [`crate::overlap_accuracy()`]; [`accuracy_report`] puts both together, and
//! [`crate::accuracy_render`] draws them.
//!
//! A state point is everything but the knob: shape (with a superquadric's exponents), X0, φ, N, neighbour method, Δ_NNL, seed
//! and run length; the other knobs are held at the campaign's baseline. Two runs at different
//! settings start from initial states prepared with those settings, so Z's deviation is judged
//! against the two runs' combined standard error.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::overlap_accuracy::{OverlapAccuracy, VerdictRow, overlap_accuracy};
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
    /// The overlap kernels' f32 against f64, when the database has points with `verdict_check`.
    pub overlap: Option<OverlapAccuracy>,
    /// The points one family lacks while the other is there (the report is drawn anyway).
    pub missing: Vec<String>,
    /// What the report could not measure, said rather than left out silently.
    pub not_measured: Vec<String>,
}

/// A point that failed for good: its parameters (in `run`; what it would have measured is
/// unset, its τ_c NaN) and the reason its last attempt gave.
#[derive(Clone, Debug, PartialEq)]
pub struct FailedRun {
    pub run: EdmdRow,
    pub reason: String,
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
    /// Geometric mean over state points of τ_c / τ_c at the tightest setting; `None` when
    /// every run of the setting failed.
    pub cost_ratio: Option<f64>,
    /// Largest |Z − Z_ref| / Z_ref.
    pub max_z_deviation_rel: f64,
    /// Largest |Z − Z_ref| / √(err² + err_ref²); `None` where no error was measured.
    pub max_z_deviation_sigmas: Option<f64>,
    pub max_energy_drift_rel: f64,
    pub overlaps: u64,
    pub solver_failures: u64,
    /// Runs of this setting that failed for good and left no result.
    pub failed_runs: u64,
    pub contact_nr_fallbacks: u64,
    /// The fewest collisions, over its state points, that its event sequence stayed identical
    /// to the tightest setting's run; `None` where no run has a fingerprint.
    pub min_identical_collisions: Option<u64>,
    pub safe: bool,
    /// Not beaten in both cost and Z deviation by a safe setting.
    pub pareto: bool,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StatePointStudy {
    pub shape: String,
    /// A superquadric's exponents; `None` for other shapes.
    pub exponents: Option<[f64; 3]>,
    pub x0: f64,
    pub phi: f64,
    pub n: u32,
    pub neighbours: String,
    pub delta_nnl: f64,
    pub seed: u64,
    pub collisions: u64,
    /// The tightest value that finished, the reference of this state point.
    pub reference: f64,
    pub runs: Vec<SettingRun>,
    /// The runs of this state point that failed, with their setting and reason.
    pub failed: Vec<FailedSetting>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FailedSetting {
    pub value: f64,
    pub reason: String,
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
    /// Collisions from the start of the run (relaxation included) during which the event
    /// sequence was identical to the reference run's, to the block of `sequence_block`
    /// collisions, and how many collisions both fingerprints cover; `None` without fingerprints.
    pub identical_collisions: Option<u64>,
    pub compared_collisions: Option<u64>,
    /// Eq. 73: the share of the time per collision spent on list updates.
    pub update_share: Option<f64>,
}

impl SettingRun {
    fn safe(&self) -> bool {
        self.overlaps == 0
            && self.solver_failures == 0
            && self.energy_drift_rel <= MAX_ENERGY_DRIFT
            && self.z_deviation_sigmas.is_none_or(|s| s <= MAX_Z_SIGMAS)
    }
}

/// Whether `run` loses nothing measurable against `reference` (the same state point at the
/// tightest setting), by the rule of this report: no overlap, no solver failure, the energy kept
/// to `MAX_ENERGY_DRIFT`, Z within `MAX_Z_SIGMAS` combined standard errors of the reference's
/// (where both measured one). A run that failed for good is unsafe and has no row.
pub fn safe_against(run: &EdmdRow, reference: &EdmdRow) -> bool {
    let z_within = match (run.pressure_z_err, reference.pressure_z_err) {
        (Some(a), Some(b)) if a.is_finite() && b.is_finite() => {
            (run.pressure_z - reference.pressure_z).abs() <= MAX_Z_SIGMAS * a.hypot(b)
        }
        _ => true,
    };
    run.overlaps == 0
        && run.solver_failures == 0
        && run.energy_drift_rel <= MAX_ENERGY_DRIFT
        && z_within
}

/// The EDMD family of the accuracy report alone (see [`accuracy_report`]).
pub fn accuracy(rows: &[EdmdRow]) -> Result<AccuracyReport, ReportError> {
    accuracy_report(rows, &[], &[])
}

/// The accuracy report over every EDMD run (`failed`: the points that left no result) and every
/// overlap point with a checking set;
/// [`ReportError::MissingPoints`] when neither family has what it needs (no state point run at
/// two values of a knob, no overlap point with `verdict_check`); when one family has, the other's
/// missing points are listed in `missing`.
pub fn accuracy_report(
    rows: &[EdmdRow],
    failed: &[FailedRun],
    verdicts: &[VerdictRow],
) -> Result<AccuracyReport, ReportError> {
    let baseline = Baseline::of(rows);
    let studies: Vec<KnobStudy> = (0..KNOBS.len())
        .filter_map(|k| study(rows, failed, &baseline, k))
        .collect();
    let overlap = overlap_accuracy(verdicts);
    let mut missing = Vec::new();
    if studies.is_empty() {
        missing.push(format!(
            "EDMD runs of one state point at two or more values of an accuracy knob ({}), the others at the campaign's baseline",
            KNOBS.map(|(name, _)| name).join(", ")
        ));
    }
    if overlap.is_none() {
        missing.push(
            "overlap points with `verdict_check` (a checking set judged against the exact verdicts), in f32 and f64".into(),
        );
    }
    if studies.is_empty() && overlap.is_none() {
        return Err(ReportError::MissingPoints {
            figure: "accuracy",
            missing,
        });
    }
    let without_fingerprints = studies
        .iter()
        .flat_map(|s| &s.state_points)
        .flat_map(|p| &p.runs)
        .filter(|r| r.identical_collisions.is_none())
        .count();
    let mut not_measured = Vec::new();
    if without_fingerprints > 0 {
        not_measured.push(format!(
            "how long the event sequence stays identical to the reference run, for {without_fingerprints} run(s) written before the engine recorded its sequence (or whose reference was)"
        ));
    }
    Ok(AccuracyReport {
        knobs: studies,
        overlap,
        missing,
        not_measured,
    })
}

/// Equal blocks from the start of two fingerprints, and how many blocks both have: the hashes
/// are chained, so the first block that differs is where the sequences parted.
pub(crate) fn identical_prefix(reference: &[u32], run: &[u32]) -> (usize, usize) {
    let same = reference
        .iter()
        .zip(run)
        .take_while(|(a, b)| a == b)
        .count();
    (same, reference.len().min(run.len()))
}

type PointKey = (
    String,
    Option<[Key; 3]>,
    Key,
    Key,
    u32,
    String,
    Key,
    u64,
    u64,
);

fn point_key(r: &EdmdRow) -> PointKey {
    (
        r.shape.clone(),
        r.exponents.map(|e| e.map(Key)),
        Key(r.x0),
        Key(r.phi),
        r.n,
        r.neighbours.clone(),
        Key(r.delta_nnl),
        r.seed,
        r.collisions,
    )
}

/// The runs of one state point: those that finished, by value, and those that failed.
#[derive(Default)]
struct PointRuns<'a> {
    done: BTreeMap<Key, Vec<&'a EdmdRow>>,
    failed: Vec<FailedSetting>,
}

fn study(
    rows: &[EdmdRow],
    failed: &[FailedRun],
    baseline: &Baseline,
    k: usize,
) -> Option<KnobStudy> {
    let (name, tighter) = KNOBS[k];
    let mut points: BTreeMap<PointKey, PointRuns> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| timed(r) && baseline.knobs_match(r, Some(k)))
    {
        points
            .entry(point_key(r))
            .or_default()
            .done
            .entry(Key(knobs(r)[k]))
            .or_default()
            .push(r);
    }
    for f in failed
        .iter()
        .filter(|f| baseline.knobs_match(&f.run, Some(k)))
    {
        points
            .entry(point_key(&f.run))
            .or_default()
            .failed
            .push(FailedSetting {
                value: knobs(&f.run)[k],
                reason: f.reason.clone(),
            });
    }
    let tightest_first = |a: &f64, b: &f64| match tighter {
        Tighter::Smaller => a.total_cmp(b),
        Tighter::Larger => b.total_cmp(a),
    };
    let mut state_points = Vec::new();
    for ((shape, exponents, x0, phi, n, neighbours, delta_nnl, seed, collisions), point) in points {
        let mut values: Vec<Key> = point.done.keys().copied().collect();
        values.extend(point.failed.iter().map(|f| Key(f.value)));
        values.sort();
        values.dedup();
        // A knob study needs two values at the state point and one finished run to compare with.
        if values.len() < 2 || point.done.is_empty() {
            continue;
        }
        let mut settings: Vec<(f64, Averaged)> = point
            .done
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
            exponents: exponents.map(|e| e.map(|k| k.0)),
            x0: x0.0,
            phi: phi.0,
            n,
            neighbours,
            delta_nnl: delta_nnl.0,
            seed,
            collisions,
            reference: reference.0,
            runs,
            failed: point.failed,
        });
    }
    if state_points.is_empty() {
        return None;
    }
    let mut values: Vec<f64> = state_points
        .iter()
        .flat_map(|p| {
            p.runs
                .iter()
                .map(|r| r.value)
                .chain(p.failed.iter().map(|f| f.value))
        })
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
        .filter_map(|s| s.cost_ratio)
        .fold(f64::INFINITY, f64::min);
    // Settings are tightest first: the first safe one within the noise of the cheapest.
    let recommended = settings
        .iter()
        .find(|s| {
            s.safe
                && s.cost_ratio
                    .is_some_and(|c| c <= cheapest * (1.0 + COST_NOISE))
        })
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
    /// The first run's fingerprint and its block length (runs of one setting at one state
    /// point share a seed, hence a sequence).
    sequence: Option<(Vec<u32>, u32)>,
    update_share: Option<f64>,
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
            sequence: runs
                .first()
                .and_then(|r| Some((r.sequence.clone()?, r.sequence_block?))),
            update_share: {
                let shares: Vec<f64> = runs.iter().filter_map(|r| r.update_share()).collect();
                (!shares.is_empty()).then(|| shares.iter().sum::<f64>() / shares.len() as f64)
            },
        }
    }

    fn against(&self, value: f64, reference: &Averaged) -> SettingRun {
        let deviation = (self.z - reference.z).abs();
        let sigmas = match (self.z_err, reference.z_err) {
            (Some(a), Some(b)) if a * a + b * b > 0.0 => Some(deviation / (a * a + b * b).sqrt()),
            _ => None,
        };
        let sequence = match (&self.sequence, &reference.sequence) {
            (Some((run, block)), Some((reference, reference_block)))
                if block == reference_block =>
            {
                let (same, compared) = identical_prefix(reference, run);
                Some((
                    same as u64 * u64::from(*block),
                    compared as u64 * u64::from(*block),
                ))
            }
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
            identical_collisions: sequence.map(|s| s.0),
            compared_collisions: sequence.map(|s| s.1),
            update_share: self.update_share,
        }
    }
}

fn summarise(value: f64, state_points: &[StatePointStudy]) -> SettingSummary {
    let runs: Vec<&SettingRun> = state_points
        .iter()
        .flat_map(|p| p.runs.iter().filter(|r| Key(r.value) == Key(value)))
        .collect();
    let failed_runs = state_points
        .iter()
        .flat_map(|p| p.failed.iter().filter(|f| Key(f.value) == Key(value)))
        .count() as u64;
    let count = runs.len() as f64;
    let sigmas: Vec<f64> = runs.iter().filter_map(|r| r.z_deviation_sigmas).collect();
    SettingSummary {
        value,
        state_points: runs.len(),
        cost_ratio: (!runs.is_empty())
            .then(|| (runs.iter().map(|r| r.cost_ratio.ln()).sum::<f64>() / count).exp()),
        max_z_deviation_rel: runs.iter().map(|r| r.z_deviation_rel).fold(0.0, f64::max),
        max_z_deviation_sigmas: (!sigmas.is_empty())
            .then(|| sigmas.iter().copied().fold(0.0, f64::max)),
        max_energy_drift_rel: runs.iter().map(|r| r.energy_drift_rel).fold(0.0, f64::max),
        overlaps: runs.iter().map(|r| r.overlaps).sum(),
        solver_failures: runs.iter().map(|r| r.solver_failures).sum(),
        failed_runs,
        contact_nr_fallbacks: runs.iter().map(|r| r.contact_nr_fallbacks).sum(),
        min_identical_collisions: runs.iter().filter_map(|r| r.identical_collisions).min(),
        safe: failed_runs == 0 && !runs.is_empty() && runs.iter().all(|r| r.safe()),
        pareto: false,
    }
}

/// A safe setting is on the front when no other safe setting is at least as cheap and as
/// accurate, and strictly better in one of the two. (A safe setting has finished runs, hence a
/// cost.)
fn mark_pareto(settings: &mut [SettingSummary]) {
    let objectives: Vec<(f64, f64, bool)> = settings
        .iter()
        .map(|s| {
            (
                s.cost_ratio.unwrap_or(f64::INFINITY),
                s.max_z_deviation_rel,
                s.safe,
            )
        })
        .collect();
    for (i, s) in settings.iter_mut().enumerate() {
        let (cost, error, safe) = objectives[i];
        s.pareto = safe
            && !objectives.iter().enumerate().any(|(j, &(c, e, ok))| {
                j != i && ok && c <= cost && e <= error && (c < cost || e < error)
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accuracy_render::{accuracy_markdown, accuracy_plot};

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
        assert!((study.settings[2].cost_ratio.expect("finished runs") - 0.8).abs() < 1e-12);
        let text = accuracy_markdown(&report);
        assert!(text.contains("**Recommended: eps_d = 1e-3**"), "{text}");
    }

    #[test]
    fn a_failed_run_makes_its_setting_unsafe() {
        // nr_tol swept at two state points; the tightest and cheapest value, 1e-14, finished at
        // φ = 0.5 but failed at φ = 0.3, where it is also the tightest value (so 1e-12 is that
        // state point's reference); 1e-8 only ever failed.
        let at = |phi: f64, nr_tol: f64, tau_c_us: f64| EdmdRow {
            phi,
            nr_tol,
            ..run(1e-5, tau_c_us, 10.0, 0)
        };
        let rows = vec![
            at(0.5, 1e-14, 40.0),
            at(0.5, 1e-12, 44.0),
            at(0.5, 1e-10, 46.0),
            at(0.3, 1e-12, 30.0),
            at(0.3, 1e-10, 30.5),
        ];
        let failed = vec![
            FailedRun {
                run: EdmdRow {
                    tau_c_us: f64::NAN,
                    ..at(0.3, 1e-14, 0.0)
                },
                reason: "edmd: unresolved distance | for bodies 248 and 57".into(),
            },
            FailedRun {
                run: EdmdRow {
                    tau_c_us: f64::NAN,
                    ..at(0.3, 1e-8, 0.0)
                },
                reason: "edmd: unresolved contact".into(),
            },
        ];
        let without = accuracy(&rows).expect("an nr_tol study");
        assert_eq!(without.knobs[0].recommended, Some(1e-14));
        let report = accuracy_report(&rows, &failed, &[]).expect("an nr_tol study");
        let study = &report.knobs[0];
        assert_eq!(study.knob, "nr_tol");
        let values: Vec<f64> = study.settings.iter().map(|s| s.value).collect();
        assert_eq!(values, vec![1e-14, 1e-12, 1e-10, 1e-8]);
        let failed_runs: Vec<u64> = study.settings.iter().map(|s| s.failed_runs).collect();
        assert_eq!(failed_runs, vec![1, 0, 0, 1]);
        let safe: Vec<bool> = study.settings.iter().map(|s| s.safe).collect();
        assert_eq!(safe, vec![false, true, true, false]);
        assert_eq!(study.settings[3].cost_ratio, None);
        assert!(!study.settings[0].pareto && !study.settings[3].pareto);
        let phi_03 = study
            .state_points
            .iter()
            .find(|p| p.phi == 0.3)
            .expect("φ = 0.3");
        assert_eq!(phi_03.reference, 1e-12);
        assert_eq!(phi_03.failed.len(), 2);
        assert_eq!(study.recommended, Some(1e-12));
        let text = accuracy_markdown(&report);
        assert!(text.contains("**Recommended: nr_tol = 1e-12**"), "{text}");
        assert!(
            text.contains(
                "| 1e-14 | **failed**: edmd: unresolved distance / for bodies 248 and 57 |"
            ),
            "{text}"
        );
        let svg = std::env::temp_dir().join(format!("accuracy-failed-{}.svg", std::process::id()));
        accuracy_plot(&report, &svg).expect("drawn without the setting that has no cost");
        let _ = std::fs::remove_file(svg);
    }

    #[test]
    fn superquadrics_of_different_exponents_are_different_state_points() {
        let sq = |p: f64, eps_d: f64, tau_c_us: f64| EdmdRow {
            shape: "superquadric".into(),
            exponents: Some([2.0, 2.0, p]),
            ..run(eps_d, tau_c_us, 10.0, 0)
        };
        let rows = vec![
            sq(2.0, 1e-7, 50.0),
            sq(2.0, 1e-5, 45.0),
            sq(4.0, 1e-7, 80.0),
            sq(4.0, 1e-5, 60.0),
        ];
        let report = accuracy(&rows).expect("an ε_d study");
        let points = &report.knobs[0].state_points;
        let exponents: Vec<Option<[f64; 3]>> = points.iter().map(|p| p.exponents).collect();
        assert_eq!(
            exponents,
            vec![Some([2.0, 2.0, 2.0]), Some([2.0, 2.0, 4.0])]
        );
        assert!((points[1].runs[1].cost_ratio - 0.75).abs() < 1e-12);
        assert!(accuracy_markdown(&report).contains("superquadric [2, 2, 4] X0 = 2"));
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
                assert!(missing[1].contains("verdict_check"), "{missing:?}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_identical_prefix_of_synthetic_fingerprints() {
        assert_eq!(identical_prefix(&[1, 2, 3, 4], &[1, 2, 3, 4]), (4, 4));
        assert_eq!(identical_prefix(&[1, 2, 3, 4], &[1, 2, 7, 8]), (2, 4));
        assert_eq!(identical_prefix(&[1, 2, 3, 4], &[9, 2, 3, 4]), (0, 4));
        // A shorter run is compared over what it has.
        assert_eq!(identical_prefix(&[1, 2, 3, 4], &[1, 2]), (2, 2));
        assert_eq!(identical_prefix(&[], &[1]), (0, 0));
    }

    #[test]
    fn settings_are_told_how_long_they_followed_the_tightest_run() {
        let with = |r: EdmdRow, sequence: &[u32]| EdmdRow {
            sequence: Some(sequence.to_vec()),
            sequence_block: Some(64),
            tau_update_us: Some(10.0),
            tau_predict_us: Some(30.0),
            ..r
        };
        let rows = vec![
            with(run(1e-7, 50.0, 10.0, 0), &[1, 2, 3, 4, 5]),
            with(run(1e-5, 45.0, 10.0, 0), &[1, 2, 3, 9, 9]),
            with(run(1e-3, 40.0, 10.0, 0), &[7, 7, 7, 7, 7]),
            // Written before fingerprints: not compared, and said so.
            run(1e-2, 30.0, 10.0, 0),
        ];
        let report = accuracy(&rows).expect("an ε_d study");
        let runs = &report.knobs[0].state_points[0].runs;
        let identical: Vec<Option<u64>> = runs.iter().map(|r| r.identical_collisions).collect();
        assert_eq!(identical, vec![Some(320), Some(192), Some(0), None]);
        assert_eq!(runs[1].compared_collisions, Some(320));
        assert_eq!(runs[1].update_share, Some(0.25));
        assert_eq!(
            report.knobs[0].settings[1].min_identical_collisions,
            Some(192)
        );
        assert!(
            report.not_measured[0].contains("1 run(s)"),
            "{:?}",
            report.not_measured
        );
        let text = accuracy_markdown(&report);
        assert!(text.contains("| 192 of 320 | 25 % |"), "{text}");
    }
}
