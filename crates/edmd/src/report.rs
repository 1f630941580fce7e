//! What a run hands back: its measured figures ([`RunReport`]) and its final configuration
//! ([`FinalState`]).

use serde::Serialize;

use crate::body::Moving;
use crate::geometry::{V3, wrap};
use crate::init::Geom;
use crate::sequence::Fingerprint;

/// The measured figures of one run (the JSON of `sweep edmd`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RunReport {
    /// Collisions in the measured run.
    pub collisions: u64,
    /// τ_c = T_tot / N_coll (Eq. 69): wall time of the measured run per collision, in µs.
    pub tau_c_us: f64,
    /// τ_c from this thread's CPU time instead of the wall clock, in µs: the paper's "CPU time"
    /// of Eq. (69); below `tau_c_us` when the core was shared with other work.
    pub tau_c_cpu_us: f64,
    /// Eq. (73) split in time (wall clock, as `tau_c_us`): Δt_u, the box and list rebuilds per
    /// collision (timed one by one; the escape-time updates after each collision are too short
    /// to time and stay in the prediction), and Δt_coll = `tau_c_us` − Δt_u, the prediction.
    pub tau_update_us: f64,
    pub tau_predict_us: f64,
    /// Wall time of the measured run's box and list rebuilds (NNL; 0 with linked cells).
    pub nnl_rebuild_s: f64,
    /// Z = P/(ρ kT) = 1 + Σ r_ij·Δp_i / (3 N kT T), with the measured kT.
    pub pressure_z: f64,
    /// Standard error of Z from 10 block averages.
    pub pressure_z_err: f64,
    /// Measured kT = (2/3)⟨translational kinetic energy⟩/(N − 1), time-averaged: the net momentum
    /// is zero, which leaves 3N − 3 translational degrees of freedom.
    pub temperature: f64,
    /// |E_end − E_start| / E_start over the measured run (translational + rotational).
    pub energy_drift_rel: f64,
    /// |P_end − P_start| over the measured run, in units of m σ/τ (total momentum starts at 0).
    pub momentum_drift: f64,
    /// Overlapping pairs in the audit of the final state (every pair, found through cells).
    pub overlaps: u64,
    /// Distance or contact-time solves that failed, over the whole run (equilibration included).
    pub solver_failures: u64,
    /// Contact times found by bisection after Newton–Raphson on Eqs. (30) failed (whole run).
    pub contact_nr_fallbacks: u64,
    /// Distances decided by the support-function fallback after Newton–Raphson and steepest
    /// descent failed (whole run; converged or a proved overlap, not failures).
    pub distance_fallbacks: u64,
    /// Distances of bodies of aspect above 5 that Gilbert's algorithm proved
    /// overlapping where Newton–Raphson found no negative distance (whole run): the certified
    /// overlap, decided before steepest descent and the support fallback (not failures).
    pub certified_overlaps: u64,
    /// Newton–Raphson iterations per solve, of the distances (Eqs. 9) and of the contact times
    /// (Eqs. 30) alike, in the measured run (0 on the sphere path). A contact time is solved
    /// without a distance before it where the search can (`contact::predict_from`).
    pub nr_iterations_mean: f64,
    /// The most Newton–Raphson iterations one distance evaluation took (whole run).
    pub nr_iterations_max: u64,
    /// Distance evaluations per collision in the measured run.
    pub distance_calls_per_collision: f64,
    /// Pair contact-time searches per collision in the measured run (0 on the sphere path).
    pub searches_per_collision: f64,
    /// Mean time between collisions of a particle, t = N T / (2 N_coll).
    pub mean_free_time: f64,
    /// Simulated time of the measured run.
    pub sim_time: f64,
    /// Linked-cell crossings in the measured run.
    pub cell_crossings: u64,
    /// Bounding boxes rebuilt in the measured run, one body each (NNL).
    pub nnl_rebuilds: u64,
    /// Predicted collisions found separating when due (grazing at exact tangency).
    pub separating_contacts: u64,
    pub box_length: f64,
    pub n: usize,
    pub phi: f64,
    /// Wall time of the initial state (s): addition (or lattice and melting), compression, first
    /// lists and events, and the collisions per particle that relax it
    /// ([`Config::relax`](crate::init::Config::relax)).
    pub init_s: f64,
    /// A mixture's figures per species and pair of species; absent (and not serialised) for one
    /// species.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub species: Option<SpeciesReport>,
    /// The collision sequence from the first collision of the run (relaxation included); kept
    /// out of the report's JSON (a job stores it as hex, `sweep edmd` does not print it).
    #[serde(skip)]
    pub sequence: Fingerprint,
}

/// A mixture's measured run by species (numbered from 1, as written in the scene).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SpeciesReport {
    /// Bodies of each species.
    pub count: Vec<usize>,
    /// Their mean diameter (in units of the first species' nominal diameter).
    pub mean_diameter: Vec<f64>,
    /// Every unordered pair of species (i ≤ j).
    pub pairs: Vec<PairReport>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairReport {
    pub species: [usize; 2],
    /// Collisions between the two species in the measured run.
    pub collisions: u64,
    /// Their share of all collisions.
    pub collision_fraction: f64,
    /// Their part of Z − 1: the pair's collision virial over 2 K (the parts sum to Z − 1).
    pub pressure_z_part: f64,
    /// Rigid bodies: the distance evaluations of the contact searches between the two species
    /// (what their pairs cost, the same on every machine; a search is made for a pair whether
    /// or not it collides). Absent for spheres, whose contact times take no solver.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_calls: Option<u64>,
}

/// The final configuration, as `sweep edmd --dump` writes it (README).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FinalState {
    #[serde(rename = "box")]
    pub box_: [f64; 3],
    pub particles: Vec<ParticleDump>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParticleDump {
    pub shape: &'static str,
    pub semi_axes: [f64; 3],
    /// Superquadric exponents; an ellipsoid (and a sphere) has 2 on every axis.
    pub exponents: [f64; 3],
    pub position: [f64; 3],
    /// Rows = body axes in the lab frame.
    pub orientation: [[f64; 3]; 3],
    pub velocity: [f64; 3],
    pub angular_velocity: [f64; 3],
}

pub(crate) fn final_state<B: Moving>(bodies: &[B], l: f64, geom: &Geom) -> FinalState {
    final_state_each(bodies, l, &|_| *geom)
}

/// [`final_state`] of bodies of several shapes or sizes (body `i` is `geom_of(i)`).
pub(crate) fn final_state_each<B: Moving>(
    bodies: &[B],
    l: f64,
    geom_of: &dyn Fn(usize) -> Geom,
) -> FinalState {
    let arr = |v: V3| [v.x, v.y, v.z];
    FinalState {
        box_: [l; 3],
        particles: bodies
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let (shape, semi_axes, exponents) = match geom_of(i) {
                    Geom::Sphere { sigma } => ("sphere", [0.5 * sigma; 3], [2.0; 3]),
                    Geom::Ellipsoid(e) => ("ellipsoid", [e.s.x, e.s.y, e.s.z], [2.0; 3]),
                    Geom::Superquadric(q) => ("superquadric", q.s.into(), q.e.into()),
                };
                ParticleDump {
                    shape,
                    semi_axes,
                    exponents,
                    position: arr(b.r().map(|x| wrap(x, l))),
                    orientation: [0, 1, 2].map(|k| arr(b.rot().row(k).transpose())),
                    velocity: arr(b.v()),
                    angular_velocity: arr(b.w()),
                }
            })
            .collect(),
    }
}
