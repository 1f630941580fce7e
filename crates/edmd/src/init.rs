//! Initial configurations at a target φ: bodies of one shape placed by random sequential
//! addition in random orientations at a dilute density (`random_sequential` for spheres,
//! `random_sequential_bodies` for the others), compressed by hard-body Monte Carlo, then
//! Maxwell–Boltzmann velocities. Where the addition jams, and for mixtures, a dilute FCC lattice
//! melted by Monte Carlo sweeps takes its place (Sec. 4.1 melts a dilute crystal similarly).
//! Spheres of one size are compressed without sweeps (`SPHERES`).
//!
//! The compression follows the "quick compress" of hard-particle Monte Carlo codes: the box
//! shrinks by a small step, which leaves some pairs overlapping; two sweeps in which no move may
//! create an overlap or deepen one resolve many of them, and the rest are pushed apart along their
//! lines of centres (Jodrey–Tory), ellipsoids along their contact normals. Every pass is O(N)
//! through cells ([`Near`]), and the number of steps does not grow with N, unlike a compression
//! limited by the closest pair (some pair is always nearly in contact, so its steps shrink as N
//! grows: O(N²) in all). The pushes leave pairs near contact, which the engine relaxes with a few
//! collisions per particle before anything is measured ([`Config::relax`]); compact bodies at a
//! dilute target are equilibrated by Monte Carlo sweeps at the target instead ([`DILUTE_SWEEPS`]).

use crate::EdmdError;
use crate::bracket::outer_factor_squared;
use crate::cells::Near;
use crate::ellipsoid::{Ellipsoid, lab_matrix};
use crate::geometry::{M3, Surface, V3, min_image, wrap};
use crate::nnl::{Obp, overlap};
use crate::pw::{self, contact_scale};
use crate::rigid::{Body, Inertia, orthonormalize, rotate};
use crate::rng::Rng;
use crate::scale;
use crate::superquadric::Superquadric;

/// The shape as the initialiser and the audit see it.
#[derive(Clone, Copy, Debug)]
pub enum Geom {
    Sphere { sigma: f64 },
    Ellipsoid(Ellipsoid),
    Superquadric(Superquadric),
}

impl Geom {
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Geom::Sphere { sigma } => 0.5 * sigma,
            Geom::Ellipsoid(e) => e.s.max(),
            Geom::Superquadric(q) => q.bounding_radius(),
        }
    }

    /// The bounding radius over the radius of the largest sphere inside (1 for a sphere).
    fn aspect(&self) -> f64 {
        match self {
            Geom::Sphere { .. } => 1.0,
            Geom::Ellipsoid(e) => e.s.max() / e.s.min(),
            // Exponents of 2 or more hold the ellipsoid of the semi-axes.
            Geom::Superquadric(q) => q.bounding_radius() / q.s.min(),
        }
    }

    /// The largest semi-axis over the smallest (1 for a sphere): how elongated or flat the body
    /// is, whatever its corners.
    fn axis_ratio(&self) -> f64 {
        match self {
            Geom::Sphere { .. } => 1.0,
            Geom::Ellipsoid(e) => e.s.max() / e.s.min(),
            Geom::Superquadric(q) => q.s.max() / q.s.min(),
        }
    }

    /// The body's volume.
    pub fn volume(&self) -> f64 {
        match self {
            Geom::Sphere { sigma } => std::f64::consts::PI / 6.0 * sigma * sigma * sigma,
            Geom::Ellipsoid(e) => 4.0 / 3.0 * std::f64::consts::PI * e.s.product(),
            Geom::Superquadric(q) => q.volume(),
        }
    }

    /// The same body as a superquadric (a sphere or an ellipsoid is one, of exponents 2).
    fn as_superquadric(&self) -> Superquadric {
        let (s, e) = match self {
            Geom::Sphere { sigma } => (V3::repeat(0.5 * sigma), V3::repeat(2.0)),
            Geom::Ellipsoid(e) => (e.s, V3::repeat(2.0)),
            Geom::Superquadric(q) => return *q,
        };
        Superquadric::new(s.into(), e.into())
            .unwrap_or_else(|| unreachable!("a valid body's semi-axes are positive and finite"))
    }

    /// Factor by which this body (`rot_a`) and `other` (`rot_b`, at separation `r`) must both be
    /// scaled about their centres to touch (< 1: overlap). For spheres |r|/((σ_a + σ_b)/2); for
    /// ellipsoids the Perram–Wertheim function, independent of the NR solver; for superquadrics
    /// [`scale::contact_scale`] on the engine's own distance, exact up to
    /// 1 + [`scale::EXACT_BELOW`] and a lower bound above (all the Monte Carlo needs). A
    /// mixture's bodies are all of one kind; two kinds meet as superquadrics.
    pub fn contact_scale(&self, other: &Geom, rot_a: &M3, rot_b: &M3, r: &V3) -> f64 {
        match (self, other) {
            (Geom::Sphere { sigma: a }, Geom::Sphere { sigma: b }) => r.norm() / (0.5 * (a + b)),
            (Geom::Ellipsoid(a), Geom::Ellipsoid(b)) => contact_scale(a, rot_a, b, rot_b, r),
            (Geom::Superquadric(a), Geom::Superquadric(b)) => {
                scale::contact_scale(a, rot_a, b, rot_b, r)
            }
            _ => scale::contact_scale(
                &self.as_superquadric(),
                rot_a,
                &other.as_superquadric(),
                rot_b,
                r,
            ),
        }
    }

    /// [`Geom::contact_scale`], or `None` where it is proved above `k` without being computed
    /// (ellipsoids, [`crate::pw::contact_scale_unless_above`]).
    pub fn contact_scale_unless_above(
        &self,
        other: &Geom,
        rot_a: &M3,
        rot_b: &M3,
        r: &V3,
        k: f64,
    ) -> Option<f64> {
        match (self, other) {
            (Geom::Ellipsoid(a), Geom::Ellipsoid(b)) => {
                crate::pw::contact_scale_unless_above(a, rot_a, b, rot_b, r, k)
            }
            _ => Some(self.contact_scale(other, rot_a, rot_b, r)),
        }
    }

    /// Whether this body and `other` touch or overlap once both are scaled by `k` (contact scale
    /// ≤ `k`): for ellipsoids decided without the maximum where the bounds of
    /// [`crate::pw::within`] suffice, the same decisions as [`Geom::contact_scale`]'s; for
    /// superquadrics by the sign of their distance at that scale ([`scale::within`]), the same
    /// decisions but within the distance solver's tolerance of contact; its certificates start
    /// from `axis` (unit, from this body to `other`) where one is given.
    pub fn within(
        &self,
        other: &Geom,
        rot_a: &M3,
        rot_b: &M3,
        r: &V3,
        k: f64,
        axis: Option<&V3>,
    ) -> bool {
        match (self, other) {
            (Geom::Sphere { .. }, Geom::Sphere { .. }) => {
                self.contact_scale(other, rot_a, rot_b, r) <= k
            }
            (Geom::Ellipsoid(a), Geom::Ellipsoid(b)) => pw::within(a, rot_a, b, rot_b, r, k),
            _ => scale::within(
                &self.as_superquadric(),
                rot_a,
                &other.as_superquadric(),
                rot_b,
                r,
                k,
                axis,
            ),
        }
    }

    /// Cheap certificate that this body and `other`, both scaled by `k` about their centres, do
    /// not touch: their bounding spheres or their bounding boxes are disjoint.
    pub fn surely_apart(&self, other: &Geom, rot_a: &M3, rot_b: &M3, r: &V3, k: f64) -> bool {
        let reach = (self.bounding_radius() + other.bounding_radius()) * k;
        if r.norm_squared() >= reach.powi(2) {
            return true;
        }
        // |x_k| ≤ s_k on a superquadric too: its semi-axes bound it as tightly.
        let semi_axes = |g: &Geom| match g {
            Geom::Sphere { .. } => None,
            Geom::Ellipsoid(e) => Some(e.s),
            Geom::Superquadric(q) => Some(q.s),
        };
        let (Some(sa), Some(sb)) = (semi_axes(self), semi_axes(other)) else {
            return false;
        };
        let a = Obp {
            c: V3::zeros(),
            rot: *rot_a,
            half: sa * k,
        };
        let b = Obp {
            c: *r,
            rot: *rot_b,
            half: sb * k,
        };
        !overlap(&a, &b, &V3::zeros())
    }

    /// Whether the body is a sphere, whatever kind of shape carries it.
    pub fn is_sphere(&self) -> bool {
        let s = match self {
            Geom::Sphere { .. } => return true,
            Geom::Ellipsoid(e) => e.s,
            Geom::Superquadric(q) => {
                if q.e != V3::repeat(2.0) {
                    return false;
                }
                q.s
            }
        };
        s.x == s.y && s.y == s.z
    }

    fn rotates(&self) -> bool {
        !matches!(self, Geom::Sphere { .. })
    }

    /// Whether the body is one of revolution about its axis 0 (the engine's uniaxial ellipsoids
    /// and superquadrics whose two other semi-axes and exponents are equal): smooth collisions
    /// then never change the spin about that axis, which is left at 0.
    pub fn revolves_about_axis_0(&self) -> bool {
        match self {
            Geom::Sphere { .. } => true,
            Geom::Ellipsoid(e) => e.s.y == e.s.z,
            Geom::Superquadric(q) => q.s.y == q.s.z && q.e.y == 2.0 && q.e.z == 2.0,
        }
    }
}

/// A uniformly random rotation matrix (from a random unit quaternion).
fn random_rotation(rng: &mut Rng) -> M3 {
    let q = loop {
        let q = nalgebra::Vector4::new(rng.normal(), rng.normal(), rng.normal(), rng.normal());
        if q.norm() > 1e-6 {
            break q.normalize();
        }
    };
    let uq = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        q[0], q[1], q[2], q[3],
    ));
    uq.to_rotation_matrix().into_inner()
}

/// Separation kept between bodies by the Monte Carlo, so that the dynamics starts without contact.
const GAP: f64 = 1e-9;

/// The lattice is melted at this packing fraction (or the target, if lower): a stable fluid for
/// spheres and the elongations simulated here.
const PHI_MELT: f64 = 0.25;

/// Monte Carlo sweeps that melt the lattice: each body moves about a lattice spacing.
const MELT_SWEEPS: usize = 60;

/// How a packing is melted and compressed.
struct Schedule {
    /// Sweeps at the melting density before the compression.
    melt_sweeps: usize,
    /// The first displacement step, in bounding radii (the steps adapt from there).
    first_dr: f64,
    /// The first compression step (relative change of the box side), from the dilute start.
    first_step: f64,
    /// The largest compression step after it.
    max_step: f64,
    /// Sweeps after each compression step.
    relax_sweeps: usize,
    /// Pairs that a step left in contact are pushed this many times the step's relative change
    /// of the box side past contact (see [`Packing::push_apart`]).
    push_ahead: f64,
    /// [`Schedule::push_ahead`] of steps that end above φ = [`DENSE_PUSHES_FROM`].
    push_ahead_dense: f64,
    /// Sweeps at the target after the compression: the equilibration of a dilute start
    /// ([`ADDED_DILUTE`]).
    final_sweeps: usize,
}

/// The packing fraction above which a step's pushes go [`Schedule::push_ahead_dense`] past
/// contact.
const DENSE_PUSHES_FROM: f64 = 0.5;

/// A lattice of any shape.
///
/// Its pushes overshoot: a pair pushed to 1 + 2 Δ of contact (Δ the step) outlives the next step
/// instead of touching again, and each step's pushes end in fewer passes. Ellipsoids X0 = 2,
/// φ = 0.5, N 4096: pushed to 1 + Δ/2 with 50 passes allowed, the pushes failed at 5 of 31
/// steps and each failure cost an unjamming (5 collisions per body); to 1 + 2 Δ with the
/// passes of [`push_apart`](Packing::push_apart), none failed (one of 15 at N 10⁵), and steps
/// of up to 3 % with one sweep each instead of 2 % with two took 0.3 s less of 2.5 (see
/// MEASUREMENTS.md, "Fast initial states, round 3").
const LATTICE: Schedule = Schedule {
    melt_sweeps: MELT_SWEEPS,
    first_dr: 0.1,
    first_step: MAX_STEP,
    max_step: MAX_STEP,
    relax_sweeps: RELAX_SWEEPS,
    push_ahead: 2.0,
    push_ahead_dense: 2.0,
    final_sweeps: 0,
};

/// Bodies of one shape other than spheres, from random sequential addition
/// ([`random_sequential_bodies`]): the lattice's compression without its melting. Ellipsoids
/// X0 = 2, φ = 0.5, N 4096: 6.3 G instructions a start instead of 12.3, of which the pushes
/// 1.9 G instead of 6.4 (they visit fewer bodies), with the same equation of state
/// (MEASUREMENTS.md, "Rigid bodies from random sequential addition").
const ADDED: Schedule = Schedule {
    melt_sweeps: 0,
    ..LATTICE
};

/// [`ADDED`] ending with [`DILUTE_SWEEPS`] at the target, and without the sweep after its step:
/// a step of under 1.3 % of the side leaves few pairs in contact, which the pushes part at once,
/// where a sweep of bodies in contact asks for their contact scales (p = 10, X0 = 2, φ 0.256,
/// N 512: 0.049 s of a 0.174 s start, against 0.011 s for the pushes alone).
const ADDED_DILUTE: Schedule = Schedule {
    relax_sweeps: 0,
    final_sweeps: DILUTE_SWEEPS,
    ..ADDED
};

/// The densest target whose start from the addition of bodies of axis ratio up to
/// [`SHORT_RELAX_AXIS_RATIO`] ends with [`DILUTE_SWEEPS`] instead of relaxing collisions: the
/// addition's density (0.25) and a compression step of under 1.3 % of the side, whose
/// pushes leave few pairs near contact. At φ 0.3 (six steps of pushes) 30 sweeps left Z over
/// the first 2 collisions per particle +0.48 ± 0.18 % above the run's later Z, 5 relaxing
/// collisions −0.20 ± 0.20 % ([2, 2, 10], X0 = 2, N 2048, 96 seeds).
pub const DILUTE_PHI: f64 = 0.26;

/// Monte Carlo sweeps at the target that end a dilute start ([`DILUTE_PHI`]) instead of relaxing
/// collisions ([`Config::relax`] is 0). The sweeps sample the equilibrium of hard bodies
/// (symmetric trial moves, every overlap refused) and cost a few µs a body each, where a
/// superquadric's collision costs 100. Z over the first 2 collisions per particle against the
/// same run's collisions 6–12 per particle, φ 0.256, X0 = 2, N 2048, 96 seeds: [2, 2, 10]
/// −0.85 ± 0.17 % after 10 sweeps, −0.52 ± 0.17 % after 20, −0.20 ± 0.16 % after 30 (0.29 ms a
/// body), where 5 relaxing collisions left +0.28 ± 0.22 % (0.88 ms a body); after 30, [2, 2, 4]
/// −0.16 ± 0.19 % and ellipsoids −0.34 ± 0.16 % (MEASUREMENTS.md, "Dilute starts equilibrated
/// by Monte Carlo sweeps").
pub const DILUTE_SWEEPS: usize = 30;

/// Spheres of one size, from random sequential addition ([`random_sequential`]): no Monte Carlo
/// sweeps at all, the compression is the box's steps of 10 % and Jodrey–Tory pushes alone. The
/// dynamics that ends every initial state relaxes what the sweeps did, and more: Z over the first
/// 2 collisions per particle after the initial state (N = 10⁵, φ = 0.45, seed 0; Kolafa 9.403)
/// was 9.75 ± 0.03 after 10 sweeps, steps of 5 % with a sweep each and 5 relaxing collisions per
/// particle, and is 9.69 ± 0.02 without the sweeps (9.67 in steps of 10 %): the compression
/// leaves g(r) within 2 % of contact 2–2.5 times the fluid's, sweeps or not, and the collisions
/// flatten it whatever the compression was. Steps of 3, 5, 7, 10, 15 % cost 1.2, 0.72, 0.89,
/// 0.57, 0.74 s of pushes at N = 10⁵ (a loaded machine); 25 % jam the pushes.
///
/// The first step, from the addition's φ 0.25, is 20 %: the pushes' visits grow with the
/// density of the step, so the dilute one takes the most. N = 10⁶, φ 0.45: 6.3 · 10⁶ visits
/// in two steps where three of 10 % took 8.0 · 10⁶, the start 1.2 s shorter (17.99, 18.73,
/// 17.90 s against 19.37, 20.41, 18.30, alternated); Z as above 9.677 against 9.696 (seeds
/// 0–3, ±0.02 each), and alike at φ 0.3, 0.4, 0.5 and 0.55 (MEASUREMENTS.md, "Safe times in
/// whole powers; the spheres' first step").
///
/// Pairs are pushed 1.25 steps past contact up to φ = 0.5 (not half a step): fewer pairs are
/// left near contact, and 3 relaxing collisions per particle leave Z within 0.4 % of Kolafa's
/// where 5 left it 2.9 % above ([`SPHERE_RELAX_COLLISIONS_PER_PARTICLE`]). The pushes past 0.5
/// stay at half a step: at φ 0.55, N 10⁵, 1.25 everywhere took 4.8 s a start against 2.3 (the
/// pushes of dense steps cascade), half a step there 1.5 s. Steps of 2 past contact at 0.45:
/// Z 9.50 after 5, but 7 s a start at N 10⁵ against 1.5.
const SPHERES: Schedule = Schedule {
    melt_sweeps: 0,
    // No sweep uses it.
    first_dr: 0.6,
    first_step: 0.2,
    max_step: 0.1,
    relax_sweeps: 0,
    push_ahead: 1.25,
    push_ahead_dense: 0.5,
    final_sweeps: 0,
};

/// The largest compression step (relative change of the box side), and the smallest, below which
/// the state is taken to be jammed.
const MAX_STEP: f64 = 0.03;
const MIN_STEP: f64 = 1e-6;
/// Sweeps after each compression step. The overlaps they leave are pushed apart; a step that
/// leaves none is followed by a larger one, a step whose overlaps cannot be pushed apart is
/// undone and followed by a smaller one.
const RELAX_SWEEPS: usize = 1;
/// Passes of pushes without progress (the bodies pushed in a pass fewer by a tenth than the
/// fewest before) after which a compression step is undone; it is undone at once where a pass
/// pushes more than twice the fewest bodies (and N/50 more): the pushes spread instead of
/// settling, as they did among long needles (X0 = 10) pushed along their lines of centres, which
/// mostly slid them into others. Dense packings (φ ≥ 0.4) take 100–250 passes whose count of
/// pushed bodies falls slowly but steadily: a fixed count of 50 passes gave up on most of them,
/// and an unjamming costs more than the passes it saves.
const PUSH_STALL: usize = 50;
/// Passes of pushes after which a compression step is undone whatever the progress.
const PUSH_PASSES: usize = 2000;
/// Visits of bodies by a step's pushes, per body, after which they give up whatever the
/// progress, and the step is rescued ([`Packing::rescue`]) or undone. Ellipsoids at N 10⁵ spent
/// 34 s (350 visits per body) on the pushes of a step that failed. With the rescue after them, 50
/// beat 100 and 30 (X0 = 2, φ 0.5: N 10⁵ 23 s of compression against 32 and 32, N 4096 1.10 s
/// against 1.15 and 1.06; X0 = 0.1 and 10, four starts each: 2.15 and 2.80 s against 2.59 and
/// 2.60 at 100).
const PUSH_VISITS: usize = 50;
/// Pushed pairs are left this far from contact at least (in contact-scale units), so that tiny
/// steps do not build a network of pairs all but touching.
const MIN_PUSH: f64 = 2e-3;
/// Collisions per particle of the dynamics after a compression step was undone.
const UNJAM_COLLISIONS: u64 = 5;
/// Rounds of [`Packing::rescue`] at most, and the Monte Carlo sweeps of the bodies in contact in
/// each.
const RESCUE_ROUNDS: usize = 12;
const RESCUE_SWEEPS: usize = 10;
/// Sweeps allowed for the whole compression, whatever its steps.
const MAX_SWEEPS: usize = 100_000;

/// Whether the passes of [`Packing::push_apart`] still settle, from the count of bodies each
/// pass pushes ([`PUSH_STALL`]), whether they have cost what an unjamming would
/// ([`PUSH_VISITS`]), and whether they have run out ([`PUSH_PASSES`]).
struct PushProgress {
    pass: usize,
    fewest: usize,
    fewest_at: usize,
    /// Counts above twice the fewest by more than this (N/50) are spreading.
    spread: usize,
    /// Bodies visited so far, and the most allowed ([`PUSH_VISITS`] per body).
    visits: usize,
    most_visits: usize,
}

impl PushProgress {
    /// Before the first pass, which pushes `first` of `n` bodies.
    fn new(first: usize, n: usize) -> Self {
        PushProgress {
            pass: 0,
            fewest: first,
            fewest_at: 0,
            spread: n / 50,
            visits: 0,
            most_visits: PUSH_VISITS * n,
        }
    }

    /// Whether the pass about to push `count` bodies is one too many.
    fn stalls(&mut self, count: usize) -> bool {
        let pass = self.pass;
        self.pass += 1;
        self.visits += count;
        if pass >= PUSH_PASSES || self.visits > self.most_visits {
            return true;
        }
        if count * 10 < self.fewest * 9 {
            (self.fewest, self.fewest_at) = (count, pass);
            return false;
        }
        pass - self.fewest_at > PUSH_STALL || count > 2 * self.fewest + self.spread
    }
}

/// Monte Carlo step sizes (displacement, rotation angle), kept near 30–50 % acceptance.
struct Steps {
    dr: f64,
    dth: f64,
}

impl Steps {
    fn adapt(&mut self, acceptance: f64, l: f64) {
        let f = if acceptance > 0.5 {
            1.2
        } else if acceptance < 0.3 {
            0.8
        } else {
            1.0
        };
        self.dr = (self.dr * f).min(0.25 * l);
        self.dth = (self.dth * f).min(1.0);
    }
}

pub struct Config {
    pub l: f64,
    pub bodies: Vec<Body>,
    /// Collisions per particle of the dynamics that ends the start: its pushes leave pairs near
    /// contact ([`RELAX_COLLISIONS_PER_PARTICLE`], [`SHORT_RELAX_COLLISIONS_PER_PARTICLE`] or
    /// [`SPHERE_RELAX_COLLISIONS_PER_PARTICLE`]); 0 where Monte Carlo sweeps ended it
    /// ([`DILUTE_SWEEPS`]).
    pub relax: u64,
}

/// Collisions per particle that end a start ([`Config::relax`]): from the lattice, from the
/// addition of bodies more elongated or flatter than [`SHORT_RELAX_AXIS_RATIO`], and for
/// mixtures.
pub const RELAX_COLLISIONS_PER_PARTICLE: u64 = 10;

/// Collisions per particle that end a start from random sequential addition of bodies of axis
/// ratio up to [`SHORT_RELAX_AXIS_RATIO`] at a target above [`DILUTE_PHI`]: their starts are as
/// relaxed after 5 as after 10. Z over the next 2 collisions per particle after k
/// (MEASUREMENTS.md, "Five relaxing collisions for rigid bodies of axis ratio up to 2"):
/// - spheres (before [`SPHERE_RELAX_COLLISIONS_PER_PARTICLE`]), N = 10⁵, φ = 0.45, seed 0
///   (Kolafa 9.403): 10.33 after 2, 9.70 after 5, 9.45 after 10 (ten took 35 of the 75 s at
///   N = 10⁶);
/// - ellipsoids X0 = 2 and 0.5, φ 0.5, N 2048, seeds 0–3, after 5 / 10 / 20 / 100: 15.17 /
///   15.05 / 15.15 / 15.21 and 15.40 / 15.16 / 15.45 / 15.58, the seeds scattering by ±0.3;
/// - superquadrics [2, 2, 4] (φ 0.4) and [2, 2, 10] (φ 0.256), X0 = 2, N 512, seeds 0–3, after
///   5 / 10 / 20 / 40: 7.98 / 8.01 / 8.00 / 8.12 and 3.77 / 3.87 / 3.77 / 3.74;
/// - but plates of aspect 3 (X0 = 1/3, φ 0.45) 14.34 after 5 against 13.26 / 13.17 / 13.53, and
///   needles and plates of aspect 10 are far from their equation of state after 5 or 10.
///
/// Five end what the pushes did (Z over the first N collisions is 55 % high for [2, 2, 4] at
/// φ 0.4); what is left is equilibration, which scenes ask for with `equilibrate`. Measured with
/// 32–96 seeds instead of 4 (MEASUREMENTS.md, "A distance the support fallback gave up on;
/// Gilbert's start from aspect 3; how relaxed the starts are"), [2, 2, 4] at φ 0.4 is still
/// 1.3 % low after 5 and 0.45 % after 10; bodies added at φ 0.256 overshoot by 0.5–1 % for 2–4
/// and settle within 6, so fewer than 5 would leave them high.
pub const SHORT_RELAX_COLLISIONS_PER_PARTICLE: u64 = 5;

/// Collisions per particle that end a start of spheres of one size (`SPHERES`), whose pushes
/// leave fewer pairs near contact. Z over the next 2 collisions per particle, N = 10⁵, seeds
/// 0–3 (MEASUREMENTS.md, "Safe times in whole powers; the spheres' first step"):
/// - φ = 0.45 (Kolafa 9.403): 9.441, 9.424, 9.465, 9.417 after 3, where the pushes of 0.5 steps
///   and 5 collisions left 9.687, 9.662, 9.658, 9.702 and 3 of them 9.97, 9.90, 9.98, 9.92;
///   after 2, 9.51–9.56;
/// - φ = 0.3 (Carnahan–Starling 3.974): 3.993 and 3.965 after 3 (seeds 0, 1), 3.973 and 3.977
///   before;
/// - φ = 0.5: 14.17 and 14.28 after 3, 15.32 and 15.31 before; φ = 0.55: 29.4 after 3, 30.0
///   before (both far above the fluid's, as after 10).
///
/// N = 10⁶, φ = 0.45, alternated: the start 18.8 and 18.1 s against 20.6 and 19.3 before.
///
/// Spheres added at φ ≤ 0.25 are not compressed, and keep
/// [`SHORT_RELAX_COLLISIONS_PER_PARTICLE`]: the addition's structure is what is left to relax
/// there, and at φ 0.25 3 collisions left Z 0.18 % above Carnahan–Starling's where 5 left it
/// 0.02 % above (N 10⁵, four seeds, ±0.08 % each).
pub const SPHERE_RELAX_COLLISIONS_PER_PARTICLE: u64 = 3;

/// The largest ratio of the largest to the smallest semi-axis whose starts from the addition end
/// with [`SHORT_RELAX_COLLISIONS_PER_PARTICLE`].
pub const SHORT_RELAX_AXIS_RATIO: f64 = 2.0;

/// The dynamics that relaxes a packing where Monte Carlo jams: bodies (at temperature 1) in a box
/// of the given side, moved through the given number of collisions per particle.
pub type Relax<'a> = dyn FnMut(Vec<Body>, f64, u64) -> Result<Vec<Body>, EdmdError> + 'a;

/// N bodies at packing fraction `phi` (volume π/6 each) without overlaps, at temperature 1.
pub fn initial_configuration(
    n: usize,
    phi: f64,
    geom: &Geom,
    inertia: Inertia,
    rng: &mut Rng,
    relax: &mut Relax,
) -> Result<Config, EdmdError> {
    let vp = std::f64::consts::PI / 6.0;
    let volume = n as f64 * vp;
    let melted = |pos: Vec<V3>, rot: Vec<M3>, l: f64| Packing::new(pos, rot, l, *geom);
    let inertial = Inertial {
        mass: 1.0 / inertia.inv_m,
        inv_i: inertia.inv_i,
        spins_about_axis_0: !geom.revolves_about_axis_0(),
    };
    let at_temperature =
        |pos: &[V3], rot: &[M3], l: f64, rng: &mut Rng| thermal(pos, rot, l, &|_| inertial, rng);
    let l_melt = (volume / phi.min(PHI_MELT)).cbrt();
    let added = match *geom {
        Geom::Sphere { sigma } => random_sequential(n, l_melt, sigma, rng).map(|pos| {
            let start = Packing::new(pos, vec![M3::identity(); n], l_melt, *geom);
            // Added at the target itself, no push ran: what is left to relax is the addition's.
            let relax = if phi > PHI_MELT {
                SPHERE_RELAX_COLLISIONS_PER_PARTICLE
            } else {
                SHORT_RELAX_COLLISIONS_PER_PARTICLE
            };
            (start, &SPHERES, relax)
        }),
        _ => addition_densities(geom, phi).find_map(|phi_add| {
            random_sequential_bodies(n, (volume / phi_add).cbrt(), geom, rng).map(|start| {
                let (schedule, relax) = after_addition(geom, phi, phi_add);
                (start, schedule, relax)
            })
        }),
    };
    let (start, schedule, relax_per_particle) = match added {
        Some(start) => start,
        None => {
            let rot: Vec<M3> = (0..n)
                .map(|_| {
                    if geom.rotates() {
                        random_rotation(rng)
                    } else {
                        M3::identity()
                    }
                })
                .collect();
            let start = lattice(&fcc_sites(n), rot, volume, phi, &melted);
            (start, &LATTICE, RELAX_COLLISIONS_PER_PARTICLE)
        }
    };
    let packing = compress(
        start,
        volume,
        phi,
        schedule,
        &melted,
        &at_temperature,
        rng,
        relax,
    )?;
    let Packing { pos, rot, l, .. } = packing;
    Ok(Config {
        l,
        bodies: at_temperature(&pos, &rot, l, rng),
        relax: relax_per_particle,
    })
}

/// The compression and the relaxing collisions per particle of a start added at `phi_add` for
/// the target `phi`. The sweeps of [`ADDED_DILUTE`] end it only where the addition reached the
/// target or the melting density (at most [`DILUTE_PHI`] then): a fallback to a lower density
/// is compressed in many steps of pushes, whose pairs near contact 30 sweeps do not relax (at
/// φ 0.3, six steps, Z over the first collisions was 0.48 % high).
fn after_addition(geom: &Geom, phi: f64, phi_add: f64) -> (&'static Schedule, u64) {
    if geom.axis_ratio() > SHORT_RELAX_AXIS_RATIO {
        (&ADDED, RELAX_COLLISIONS_PER_PARTICLE)
    } else if phi <= DILUTE_PHI && phi_add >= phi.min(PHI_MELT) {
        (&ADDED_DILUTE, 0)
    } else {
        (&ADDED, SHORT_RELAX_COLLISIONS_PER_PARTICLE)
    }
}

/// What a body's thermal velocities depend on.
#[derive(Clone, Copy, Debug)]
pub struct Inertial {
    pub mass: f64,
    /// 0: the body's rotation is not simulated.
    pub inv_i: f64,
    /// Whether collisions change the spin about the body's axis 0 (see
    /// [`Geom::revolves_about_axis_0`]).
    pub spins_about_axis_0: bool,
}

/// Bodies placed (positions, orientations, box side) as the Monte Carlo sees them.
type PackingOf<'a> = dyn Fn(Vec<V3>, Vec<M3>, f64) -> Packing + 'a;
/// Bodies placed as the dynamics takes them, at temperature 1.
type Thermal<'a> = dyn Fn(&[V3], &[M3], f64, &mut Rng) -> Vec<Body> + 'a;

/// The densest FCC lattice, in steps of 5 % from the target box, on which the bodies
/// (`packing_of` places them) do not overlap, at the density it is melted at: the less
/// compression is left to the Monte Carlo, the better.
fn lattice(sites: &[V3], rot: Vec<M3>, volume: f64, phi: f64, packing_of: &PackingOf) -> Packing {
    let mut l = (volume / phi).cbrt();
    let mut packing = loop {
        let packing = packing_of(sites.iter().map(|s| s * l).collect(), rot.clone(), l);
        if packing.overlaps == 0 {
            break packing;
        }
        l *= 1.05;
    };
    // The lattice is melted first, at a density where the fluid is stable and moves are cheap,
    // as in Sec. 4.1: compressed without melting, an FCC lattice stays a crystal above freezing
    // (at φ = 0.5 hard spheres then give the crystal's Z ≈ 9.5, not the fluid's 13).
    let l_melt = (volume / phi.min(PHI_MELT)).cbrt();
    if packing.l < l_melt {
        packing.scale(l_melt / packing.l);
    }
    packing
}

/// Spheres of diameter `sigma` placed one after another at uniformly random points of a
/// periodic box of side `l`, each where it overlaps none placed before (random sequential
/// addition), O(N) through cells; `None` where the box has fewer than 3 cells a side, or where
/// a sphere finds no place in 10⁴ tries (the addition jams near φ = 0.38).
///
/// The box is filled block by block (blocks of about 16 σ a side, in a random order, each given
/// its share of the spheres by its volume): the spheres a try looks at are then the last few
/// thousand placed, in cache. Tries spread over the whole box took 35 s at N = 10⁶ (a cache miss
/// per sphere looked at), and sweeps in that order 170 s. The spheres are then numbered along a
/// Z-order curve, so that the few in each cell of the compression's scans lie side by side in
/// memory, not anywhere in their block: at N = 10⁶ its steps and pushes took 4.0 s instead of
/// 4.6 and 5.2 (alternated runs).
///
/// A start without a lattice's memory: sixty sweeps at φ = 0.25 left an FCC lattice of 10⁵
/// spheres with |ρ_k| = 0.019 at its first Bragg vector (1/√N = 0.003 without order), which the
/// compression carried to the target (0.014); the addition has none to begin with.
fn random_sequential(n: usize, l: f64, sigma: f64, rng: &mut Rng) -> Option<Vec<V3>> {
    const NONE: u32 = u32::MAX;
    // NaN (a degenerate box) gives 0 cells, refused with the small boxes.
    let m = (l / sigma).floor() as usize;
    if m < 3 {
        return None;
    }
    let side = l / m as f64;
    // Apart by GAP at least, so that the Monte Carlo starts without contact.
    let reach2 = (sigma * (1.0 + GAP)).powi(2);
    let cell = |x: f64| ((x / side) as usize).min(m - 1);
    let mut head = vec![NONE; m * m * m];
    let mut next = Vec::with_capacity(n);
    let mut pos: Vec<V3> = Vec::with_capacity(n);
    // Blocks per side, and the first cell of block k along an axis (k = 0..=per_side).
    let per_side = (m / 16).max(1);
    let edge = |k: usize| k * m / per_side;
    let mut blocks: Vec<usize> = (0..per_side.pow(3)).collect();
    for i in (1..blocks.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        blocks.swap(i, j);
    }
    let cells_total = (m * m * m) as f64;
    let mut cells_before = 0.0;
    for b in blocks {
        let [bx, by, bz] = [
            b % per_side,
            b / per_side % per_side,
            b / per_side / per_side,
        ];
        let lo = V3::new(edge(bx) as f64, edge(by) as f64, edge(bz) as f64) * side;
        let size = V3::new(
            (edge(bx + 1) - edge(bx)) as f64,
            (edge(by + 1) - edge(by)) as f64,
            (edge(bz + 1) - edge(bz)) as f64,
        ) * side;
        // Its share by volume, rounded so that the shares add up to n.
        let share = |cells: f64| (n as f64 * cells / cells_total).round() as usize;
        let cells = size.x * size.y * size.z / side.powi(3);
        let count = share(cells_before + cells) - share(cells_before);
        cells_before += cells;
        for _ in 0..count {
            let (p, c) = (0..10_000).find_map(|_| {
                let u = V3::new(rng.uniform(), rng.uniform(), rng.uniform());
                let p = lo + u.component_mul(&size);
                let c = [cell(p.x), cell(p.y), cell(p.z)];
                // The cells before, at and after c along each axis, wrapped without a division
                // (three a cell were 7 % of a start's instructions at N 10⁵).
                let [xs, ys, zs] =
                    c.map(|c| [c + m - 1, c, c + 1].map(|v| if v >= m { v - m } else { v }));
                let free = (0..27).all(|k| {
                    let idx = xs[k % 3] + m * (ys[k / 3 % 3] + m * zs[k / 9]);
                    let mut j = head[idx];
                    while j != NONE {
                        if min_image(pos[j as usize] - p, l).norm_squared() < reach2 {
                            return false;
                        }
                        j = next[j as usize];
                    }
                    true
                });
                free.then_some((p, c[0] + m * (c[1] + m * c[2])))
            })?;
            next.push(head[c]);
            head[c] = pos.len() as u32;
            pos.push(p);
        }
    }
    (pos.len() == n).then(|| {
        z_order(n, |i| pos[i], l)
            .into_iter()
            .map(|i| pos[i])
            .collect()
    })
}

/// Bodies of shape `geom` (any but a sphere) placed one after another at uniformly random
/// points and orientations of a periodic box of side `l`, each where it touches none placed
/// before (random sequential addition, [`Packing::add_at_random`]), then numbered along a Z-order
/// curve, so that neighbours sit near in memory for the sweeps and pushes that follow, as the
/// lattice's did. `None` where a body finds no place in [`ADD_TRIES`] tries: long or flat
/// bodies jam at lower densities than spheres.
fn random_sequential_bodies(n: usize, l: f64, geom: &Geom, rng: &mut Rng) -> Option<Packing> {
    // Places to start from, each replaced in its turn; the bodies not yet added are not looked at,
    // so their contacts are not counted (N 10⁵ superquadrics: 0.95 s).
    let pos = (0..n).map(|_| random_point(l, rng)).collect();
    let mut packing = Packing::uncounted(pos, vec![M3::identity(); n], l, *geom);
    for i in 0..n {
        (0..ADD_TRIES).find(|_| packing.add_at_random(i, rng))?;
    }
    let order = z_order(n, |i| packing.pos[i], l);
    Some(Packing::new(
        order.iter().map(|&i| packing.pos[i]).collect(),
        order.iter().map(|&i| packing.rot[i]).collect(),
        l,
        *geom,
    ))
}

/// Tries of [`random_sequential_bodies`] to place one body. Superquadrics [2, 2, 10], X0 = 2,
/// at φ 0.25 (seed 0) took 20 tries a body on average and at most 584 at N 2048, 1100 at
/// N 8192 and 1092 at N 10⁵: with 1000 the two larger additions failed and fell back to φ 0.15,
/// whose compression (7 steps of pushes) took ten times the addition's time (MEASUREMENTS.md,
/// "Dilute starts equilibrated by Monte Carlo sweeps").
const ADD_TRIES: usize = 10_000;

/// Packing fractions at which [`random_sequential_bodies`] is tried in turn, before the lattice:
/// the melting density, or 0.8 / aspect where lower, then lower again. Long and flat bodies
/// jam early: with 1000 tries a body (N 512, seed 0) the addition placed X0 = 5 up to
/// φ 0.2, X0 = 0.2 up to 0.15, X0 = 10 and 0.1 only at 0.1. A failed addition fails at its
/// last bodies, so it costs about as much as one that succeeds.
fn addition_densities(geom: &Geom, phi: f64) -> impl Iterator<Item = f64> {
    let first = phi.min(PHI_MELT).min(0.8 / geom.aspect());
    [1.0, 0.6, 0.36].into_iter().map(move |f| first * f)
}

/// A uniformly random point of the box of side `l`.
fn random_point(l: f64, rng: &mut Rng) -> V3 {
    V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * l
}

/// The compression of every initial state: `packing` melted at its density by `schedule`'s
/// sweeps, then compressed to packing fraction `phi` (bodies' total volume `volume`) by Monte
/// Carlo steps with Jodrey–Tory pushes, and the dynamics (`thermal` bodies relaxed) where they
/// jam.
#[allow(clippy::too_many_arguments)]
fn compress(
    mut packing: Packing,
    volume: f64,
    phi: f64,
    schedule: &Schedule,
    packing_of: &PackingOf,
    thermal: &Thermal,
    rng: &mut Rng,
    relax: &mut Relax,
) -> Result<Packing, EdmdError> {
    let l_target = (volume / phi).cbrt();
    let mut steps = Steps {
        dr: schedule.first_dr * packing.geom.bounding_radius(),
        // Rotations are tried only where bodies rotate.
        dth: 0.1,
    };
    packing.sweeps(schedule.melt_sweeps, &mut steps, rng);
    let mut step = schedule.first_step;
    let mut sweeps = 0;
    while packing.l > l_target {
        let before = (packing.pos.clone(), packing.rot.clone(), packing.l);
        let shrink = (l_target / packing.l).max(1.0 / (1.0 + step));
        // The last step is often smaller than `step`: pushes beyond what it took cost passes.
        let taken = 1.0 / shrink - 1.0;
        let ahead = if volume / (packing.l * shrink).powi(3) > DENSE_PUSHES_FROM {
            schedule.push_ahead_dense
        } else {
            schedule.push_ahead
        };
        packing.scale(shrink);
        packing.sweeps(schedule.relax_sweeps, &mut steps, rng);
        sweeps += schedule.relax_sweeps;
        let clear = packing.overlaps == 0
            || packing.push_apart(1.0 + ahead * taken.max(MIN_PUSH))
            || packing.rescue(&steps, rng);
        if clear {
            step = (step * 1.5).min(schedule.max_step);
        } else {
            // The pushes of earlier steps left pairs near contact that block this one, and Monte
            // Carlo opens gaps slowly in a dense fluid (of long or flat bodies above all): the
            // dynamics relaxes the last packing before the next, smaller step.
            let (pos, rot, l) = before;
            let bodies = relax(thermal(&pos, &rot, l, rng), l, UNJAM_COLLISIONS)?;
            packing = packing_of(
                bodies.iter().map(|b| b.r.map(|x| wrap(x, l))).collect(),
                bodies.iter().map(|b| b.rot).collect(),
                l,
            );
            step *= 0.5;
        }
        if step < MIN_STEP || sweeps > MAX_SWEEPS {
            return Err(EdmdError::Compression {
                reached: volume / packing.l.powi(3),
                target: phi,
            });
        }
    }
    packing.sweeps(schedule.final_sweeps, &mut steps, rng);
    Ok(packing)
}

/// A mixture of the given bodies (`shapes`, all of one kind: spheres, ellipsoids or
/// superquadrics; a body's index is its shape's and its `inertial`'s) at packing fraction
/// φ = Σ v_i / V without overlaps, at temperature 1: the compression of
/// [`initial_configuration`] (lattice of the largest body, melting, Monte Carlo steps with
/// Jodrey–Tory pushes, the dynamics where they jam) with each pair's own contact scale. The
/// bodies are placed on the lattice in the order given: shuffle them first.
pub fn initial_mixture(
    shapes: &[Geom],
    inertial: &[Inertial],
    phi: f64,
    rng: &mut Rng,
    relax: &mut Relax,
) -> Result<Config, EdmdError> {
    let n = shapes.len();
    let volume: f64 = shapes.iter().map(Geom::volume).sum();
    let rotates = shapes.first().is_some_and(Geom::rotates);
    let rot: Vec<M3> = (0..n)
        .map(|_| {
            if rotates {
                random_rotation(rng)
            } else {
                M3::identity()
            }
        })
        .collect();
    let packing_of = |pos, rot, l| Packing::of_each(pos, rot, l, shapes);
    let start = lattice(&fcc_sites(n), rot, volume, phi, &packing_of);
    let packing = compress(
        start,
        volume,
        phi,
        &LATTICE,
        &packing_of,
        &|pos, rot, l, rng| thermal(pos, rot, l, &|i| inertial[i], rng),
        rng,
        relax,
    )?;
    Ok(Config {
        l: packing.l,
        bodies: thermal(&packing.pos, &packing.rot, packing.l, &|i| inertial[i], rng),
        relax: RELAX_COLLISIONS_PER_PARTICLE,
    })
}

/// A mixture's κ² ([`Packing::kappa2`]): one per body where all are superquadrics (κ depends
/// on the exponents alone: a run of bodies of the same exponents shares it), none otherwise.
fn kappa2_of_each(shapes: &[Geom]) -> Vec<f64> {
    let mut last: Option<(V3, f64)> = None;
    let mut kappa2 = Vec::with_capacity(shapes.len());
    for g in shapes {
        let Geom::Superquadric(q) = g else {
            return Vec::new();
        };
        let k2 = match last {
            Some((e, k2)) if e == q.e => k2,
            _ => outer_factor_squared(q.e.into()),
        };
        last = Some((q.e, k2));
        kappa2.push(k2);
    }
    kappa2
}

/// The order [`sort_along_z_curve`] puts the bodies in: the index of the body that goes first,
/// second, … (for a mixture, whose sizes must follow their bodies).
pub fn z_curve_order(bodies: &[Body], l: f64) -> Vec<usize> {
    z_order(bodies.len(), |i| bodies[i].r, l)
}

/// The order of `n` points (point `i` at `at(i)`) along a Z-order curve through the box.
fn z_order(n: usize, at: impl Fn(usize) -> V3, l: f64) -> Vec<usize> {
    // 21 bits per axis: cells of side σ up to a box of 2·10⁶ σ.
    let per_side = l.floor().clamp(1.0, f64::from((1u32 << 21) - 1));
    let cell = |x: f64| ((wrap(x, l) / l * per_side) as u32).min(per_side as u32 - 1);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_cached_key(|&i| {
        let r = at(i);
        spread(cell(r.x)) | spread(cell(r.y)) << 1 | spread(cell(r.z)) << 2
    });
    order
}

/// Bodies at the given places with Maxwell–Boltzmann velocities at k_B T = 1 (body `i`'s
/// inertia `of(i)`: each velocity component of variance 1/m_i, each spin component 1/I_i), no
/// net momentum Σ m_i v_i. The translational kinetic energy is then set to the 3(N − 1)/2 of
/// the 3N − 3 degrees of freedom the zero momentum leaves, the temperature a run measures.
fn thermal(
    pos: &[V3],
    rot: &[M3],
    l: f64,
    of: &dyn Fn(usize) -> Inertial,
    rng: &mut Rng,
) -> Vec<Body> {
    let mut mass = Vec::with_capacity(pos.len());
    let mut bodies: Vec<Body> = pos
        .iter()
        .zip(rot)
        .enumerate()
        .map(|(i, (r, rot))| {
            let body = of(i);
            mass.push(body.mass);
            let v = V3::new(rng.normal(), rng.normal(), rng.normal()) / body.mass.sqrt();
            let w = if body.inv_i > 0.0 {
                // Equipartition over the axes that collisions couple to the rest: not the axis of
                // a body of revolution (a superquadric [2, 2, p > 2] is none, and left without that
                // spin it equilibrates slowly: T = 0.80 after 1.2e5 collisions at p = 4, φ 0.667).
                let s = body.inv_i.sqrt();
                let mut w =
                    rot.row(1).transpose() * rng.normal() + rot.row(2).transpose() * rng.normal();
                if body.spins_about_axis_0 {
                    w += rot.row(0).transpose() * rng.normal();
                }
                w * s
            } else {
                V3::zeros()
            };
            Body {
                r: r.map(|x| wrap(x, l)),
                v,
                rot: *rot,
                w,
                t: 0.0,
            }
        })
        .collect();
    let total: f64 = mass.iter().sum();
    let mean = bodies
        .iter()
        .zip(&mass)
        .fold(V3::zeros(), |p, (b, m)| p + b.v * *m)
        / total;
    let ke: f64 = bodies
        .iter()
        .zip(&mass)
        .map(|(b, m)| 0.5 * m * (b.v - mean).norm_squared())
        .sum();
    let scale = (1.5 * (pos.len() as f64 - 1.0) / ke).sqrt();
    for b in bodies.iter_mut() {
        b.v = (b.v - mean) * scale;
    }
    bodies
}

/// Orders bodies along a Z-order (Morton) curve through cells of side about σ, so that bodies
/// close in space are close in memory: a prediction's neighbours then share cache lines and
/// pages, which keeps τ_c from growing with N once the bodies no longer fit in cache.
pub fn sort_along_z_curve(bodies: &mut [Body], l: f64) {
    let sorted: Vec<Body> = z_curve_order(bodies, l)
        .into_iter()
        .map(|k| bodies[k])
        .collect();
    bodies.copy_from_slice(&sorted);
}

/// The low 21 bits of `x`, two zero bits after each.
fn spread(x: u32) -> u64 {
    let mut x = u64::from(x) & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The first `n` sites of an FCC lattice of ⌈(n/4)^⅓⌉³ cells in the unit cube, x fastest.
fn fcc_sites(n: usize) -> Vec<V3> {
    let nc = ((n as f64 / 4.0).cbrt().ceil() as usize).max(1);
    let basis = [
        [0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.5, 0.0, 0.5],
        [0.0, 0.5, 0.5],
    ];
    let mut sites = Vec::with_capacity(n);
    'fill: for z in 0..nc {
        for y in 0..nc {
            for x in 0..nc {
                for b in &basis {
                    if sites.len() == n {
                        break 'fill;
                    }
                    sites.push(
                        V3::new(
                            x as f64 + b[0] + 0.25,
                            y as f64 + b[1] + 0.25,
                            z as f64 + b[2] + 0.25,
                        ) / nc as f64,
                    );
                }
            }
        }
    }
    sites
}

/// A body in contact with the one a query is about, as the query found it.
#[derive(Clone, Copy, Debug)]
struct Partner {
    j: usize,
    /// The pair's contact scale, and the separation of `j` from the body it was found at.
    mu: f64,
    r: V3,
    /// Ellipsoids: the maximiser λ* of the Perram–Wertheim function, where their contact normal
    /// is ([`pw::normal_at_lab`]).
    lambda: Option<f64>,
}

/// The reach of a packing's cells: the largest at which two bodies of the shape (the largest of
/// a mixture) may touch, with the margin of [`Packing::spheres_apart`].
fn reach_of(geom: &Geom) -> f64 {
    2.0 * geom.bounding_radius() * (1.0 + GAP)
}

/// Where the bounding spheres of two bodies, scaled by 1 + GAP, meet ([`Packing::spheres_apart`]).
enum Reach {
    /// Bodies of one shape: the square of [`reach_of`] the shape.
    One { squared: f64 },
    /// A mixture: each body's bounding radius, scaled.
    Each(Vec<f64>),
}

/// What a pair's circumscribed ellipsoids tell at a scale ([`Packing::outer_ellipsoids`]).
enum Outer {
    Apart,
    /// Touching at the scale: their lab matrices, and the maximiser λ* of Perram–Wertheim's F.
    Touch {
        a: M3,
        b: M3,
        lambda: f64,
    },
    /// Not superquadrics.
    Unknown,
}

/// Bodies in a periodic box for the Monte Carlo, with what each overlaps. Positions stay wrapped
/// into the box.
struct Packing {
    pos: Vec<V3>,
    rot: Vec<M3>,
    l: f64,
    geom: Geom,
    near: Near,
    /// How many bodies each body overlaps (or touches), and the pairs in all.
    touching: Vec<u32>,
    overlaps: usize,
    /// Scratch: the bodies one body touches, at two places.
    partners: [Vec<Partner>; 2],
    /// Where two bodies' bounding spheres meet.
    reach: Reach,
    /// Per-body shapes of a mixture ([`initial_mixture`]), whose `geom` is then the one of the
    /// largest bounding sphere; `None`: every body is `geom`.
    shapes: Option<Vec<Geom>>,
    /// The diameter where every body is the same sphere: a pair test is then a distance
    /// compared ([`Packing::partners_of`]), with the generic path's decisions and scales.
    one_sphere: Option<f64>,
    /// Per body, the lab matrix A = Rᵀ diag(s²) R of its ellipsoid (a superquadric's inscribed
    /// one), kept with its orientation, so that a pair's Perram–Wertheim test is one 3×3 solve
    /// (ellipsoids and superquadrics; empty for spheres).
    lab: Vec<M3>,
    /// Every body is an ellipsoid: pairs are decided by their bounding spheres, then by
    /// Perram–Wertheim alone ([`Packing::touch`]), without the boxes of [`Geom::surely_apart`].
    ellipsoids: bool,
    /// Superquadrics' κ² ([`crate::bracket`]): the circumscribed ellipsoid's lab matrix is κ² A.
    /// One for every body, or one per body of a mixture; empty for other shapes.
    kappa2: Vec<f64>,
}

impl Packing {
    fn new(pos: Vec<V3>, rot: Vec<M3>, l: f64, geom: Geom) -> Self {
        let mut p = Packing::uncounted(pos, rot, l, geom);
        p.count_overlaps();
        p
    }

    /// [`Packing::new`] without its count of the pairs in contact (`touching` all 0), for
    /// packings whose count is taken later or never looked at.
    fn uncounted(pos: Vec<V3>, rot: Vec<M3>, l: f64, geom: Geom) -> Self {
        let n = pos.len();
        let mut p = Packing {
            near: Near::new(&pos, l, reach_of(&geom)),
            pos,
            rot,
            l,
            geom,
            touching: vec![0; n],
            overlaps: 0,
            partners: [Vec::new(), Vec::new()],
            shapes: None,
            reach: Reach::One {
                squared: reach_of(&geom).powi(2),
            },
            one_sphere: match geom {
                Geom::Sphere { sigma } => Some(sigma),
                _ => None,
            },
            lab: Vec::new(),
            ellipsoids: matches!(geom, Geom::Ellipsoid(_)),
            kappa2: match geom {
                Geom::Superquadric(q) => vec![outer_factor_squared(q.e.into())],
                _ => Vec::new(),
            },
        };
        p.lab = p.labs();
        p
    }

    /// Bodies of the given shapes (body `i` is `shapes[i]`) at `pos` in a box of side `l`.
    fn of_each(pos: Vec<V3>, rot: Vec<M3>, l: f64, shapes: &[Geom]) -> Self {
        let largest = shapes
            .iter()
            .copied()
            .max_by(|a, b| a.bounding_radius().total_cmp(&b.bounding_radius()))
            .unwrap_or(Geom::Sphere { sigma: 1.0 });
        let mut p = Packing::uncounted(pos, rot, l, largest);
        p.shapes = Some(shapes.to_vec());
        p.reach = Reach::Each(
            shapes
                .iter()
                .map(|g| g.bounding_radius() * (1.0 + GAP))
                .collect(),
        );
        p.one_sphere = None;
        p.ellipsoids = shapes.iter().all(|g| matches!(g, Geom::Ellipsoid(_)));
        p.kappa2 = kappa2_of_each(shapes);
        p.lab = p.labs();
        p.count_overlaps();
        p
    }

    #[inline]
    fn geom_of(&self, i: usize) -> &Geom {
        match &self.shapes {
            Some(shapes) => &shapes[i],
            None => &self.geom,
        }
    }

    /// Every body's lab matrix ([`Packing::lab`]), none where one is a sphere.
    fn labs(&self) -> Vec<M3> {
        (0..self.pos.len())
            .map(|i| self.lab_of(i, &self.rot[i]))
            .collect::<Option<_>>()
            .unwrap_or_default()
    }

    /// Body `i`'s lab matrix at orientation `q` ([`Packing::lab`]).
    #[inline]
    fn lab_of(&self, i: usize, q: &M3) -> Option<M3> {
        match self.geom_of(i) {
            Geom::Sphere { .. } => None,
            Geom::Ellipsoid(e) => Some(e.a_lab(q)),
            Geom::Superquadric(sq) => Some(lab_matrix(&sq.s, q)),
        }
    }

    /// Body `i`'s lab matrix at orientation `q` where it has one, else zeros (which no pair
    /// test reads).
    #[inline]
    fn lab_or_zero(&self, i: usize, q: &M3) -> M3 {
        if self.lab.is_empty() {
            M3::zeros()
        } else {
            self.lab_of(i, q).unwrap_or_else(M3::zeros)
        }
    }

    /// Body `i`'s kept lab matrix, at its present orientation (zeros where it has none).
    #[inline]
    fn kept_lab(&self, i: usize) -> M3 {
        self.lab.get(i).copied().unwrap_or_else(M3::zeros)
    }

    #[inline]
    fn kappa2_of(&self, i: usize) -> f64 {
        self.kappa2[if self.kappa2.len() == 1 { 0 } else { i }]
    }

    /// Whether the bounding spheres of `i` and `j` at separation `r`, scaled by 1 + GAP, are apart:
    /// the test that rules out most candidates of a query, inlined in its loop.
    #[inline(always)]
    fn spheres_apart(&self, i: usize, j: usize, r: &V3) -> bool {
        let squared = match &self.reach {
            Reach::One { squared } => *squared,
            Reach::Each(radii) => (radii[i] + radii[j]).powi(2),
        };
        r.norm_squared() >= squared
    }

    /// The contact scale of bodies `i` and `j` at separation `r` (both where they are).
    #[inline]
    fn pair_scale(&self, i: usize, j: usize, r: &V3) -> f64 {
        if self.ellipsoids {
            return pw::contact_scale_lab(&self.lab[i], &self.lab[j], r);
        }
        self.geom_of(i)
            .contact_scale(self.geom_of(j), &self.rot[i], &self.rot[j], r)
    }

    /// The contact scale of bodies `i` (orientation `q`, lab matrix `ai`) and `j` at separation
    /// `r`, whose bounding spheres meet, or `None` where it is proved above `k` without being
    /// computed ([`Geom::contact_scale_unless_above`], a superquadric's circumscribed
    /// ellipsoid). Out of line, so that the queries' loops keep only the bounding spheres' test
    /// ([`Packing::spheres_apart`]).
    #[inline(never)]
    fn pair_scale_unless_above(
        &self,
        i: usize,
        j: usize,
        q: &M3,
        ai: &M3,
        r: &V3,
        k: f64,
    ) -> Option<(f64, Option<f64>)> {
        if self.ellipsoids {
            return pw::contact_scale_unless_above_lab(ai, &self.lab[j], r, k)
                .map(|(mu, lambda)| (mu, Some(lambda)));
        }
        if self.surely_apart(i, j, q, r)
            || matches!(self.outer_ellipsoids(i, j, ai, r, k), Outer::Apart)
        {
            return None;
        }
        self.geom_of(i)
            .contact_scale_unless_above(self.geom_of(j), q, &self.rot[j], r, k)
            .map(|mu| (mu, None))
    }

    /// What the circumscribed ellipsoids of superquadrics `i` (lab matrix `ai`) and `j` at
    /// separation `r` tell of the pair at scale `k`: apart (μ_SQ ≥ μ_outer > k), or touching,
    /// with what gives the normal they share where they touch once scaled by μ_outer.
    #[inline]
    fn outer_ellipsoids(&self, i: usize, j: usize, ai: &M3, r: &V3, k: f64) -> Outer {
        if self.kappa2.is_empty() {
            return Outer::Unknown;
        }
        let (a, b) = (ai * self.kappa2_of(i), self.lab[j] * self.kappa2_of(j));
        match pw::contact_scale_unless_above_lab(&a, &b, r, k) {
            Some((mu, lambda)) if mu <= k => Outer::Touch { a, b, lambda },
            _ => Outer::Apart,
        }
    }

    /// Whether bodies `i` (orientation `q`, lab matrix `ai`) and `j` at separation `r` touch or
    /// overlap (contact scale ≤ 1 + GAP), as [`Packing::pair_scale_unless_above`] decides it.
    /// Ellipsoids are decided by [`pw::within_lab`]; superquadrics whose inscribed ellipsoids
    /// touch do (μ_SQ ≤ μ_inner) without their distance.
    #[inline(always)]
    fn touch(&self, i: usize, j: usize, q: &M3, ai: &M3, r: &V3) -> bool {
        !self.spheres_apart(i, j, r) && self.near_touch(i, j, q, ai, r)
    }

    /// [`Packing::touch`] of bodies whose bounding spheres meet, out of line.
    #[inline(never)]
    fn near_touch(&self, i: usize, j: usize, q: &M3, ai: &M3, r: &V3) -> bool {
        let k = 1.0 + GAP;
        if self.ellipsoids {
            return pw::within_lab(ai, &self.lab[j], r, k);
        }
        if self.surely_apart(i, j, q, r) {
            return false;
        }
        let axis = match self.outer_ellipsoids(i, j, ai, r, k) {
            Outer::Apart => return false,
            Outer::Touch { a, b, lambda } => {
                // The inscribed ellipsoids touch: so do the superquadrics.
                if pw::within_lab(ai, &self.lab[j], r, k) {
                    return true;
                }
                // The certificates start from the outer ellipsoids' normal: from the line of
                // centres, which long bodies seldom touch along, they took 5.6 iterations a
                // pair ([2, 2, 10], X0 = 2, φ 0.256), and a start 2,141 M instructions at
                // N 2048 where it takes 1,527 M.
                Some(pw::normal_at_lab(&a, &b, r, lambda))
            }
            Outer::Unknown => None,
        };
        self.geom_of(i)
            .within(self.geom_of(j), q, &self.rot[j], r, k, axis.as_ref())
    }

    /// Whether bodies `i` (orientation `q`) and `j` at separation `r` surely do not touch
    /// ([`Geom::surely_apart`]).
    #[inline]
    fn surely_apart(&self, i: usize, j: usize, q: &M3, r: &V3) -> bool {
        self.geom_of(i)
            .surely_apart(self.geom_of(j), q, &self.rot[j], r, 1.0)
    }

    fn count_overlaps(&mut self) {
        if let Some(sigma) = self.one_sphere {
            // Each pair once ([`Near::pairs`]), where the scan around every sphere saw each twice.
            let reach2 = sigma * sigma;
            let touching = &mut self.touching;
            touching.fill(0);
            self.near.pairs(&self.pos, |i, j, r| {
                if r.norm_squared() < reach2 {
                    touching[i] += 1;
                    touching[j] += 1;
                }
            });
        } else {
            // Counts need no contact scales: [`Packing::touch`] decides each pair.
            for i in 0..self.pos.len() {
                let (p, q, ai) = (self.pos[i], self.rot[i], self.kept_lab(i));
                let mut count = 0;
                self.near.around(&self.pos, &p, |j, r| {
                    if j != i && self.touch(i, j, &q, &ai, &r) {
                        count += 1;
                    }
                    true
                });
                self.touching[i] = count;
            }
        }
        self.overlaps = self.touching.iter().map(|&c| c as usize).sum::<usize>() / 2;
    }

    /// Scales the box and the positions in it by `s`.
    fn scale(&mut self, s: f64) {
        self.l *= s;
        for p in self.pos.iter_mut() {
            *p = (*p * s).map(|x| wrap(x, self.l));
        }
        self.near = Near::new(&self.pos, self.l, reach_of(&self.geom));
        self.count_overlaps();
    }

    /// The bodies that body `i`, placed at `p` with orientation `q` (lab matrix `ai`), touches
    /// or overlaps, with their contact scales.
    fn partners_of(&self, i: usize, p: &V3, q: &M3, ai: &M3, out: &mut Vec<Partner>) {
        out.clear();
        if let Some(sigma) = self.one_sphere {
            // `Geom::surely_apart`'s bound is the contact itself: spheres touch where r < σ.
            let reach2 = sigma * sigma;
            self.near.around(&self.pos, p, |j, r| {
                let d2 = r.norm_squared();
                if d2 < reach2 && j != i {
                    out.push(Partner {
                        j,
                        mu: d2.sqrt() / sigma,
                        r,
                        lambda: None,
                    });
                }
                true
            });
            return;
        }
        self.near.around(&self.pos, p, |j, r| {
            if j != i
                && !self.spheres_apart(i, j, &r)
                && let Some((mu, lambda)) = self.pair_scale_unless_above(i, j, q, ai, &r, 1.0 + GAP)
                && mu <= 1.0 + GAP
            {
                out.push(Partner { j, mu, r, lambda });
            }
            true
        });
    }

    /// Body `i` moved to a random point and orientation if it touches none of the bodies before
    /// it there ([`random_sequential_bodies`]); whether it was.
    fn add_at_random(&mut self, i: usize, rng: &mut Rng) -> bool {
        let p = random_point(self.l, rng);
        let q = random_rotation(rng);
        let ai = self.lab_or_zero(i, &q);
        let free = self.near.around(&self.pos, &p, |j, r| {
            j >= i || !self.touch(i, j, &q, &ai, &r)
        });
        if free {
            self.put(i, p, q, ai);
        }
        free
    }

    /// Body `i` moved to `p` and turned to `q`, of lab matrix `ai`.
    fn put(&mut self, i: usize, p: V3, q: M3, ai: M3) {
        self.near.moved(i, &p);
        self.pos[i] = p;
        self.rot[i] = q;
        if !self.lab.is_empty() {
            self.lab[i] = ai;
        }
    }

    /// Whether body `i` at `p` with orientation `q` (lab matrix `ai`) touches or overlaps
    /// another body.
    fn touches_any(&self, i: usize, p: &V3, q: &M3, ai: &M3) -> bool {
        if let Some(sigma) = self.one_sphere {
            let reach2 = sigma * sigma;
            return !self
                .near
                .around(&self.pos, p, |j, r| j == i || r.norm_squared() >= reach2);
        }
        !self
            .near
            .around(&self.pos, p, |j, r| j == i || !self.touch(i, j, q, ai, &r))
    }

    /// `count` sweeps ([`Packing::sweep`]), the steps adapted to each one's acceptance.
    fn sweeps(&mut self, count: usize, steps: &mut Steps, rng: &mut Rng) {
        for _ in 0..count {
            let acc = self.sweep(steps, rng);
            steps.adapt(acc, self.l);
        }
    }

    /// One Monte Carlo sweep of random displacements (and rotations) of every body in turn; a
    /// move is refused if it brings the body into contact with one it did not touch before, or
    /// deepens an overlap it had. Returns the acceptance ratio.
    fn sweep(&mut self, steps: &Steps, rng: &mut Rng) -> f64 {
        // In index order, which is the lattice's at first: neighbours then sit near in memory.
        self.sweep_over(0..self.pos.len(), steps, rng)
    }

    /// [`Packing::sweep`] of the given bodies alone, in the order given.
    fn sweep_over(
        &mut self,
        bodies: impl ExactSizeIterator<Item = usize>,
        steps: &Steps,
        rng: &mut Rng,
    ) -> f64 {
        let n = bodies.len();
        let mut accepted = 0;
        let [mut now, mut was] = std::mem::take(&mut self.partners);
        for i in bodies {
            let (p, q) = self.trial_move(i, steps, rng);
            let ai = self.lab_or_zero(i, &q);
            let ok = if self.touching[i] == 0 {
                !self.touches_any(i, &p, &q, &ai)
            } else {
                self.partners_of(i, &p, &q, &ai, &mut now);
                let was_lab = self.kept_lab(i);
                self.partners_of(i, &self.pos[i], &self.rot[i], &was_lab, &mut was);
                let ok = now
                    .iter()
                    .all(|n| was.iter().any(|w| w.j == n.j && n.mu >= w.mu));
                if ok {
                    for j in was
                        .iter()
                        .map(|w| w.j)
                        .filter(|&j| !now.iter().any(|n| n.j == j))
                    {
                        self.touching[j] -= 1;
                    }
                    self.overlaps -= was.len() - now.len();
                    self.touching[i] = now.len() as u32;
                }
                ok
            };
            if ok {
                self.put(i, p, q, ai);
                accepted += 1;
            }
        }
        self.partners = [now, was];
        accepted as f64 / n as f64
    }

    /// Pushes every pair in contact apart, both bodies by half, until its contact scale is
    /// `target`, as Jodrey and Tory's algorithm does for spheres. The contact scale is homogeneous
    /// of degree one in the separation (scaling both bodies by μ about their centres is scaling
    /// the separation by 1/μ), so a push along the line of centres is exact for every shape.
    /// Ellipsoids are pushed instead along the normal they share where they touch once scaled by μ
    /// ([`pw::contact_scale_and_normal_lab`]), by (r·n)(target/μ − 1): r·n = μ(h_A + h_B) along
    /// n (h the support functions) becomes target·(h_A + h_B), so the bodies scaled by `target`
    /// touch there, to first order in the turn of n: the least move that parts them, where the
    /// line of centres slides long bodies along each other into third ones. Measured (X0 = 2,
    /// φ 0.5, N 32,768): the step that took 50 visits per body and an unjamming needs neither,
    /// 3.3 · 10⁶ visits against 5.3 · 10⁶; needles (X0 = 10) no longer unjam at all
    /// (MEASUREMENTS.md, "Fast initial states, round 5"). A push may bring a body into contact
    /// with a third, which the next pass sees. Returns whether no contact is left before the
    /// passes stall, spread, cost an unjamming or run out ([`PushProgress`]).
    fn push_apart(&mut self, target: f64) -> bool {
        let mut pushed: Vec<usize> = (0..self.pos.len())
            .filter(|&i| self.touching[i] > 0)
            .collect();
        let [mut partners, other] = std::mem::take(&mut self.partners);
        let mut clear = false;
        let mut progress = PushProgress::new(pushed.len(), self.pos.len());
        // The bodies a pass pushes, one bit each: read out in increasing order, they are the
        // next pass's list without a sort (which was 3 % of a start of 10⁵ spheres).
        let mut moved = vec![0u64; self.pos.len().div_ceil(64)];
        while !progress.stalls(pushed.len()) {
            let looked_at = std::mem::take(&mut pushed);
            for &i in &looked_at {
                let ai = self.kept_lab(i);
                self.partners_of(i, &self.pos[i], &self.rot[i], &ai, &mut partners);
                for (nth, found) in partners.iter().enumerate() {
                    let j = found.j;
                    // What the search found holds until the first push moves i; after it, the
                    // pair is looked at anew.
                    let (mu, r, lambda) = if nth == 0 {
                        (Some(found.mu), found.r, found.lambda)
                    } else {
                        (None, min_image(self.pos[j] - self.pos[i], self.l), None)
                    };
                    let (mu, half) = if self.ellipsoids {
                        let (a, b) = (&self.lab[i], &self.lab[j]);
                        let (mu, n) = match (mu, lambda) {
                            (Some(mu), Some(lambda)) => (mu, pw::normal_at_lab(a, b, &r, lambda)),
                            _ => pw::contact_scale_and_normal_lab(a, b, &r),
                        };
                        (mu, n * (0.5 * r.dot(&n) * (target / mu - 1.0)))
                    } else {
                        let mu = mu.unwrap_or_else(|| self.pair_scale(i, j, &r));
                        (mu, r * (0.5 * (target / mu - 1.0)))
                    };
                    if mu > 1.0 + GAP {
                        continue;
                    }
                    for (k, d) in [(i, -half), (j, half)] {
                        self.pos[k] = (self.pos[k] + d).map(|x| wrap(x, self.l));
                        self.near.moved(k, &self.pos[k]);
                        moved[k / 64] |= 1 << (k % 64);
                    }
                }
            }
            for (w, word) in moved.iter_mut().enumerate() {
                while *word != 0 {
                    pushed.push(64 * w + word.trailing_zeros() as usize);
                    *word &= *word - 1;
                }
            }
            if pushed.is_empty() {
                clear = true;
                break;
            }
        }
        self.partners = [partners, other];
        if clear {
            // Every body a pass moved is looked at in the next: a pass that moves none leaves
            // no contact anywhere, and the counts need no pass of their own.
            self.touching.fill(0);
            self.overlaps = 0;
        } else {
            self.count_overlaps();
        }
        clear
    }

    /// Where pushes stalled with at most half of the bodies in contact, Monte Carlo sweeps
    /// of those bodies alone (which turn them where pushes only slide them, and never make a new
    /// contact), in rounds of [`RESCUE_SWEEPS`] until no contact is left or a round clears less
    /// than a fifth of the overlaps; those left then get one push to just past contact, without
    /// the overshoot that would cascade (it may move their neighbours too). Returns whether no
    /// contact is left. Measured (X0 = 2, φ = 0.5): at N = 4096 every step whose pushes stalled
    /// (in 6 of 20 starts) was cleared, and at N = 10⁵ the one of seed 0 (49,892 bodies in
    /// contact after [`PUSH_VISITS`]), each instead of an unjamming (5 collisions per body) and a
    /// smaller step. Half, not a quarter or all: X0 = 10 and 0.1 took 8 % more and 17 % less than
    /// with a quarter, and 20 % more with all (their overlaps are deep, and the rescue's last push
    /// cascades).
    fn rescue(&mut self, steps: &Steps, rng: &mut Rng) -> bool {
        let in_contact = |p: &Packing| -> Vec<usize> {
            (0..p.pos.len()).filter(|&i| p.touching[i] > 0).collect()
        };
        let mut stuck = in_contact(self);
        if 2 * stuck.len() > self.pos.len() {
            return false;
        }
        for _ in 0..RESCUE_ROUNDS {
            let before = self.overlaps;
            for _ in 0..RESCUE_SWEEPS {
                self.sweep_over(stuck.iter().copied(), steps, rng);
            }
            if self.overlaps == 0 {
                return true;
            }
            if 5 * self.overlaps > 4 * before {
                return self.push_apart(1.0 + MIN_PUSH);
            }
            stuck = in_contact(self);
        }
        false
    }

    /// A random displacement (and rotation) of body `i`.
    fn trial_move(&self, i: usize, steps: &Steps, rng: &mut Rng) -> (V3, M3) {
        let dr = steps.dr;
        let p = (self.pos[i] + V3::new(rng.range(-dr, dr), rng.range(-dr, dr), rng.range(-dr, dr)))
            .map(|x| wrap(x, self.l));
        let q = if self.geom.rotates() {
            let axis = V3::new(rng.normal(), rng.normal(), rng.normal());
            orthonormalize(&rotate(
                &self.rot[i],
                &axis,
                steps.dth * rng.uniform() / axis.norm().max(1e-300),
            ))
        } else {
            self.rot[i]
        };
        (p, q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equipartition at the start: every rotational degree of freedom that collisions couple gets
    /// k_B T on average (⟨ω_k²⟩ = k_B T / I), the axis of a body of revolution none.
    #[test]
    fn initial_spins_are_thermal_about_every_coupled_axis() {
        let n = 4000;
        let inertia = Inertia {
            inv_m: 1.0,
            inv_i: 2.5,
        };
        let mut rng = Rng::new(7);
        let rot: Vec<M3> = (0..n).map(|_| random_rotation(&mut rng)).collect();
        let pos = vec![V3::zeros(); n];
        let cube = Superquadric::with_unit_volume([0.5, 1.0, 1.0], [2.0, 2.0, 4.0]).unwrap();
        let spheroid = Superquadric::with_unit_volume([0.5, 1.0, 1.0], [4.0, 2.0, 2.0]).unwrap();
        let ellipsoid = Ellipsoid::new(0.6, 0.9, 0.9);
        for (geom, about_axis_0) in [
            (Geom::Superquadric(cube), true),
            (Geom::Superquadric(spheroid), false),
            (Geom::Ellipsoid(ellipsoid), false),
        ] {
            let inertial = Inertial {
                mass: 1.0 / inertia.inv_m,
                inv_i: inertia.inv_i,
                spins_about_axis_0: !geom.revolves_about_axis_0(),
            };
            let bodies = thermal(&pos, &rot, 10.0, &|_| inertial, &mut rng);
            let mean_square = |axis: usize| {
                bodies
                    .iter()
                    .map(|b| b.rot.row(axis).transpose().dot(&b.w).powi(2))
                    .sum::<f64>()
                    / n as f64
            };
            // k_B T / I = inv_i; the mean of n squared normals is within 10 % at 4000.
            for axis in 1..3 {
                assert!(
                    (mean_square(axis) / inertia.inv_i - 1.0).abs() < 0.1,
                    "{geom:?} {axis}"
                );
            }
            if about_axis_0 {
                assert!(
                    (mean_square(0) / inertia.inv_i - 1.0).abs() < 0.1,
                    "{geom:?}"
                );
            } else {
                // Zero up to the rounding of orthonormal rows.
                assert!(mean_square(0) < 1e-20, "{geom:?}");
            }
        }
    }

    /// Random sequential addition places every sphere at least σ(1 + GAP) from every other
    /// (all pairs, nearest image), inside the box, filling it evenly (each octant within 5 % of
    /// its share); a density past its jamming is refused, not returned short.
    #[test]
    fn random_sequential_addition_places_every_sphere_apart_and_evenly() {
        let mut rng = Rng::new(3);
        for (n, phi) in [(3000, 0.25), (400, 0.3)] {
            let l = (n as f64 * std::f64::consts::PI / 6.0 / phi).cbrt();
            let pos = random_sequential(n, l, 1.0, &mut rng).expect("below jamming");
            assert_eq!(pos.len(), n);
            for (i, p) in pos.iter().enumerate() {
                assert!(p.iter().all(|&x| (0.0..l).contains(&x)));
                for q in &pos[..i] {
                    assert!(min_image(q - p, l).norm() >= 1.0 + GAP, "{n}: too close");
                }
            }
            let mut octants = [0usize; 8];
            for p in &pos {
                let o = p.map(|x| usize::from(x >= 0.5 * l));
                octants[o.x + 2 * o.y + 4 * o.z] += 1;
            }
            for c in octants {
                assert!(
                    (c as f64 / (n as f64 / 8.0) - 1.0).abs()
                        < 0.05 + 3.0 / (n as f64 / 8.0).sqrt(),
                    "{octants:?}"
                );
            }
        }
        // 0.5 is past the addition's jamming (0.38).
        let l = (2000.0 * std::f64::consts::PI / 6.0 / 0.5_f64).cbrt();
        assert!(random_sequential(2000, l, 1.0, &mut rng).is_none());
    }

    /// The addition of rigid bodies leaves every pair (nearest images) farther than 1 + GAP
    /// from contact, as the Monte Carlo needs, with isotropic orientations (nematic order S of
    /// random axes), numbered along the Z-order curve; past its jamming it is refused, not
    /// returned short, and the densities tried go below that of the needles' jamming.
    #[test]
    fn random_sequential_addition_places_rigid_bodies_apart_in_random_orientations() {
        let mut rng = Rng::new(5);
        let ellipsoid = Geom::Ellipsoid(Ellipsoid::new(0.7937, 0.3969, 0.3969));
        let cube = Geom::Superquadric(
            Superquadric::with_unit_volume([1.0, 1.0, 1.0], [2.0, 2.0, 6.0]).unwrap(),
        );
        for (geom, n, phi) in [(ellipsoid, 600, 0.25), (cube, 150, 0.25)] {
            let l = (n as f64 * geom.volume() / phi).cbrt();
            let p = random_sequential_bodies(n, l, &geom, &mut rng).expect("below jamming");
            assert_eq!((p.pos.len(), p.overlaps), (n, 0));
            for i in 0..n {
                assert!(p.pos[i].iter().all(|&x| (0.0..l).contains(&x)));
                for j in 0..i {
                    let r = min_image(p.pos[j] - p.pos[i], l);
                    let mu = geom.contact_scale(&geom, &p.rot[i], &p.rot[j], &r);
                    assert!(mu > 1.0 + GAP, "{geom:?}: pair {i} {j} at {mu}");
                }
            }
            let q = p.rot.iter().fold(M3::zeros(), |q, rot| {
                let u = rot.row(0).transpose();
                q + (u * u.transpose() * 1.5 - M3::identity() * 0.5) / n as f64
            });
            let s = q.symmetric_eigenvalues().max();
            assert!(s < 4.0 / (n as f64).sqrt(), "{geom:?}: S = {s}");
            let order = z_order(n, |i| p.pos[i], l);
            assert!(
                order.iter().enumerate().all(|(k, &i)| k == i),
                "not in Z order"
            );
        }
        let needle = Geom::Ellipsoid(Ellipsoid::new(1.0772, 0.1077, 0.1077));
        let l = |phi: f64| (500.0 * needle.volume() / phi).cbrt();
        assert!(random_sequential_bodies(500, l(0.3), &needle, &mut rng).is_none());
        let first = addition_densities(&needle, 0.3).next().expect("a density");
        assert!(random_sequential_bodies(500, l(first), &needle, &mut rng).is_some());
    }

    /// A dilute start of compact bodies ends with Monte Carlo sweeps at the target and asks for
    /// no relaxing collision, and no pair is left in contact; above [`DILUTE_PHI`], and for
    /// bodies longer than [`SHORT_RELAX_AXIS_RATIO`], the collisions stay.
    #[test]
    fn dilute_starts_end_with_sweeps_not_collisions() {
        let inertia = Inertia {
            inv_m: 1.0,
            inv_i: 2.5,
        };
        let p10 = Geom::Superquadric(
            Superquadric::with_unit_volume([1.0, 1.0, 2.0], [2.0, 2.0, 10.0]).unwrap(),
        );
        let long = Geom::Ellipsoid(Ellipsoid::new(1.0, 0.125f64.sqrt(), 0.125f64.sqrt()));
        // A fallback addition is compressed by many steps of pushes: collisions relax it.
        assert_eq!(
            after_addition(&p10, 0.256, 0.6 * PHI_MELT).1,
            SHORT_RELAX_COLLISIONS_PER_PARTICLE
        );
        let mut unchanged = |bodies: Vec<Body>, _: f64, _: u64| Ok(bodies);
        for (geom, phi, relax) in [
            (p10, 0.256, 0),
            (p10, DILUTE_PHI, 0),
            (p10, 0.35, SHORT_RELAX_COLLISIONS_PER_PARTICLE),
            (long, 0.2, RELAX_COLLISIONS_PER_PARTICLE),
        ] {
            let n = 120;
            let mut rng = Rng::new(3);
            let cfg = initial_configuration(n, phi, &geom, inertia, &mut rng, &mut unchanged)
                .expect("a start");
            assert_eq!(cfg.relax, relax, "{geom:?} at {phi}");
            let reached = n as f64 * std::f64::consts::PI / 6.0 / cfg.l.powi(3);
            assert!((reached / phi - 1.0).abs() < 1e-12, "φ {reached}");
            let b = &cfg.bodies;
            for i in 0..n {
                for j in 0..i {
                    let r = min_image(b[j].r - b[i].r, cfg.l);
                    if r.norm() < 2.0 * geom.bounding_radius() {
                        let mu = geom.contact_scale(&geom, &b[i].rot, &b[j].rot, &r);
                        assert!(mu > 1.0 + GAP, "{geom:?} at {phi}: pair {i} {j} at {mu}");
                    }
                }
            }
        }
    }

    /// Pushes that end clear leave no contact anywhere (the counts they skip, recounted, are 0),
    /// from overlaps deep and many: spheres at φ = 0.25 squeezed by 10 % and 20 % at once.
    #[test]
    fn pushes_that_end_clear_leave_no_contact() {
        let mut rng = Rng::new(11);
        for squeeze in [1.1, 1.2] {
            let (n, phi) = (3000, 0.25);
            let l = (n as f64 * std::f64::consts::PI / 6.0 / phi).cbrt();
            let pos = random_sequential(n, l, 1.0, &mut rng).expect("below jamming");
            let mut packing =
                Packing::new(pos, vec![M3::identity(); n], l, Geom::Sphere { sigma: 1.0 });
            packing.scale(1.0 / squeeze);
            assert!(packing.overlaps > n / 10, "{squeeze}: {}", packing.overlaps);
            assert!(packing.push_apart(1.0 + 0.5 * (squeeze - 1.0)), "{squeeze}");
            assert_eq!(packing.overlaps, 0);
            packing.count_overlaps();
            assert_eq!(packing.overlaps, 0, "{squeeze}");
            assert!(packing.touching.iter().all(|&c| c == 0));
            for (i, p) in packing.pos.iter().enumerate() {
                for q in &packing.pos[..i] {
                    assert!(min_image(q - p, packing.l).norm() >= 1.0, "{squeeze}");
                }
            }
        }
    }

    /// Ellipsoids pushed along their contact normals: a melted packing squeezed by 4 % (more than a
    /// compression step) is cleared, every pair then apart by the full Perram–Wertheim
    /// maximisation over all pairs, not the cells' candidates (a push along a normal is exact only
    /// to first order: the passes must finish what it leaves).
    #[test]
    fn ellipsoid_pushes_along_the_normal_clear_a_squeezed_packing() {
        let mut rng = Rng::new(17);
        let e = Ellipsoid::new(0.794, 0.397, 0.397);
        let n = 400;
        let rot: Vec<M3> = (0..n).map(|_| random_rotation(&mut rng)).collect();
        let volume = n as f64 * Geom::Ellipsoid(e).volume();
        let mut packing = lattice(&fcc_sites(n), rot, volume, 0.4, &|pos, rot, l| {
            Packing::new(pos, rot, l, Geom::Ellipsoid(e))
        });
        let steps = Steps { dr: 0.1, dth: 0.1 };
        for _ in 0..20 {
            packing.sweep(&steps, &mut rng);
        }
        packing.scale(1.0 / 1.04);
        assert!(packing.overlaps > n / 20, "{}", packing.overlaps);
        assert!(packing.push_apart(1.08));
        let lab: Vec<M3> = packing.rot.iter().map(|q| e.a_lab(q)).collect();
        for i in 0..n {
            for j in 0..i {
                let r = min_image(packing.pos[j] - packing.pos[i], packing.l);
                let mu = pw::contact_scale_lab(&lab[i], &lab[j], &r);
                assert!(mu > 1.0 + GAP, "{i} and {j} at scale {mu}");
            }
        }
    }

    /// Monte Carlo of the bodies in contact clears a few deep overlaps, moving hardly any other
    /// body; with more than half of the bodies in contact it leaves the packing as it is (an
    /// unjamming is then due).
    #[test]
    fn a_rescue_clears_a_few_overlaps_where_they_are() {
        let mut rng = Rng::new(5);
        let e = Geom::Ellipsoid(Ellipsoid::new(0.794, 0.397, 0.397));
        let n = 500;
        let rot: Vec<M3> = (0..n).map(|_| random_rotation(&mut rng)).collect();
        let melted = |rng: &mut Rng| {
            let mut p = lattice(
                &fcc_sites(n),
                rot.clone(),
                n as f64 * e.volume(),
                0.35,
                &|pos, rot, l| Packing::new(pos, rot, l, e),
            );
            let steps = Steps { dr: 0.1, dth: 0.1 };
            for _ in 0..20 {
                p.sweep(&steps, rng);
            }
            assert_eq!(p.overlaps, 0);
            p
        };
        let steps = Steps { dr: 0.05, dth: 0.1 };
        // Three bodies moved halfway onto a neighbour: deep overlaps among a handful of bodies.
        let mut packing = melted(&mut rng);
        for i in [7, 123, 301] {
            let j = (0..n)
                .filter(|&j| j != i)
                .min_by(|&a, &b| {
                    let d = |k: usize| min_image(packing.pos[k] - packing.pos[i], packing.l).norm();
                    d(a).total_cmp(&d(b))
                })
                .expect("neighbours");
            let to = packing.pos[i] + min_image(packing.pos[j] - packing.pos[i], packing.l) * 0.5;
            packing.pos[i] = to.map(|x| wrap(x, packing.l));
            packing.near.moved(i, &packing.pos[i]);
        }
        packing.count_overlaps();
        assert!(packing.overlaps >= 3, "{}", packing.overlaps);
        let (was, in_contact): (Vec<V3>, Vec<bool>) = (
            packing.pos.clone(),
            packing.touching.iter().map(|&c| c > 0).collect(),
        );
        assert!(packing.rescue(&steps, &mut rng));
        packing.count_overlaps();
        assert_eq!(packing.overlaps, 0);
        // The bodies in contact, and the few a last push reached (1 here): nothing far away.
        let stuck = in_contact.iter().filter(|&&c| c).count();
        let strays = (0..n)
            .filter(|&i| !in_contact[i] && packing.pos[i] != was[i])
            .count();
        assert!(strays <= stuck / 2, "{strays} moved of {} apart", n - stuck);
        // Squeezed by 15 %: most bodies in contact.
        let mut packing = melted(&mut rng);
        packing.scale(1.0 / 1.15);
        assert!(2 * packing.touching.iter().filter(|&&c| c > 0).count() > n);
        let was = packing.pos.clone();
        assert!(!packing.rescue(&steps, &mut rng));
        assert_eq!(packing.pos, was);
    }

    /// Pushes go on while the count of bodies pushed per pass falls, however slowly (the tail
    /// of a dense step: 100–250 passes), and stop where it stays flat for [`PUSH_STALL`] passes,
    /// spreads (needles, whose pushes slide them into others) or has visited [`PUSH_VISITS`]
    /// bodies per body; the counts are those logged from ellipsoids X0 = 2 at φ 0.49 and X0 = 10
    /// at φ 0.13.
    #[test]
    fn pushes_stop_where_they_stall_or_spread_not_where_they_settle_slowly() {
        let passes = |counts: &[usize], n: usize| {
            let mut p = PushProgress::new(counts[0], n);
            counts.iter().position(|&c| p.stalls(c))
        };
        // Falls by 1.5 % a pass with noise of ±5 %, 250 passes.
        let slow: Vec<usize> = (0..250)
            .map(|k| (2000.0 * 0.985_f64.powi(k) * (1.0 + 0.05 * (k as f64).sin())) as usize)
            .collect();
        assert_eq!(passes(&slow, 4096), None);
        // The same from 10⁴ of 4096 bodies visits 160 per body: it gives up at the pass that
        // takes it past PUSH_VISITS.
        let costly: Vec<usize> = slow.iter().map(|c| c * 5).collect();
        let past_visits = costly
            .iter()
            .scan(0, |visits, &c| {
                *visits += c;
                Some(*visits)
            })
            .position(|visits| visits > PUSH_VISITS * 4096);
        assert!(past_visits.is_some());
        assert_eq!(passes(&costly, 4096), past_visits);
        // Down to a handful that jostle for 40 passes before they clear.
        let tail: Vec<usize> = [
            9866, 6372, 4628, 3560, 2748, 2126, 1654, 1316, 964, 800, 618,
        ]
        .into_iter()
        .chain((0..40).map(|k| [14, 16, 20, 24, 32, 22, 18][k % 7]))
        .collect();
        assert_eq!(passes(&tail, 4096), None);
        let flat: Vec<usize> = (0..200).map(|k| 500 + k % 7).collect();
        assert_eq!(passes(&flat, 4096), Some(PUSH_STALL + 1));
        let needles = [304, 174, 200, 202, 192, 246, 280, 358, 378, 434, 448];
        assert_eq!(passes(&needles, 512), Some(8));
    }

    /// The Monte Carlo's pair decisions (bounding spheres and Perram–Wertheim's bounds for
    /// ellipsoids, the bracketing ellipsoids for superquadrics) are those of the contact scale
    /// itself: every body's count of bodies it touches, and each trial place's verdict, agree with
    /// all pairs tested by [`Geom::contact_scale`] (an oracle without any shortcut), for
    /// ellipsoids, superquadrics and a mixture of superquadrics, random places and orientations
    /// dense enough that most bodies touch one.
    #[test]
    fn shortcut_pair_decisions_are_the_contact_scales() {
        let mut rng = Rng::new(5);
        let e = Ellipsoid::new(0.794, 0.397, 0.397);
        let q = Superquadric::with_unit_volume([2.0, 1.0, 1.0], [2.0, 2.0, 4.0]).unwrap();
        let flat = Superquadric::with_unit_volume([0.5, 1.0, 1.0], [3.0, 2.5, 6.0]).unwrap();
        let n = 300;
        let mixture: Vec<Geom> = (0..n)
            .map(|i| Geom::Superquadric(if i % 3 == 0 { flat } else { q }))
            .collect();
        for shapes in [
            vec![Geom::Ellipsoid(e); n],
            vec![Geom::Superquadric(q); n],
            mixture,
        ] {
            let l = (n as f64 * std::f64::consts::PI / 6.0 / 0.3).cbrt();
            let pos: Vec<V3> = (0..n)
                .map(|_| V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * l)
                .collect();
            let rot: Vec<M3> = (0..n).map(|_| random_rotation(&mut rng)).collect();
            let packing = Packing::of_each(pos, rot, l, &shapes);
            let oracle = |p: &Packing, i: usize, at: &V3, q: &M3, j: usize| {
                shapes[i].contact_scale(&shapes[j], q, &p.rot[j], &min_image(p.pos[j] - at, l))
                    <= 1.0 + GAP
            };
            let mut touching = 0;
            for (i, shape) in shapes.iter().enumerate() {
                let count = (0..n)
                    .filter(|&j| j != i && oracle(&packing, i, &packing.pos[i], &packing.rot[i], j))
                    .count();
                assert_eq!(packing.touching[i] as usize, count, "{shape:?} body {i}");
                touching += usize::from(count > 0);
            }
            assert!(touching > n / 3, "{touching}");
            for _ in 0..200 {
                let i = (rng.next_u64() % n as u64) as usize;
                let at = V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * l;
                let q = random_rotation(&mut rng);
                let ai = packing.lab_or_zero(i, &q);
                let any = (0..n).any(|j| j != i && oracle(&packing, i, &at, &q, j));
                assert_eq!(packing.touches_any(i, &at, &q, &ai), any);
            }
        }
    }

    #[test]
    fn the_z_curve_interleaves_the_bits_of_the_three_cells() {
        let mut oracle = 0u64;
        let (x, y, z) = (0b1011u32, 0b0110u32, (1 << 20) | 1);
        for bit in 0..21 {
            oracle |= u64::from(x >> bit & 1) << (3 * bit);
            oracle |= u64::from(y >> bit & 1) << (3 * bit + 1);
            oracle |= u64::from(z >> bit & 1) << (3 * bit + 2);
        }
        assert_eq!(spread(x) | spread(y) << 1 | spread(z) << 2, oracle);
    }
}
