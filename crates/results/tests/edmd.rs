//! EDMD jobs read back: a run as `jobs::run` stores it, τ_c by either clock, records written
//! before a field existed, a record that lacks one, and a job that failed for good.

mod common;

use common::*;
use jobs::JobSpec;
use report::Clock;

fn scene(toml: &str) -> edmd::Scene {
    edmd::Scene::from_toml_str(toml).expect("a valid scene")
}

fn ellipsoid() -> edmd::Scene {
    scene(
        "shape = \"ellipsoid\"\nn = 64\nphi = 0.3\nx0 = 2.0\nneighbours = \"nnl\"\n\
         delta_nnl = 0.06\nnr_tol = 1e-10\ncollisions = 1000\nequilibrate = 100\nseed = 3\n",
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_reads_back_with_its_scene_and_its_record() {
    let (_dir, _path, store) = temp_store().await;
    let spec = JobSpec::Edmd(ellipsoid());
    let mut record = serde_json::Map::new();
    complete_all(&store, "c", std::slice::from_ref(&spec), |spec| {
        let records = jobs::run(spec, 1).map_err(|e| e.to_string())?;
        record = records[0].clone();
        Ok(vec![
            serde_json::Value::Object(records[0].clone()).to_string(),
        ])
    })
    .await;
    let number = |key: &str| record[key].as_f64().unwrap();
    let [cpu] = results::edmd_runs(&store, Clock::Cpu)
        .await
        .unwrap()
        .try_into()
        .unwrap();
    let [wall] = results::edmd_runs(&store, Clock::Wall)
        .await
        .unwrap()
        .try_into()
        .unwrap();
    assert_eq!((cpu.clock, wall.clock), (Clock::Cpu, Clock::Wall));
    assert_eq!(cpu.tau_c_us, number("tau_c_cpu_us"));
    assert_eq!(wall.tau_c_us, number("tau_c_us"));
    let scene = ellipsoid();
    assert_eq!(
        (cpu.shape.as_str(), cpu.neighbours.as_str()),
        ("ellipsoid", "nnl")
    );
    assert_eq!(
        (cpu.n, cpu.phi, cpu.x0, cpu.delta_nnl, cpu.nr_tol, cpu.seed),
        (64, 0.3, 2.0, 0.06, 1e-10, 3)
    );
    assert_eq!(
        (cpu.eps_d, cpu.nr_max_iter, cpu.brent_tol),
        (scene.eps_d, scene.nr_max_iter, scene.brent_tol)
    );
    assert_eq!(cpu.collisions, record["collisions"].as_u64().unwrap());
    assert_eq!(cpu.pressure_z, number("pressure_z"));
    assert_eq!(cpu.wall_s, Some(number("wall_s")));
    assert_eq!(cpu.overlaps, 0);
    let sequence = cpu.sequence.as_ref().expect("the fingerprint");
    assert_eq!(
        sequence.len() * 8,
        record["sequence_fingerprint"].as_str().unwrap().len()
    );
    assert_eq!(cpu.sequence_block, Some(edmd::sequence::BLOCK));
}

/// A record written before the CPU τ_c, the Eq. 73 split and the fingerprint were kept: it
/// reads, with the wall clock's τ_c and nothing in their place; one without `tau_c_us` does not.
#[tokio::test]
async fn older_records_read_and_a_record_without_tau_c_is_an_error() {
    let (_dir, _path, store) = temp_store().await;
    let spec = JobSpec::Edmd(ellipsoid());
    let old = serde_json::json!({
        "collisions": 1000, "tau_c_us": 12.5, "pressure_z": 3.0, "pressure_z_err": null,
        "energy_drift_rel": 1e-13, "overlaps": 0, "solver_failures": 0, "contact_nr_fallbacks": 0,
        "nr_iterations_mean": 4.0, "nnl_rebuilds": 10,
    });
    complete_all(&store, "c", std::slice::from_ref(&spec), |_| {
        Ok(vec![old.to_string()])
    })
    .await;
    let [row] = results::edmd_runs(&store, Clock::Cpu)
        .await
        .unwrap()
        .try_into()
        .unwrap();
    assert_eq!((row.tau_c_us, row.clock), (12.5, Clock::Wall));
    assert_eq!(
        (row.pressure_z_err, row.tau_update_us, row.sequence),
        (None, None, None)
    );

    let (_dir, _path, store) = temp_store().await;
    let mut broken = old.clone();
    broken.as_object_mut().unwrap().remove("tau_c_us");
    complete_all(&store, "c", std::slice::from_ref(&spec), |_| {
        Ok(vec![broken.to_string()])
    })
    .await;
    let error = results::edmd_runs(&store, Clock::Cpu).await.unwrap_err();
    let message = error.to_string();
    assert!(
        message.contains(&spec.id()) && message.contains("tau_c_us"),
        "{message}"
    );
}

/// A point that failed for good reads back with the parameters a done run's row has, and its
/// reason; parameters that are not an EDMD spec are an error naming the job.
#[tokio::test]
async fn a_failed_job_reads_with_the_parameters_a_done_one_has() {
    let (_dir, _path, store) = temp_store().await;
    let superquadric = scene(
        "shape = \"superquadric\"\nexponents = [2.0, 2.0, 4.0]\nn = 64\nphi = 0.256\nx0 = 2.0\n",
    );
    let specs = [
        JobSpec::Edmd(ellipsoid()),
        JobSpec::Edmd(superquadric.clone()),
    ];
    complete_all(&store, "c", &specs, |_| {
        Err("edmd: unresolved distance".into())
    })
    .await;
    let failed = results::failed_edmd_runs(&store).await.unwrap();
    assert_eq!(failed.len(), 2);
    let scene = ellipsoid();
    let ellipsoid = failed
        .iter()
        .find(|f| f.run.shape == "ellipsoid")
        .expect("the ellipsoid");
    let run = &ellipsoid.run;
    assert_eq!(ellipsoid.reason, "edmd: unresolved distance");
    assert_eq!(run.neighbours, "nnl");
    assert_eq!(
        (run.n, run.phi, run.x0, run.delta_nnl),
        (64, 0.3, 2.0, 0.06)
    );
    assert_eq!(
        (run.nr_tol, run.eps_d, run.eps_nnl),
        (1e-10, scene.eps_d, scene.eps_nnl)
    );
    assert_eq!(
        (run.nr_max_iter, run.sd_max_iter, run.nr_relax, run.sd_tol),
        (
            scene.nr_max_iter,
            scene.sd_max_iter,
            scene.nr_relax,
            scene.sd_tol
        )
    );
    assert_eq!((run.seed, run.collisions), (3, 1000));
    assert!(run.tau_c_us.is_nan(), "a failed run has no τ_c");
    assert_eq!(run.exponents, None);
    let superquadric = failed
        .iter()
        .find(|f| f.run.shape == "superquadric")
        .expect("the superquadric");
    assert_eq!(superquadric.run.exponents, Some([2.0, 2.0, 4.0]));

    // A job stored with parameters that do not make a scene.
    let (_dir, _path, store) = temp_store().await;
    let broken = store::NewJob {
        id: "j1".into(),
        kind: "edmd".into(),
        params_json: r#"{"kind":"edmd","shape":"ellipsoid"}"#.into(),
        estimate_s: 1.0,
        exclusive: false,
        pass: 0,
        foreign_code: false,
    };
    let campaign = store::NewCampaign {
        id: "c".into(),
        name: "c".into(),
        plan_text: String::new(),
        searches: Vec::new(),
    };
    store.submit(&campaign, &[broken], T0).await.unwrap();
    let lease = store
        .lease("w1", 1, std::time::Duration::from_secs(60), T0, true)
        .await
        .unwrap()
        .remove(0);
    store
        .fail("w1", "j1", lease.token, "boom", 1, T0)
        .await
        .unwrap();
    let message = results::failed_edmd_runs(&store)
        .await
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("\"j1\"") && message.contains("`n`"),
        "{message}"
    );
}

/// A mixture's rows carry a shape of their own, named after its most general species, so that
/// they are never points of a one-shape curve: `sphere-mixture`, `ellipsoid-mixture`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mixture_reads_back_as_a_shape_of_its_own() {
    let (_dir, _path, store) = temp_store().await;
    let species = "[[species]]\nshape = \"sphere\"\nfraction = 0.5\n[[species]]\n";
    let specs = [
        format!("{species}shape = \"sphere\"\ndiameter = 1.4\nfraction = 0.5\n"),
        format!("{species}shape = \"ellipsoid\"\nx0 = 2.0\nfraction = 0.5\n"),
    ]
    .map(|tail| {
        JobSpec::Edmd(scene(&format!(
            "n = 64\nphi = 0.3\nneighbours = \"nnl\"\ncollisions = 500\nequilibrate = 50\n{tail}"
        )))
    });
    complete_all(&store, "c", &specs, |spec| {
        let records = jobs::run(spec, 1).map_err(|e| e.to_string())?;
        Ok(vec![
            serde_json::Value::Object(records[0].clone()).to_string(),
        ])
    })
    .await;
    let mut shapes: Vec<String> = results::edmd_runs(&store, Clock::Cpu)
        .await
        .unwrap()
        .into_iter()
        .map(|r| r.shape)
        .collect();
    shapes.sort();
    assert_eq!(shapes, ["ellipsoid-mixture", "sphere-mixture"]);
}
