//! The state file: a run saved so that another continues it bit for bit, or starts from its
//! configuration (`--save-state`, `--checkpoint-every`, the scene key `from_state`).
//!
//! Format: one CBOR document (RFC 8949, as `ciborium` writes serde data), a map with
//! - `format`: the text `"sweep-edmd-state"`, `version`: [`VERSION`] (a reader refuses later ones);
//! - `scene`: the scene of the run that saved it, every key (as in the scene TOML);
//! - `box_length`: the side of the periodic box;
//! - `engine`: a map with one key, the model (`sphere`, `ellipsoid`, `superquadric`), holding
//!   everything the engine's future depends on (`crate::engine::Engine::snapshot`): every body
//!   as it is (position, unwrapped, velocity, orientation rows, angular velocity, at its own local
//!   time: bodies are advanced lazily), the clock, the collision counters, the calendar in its
//!   heap order, the linked cells or the neighbour lists with their regions and build grid, the
//!   measurement sums, the solver counters and the collisions behind the escape horizon. f64
//!   are stored exactly (CBOR doubles, ±∞ included).
//!
//! The engine draws no random numbers after the initial state, so there is no random state to
//! save: the seed only makes the initial configuration.
//!
//! A state continues exactly (the same events, bit for bit, as the run that saved it would have
//! had) when the scene agrees with the saved one on everything the predictions depend on
//! (neighbour method, Δ_NNL, ε_d^nnl, ε_d and the solver tolerances). A scene that changes one of
//! those (a sweep over Δ_NNL from one equilibrated state) starts from the saved configuration
//! with its own lists and calendar, built afresh at the saved clock. Shape, N, φ, X0 and
//! exponents must agree in either case.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::ball::Ball;
use crate::engine::EngineState;
use crate::geometry::V3;
use crate::nnl::Obp;
use crate::rigid::Body;
use crate::scene::Scene;

/// What the `format` field of a state file holds.
pub const FORMAT: &str = "sweep-edmd-state";
/// The layout of [`SavedState`]; a change to any saved engine structure must raise it.
/// Version 2 lets a neighbour list spill beyond its room (`lists.lists.spill`); version 3 keeps
/// rigid pairs' separating axes (`engine.*.axes`); version 4 the collisions that set how far an
/// escape time looks (`engine.*.pace`). An older file is a newer one without them, and is read
/// as one (a rigid run from a version 2 file continues with no axes kept, one from a version 3
/// file counts its collisions afresh).
pub const VERSION: u32 = 4;

/// A saved run (see the module's documentation for the format).
#[derive(Serialize, Deserialize)]
pub struct SavedState {
    format: String,
    version: u32,
    pub(crate) scene: Scene,
    pub(crate) box_length: f64,
    pub(crate) engine: SavedEngine,
}

/// The engine's state, for the model it was made with.
#[derive(Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum SavedEngine {
    Sphere(EngineState<(), Ball>),
    Ellipsoid(EngineState<(V3, V3), Obp>),
    Superquadric(EngineState<(V3, V3), Obp>),
}

#[derive(Debug, Error)]
pub enum StateError {
    #[error("not a sweep EDMD state file: {0}")]
    Decode(String),
    #[error("`format` is {0:?}, not {FORMAT:?}: not a sweep EDMD state file")]
    Format(String),
    #[error("state file version {0}; this sweep reads versions 1 to {VERSION}")]
    Version(u32),
    /// The scene asks for another system than the one saved.
    #[error("key `{key}`: the state holds {saved}, the scene asks for {scene}")]
    Mismatch {
        key: &'static str,
        saved: String,
        scene: String,
    },
    #[error("the state file is inconsistent: {0}")]
    Inconsistent(String),
    #[error("cannot encode the state: {0}")]
    Encode(String),
}

/// How a run starts from a state.
pub(crate) enum Start {
    /// The same predictions: the saved engine goes on as it was.
    Continue,
    /// Other neighbour lists or solver knobs: the saved configuration, with lists and calendar
    /// built afresh.
    Rebuild,
}

/// The first two keys, read before the rest so that another version is named, not misparsed.
#[derive(Deserialize)]
struct Header {
    format: String,
    version: u32,
}

impl SavedState {
    pub(crate) fn new(scene: &Scene, box_length: f64, engine: SavedEngine) -> Self {
        SavedState {
            format: FORMAT.into(),
            version: VERSION,
            scene: scene.clone(),
            box_length,
            engine,
        }
    }

    /// The CBOR bytes of the state file.
    pub fn to_bytes(&self) -> Result<Vec<u8>, StateError> {
        let mut out = Vec::new();
        ciborium::into_writer(self, &mut out).map_err(|e| StateError::Encode(e.to_string()))?;
        Ok(out)
    }

    /// Reads a state file's bytes, checking its format, version and the sizes of what it holds.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, StateError> {
        let decode = |e: ciborium::de::Error<std::io::Error>| StateError::Decode(e.to_string());
        let header: Header = ciborium::from_reader(bytes).map_err(decode)?;
        if header.format != FORMAT {
            return Err(StateError::Format(header.format));
        }
        if !(1..=VERSION).contains(&header.version) {
            return Err(StateError::Version(header.version));
        }
        let state: SavedState = ciborium::from_reader(bytes).map_err(decode)?;
        state.check_sizes()?;
        Ok(state)
    }

    /// The scene of the run that saved this state.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The clock of the saved run.
    pub fn time(&self) -> f64 {
        self.with_bodies(|_, t| t)
    }

    /// The saved bodies, each at its own time, and the clock.
    fn with_bodies<T>(&self, f: impl FnOnce(&[Body], f64) -> T) -> T {
        match &self.engine {
            SavedEngine::Sphere(e) => f(&e.bodies, e.t),
            SavedEngine::Ellipsoid(e) | SavedEngine::Superquadric(e) => f(&e.bodies, e.t),
        }
    }

    /// The configuration at the saved clock: every body advanced to it (a copy; the saved
    /// bodies stay as they are).
    pub fn bodies_now(&self) -> Vec<Body> {
        self.with_bodies(|bodies, t| bodies.iter().map(|b| b.at(t)).collect())
    }

    pub fn box_length(&self) -> f64 {
        self.box_length
    }

    /// A file that decodes but whose arrays do not fit its scene would index out of bounds
    /// later; refused here.
    fn check_sizes(&self) -> Result<(), StateError> {
        let n = self.scene.n;
        let (bodies, count) = match &self.engine {
            SavedEngine::Sphere(e) => (e.bodies.len(), e.count.len()),
            SavedEngine::Ellipsoid(e) | SavedEngine::Superquadric(e) => {
                (e.bodies.len(), e.count.len())
            }
        };
        if bodies != n || count != n {
            return Err(StateError::Inconsistent(format!(
                "{bodies} bodies and {count} counters for n = {n}"
            )));
        }
        let model_fits = matches!(
            (&self.engine, self.scene.shape),
            (SavedEngine::Sphere(_), crate::ShapeKind::Sphere)
                | (SavedEngine::Ellipsoid(_), crate::ShapeKind::Ellipsoid)
                | (SavedEngine::Superquadric(_), crate::ShapeKind::Superquadric)
        );
        if !model_fits {
            return Err(StateError::Inconsistent(format!(
                "the engine saved is not of shape {:?}",
                self.scene.shape
            )));
        }
        Ok(())
    }

    /// Whether `scene` can start from this state (the rules are the module's): an
    /// error names the first key that differs.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), StateError> {
        self.start_for(scene).map(|_| ())
    }

    /// Whether `scene` can start from this state, and how: the system (shape, N, φ, X0,
    /// exponents) must be the saved one; the knobs of the predictions decide between continuing
    /// and rebuilding.
    pub(crate) fn start_for(&self, scene: &Scene) -> Result<Start, StateError> {
        let saved = &self.scene;
        let differ = |key: &'static str, a: String, b: String| {
            Err(StateError::Mismatch {
                key,
                saved: a,
                scene: b,
            })
        };
        if saved.shape != scene.shape {
            return differ(
                "shape",
                format!("{:?}", saved.shape),
                format!("{:?}", scene.shape),
            );
        }
        if saved.n != scene.n {
            return differ("n", saved.n.to_string(), scene.n.to_string());
        }
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits();
        for (key, a, b) in [("phi", saved.phi, scene.phi), ("x0", saved.x0, scene.x0)] {
            if !same(a, b) {
                return differ(key, a.to_string(), b.to_string());
            }
        }
        if saved.exponents != scene.exponents {
            return differ(
                "exponents",
                format!("{:?}", saved.exponents),
                format!("{:?}", scene.exponents),
            );
        }
        let knobs_equal = saved.neighbours == scene.neighbours
            && same(saved.delta_nnl, scene.delta_nnl)
            && same(saved.eps_nnl, scene.eps_nnl)
            && same(saved.eps_d, scene.eps_d)
            && same(saved.nr_tol, scene.nr_tol)
            && saved.nr_max_iter == scene.nr_max_iter
            && same(saved.nr_relax, scene.nr_relax)
            && saved.sd_max_iter == scene.sd_max_iter
            && same(saved.sd_tol, scene.sd_tol)
            && same(saved.brent_tol, scene.brent_tol);
        Ok(if knobs_equal {
            Start::Continue
        } else {
            Start::Rebuild
        })
    }
}
