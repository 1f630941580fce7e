//! The JSON contract of `sweep edmd` (README): the report fields and the `--dump` format.

use edmd::{Neighbours, Scene, ShapeKind, run_with_state};

#[test]
fn report_and_dump_have_the_documented_fields() {
    let mut s = Scene::new(ShapeKind::Ellipsoid, 32, 0.2);
    s.x0 = 2.0;
    s.neighbours = Neighbours::Nnl;
    s.collisions = 200;
    s.equilibrate = 50;
    let mut calls = Vec::new();
    let (report, state) = run_with_state(&s, &mut |c| calls.push(c)).unwrap();
    assert_eq!(
        calls.last(),
        Some(&250),
        "progress ends at the total number of collisions"
    );

    let r = serde_json::to_value(&report).unwrap();
    for key in [
        "collisions",
        "tau_c_us",
        "tau_c_cpu_us",
        "pressure_z",
        "temperature",
        "energy_drift_rel",
        "momentum_drift",
        "overlaps",
        "solver_failures",
        "nr_iterations_mean",
        "nr_iterations_max",
    ] {
        assert!(r.get(key).is_some(), "report lacks `{key}`");
    }
    assert_eq!(r["collisions"], 200);
    assert_eq!(r["overlaps"], 0);

    let d = serde_json::to_value(&state).unwrap();
    let l = report.box_length;
    assert_eq!(d["box"], serde_json::json!([l, l, l]));
    let ps = d["particles"].as_array().unwrap();
    assert_eq!(ps.len(), 32);
    let p = &ps[0];
    assert_eq!(p["shape"], "ellipsoid");
    assert_eq!(p["exponents"], serde_json::json!([2.0, 2.0, 2.0]));
    let semi: Vec<f64> = serde_json::from_value(p["semi_axes"].clone()).unwrap();
    assert!((semi[0] / semi[1] - 2.0).abs() < 1e-12 && semi[1] == semi[2]);
    let pos: Vec<f64> = serde_json::from_value(p["position"].clone()).unwrap();
    assert!(pos.iter().all(|&x| (0.0..l).contains(&x)));
    // Orientation rows are orthonormal body axes.
    let o: Vec<Vec<f64>> = serde_json::from_value(p["orientation"].clone()).unwrap();
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| o[i][k] * o[j][k]).sum();
            assert!((dot - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
        }
    }
    assert!(p["velocity"].is_array() && p["angular_velocity"].is_array());
}

/// The collision sequence is reproducible from the scene alone, starts with the relaxation (so
/// it covers collisions before the measured run), and the time split of Eq. (73) adds up.
#[test]
fn the_sequence_fingerprint_is_reproducible_and_eq_73_adds_up() {
    let mut s = Scene::new(ShapeKind::Ellipsoid, 32, 0.3);
    s.x0 = 2.0;
    s.neighbours = Neighbours::Nnl;
    s.collisions = 300;
    s.equilibrate = 0;
    let a = edmd::run(&s, &mut |_| {}).unwrap();
    let b = edmd::run(&s, &mut |_| {}).unwrap();
    // 5 collisions per particle of relaxation (aspect 2, from the addition), then the measured
    // run, at least.
    let relax = edmd::init::SHORT_RELAX_COLLISIONS_PER_PARTICLE;
    let blocks = a.sequence.blocks().len() as u64;
    assert!(blocks >= (32 * relax + 300) / 64, "{blocks} blocks");
    assert_eq!(a.sequence, b.sequence);
    assert!(a.nnl_rebuilds > 0 && a.nnl_rebuild_s > 0.0);
    assert!(a.tau_update_us > 0.0 && a.tau_update_us < a.tau_c_us);
    assert!((a.tau_update_us + a.tau_predict_us - a.tau_c_us).abs() <= 1e-9 * a.tau_c_us);
    // A different seed is a different trajectory from its first block.
    s.seed += 1;
    let c = edmd::run(&s, &mut |_| {}).unwrap();
    assert_ne!(a.sequence.blocks()[0], c.sequence.blocks()[0]);
    assert!(serde_json::to_value(&a).unwrap().get("sequence").is_none());
}
