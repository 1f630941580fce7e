//! A run of a scene: its set-up (shape, inertia, box, solver tolerances), the initial state, then
//! the measured phases and the figures of the measured one.

use std::time::Instant;

use crate::EdmdError;
use crate::audit::{audit, audit_each};
use crate::ball::{Ball, SizedBall};
use crate::body::{Moving, SphereBody};
use crate::contact::ContactParams;
use crate::distance::{SolverStats, Tolerances};
use crate::ellipsoid::Ellipsoid;
use crate::engine::EngineState;
use crate::engine::{Accounting, Engine, FirstCollision};
use crate::geometry::{Surface, V3};
use crate::init::{
    Geom, Inertial, initial_configuration, initial_mixture, sort_along_z_curve, z_curve_order,
};
use crate::model::{MixedRigidModel, MixedSphereModel, RigidModel, SpeciesSums, SphereModel};
use crate::nnl::Obp;
use crate::report::{FinalState, RunReport, SpeciesReport, final_state, final_state_each};
use crate::rigid::{Body, Inertia};
use crate::rng::Rng;
use crate::scene::{Scene, ShapeKind};
use crate::sequence::Fingerprint;
use crate::state::{SavedEngine, SavedState, Start, StateError};
use crate::superquadric::Superquadric;

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
    run_with_hooks(scene, progress, Hooks::default())
}

/// A failure of a [`Hooks`] callback (a file that cannot be written): it stops the run.
pub type HookResult = Result<(), String>;

/// What a run does besides measuring: where it starts, what it saves and shows on the way.
/// Neither saving nor showing changes the run: both read the engine (bodies are copied before
/// they are advanced to the present), so a run's events are the same with and without them.
#[derive(Default)]
pub struct Hooks<'a> {
    /// Start from this state instead of an initial configuration (no relaxation either): the
    /// saved engine itself where the scene's prediction knobs are the saved ones, otherwise its
    /// configuration at the saved clock (see [`crate::state`]). The scene's `equilibrate` and
    /// `collisions` then run on from there; a continued run keeps its collision count, and its
    /// measured run starts without advancing every body to the present (which the continuous
    /// run would not have done there either).
    pub from: Option<SavedState>,
    /// Collisions between checkpoints handed to `on_state` (0: none), counted from the end of
    /// the initial state (over restarts).
    pub checkpoint_every: u64,
    /// Hand the state at the end of the run to `on_state` too (before the bodies are advanced
    /// to the present, so that a continuation is bit for bit the continuous run).
    pub save_final: bool,
    pub on_state: Option<&'a mut dyn FnMut(&SavedState) -> HookResult>,
    /// When frames are handed to `on_frame`; the first frame is the state the equilibration
    /// starts from.
    pub frame_every: FrameEvery,
    pub on_frame: Option<&'a mut dyn FnMut(&Frame) -> HookResult>,
}

/// How often a run shows a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum FrameEvery {
    #[default]
    Never,
    /// Every this many collisions (counted from the end of the initial state).
    Collisions(u64),
    /// Every this much simulated time (the engine's unit, σ √(m / k_B T)): a frame at the
    /// first collision at or after each multiple of it, with the bodies at that collision's
    /// time (`Frame::time`), so a frame never extrapolates a trajectory past an event it has
    /// not seen. Frames are then at most one collision late: ≈ τ_free / N after the multiple.
    Time(f64),
}

/// The configuration at one moment, for a trajectory: every body advanced to `time` (copies),
/// positions unwrapped (periodic images are not folded back).
pub struct Frame<'a> {
    /// Collisions since the end of the initial state.
    pub step: u64,
    pub time: f64,
    pub box_length: f64,
    pub bodies: &'a [Body],
}

/// As [`run_with_state`], with a start, checkpoints and frames as `hooks` ask.
pub fn run_with_hooks(
    scene: &Scene,
    progress: &mut dyn FnMut(u64),
    hooks: Hooks<'_>,
) -> Result<(RunReport, FinalState), EdmdError> {
    scene.validate()?;
    let params = contact_params(scene);
    if scene.is_mixture() {
        return simulate_mixture(scene, params, progress, hooks);
    }
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
            hooks,
        ),
        (ShapeKind::Superquadric, Some(q)) => simulate(
            RigidModel::new(q, params, inertia_rot),
            Geom::Superquadric(q),
            inertia_rot,
            scene,
            progress,
            hooks,
        ),
        (ShapeKind::Ellipsoid, _) => {
            let e = Ellipsoid::new(a, b, c);
            simulate(
                RigidModel::new(e, params, inertia_rot),
                Geom::Ellipsoid(e),
                inertia_rot,
                scene,
                progress,
                hooks,
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
fn simulate<M: Saves>(
    model: M,
    geom: Geom,
    inertia: Inertia,
    scene: &Scene,
    progress: &mut dyn FnMut(u64),
    mut hooks: Hooks<'_>,
) -> Result<(RunReport, FinalState), EdmdError> {
    let init = Instant::now();
    if let Some(saved) = hooks.from.take() {
        let (eng, origin) = restored(model, saved, scene)?;
        return measure(eng, scene, geom, init, progress, origin, hooks);
    }
    let mut rng = Rng::new(scene.seed);
    let mut slot = Some(model);
    // The collision sequence starts at the first collision of the first relaxation: the Monte
    // Carlo state before it depends on the seed alone, not on the accuracy knobs.
    let mut sequence = Fingerprint::default();
    let mut relax = |bodies: Vec<Body>, l: f64, per_particle: u64| {
        let Some(m) = slot.take() else {
            unreachable!("the model is put back after every relaxation")
        };
        let (m, bodies) = relaxed(m, bodies, l, per_particle, scene, &mut sequence)?;
        slot = Some(m);
        Ok(bodies)
    };
    let mut cfg = initial_configuration(scene.n, scene.phi, &geom, inertia, &mut rng, &mut relax)?;
    sort_along_z_curve(&mut cfg.bodies, cfg.l);
    let Some(m) = slot else {
        unreachable!("the model is put back after every relaxation")
    };
    let bodies = stored(&cfg.bodies);
    drop(cfg.bodies);
    let mut eng = Engine::new(m, cfg.l, bodies, scene, 0.0)?;
    eng.sequence = sequence;
    let origin = Origin::Fresh(cfg.relax);
    measure(eng, scene, geom, init, progress, origin, hooks)
}

/// The dynamics of an initial state (see [`crate::init::Relax`]): `per_particle` collisions per
/// body in a box of side `l`, with model `m`, the collision sequence carried on in `sequence`;
/// the model back with the bodies, every one at the present time.
fn relaxed<M: FirstCollision>(
    m: M,
    bodies: Vec<Body>,
    l: f64,
    per_particle: u64,
    scene: &Scene,
    sequence: &mut Fingerprint,
) -> Result<(M, Vec<Body>), EdmdError> {
    let n = bodies.len() as u64;
    let mut eng = Engine::new(m, l, stored(&bodies), scene, 0.0)?;
    drop(bodies);
    eng.sequence = std::mem::take(sequence);
    eng.advance(per_particle * n, |_| {})?;
    eng.sync_all();
    *sequence = std::mem::take(&mut eng.sequence);
    let (m, bodies) = eng.into_parts();
    Ok((m, bodies.iter().map(Moving::to_body).collect()))
}

/// Bodies as model `M` stores them.
fn stored<B: Moving>(bodies: &[Body]) -> Vec<B> {
    bodies.iter().map(B::from_body).collect()
}

/// The contact search's knobs of a scene.
fn contact_params(scene: &Scene) -> ContactParams {
    ContactParams {
        eps_d: scene.eps_d,
        brent_tol: scene.brent_tol,
        tol: Tolerances {
            nr_tol: scene.nr_tol,
            nr_max_iter: scene.nr_max_iter,
            nr_relax: scene.nr_relax,
            sd_max_iter: scene.sd_max_iter,
            sd_tol: scene.sd_tol,
        },
    }
}

/// A mixture: the bodies' sizes and species drawn ([`mixture_sizes`]), each body its species'
/// shape scaled by its size (spheres among rigid species are ellipsoids of X0 = 1, ellipsoids
/// among superquadrics superquadrics of exponents 2), the initial state of [`initial_mixture`],
/// then the measured run as for one species: spheres alone with [`MixedSphereModel`], rigid
/// bodies with [`MixedRigidModel`]. State files, checkpoints and trajectories are not written
/// for mixtures yet: a run that asks for them is refused before anything is simulated.
fn simulate_mixture(
    scene: &Scene,
    params: ContactParams,
    progress: &mut dyn FnMut(u64),
    hooks: Hooks<'_>,
) -> Result<(RunReport, FinalState), EdmdError> {
    if hooks.from.is_some()
        || hooks.checkpoint_every > 0
        || hooks.save_final
        || hooks.frame_every != FrameEvery::Never
    {
        return Err(EdmdError::Scene(crate::SceneError::Invalid {
            key: "species",
            line: None,
            reason: "state files, checkpoints and trajectories are not written for mixtures yet"
                .into(),
        }));
    }
    let init = Instant::now();
    let mut rng = Rng::new(scene.seed);
    let (sizes, species) = mixture_sizes(scene, &mut rng);
    let kinds = scene.species.as_ref().map_or(1, Vec::len);
    let bodies = MixtureBodies::new(scene, sizes, species)?;
    let start = Beginning {
        scene,
        init,
        rng,
        progress,
        hooks,
    };
    match scene.shape {
        ShapeKind::Sphere => bodies.simulate(start, |order| {
            let sizes: Vec<f64> = order.iter().map(|&k| bodies.sizes[k]).collect();
            MixedSphereModel::new(&sizes, bodies.sums(order, kinds))
        }),
        ShapeKind::Ellipsoid => bodies.simulate(start, |order| {
            bodies.rigid_model::<Ellipsoid>(order, kinds, params)
        }),
        ShapeKind::Superquadric => bodies.simulate(start, |order| {
            bodies.rigid_model::<Superquadric>(order, kinds, params)
        }),
    }
}

/// The shape of a rigid mixture's bodies, as the initial state and the audit see it ([`Geom`]).
trait MixtureShape: Surface + Copy {
    /// The body `g` describes; every body of a mixture is of its one kind.
    fn of(g: &Geom) -> Self;
    fn geom(self) -> Geom;
}

impl MixtureShape for Ellipsoid {
    fn of(g: &Geom) -> Self {
        match g {
            Geom::Ellipsoid(e) => *e,
            _ => unreachable!("the bodies of an ellipsoid mixture are ellipsoids"),
        }
    }
    fn geom(self) -> Geom {
        Geom::Ellipsoid(self)
    }
}

impl MixtureShape for Superquadric {
    fn of(g: &Geom) -> Self {
        match g {
            Geom::Superquadric(q) => *q,
            _ => unreachable!("the bodies of a superquadric mixture are superquadrics"),
        }
    }
    fn geom(self) -> Geom {
        Geom::Superquadric(self)
    }
}

/// What a run starts from besides its model: the scene, the clock and the random stream of the
/// initial state, and what it reports to.
struct Beginning<'s, 'h> {
    scene: &'s Scene,
    init: Instant,
    rng: Rng,
    progress: &'s mut dyn FnMut(u64),
    hooks: Hooks<'h>,
}

/// The bodies of a mixture, in the order drawn: size (equal-volume diameter), species, shape
/// and inertia of each.
struct MixtureBodies {
    sizes: Vec<f64>,
    species: Vec<u16>,
    shapes: Vec<Geom>,
    inertial: Vec<Inertial>,
}

impl MixtureBodies {
    /// Masses ∝ volume (the first species' unit-diameter body has mass 1); a rigid body's moment
    /// of inertia is a one-species scene's, (2/5) m r², r its smallest semi-axis (run_with_hooks).
    fn new(scene: &Scene, sizes: Vec<f64>, species: Vec<u16>) -> Result<Self, EdmdError> {
        let kinds = scene.species.as_deref().unwrap_or_default();
        let mut shapes = Vec::with_capacity(sizes.len());
        let mut inertial = Vec::with_capacity(sizes.len());
        for (&d, &k) in sizes.iter().zip(&species) {
            let kind = &kinds[k as usize];
            let s = V3::from(kind.semi_axes()) * d;
            let mass = d * d * d;
            let shape = match scene.shape {
                ShapeKind::Sphere => Geom::Sphere { sigma: d },
                ShapeKind::Ellipsoid => Geom::Ellipsoid(Ellipsoid::new(s.x, s.y, s.z)),
                ShapeKind::Superquadric => {
                    let e = kind.exponents.unwrap_or([2.0; 3]);
                    Geom::Superquadric(Superquadric::new(s.into(), e).ok_or_else(|| {
                        EdmdError::Scene(crate::SceneError::Invalid {
                            key: "species",
                            line: None,
                            reason: format!(
                                "species {}: no superquadric of semi-axes {s:?}",
                                k + 1
                            ),
                        })
                    })?)
                }
            };
            let rmin = s.x.min(s.y);
            let inv_i = match scene.shape {
                ShapeKind::Sphere => 0.0,
                _ => 1.0 / (0.4 * mass * rmin * rmin),
            };
            inertial.push(Inertial {
                mass,
                inv_i,
                spins_about_axis_0: !shape.revolves_about_axis_0(),
            });
            shapes.push(shape);
        }
        Ok(MixtureBodies {
            sizes,
            species,
            shapes,
            inertial,
        })
    }

    /// The species sums of the bodies in the given order (`kinds` species).
    fn sums(&self, order: &[usize], kinds: usize) -> SpeciesSums {
        SpeciesSums::new(
            order.iter().map(|&k| self.species[k]).collect(),
            order.iter().map(|&k| self.sizes[k]).collect(),
            kinds,
        )
    }

    /// The rigid model of the bodies in the given order.
    fn rigid_model<S: MixtureShape>(
        &self,
        order: &[usize],
        kinds: usize,
        params: ContactParams,
    ) -> MixedRigidModel<S> {
        MixedRigidModel::new(
            order.iter().map(|&k| S::of(&self.shapes[k])).collect(),
            order.iter().map(|&k| self.shapes[k].is_sphere()).collect(),
            order
                .iter()
                .map(|&k| Inertia {
                    inv_m: 1.0 / self.inertial[k].mass,
                    inv_i: self.inertial[k].inv_i,
                })
                .collect(),
            self.sums(order, kinds).counting_distance_calls(),
            params,
        )
    }

    /// The initial state, relaxed by the model `model_of` gives for the bodies in an order
    /// (first as drawn, then along a Z curve), and the measured run.
    fn simulate<M: Saves>(
        &self,
        start: Beginning<'_, '_>,
        model_of: impl Fn(&[usize]) -> M,
    ) -> Result<(RunReport, FinalState), EdmdError> {
        let Beginning {
            scene,
            init,
            mut rng,
            progress,
            hooks,
        } = start;
        let drawn: Vec<usize> = (0..self.sizes.len()).collect();
        let mut sequence = Fingerprint::default();
        let mut relax = |bodies: Vec<Body>, l: f64, per_particle: u64| {
            relaxed(
                model_of(&drawn),
                bodies,
                l,
                per_particle,
                scene,
                &mut sequence,
            )
            .map(|(_, bodies)| bodies)
        };
        let cfg = initial_mixture(
            &self.shapes,
            &self.inertial,
            scene.phi,
            &mut rng,
            &mut relax,
        )?;
        // Bodies close in space close in memory, as for one species; their shapes follow them.
        let order = z_curve_order(&cfg.bodies, cfg.l);
        let bodies: Vec<M::Body> = order
            .iter()
            .map(|&k| Moving::from_body(&cfg.bodies[k]))
            .collect();
        let bound = self
            .shapes
            .iter()
            .fold(0.0, |m: f64, g| m.max(g.bounding_radius()));
        if cfg.l <= 4.0 * bound {
            return Err(EdmdError::BoxTooSmall {
                l: cfg.l,
                needed: 4.0 * bound,
                why: "the box must exceed twice the largest bounding-sphere diameter",
            });
        }
        let mut eng = Engine::new(model_of(&order), cfg.l, bodies, scene, 0.0)?;
        eng.sequence = sequence;
        // The largest body: what the final state's records fall back to (see Saves::final_state).
        let geom = self
            .shapes
            .iter()
            .copied()
            .max_by(|a, b| a.bounding_radius().total_cmp(&b.bounding_radius()))
            .unwrap_or(Geom::Sphere { sigma: 1.0 });
        let origin = Origin::Fresh(cfg.relax);
        measure(eng, scene, geom, init, progress, origin, hooks)
    }
}

/// Each body's diameter and species, in a random order: N x_k bodies of species k
/// ([`Scene::species_counts`]) of diameter σ_k / σ_1 (1 + δ_k g), g a standard normal redrawn
/// until |g| ≤ 3 (δ_k the species' polydispersity), shuffled (Fisher–Yates) so that the
/// species are mixed on the initial lattice.
pub fn mixture_sizes(scene: &Scene, rng: &mut Rng) -> (Vec<f64>, Vec<u16>) {
    let Some(species) = &scene.species else {
        return (vec![1.0; scene.n], vec![0; scene.n]);
    };
    let unit = species[0].diameter;
    let mut bodies: Vec<(f64, u16)> = Vec::with_capacity(scene.n);
    for (k, (s, count)) in species.iter().zip(scene.species_counts()).enumerate() {
        for _ in 0..count {
            let g = if s.polydispersity > 0.0 {
                loop {
                    let g = rng.normal();
                    if g.abs() <= 3.0 {
                        break g;
                    }
                }
            } else {
                0.0
            };
            bodies.push((s.diameter / unit * (1.0 + s.polydispersity * g), k as u16));
        }
    }
    for i in (1..bodies.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        bodies.swap(i, j);
    }
    bodies.into_iter().unzip()
}

/// Where the engine of a run came from.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Origin {
    /// An initial configuration, to be relaxed by this many collisions per particle
    /// ([`crate::init::Config::relax`]).
    Fresh(u64),
    /// A saved configuration, with lists and calendar built afresh.
    Rebuilt,
    /// A saved engine, going on exactly as it was.
    Continued,
}

/// The engine of a run that starts from `saved` (see [`crate::state`]).
fn restored<M: Saves>(
    m: M,
    saved: SavedState,
    scene: &Scene,
) -> Result<(Engine<M>, Origin), EdmdError> {
    let l = (scene.n as f64 * std::f64::consts::PI / 6.0 / scene.phi).cbrt();
    match saved.start_for(scene)? {
        Start::Rebuild => {
            let bodies = stored(&saved.bodies_now());
            let eng = Engine::new(m, saved.box_length, bodies, scene, saved.time())?;
            Ok((eng, Origin::Rebuilt))
        }
        Start::Continue => {
            if saved.box_length.to_bits() != l.to_bits() {
                return Err(StateError::Inconsistent(format!(
                    "box length {} for the scene's {l}",
                    saved.box_length
                ))
                .into());
            }
            let state = M::unwrap(saved.engine)
                .filter(|s| s.neighbours() == scene.neighbours)
                .ok_or_else(|| {
                    StateError::Inconsistent("the saved engine is not of the scene's model".into())
                })?;
            Ok((Engine::restore(m, l, state), Origin::Continued))
        }
    }
}

/// The models a run measures: whose engine a state file holds (`wrap` gives `None` for a model
/// that is not saved yet), and how its final state is audited, dumped and broken down.
pub(crate) trait Saves: FirstCollision + Sized {
    fn wrap(s: EngineState<Self::Extra, Self::Region>) -> Option<SavedEngine>;
    fn unwrap(s: SavedEngine) -> Option<EngineState<Self::Extra, Self::Region>>;
    /// Overlapping pairs of the final state ([`audit`]). The audit and the final configuration
    /// see the model and its bodies alone: the engine's lists and calendar are freed before them
    /// (at N = 10⁶ the audit's cells take 39 MB, the dump 208 MB, the lists and calendar 290 MB).
    fn audit(_: &Self, bodies: &[Self::Body], l: f64, geom: &Geom, tol: f64) -> u64 {
        audit(bodies, l, geom, tol)
    }
    /// The final configuration.
    fn final_state(_: &Self, bodies: &[Self::Body], l: f64, geom: &Geom) -> FinalState {
        final_state(bodies, l, geom)
    }
    /// The figures per species and pair of species of a mixture.
    fn species_report(_: &Engine<Self>, _three_nkt: f64) -> Option<SpeciesReport> {
        None
    }
}

impl Saves for MixedSphereModel {
    fn wrap(_: EngineState<(), SizedBall>) -> Option<SavedEngine> {
        None
    }
    fn unwrap(_: SavedEngine) -> Option<EngineState<(), SizedBall>> {
        None
    }
    fn audit(m: &Self, bodies: &[SphereBody], l: f64, _: &Geom, tol: f64) -> u64 {
        audit_each(bodies, l, &|i| sphere_of(m, i), tol)
    }
    fn final_state(m: &Self, bodies: &[SphereBody], l: f64, _: &Geom) -> FinalState {
        final_state_each(bodies, l, &|i| sphere_of(m, i))
    }
    fn species_report(eng: &Engine<Self>, three_nkt: f64) -> Option<SpeciesReport> {
        Some(eng.m.sums.report(three_nkt))
    }
}

fn sphere_of(m: &MixedSphereModel, i: usize) -> Geom {
    Geom::Sphere {
        sigma: 2.0 * m.radius[i],
    }
}

/// A rigid mixture's model: not saved yet; audited and reported as its bodies' shapes say.
impl<S: MixtureShape> Saves for MixedRigidModel<S> {
    fn wrap(_: EngineState<(V3, V3), Obp>) -> Option<SavedEngine> {
        None
    }
    fn unwrap(_: SavedEngine) -> Option<EngineState<(V3, V3), Obp>> {
        None
    }
    fn audit(m: &Self, bodies: &[Body], l: f64, _: &Geom, tol: f64) -> u64 {
        audit_each(bodies, l, &|i| m.shape(i).geom(), tol)
    }
    fn final_state(m: &Self, bodies: &[Body], l: f64, _: &Geom) -> FinalState {
        final_state_each(bodies, l, &|i| m.shape(i).geom())
    }
    fn species_report(eng: &Engine<Self>, three_nkt: f64) -> Option<SpeciesReport> {
        Some(eng.m.sums.report(three_nkt))
    }
}

impl Saves for SphereModel {
    fn wrap(s: EngineState<(), Ball>) -> Option<SavedEngine> {
        Some(SavedEngine::Sphere(s))
    }
    fn unwrap(s: SavedEngine) -> Option<EngineState<(), Ball>> {
        match s {
            SavedEngine::Sphere(s) => Some(s),
            _ => None,
        }
    }
}

impl Saves for RigidModel<Ellipsoid> {
    fn wrap(s: EngineState<(V3, V3), Obp>) -> Option<SavedEngine> {
        Some(SavedEngine::Ellipsoid(s))
    }
    fn unwrap(s: SavedEngine) -> Option<EngineState<(V3, V3), Obp>> {
        match s {
            SavedEngine::Ellipsoid(s) => Some(s),
            _ => None,
        }
    }
}

impl Saves for RigidModel<Superquadric> {
    fn wrap(s: EngineState<(V3, V3), Obp>) -> Option<SavedEngine> {
        Some(SavedEngine::Superquadric(s))
    }
    fn unwrap(s: SavedEngine) -> Option<EngineState<(V3, V3), Obp>> {
        match s {
            SavedEngine::Superquadric(s) => Some(s),
            _ => None,
        }
    }
}

/// The relaxation that ends the initial state, then `equilibrate` collisions, then the measured
/// ones; the figures of those, and the final configuration.
#[allow(clippy::too_many_arguments)]
fn measure<M: Saves>(
    mut eng: Engine<M>,
    scene: &Scene,
    geom: Geom,
    init: Instant,
    progress: &mut dyn FnMut(u64),
    origin: Origin,
    hooks: Hooks<'_>,
) -> Result<(RunReport, FinalState), EdmdError> {
    if let Origin::Fresh(per_particle) = origin {
        relax(&mut eng, per_particle)?;
    }
    let init_s = init.elapsed().as_secs_f64();
    let total = scene.equilibrate + scene.collisions;
    let every = (total / 100).clamp(1, 10_000);
    let Hooks {
        checkpoint_every,
        save_final,
        mut on_state,
        frame_every,
        mut on_frame,
        ..
    } = hooks;
    let mut frame_bodies = Vec::new();
    let mut show = |e: &mut Engine<M>| {
        if let Some(f) = on_frame.as_mut() {
            frame_bodies.clear();
            frame_bodies.extend(e.bodies.iter().map(|b| b.to_body().at(e.t)));
            let frame = Frame {
                step: e.acc.collisions,
                time: e.t,
                box_length: e.l,
                bodies: &frame_bodies,
            };
            if let Err(why) = f(&frame) {
                e.fail(EdmdError::Hook(why));
            }
        }
    };
    let mut save = |e: &mut Engine<M>| {
        if let Some(f) = on_state.as_mut() {
            let Some(engine) = M::wrap(e.snapshot()) else {
                e.fail(EdmdError::Hook("this model's state is not saved".into()));
                return;
            };
            if let Err(why) = f(&SavedState::new(scene, e.l, engine)) {
                e.fail(EdmdError::Hook(why));
            }
        }
    };
    if frame_every != FrameEvery::Never {
        show(&mut eng);
    }
    // Time frames are counted from the clock the equilibration starts at.
    let (t0, mut next_frame) = (eng.t, 1.0);
    let mut observe = |e: &mut Engine<M>| {
        let done = e.acc.collisions;
        if done.is_multiple_of(every) {
            progress(done);
        }
        if checkpoint_every > 0 && done.is_multiple_of(checkpoint_every) {
            save(e);
        }
        match frame_every {
            FrameEvery::Collisions(k) if k > 0 && done.is_multiple_of(k) => show(e),
            FrameEvery::Time(dt) if dt > 0.0 && e.t - t0 >= next_frame * dt => {
                show(e);
                // One frame however many multiples a long free flight passed.
                next_frame = ((e.t - t0) / dt).floor() + 1.0;
            }
            _ => {}
        }
    };
    eng.advance(scene.equilibrate, &mut observe)?;
    let measured = measured_run(
        &mut eng,
        scene.collisions,
        origin != Origin::Continued,
        &mut observe,
    )?;
    if save_final {
        save(&mut eng);
        if let Some(e) = eng.take_failure() {
            return Err(e);
        }
    }
    eng.sync_all();
    progress(eng.acc.collisions);
    let mut report = figures(&mut eng, scene, &measured, init_s);
    let (l, (m, bodies)) = (eng.l, eng.into_parts());
    report.overlaps = M::audit(&m, &bodies, l, &geom, scene.audit_tol);
    let state = M::final_state(&m, &bodies, l, &geom);
    Ok((report, state))
}

/// Runs `per_particle` collisions per particle ([`crate::init::Config::relax`]), then starts
/// the sums of the measurements and the collision count afresh; the counters of crossings,
/// rebuilds and separating contacts run on.
fn relax<M: Saves>(eng: &mut Engine<M>, per_particle: u64) -> Result<(), EdmdError> {
    // The compression leaves pairs pushed to near contact; a few collisions per particle relax
    // them (Z of hard spheres at φ = 0.45 is within 0.4 % of Kolafa's after 3 per particle,
    // N 10⁵), far faster than Monte Carlo would. They belong to the initial state, not to
    // `equilibrate`.
    eng.advance(per_particle * eng.bodies.len() as u64, |_| {})?;
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

/// The measured run: `collisions` collisions in up to 10 blocks, from sums started afresh and,
/// if `sync`, every body at the present time (a continued run leaves them where the saved run
/// had them). `observe` sees every collision.
fn measured_run<M: FirstCollision>(
    eng: &mut Engine<M>,
    collisions: u64,
    sync: bool,
    observe: &mut impl FnMut(&mut Engine<M>),
) -> Result<Measured, EdmdError> {
    if sync {
        eng.sync_all();
    }
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
    eng.m.reset_sums();
    let (e0, p0, t0, stats0) = (eng.energy(), eng.momentum(), eng.t, eng.m.stats());
    let blocks = collisions.min(10);
    let mut marks: Vec<(f64, f64)> = Vec::with_capacity(blocks as usize);
    let (wall, cpu) = (Instant::now(), crate::clock::thread_cpu_seconds());
    measured_collisions(eng, collisions, |e| {
        let k = e.acc.collisions - base_collisions;
        observe(e);
        if (k * blocks).is_multiple_of(collisions) {
            marks.push((e.acc.virial, e.acc.ke_int));
        }
    })?;
    let elapsed = wall.elapsed().as_secs_f64();
    let cpu_elapsed = crate::clock::thread_cpu_seconds() - cpu;
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

/// ∫ 3 N k_B T dt from ∫ K dt, K the translational kinetic energy, with the measured
/// k_B T = 2K / (3(N − 1)): the net momentum is zero (every start removes it, and collisions keep
/// it), which leaves 3N − 3 translational degrees of freedom.
///
/// Z = P V / (N k_B T) = 1 + W / (3 N k_B T t), W = Σ r_ij·Δp the collision virial over the time
/// t, is W over this. Dividing by 2K, as if there were 3N degrees of freedom, put Z − 1 a factor
/// N / (N − 1) high: 0.1–0.2 % above Kolafa's Z at N 500 (MEASUREMENTS.md, "Z with the measured
/// temperature of 3N − 3 degrees of freedom").
pub(crate) fn three_nkt_integral(ke_int: f64, n: usize) -> f64 {
    2.0 * ke_int * n as f64 / (n as f64 - 1.0)
}

/// Z = 1 + W / [`three_nkt_integral`] over the whole measured run, and its standard error from
/// the blocks' own values of Z.
fn pressure(acc: &Accounting, marks: &[(f64, f64)], n: usize) -> (f64, f64) {
    let z_of = |w: f64, k: f64| 1.0 + w / three_nkt_integral(k, n);
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

/// The report of the measured run, from the engine at its end (whose collision sequence it
/// takes), but for its overlaps: the audit counts them once the engine is freed ([`measure`]).
fn figures<M: Saves>(
    eng: &mut Engine<M>,
    scene: &Scene,
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
    let (z, z_err) = pressure(&eng.acc, marks, n);
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
        temperature: three_nkt_integral(eng.acc.ke_int, n) / (3.0 * n as f64 * sim_time),
        energy_drift_rel: (eng.energy() - e0).abs() / e0,
        momentum_drift: (eng.momentum() - p0).norm(),
        overlaps: 0,
        solver_failures: stats.failures,
        contact_nr_fallbacks: stats.contact_fallbacks,
        distance_fallbacks: stats.distance_fallbacks,
        certified_overlaps: stats.certified_overlaps,
        nr_iterations_mean: {
            let solves = calls + (stats.contact_solves - stats0.contact_solves) as f64;
            if solves > 0.0 {
                (stats.nr_iterations - stats0.nr_iterations) as f64 / solves
            } else {
                0.0
            }
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
        species: M::species_report(eng, three_nkt_integral(eng.acc.ke_int, n)),
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
