//! Fig. 11 from searches: which searches give a Δ*_NNL, in which unit, and when it is only a
//! bound.

use jobs::TuneGoal;
use report::{Clock, LengthUnit, MinimumMethod};
use tune::report::{SearchRow, fig11_minima};
use tune::{Conclusion, Objective, Stopped};

fn row(shape: &str, knob: &str, field: &str, x0: f64, best_run: f64) -> SearchRow {
    SearchRow {
        campaign: "c".into(),
        shape: shape.into(),
        n: 256,
        phi: 0.45,
        x0,
        knob: knob.into(),
        goal: TuneGoal::Min(field.into()),
        range: [0.02, 1.5],
        conclusion: Some(Conclusion {
            best: Some(0.3),
            interval: Some([0.2, 0.5]),
            objective: Some(Objective {
                x: best_run,
                mean: 12.5,
                half_width: 0.4,
                runs: 3,
            }),
            evaluations: 9,
            stopped: Stopped::Converged,
        }),
        evaluations: 9,
        max_evaluations: 20,
        path: Vec::new(),
    }
}

#[test]
fn only_ellipsoid_searches_of_delta_nnl_minimising_the_clocks_tau_c_are_drawn() {
    let rows = [
        row("ellipsoid", "delta_nnl", "tau_c_cpu_us", 2.0, 0.32),
        row("ellipsoid", "delta_nnl", "tau_c_us", 2.0, 0.32),
        row("ellipsoid", "eps_d", "tau_c_cpu_us", 2.0, 0.32),
        row("superquadric", "delta_nnl", "tau_c_cpu_us", 2.0, 0.32),
    ];
    let (found, other_clock) = fig11_minima(&rows, Clock::Cpu, LengthUnit::Sigma);
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(other_clock, 1, "the wall-clock search of delta_nnl");
    let m = &found[0];
    assert_eq!(m.method, MinimumMethod::Search);
    assert!(m.bracketed);
    assert_eq!((m.delta_star, m.delta_star_sigma), (0.3, 0.3));
    assert_eq!(m.interval, Some([0.2, 0.5]));
    assert_eq!(m.tau_c_us, 12.5);
    assert_eq!(m.grid, [0.02, 1.5]);

    let mut running = row("ellipsoid", "delta_nnl", "tau_c_us", 2.0, 0.32);
    running.conclusion = None;
    assert!(
        fig11_minima(&[running], Clock::Wall, LengthUnit::Sigma)
            .0
            .is_empty()
    );
}

#[test]
fn a_best_run_at_the_range_end_is_a_bound_and_lengths_follow_the_unit() {
    let at_end = row("ellipsoid", "delta_nnl", "tau_c_us", 2.0, 1.5);
    let (found, _) = fig11_minima(&[at_end], Clock::Wall, LengthUnit::SemiAxis);
    assert_eq!(found.len(), 1);
    assert!(!found[0].bracketed);
    // X0 = 2 at equal volume to a unit sphere: b = 0.5 / 2^(1/3), the smallest semi-axis.
    let b = 0.5 / 2f64.cbrt();
    assert!((found[0].delta_star - 0.3 / b).abs() < 1e-12);
    assert_eq!(found[0].delta_star_sigma, 0.3);
    assert!((found[0].grid[1] - 1.5 / b).abs() < 1e-12);
}
