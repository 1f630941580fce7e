//! A run of a scene: its set-up (shape, inertia, box, solver tolerances), the initial state, then
//! the measured phases and the figures of the measured one.

use std::time::Instant;

use crate::EdmdError;
use crate::audit::audit;
use crate::contact::ContactParams;
use crate::distance::{SolverStats, Tolerances};
use crate::ellipsoid::Ellipsoid;
use crate::engine::{Accounting, Engine, FirstCollision};
use crate::geometry::{Surface, V3};
use crate::init::{Geom, initial_configuration, sort_along_z_curve};
use crate::model::{RigidModel, SphereModel};
use crate::report::{FinalState, RunReport, final_state};
use crate::rigid::{Body, Inertia};
use crate::rng::Rng;
use crate::scene::{Scene, ShapeKind};
use crate::sequence::Fingerprint;

/// Runs a scene: initial configuration, `equilibrate` collisions, then `collisions` measured ones.
/// `progress` receives the number of collisions done so far (equilibration included), sparsely.
pub fn run(scene: &Scene, progress: &mut dyn FnMut(u64)) -> Result<RunReport, EdmdError> {
    run_with_state(scene, progress).map(|(r, _)| r)
}

/// As [`run`], also returning the final configuration.
pub fn run_with_state(
    scene: &Scene,
    progress: &mut dyn FnMut(u64),
) -> Result<(RunReport, FinalState), EdmdError> {
    scene.validate()?;
    let [a, b, c] = scene.semi_axes();
    // Isotropic inertia of the inscribed sphere, I = (2/5) m r², r = min(a, b), as in Sec. 4 (and,
    // for superquadrics, of the sphere inscribed in the ellipsoid inscribed in them).
    let rmin = a.min(b);
    let inertia_rot = Inertia {
        inv_m: 1.0,
        inv_i: 1.0 / (0.4 * rmin * rmin),
    };
    let quadric = scene.superquadric();
    let bounding = match quadric {
        Some(q) => q.bounding_radius(),
        None => a.max(b),
    };
    let vp = std::f64::consts::PI / 6.0;
    let l = (scene.n as f64 * vp / scene.phi).cbrt();
    // A body must not reach its own periodic image, nor a neighbour through two images.
    if l <= 4.0 * bounding {
        return Err(EdmdError::BoxTooSmall {
            l,
            needed: 4.0 * bounding,
            why: "the box must exceed twice the bounding-sphere diameter",
        });
    }
    let params = ContactParams {
        eps_d: scene.eps_d,
        brent_tol: scene.brent_tol,
        tol: Tolerances {
            nr_tol: scene.nr_tol,
            nr_max_iter: scene.nr_max_iter,
            nr_relax: scene.nr_relax,
            sd_max_iter: scene.sd_max_iter,
            sd_tol: scene.sd_tol,
        },
    };
    match (scene.shape, quadric) {
        (ShapeKind::Sphere, _) => simulate(
            SphereModel::new(1.0),
            Geom::Sphere { sigma: 1.0 },
            Inertia {
                inv_m: 1.0,
                inv_i: 0.0,
            },
            scene,
            progress,
        ),
        (ShapeKind::Superquadric, Some(q)) => simulate(
            RigidModel::new(q, params, inertia_rot),
            Geom::Superquadric(q),
            inertia_rot,
            scene,
            progress,
        ),
        (ShapeKind::Ellipsoid, _) => {
            let e = Ellipsoid::new(a, b, c);
            simulate(
                RigidModel::new(e, params, inertia_rot),
                Geom::Ellipsoid(e),
                inertia_rot,
                scene,
                progress,
            )
        }
        (ShapeKind::Superquadric, None) => Err(EdmdError::Scene(crate::SceneError::Invalid {
            key: "exponents",
            line: None,
            reason: "a superquadric needs valid `exponents` and `x0`".into(),
        })),
    }
}

/// The initial state (whose compression the model's own dynamics helps where Monte Carlo
/// jams), then the measured run.
fn simulate<M: FirstCollision>(
    model: M,
    geom: Geom,
    inertia: Inertia,
    scene: &Scene,
    progress: &mut dyn FnMut(u64),
) -> Result<(RunReport, FinalState), EdmdError> {
    let mut rng = Rng::new(scene.seed);
    let init = Instant::now();
    let mut slot = Some(model);
    // The collision sequence starts at the first collision of the first relaxation: the Monte
    // Carlo state before it depends on the seed alone, not on the accuracy knobs.
    let mut sequence = Fingerprint::default();
    let mut relax = |bodies: Vec<Body>, l: f64, per_particle: u64| {
        let Some(m) = slot.take() else {
            unreachable!("the model is put back after every relaxation")
        };
        let n = bodies.len() as u64;
        let mut eng = Engine::new(m, l, bodies, inertia.inv_i, scene)?;
        eng.sequence = std::mem::take(&mut sequence);
        eng.advance(per_particle * n, |_| {})?;
        eng.sync_all();
        let Engine {
            m,
            bodies,
            sequence: so_far,
            ..
        } = eng;
        slot = Some(m);
        sequence = so_far;
        Ok(bodies)
    };
    let mut cfg = initial_configuration(scene.n, scene.phi, &geom, inertia, &mut rng, &mut relax)?;
    sort_along_z_curve(&mut cfg.bodies, cfg.l);
    let Some(m) = slot else {
        unreachable!("the model is put back after every relaxation")
    };
    let mut eng = Engine::new(m, cfg.l, cfg.bodies, inertia.inv_i, scene)?;
    eng.sequence = sequence;
    measure(eng, scene, geom, init, progress)
}

/// Collisions per particle run at the end of the initial state (see [`relax`]).
pub const RELAX_COLLISIONS_PER_PARTICLE: u64 = 10;

/// The relaxation that ends the initial state, then `equilibrate` collisions, then the measured
/// ones; the figures of those, and the final configuration.
fn measure<M: FirstCollision>(
    mut eng: Engine<M>,
    scene: &Scene,
    geom: Geom,
    init: Instant,
    progress: &mut dyn FnMut(u64),
) -> Result<(RunReport, FinalState), EdmdError> {
    relax(&mut eng)?;
    let init_s = init.elapsed().as_secs_f64();
    let total = scene.equilibrate + scene.collisions;
    let every = (total / 100).clamp(1, 10_000);
    let mut tick = |done: u64| {
        if done.is_multiple_of(every) {
            progress(done);
        }
    };
    eng.advance(scene.equilibrate, |e| tick(e.acc.collisions))?;
    let measured = measured_run(&mut eng, scene.collisions, &mut tick)?;
    progress(eng.acc.collisions);
    let report = figures(&mut eng, scene, &geom, &measured, init_s);
    let state = final_state(&eng.bodies, eng.l, &geom);
    Ok((report, state))
}

/// Runs [`RELAX_COLLISIONS_PER_PARTICLE`] collisions per particle, then starts the sums of the
/// measurements and the collision count afresh; the counters of crossings, rebuilds and
/// separating contacts run on.
fn relax<M: FirstCollision>(eng: &mut Engine<M>) -> Result<(), EdmdError> {
    // The compression leaves pairs pushed to near contact; a few collisions per particle relax
    // them (Z of hard spheres at φ = 0.45 is Kolafa's, within its error, after 5 per particle),
    // far faster than Monte Carlo would. They belong to the initial state, not to `equilibrate`.
    eng.advance(
        RELAX_COLLISIONS_PER_PARTICLE * eng.bodies.len() as u64,
        |_| {},
    )?;
    eng.acc = Accounting {
        ke_trans: eng.acc.ke_trans,
        t_last: eng.t,
        separating: eng.acc.separating,
        crossings: eng.acc.crossings,
        rebuilds: eng.acc.rebuilds,
        rebuild_s: eng.acc.rebuild_s,
        ..Default::default()
    };
    Ok(())
}

/// Where the measured run started (its figures are differences from there), what it recorded
/// on the way, and how long it took.
struct Measured {
    e0: f64,
    p0: V3,
    t0: f64,
    stats0: SolverStats,
    crossings0: u64,
    rebuilds0: u64,
    rebuild_s0: f64,
    /// The collision virial and the kinetic-energy integral at the end of each block.
    marks: Vec<(f64, f64)>,
    /// Wall time of the measured collisions, in seconds.
    elapsed: f64,
    /// This thread's CPU time of the measured collisions, in seconds.
    cpu_elapsed: f64,
}

/// The measured run: `collisions` collisions in up to 10 blocks, from sums started afresh and
/// every body at the present time; it ends with every body at the present time again.
fn measured_run<M: FirstCollision>(
    eng: &mut Engine<M>,
    collisions: u64,
    tick: &mut impl FnMut(u64),
) -> Result<Measured, EdmdError> {
    eng.sync_all();
    let start_acc = Accounting {
        ke_trans: eng.acc.ke_trans,
        t_last: eng.t,
        collisions: eng.acc.collisions,
        ..Default::default()
    };
    let base_collisions = eng.acc.collisions;
    let (crossings0, rebuilds0, rebuild_s0) =
        (eng.acc.crossings, eng.acc.rebuilds, eng.acc.rebuild_s);
    eng.acc = Accounting {
        crossings: crossings0,
        rebuilds: rebuilds0,
        rebuild_s: rebuild_s0,
        separating: eng.acc.separating,
        ..start_acc
    };
    let (e0, p0, t0, stats0) = (eng.energy(), eng.momentum(), eng.t, eng.m.stats());
    let blocks = collisions.min(10);
    let mut marks: Vec<(f64, f64)> = Vec::with_capacity(blocks as usize);
    let (wall, cpu) = (Instant::now(), crate::clock::thread_cpu_seconds());
    measured_collisions(eng, collisions, |e| {
        let k = e.acc.collisions - base_collisions;
        tick(e.acc.collisions);
        if (k * blocks).is_multiple_of(collisions) {
            marks.push((e.acc.virial, e.acc.ke_int));
        }
    })?;
    let elapsed = wall.elapsed().as_secs_f64();
    let cpu_elapsed = crate::clock::thread_cpu_seconds() - cpu;
    eng.sync_all();
    Ok(Measured {
        e0,
        p0,
        t0,
        stats0,
        crossings0,
        rebuilds0,
        rebuild_s0,
        marks,
        elapsed,
        cpu_elapsed,
    })
}

/// Z = 1 + W / (2 K), W the collision virial and K the time integral of the kinetic energy, over
/// the whole measured run, and its standard error from the blocks' own values of Z.
fn pressure(acc: &Accounting, marks: &[(f64, f64)]) -> (f64, f64) {
    let z_of = |w: f64, k: f64| 1.0 + w / (2.0 * k);
    let z = z_of(acc.virial, acc.ke_int);
    let mut zb = Vec::with_capacity(marks.len());
    let mut prev = (0.0, 0.0);
    for &m in marks {
        zb.push(z_of(m.0 - prev.0, m.1 - prev.1));
        prev = m;
    }
    let z_err = if zb.len() > 1 {
        let mean = zb.iter().sum::<f64>() / zb.len() as f64;
        let var = zb.iter().map(|z| (z - mean).powi(2)).sum::<f64>() / (zb.len() - 1) as f64;
        (var / zb.len() as f64).sqrt()
    } else {
        f64::NAN
    };
    (z, z_err)
}

/// The report of the measured run, from the engine at its end (whose collision sequence it takes).
fn figures<M: FirstCollision>(
    eng: &mut Engine<M>,
    scene: &Scene,
    geom: &Geom,
    measured: &Measured,
    init_s: f64,
) -> RunReport {
    let Measured {
        e0,
        p0,
        t0,
        stats0,
        crossings0,
        rebuilds0,
        rebuild_s0,
        ref marks,
        elapsed,
        cpu_elapsed,
    } = *measured;
    let n = eng.bodies.len();
    let stats = eng.m.stats();
    let sim_time = eng.t - t0;
    let (z, z_err) = pressure(&eng.acc, marks);
    let calls = (stats.distance_calls - stats0.distance_calls) as f64;
    let per_collision_us = |s: f64| s * 1e6 / scene.collisions as f64;
    let nnl_rebuild_s = eng.acc.rebuild_s - rebuild_s0;
    RunReport {
        collisions: scene.collisions,
        tau_c_us: per_collision_us(elapsed),
        tau_update_us: per_collision_us(nnl_rebuild_s),
        tau_predict_us: per_collision_us(elapsed - nnl_rebuild_s),
        nnl_rebuild_s,
        tau_c_cpu_us: cpu_elapsed * 1e6 / scene.collisions as f64,
        pressure_z: z,
        pressure_z_err: z_err,
        temperature: 2.0 * eng.acc.ke_int / (3.0 * n as f64 * sim_time),
        energy_drift_rel: (eng.energy() - e0).abs() / e0,
        momentum_drift: (eng.momentum() - p0).norm(),
        overlaps: audit(&eng.bodies, eng.l, geom, scene.audit_tol),
        solver_failures: stats.failures,
        contact_nr_fallbacks: stats.contact_fallbacks,
        distance_fallbacks: stats.distance_fallbacks,
        nr_iterations_mean: if calls > 0.0 {
            (stats.nr_iterations - stats0.nr_iterations) as f64 / calls
        } else {
            0.0
        },
        nr_iterations_max: stats.nr_iterations_max,
        distance_calls_per_collision: calls / scene.collisions as f64,
        searches_per_collision: (stats.searches - stats0.searches) as f64 / scene.collisions as f64,
        mean_free_time: n as f64 * sim_time / (2.0 * scene.collisions as f64),
        sim_time,
        cell_crossings: eng.acc.crossings - crossings0,
        nnl_rebuilds: eng.acc.rebuilds - rebuilds0,
        separating_contacts: eng.acc.separating,
        box_length: eng.l,
        n,
        phi: scene.phi,
        init_s,
        sequence: std::mem::take(&mut eng.sequence),
    }
}

/// The measured run's collisions, in a frame of their own so that a profiler can select them
/// alone (`valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*measured_collisions*'`).
#[inline(never)]
fn measured_collisions<M: FirstCollision>(
    eng: &mut Engine<M>,
    n: u64,
    on_collision: impl FnMut(&mut Engine<M>),
) -> Result<(), EdmdError> {
    eng.advance(n, on_collision)
}
