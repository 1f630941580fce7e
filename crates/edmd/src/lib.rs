//! Event-driven molecular dynamics of hard spheres, hard uniaxial ellipsoids and superquadrics, after
//! C. De Michele, "Simulating hard rigid bodies" (equation numbers in the docs refer to it).
//! Pure computation: no files, no printing, no threads.
//!
//! Map of the modules, from geometry up to the run:
//! - [`scene`]: the TOML scene, its defaults and validation ([`Scene`], [`SceneError`]).
//! - [`geometry`]: implicit surfaces f(x) = 0, poses, lab-frame gradients and Hessians;
//!   [`sphere`] (analytic path), [`ellipsoid`] (Eqs. 42–44) and [`superquadric`] (Eq. 77), one
//!   shape per file; the rigid-body model of [`model`] is generic over the [`geometry::Surface`]
//!   trait.
//! - [`rigid`]: free motion (Eqs. 3–6), ḋ_max (Eq. 32), the elastic collision (Eqs. 40–41).
//!   [`body`]: what the event loop reads of a body ([`body::Moving`]), stored as a rigid body or
//!   as a sphere's position, velocity and time alone ([`body::SphereBody`], one cache line).
//! - [`distance`]: Newton–Raphson on Eqs. (23) with the relaxed step (26–29), the guess of
//!   Sec. 3.2 and steepest descent (Sec. 2.3.2); negative distances for slight overlaps.
//!   [`support_distance`]: the globally convergent fallback when all of those fail (Gilbert's
//!   algorithm on support functions, with certified bounds, and Newton–Raphson from its support
//!   points, whose last try backtracks on the residual); a distance it cannot decide either
//!   stops the run with [`EdmdError::Unresolved`], naming the pair.
//! - [`contact`]: contact time (Sec. 2.4): bounding spheres, ε_d stepping (Eq. 39), grazing by
//!   quadratic interpolation and Brent's method, Newton–Raphson on Eqs. (30)–(31); the bounds
//!   that rule candidates out before a search (`quick_bound`, and `enclosing_bound` from the
//!   boxes and cylinders that hold superquadrics). [`first_step`]: the first step of its quick bound for one ellipsoid shape, four candidates
//!   at a time on AVX2, which rules out most candidates of a prediction. `lanes`: the AVX2
//!   arithmetic it shares with [`nnl`]'s box tests, four at a time.
//! - [`calendar`]: one event per particle in a 4-ary heap that knows where each particle's is.
//! - [`cells`]: periodic linked cells; [`nnl`]: bounding parallelepipeds, 15-axis test (four boxes
//!   at a time on AVX2), escape times;
//!   [`ball`]: bounding balls, the spheres' regions; [`lists`]: the neighbour lists built from
//!   either, kept per particle.
//! - [`pw`]: Perram–Wertheim contact function, the independent overlap oracle for ellipsoids;
//!   superquadrics are compressed with the contact scale of [`scale`].
//! - [`init`]: random sequential addition (or a dilute lattice) → Monte Carlo compression →
//!   Maxwell–Boltzmann velocities (for a sphere mixture [`init::initial_mixture`], each pair in
//!   contact at (σ_i + σ_j)/2);
//!   [`rng`]: the seeded generator it draws from.
//! - [`sequence`]: a fingerprint of the collision sequence, to find where two runs part.
//! - [`model`]: the body models, what one particle kind costs to simulate: the analytic sphere,
//!   spheres of several sizes (mixtures and polydisperse spheres: a radius and a mass ∝ σ³ per
//!   body, lists of [`ball::SizedBall`]s sized per pair), or the general rigid body (its collision
//!   rule and the contact-time search of one pair).
//! - [`engine`]: the event loop, generic over the model: collisions, cell crossings, box escapes,
//!   each body's first-collision search, and the sums the measurements are made of; `axes`: the
//!   rigid pairs' separating axes kept from one prediction to the next.
//! - [`audit`]: the overlap audit of the final state, every pair found through cells and decided
//!   independently of the engine's solvers; superquadrics by [`audit::overlap_certified`] (a
//!   separating axis with a positive support gap, from Gilbert's algorithm or Newton's normal).
//! - [`state`]: the state file (a run saved, to be continued bit for bit or started from).
//! - [`run`](mod@run): a scene's set-up, initial state and measured phases ([`run()`],
//!   [`run_with_state`]), timed by [`clock`]; [`report`]: what a run hands back ([`RunReport`],
//!   [`FinalState`]).
//!
//! Where this engine departs from the paper, and why:
//! - The calendar holds one event per particle (its earliest collision, cell crossing or box
//!   escape), replaced in place when the particle is predicted anew, so it never holds stale
//!   events; an event whose partner has moved on re-predicts the particle when it comes due. The earliest event
//!   found so far bounds every further contact search (the horizon of Eq. 65, generalised), and
//!   rigid-body partners are searched in the order of a lower bound on their contact time. A
//!   rigid body's search for a partner also ends at the partner's own next event: every event
//!   predicts its body anew against all it may meet, so whichever of the pair is predicted last
//!   before their contact finds it (17–25 % fewer distance calls, X0 = 2, φ = 0.5).
//! - Neighbour lists are updated per particle, as Donev et al. \[26\] do: a body that escapes its box
//!   gets a new box and list alone, instead of the global rebuild of Sec. 3.5 step 4. Spheres,
//!   which do not rotate, get a ball instead of a box (the centre may wander Δ_NNL), with an exact
//!   escape time and no 15-axis test. Lists hold indices; a sphere prediction gathers the list's
//!   trajectories (each neighbour's [`body::SphereBody`]: position, velocity, time, one cache
//!   line) into a contiguous batch and takes four neighbours at a time on AVX2
//!   ([`sphere::first_contact`]).
//! - Lower bounds on contact times go beyond ḋ_max (Eq. 32): the support gap along a fixed
//!   direction bounds the distance from below at all times and changes at a rate and acceleration
//!   that depend on that direction ([`rigid::gap_closing_rates`], [`rigid::support_acceleration_bound`];
//!   for flat faces, whose curvature is unbounded, a Hölder bound on the support function,
//!   [`geometry::SupportModulus`]).
//!   They prune partners before any Newton–Raphson, and they let the search of Eq. (39) step over
//!   intervals that are provably free of contact, e.g. just after two bodies collided.
//! - The escape time from a bounding parallelepiped uses the ellipsoid's support function, exact
//!   and closed-form, instead of Newton–Raphson on the planes (Eqs. 56–58); the stepping of Eq. (61)
//!   with ε_d^nnl is kept for rotating bodies.
//! - Initial configurations come from random sequential addition at a dilute density (a dilute
//!   FCC lattice melted by Monte Carlo, where the addition jams and for mixtures), compressed by
//!   hard-body Monte Carlo with the Perram–Wertheim overlap test and Jodrey–Tory pushes, in O(N)
//!   per pass through cells, then relaxed by 5 or 10 collisions per particle
//!   (`init::Config::relax`); not from a Lubachevsky–Stillinger growth.
//!
//! Units: the diameter σ of the sphere of equal volume (every body has volume π/6), the mass m,
//! and k_B T of the initial state (= 1). Ellipsoids have semi-axes a = X0·b, b = c, a·b·c = 1/8
//! and the isotropic moment of inertia (2/5) m min(a, b)² of their inscribed sphere.

mod arena;
pub mod audit;
mod axes;
pub mod ball;
pub mod body;
pub mod bracket;
pub mod calendar;
pub mod cells;
pub mod clock;
pub mod contact;
pub mod distance;
pub mod ellipsoid;
pub mod engine;
pub mod first_step;
pub mod geometry;
pub mod init;
#[cfg(target_arch = "x86_64")]
mod lanes;
pub mod lists;
pub mod model;
pub mod nnl;
pub mod pw;
pub mod report;
pub mod rigid;
pub mod rng;
pub mod run;
pub mod scale;
pub mod scene;
pub mod sequence;
pub mod sphere;
pub mod state;
pub mod superquadric;
pub mod support_distance;

pub use report::{FinalState, PairReport, ParticleDump, RunReport, SpeciesReport};
pub use run::{Frame, FrameEvery, HookResult, Hooks, run, run_with_hooks, run_with_state};
pub use scene::{
    Neighbours, Scene, SceneError, ShapeKind, default_delta_nnl, default_neighbours,
    fill_shape_defaults,
};
pub use state::{SavedState, StateError};

use thiserror::Error;

/// Asks for the cache line holding `x` ahead of its use: a hint, without effect on any result.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of every x86_64 CPU, and a prefetch reads nothing the program sees.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            (x as *const T).cast(),
        )
    };
}

#[derive(Debug, Error)]
pub enum EdmdError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("box of side {l:.4} too small (need more than {needed:.4}): {why}")]
    BoxTooSmall {
        l: f64,
        needed: f64,
        why: &'static str,
    },
    #[error("could not compress to phi = {target} (reached {reached:.4}); the state may be jammed")]
    Compression { reached: f64, target: f64 },
    #[error("the event calendar ran empty (nothing moves)")]
    Stalled,
    /// A solver found no answer even with its fallbacks: the run stops rather than advance past
    /// a contact it could not resolve.
    #[error("{0}")]
    Unresolved(Box<UnresolvedContact>),
    #[error(transparent)]
    ListLimit(#[from] lists::ListLimit),
    /// A state file that the scene cannot start from.
    #[error(transparent)]
    State(#[from] state::StateError),
    /// A checkpoint or a frame that could not be written: the run stops.
    #[error("{0}")]
    Hook(String),
}

/// What failed, where the quantity does not say it: every distance solver, for a distance.
fn why_unresolved(quantity: &str) -> &'static str {
    if quantity.contains("distance") {
        ": Newton–Raphson, steepest descent and the support-function fallback all failed"
    } else {
        ""
    }
}

/// The pair and state of a contact search no solver could resolve.
#[derive(Debug, Error)]
#[error(
    "unresolved {quantity} for bodies {a} and {b} at t = {t:.17e} (centres {ra:?} and {rb:?}, velocities {va:?} and {vb:?}){}",
    why_unresolved(.quantity)
)]
pub struct UnresolvedContact {
    pub quantity: &'static str,
    pub a: usize,
    pub b: usize,
    pub t: f64,
    pub ra: [f64; 3],
    pub rb: [f64; 3],
    pub va: [f64; 3],
    pub vb: [f64; 3],
}

#[cfg(test)]
mod tests {
    use super::UnresolvedContact;

    fn unresolved(quantity: &'static str) -> String {
        UnresolvedContact {
            quantity,
            a: 1,
            b: 2,
            t: 0.5,
            ra: [0.0; 3],
            rb: [1.0; 3],
            va: [0.0; 3],
            vb: [0.0; 3],
        }
        .to_string()
    }

    #[test]
    fn only_a_distance_failure_is_blamed_on_the_distance_solvers() {
        assert!(unresolved("distance").ends_with("the support-function fallback all failed"));
        let stepping = unresolved("contact time (Eq. 39 stepping)");
        assert!(
            stepping.starts_with("unresolved contact time (Eq. 39 stepping) for bodies 1 and 2")
        );
        assert!(!stepping.contains("Newton"), "{stepping}");
    }
}
