//! The body models the event loop is generic over: what one particle kind costs to simulate,
//! from its shape to its collision rule and the contact-time search of one pair.

use crate::ball::{Ball, SizedBall};
use crate::body::{Moving, SphereBody};
use crate::contact::{
    ContactParams, Known, QuickBound, enclosing_bound, predict_from, quick_bound,
};
use crate::distance::{SolverStats, elongated};
use crate::ellipsoid::Ellipsoid;
use crate::first_step::EllipsoidLanes;
use crate::geometry::{Surface, V3};
use crate::lists::Region;
use crate::nnl::Obp;
use crate::report::{PairReport, SpeciesReport};
use crate::rigid::{Body, Inertia, collide};
use crate::sphere::{self, Trajectory};

/// What one particle kind costs to simulate: the analytic sphere, or the general rigid body.
pub(crate) trait Model {
    /// Stored with a predicted collision (contact point and normal for rigid bodies).
    type Extra: Copy + Default;
    /// How a body is stored: a rigid body, or a sphere's position, velocity and time alone
    /// (one cache line, and a third of the memory: nothing of it is read for nothing).
    type Body: Moving;
    /// The region a body's neighbour list is built for.
    type Region: Region<Body = Self::Body>;
    /// The shape every body has.
    type Shape: Surface + Copy;
    /// Whether predictions read other bodies' event times
    /// ([`crate::calendar::Calendar::time_of`]), which the calendar then keeps in an array of
    /// their own ([`crate::calendar::Calendar::keep_times`]).
    const READS_EVENT_TIMES: bool = false;
    /// The largest body's bounding radius: what linked cells are sized for.
    fn bounding_radius(&self) -> f64;
    /// Body `i`'s own shape, which its neighbour-list region is built around (one shape for
    /// every body unless they differ).
    fn surface_of(&self, i: usize) -> Self::Shape;
    /// Applies the collision of `a` with the image of `b` displaced by `offset`; returns the
    /// impulse given to `b`, or `None` if the bodies separate. `pair` holds their indices, which
    /// only a model with per-body sizes reads.
    fn collide(
        &mut self,
        pair: [usize; 2],
        a: &mut Self::Body,
        b: &mut Self::Body,
        offset: &V3,
        x: &Self::Extra,
    ) -> Option<V3>;
    /// The translational kinetic energy of bodies `a` and `b` (indices in `pair`): unit masses
    /// unless the model has its own.
    #[inline(always)]
    fn pair_kinetic(&self, _pair: [usize; 2], a: &Self::Body, b: &Self::Body) -> f64 {
        0.5 * (a.v().norm_squared() + b.v().norm_squared())
    }
    /// The translational kinetic energy of body `i`.
    #[inline(always)]
    fn kinetic(&self, _i: usize, b: &Self::Body) -> f64 {
        0.5 * b.v().norm_squared()
    }
    /// The momentum of body `i`.
    #[inline(always)]
    fn momentum(&self, _i: usize, b: &Self::Body) -> V3 {
        b.v()
    }
    /// The rotational kinetic energy of body `i`: none where rotation is not simulated.
    fn spin_kinetic(&self, _i: usize, _b: &Self::Body) -> f64 {
        0.0
    }
    /// Starts the model's own sums afresh (a mixture's per-pair counts), with the measured run.
    fn reset_sums(&mut self) {}
    fn stats(&self) -> SolverStats;
    /// Puts back the counters of a restored run.
    fn set_stats(&mut self, stats: SolverStats);
}

/// Hard spheres: quadratic contact time, no rotation, normal along the line of centres.
pub(crate) struct SphereModel {
    sigma: f64,
    /// Scratch: a neighbour list's trajectories with their images applied, contiguous for
    /// [`crate::sphere::first_contact`], each from one [`SphereBody`].
    pub(crate) gathered: Vec<Trajectory>,
}

impl SphereModel {
    pub(crate) fn new(sigma: f64) -> Self {
        SphereModel {
            sigma,
            gathered: Vec::new(),
        }
    }
}

impl Model for SphereModel {
    type Extra = ();
    type Body = SphereBody;
    type Region = Ball;
    type Shape = Ellipsoid;
    fn bounding_radius(&self) -> f64 {
        0.5 * self.sigma
    }
    fn surface_of(&self, _: usize) -> Ellipsoid {
        let r = 0.5 * self.sigma;
        Ellipsoid::new(r, r, r)
    }
    fn collide(
        &mut self,
        _: [usize; 2],
        a: &mut SphereBody,
        b: &mut SphereBody,
        offset: &V3,
        _: &(),
    ) -> Option<V3> {
        let n = ((b.r + offset) - a.r).normalize();
        let un = (a.v - b.v).dot(&n);
        if un <= 0.0 {
            return None;
        }
        // Equal unit masses: Eq. (41) reduces to Δp = u·n.
        a.v -= n * un;
        b.v += n * un;
        Some(n * un)
    }
    fn stats(&self) -> SolverStats {
        SolverStats::default()
    }
    fn set_stats(&mut self, _: SolverStats) {}
}

/// The sums a mixture keeps per species and pair of species: each body's species, and per
/// unordered pair of species the collisions and the collision virial Σ r·Δp (Z per pair).
pub(crate) struct SpeciesSums {
    /// Per body, in the engine's order.
    species: Vec<u16>,
    /// Per body: the diameter of the sphere of equal volume.
    diameter: Vec<f64>,
    kinds: usize,
    /// Per unordered pair of species, index [`pair_index`](Self::pair_index).
    collisions: Vec<u64>,
    virial: Vec<f64>,
    /// Distance evaluations of the pairs' contact searches (rigid bodies only).
    distance_calls: Option<Vec<u64>>,
}

impl SpeciesSums {
    pub(crate) fn new(species: Vec<u16>, diameter: Vec<f64>, kinds: usize) -> Self {
        let pairs = kinds * (kinds + 1) / 2;
        SpeciesSums {
            species,
            diameter,
            kinds,
            collisions: vec![0; pairs],
            virial: vec![0.0; pairs],
            distance_calls: None,
        }
    }

    /// Also counts the distance evaluations of each pair's contact searches.
    pub(crate) fn counting_distance_calls(mut self) -> Self {
        self.distance_calls = Some(vec![0; self.collisions.len()]);
        self
    }

    /// `calls` distance evaluations in a contact search of bodies `i` and `j`.
    #[inline]
    fn searched(&mut self, [i, j]: [usize; 2], calls: u64) {
        let k = self.pair_index(self.species[i], self.species[j]);
        if let Some(c) = &mut self.distance_calls {
            c[k] += calls;
        }
    }

    /// The index of the unordered pair of species (a, b) among the S(S+1)/2 pairs, row by row:
    /// (0,0), (0,1), …, (0,S−1), (1,1), …
    fn pair_index(&self, a: u16, b: u16) -> usize {
        let (a, b) = (a.min(b) as usize, a.max(b) as usize);
        a * self.kinds - a * a.saturating_sub(1) / 2 + (b - a)
    }

    /// A collision of bodies `i` and `j` at separation `r` (from i to j) with impulse `dp` on j.
    #[inline]
    fn record(&mut self, [i, j]: [usize; 2], r: &V3, dp: &V3) {
        let k = self.pair_index(self.species[i], self.species[j]);
        self.collisions[k] += 1;
        self.virial[k] += r.dot(dp);
    }

    fn reset(&mut self) {
        self.collisions.fill(0);
        self.virial.fill(0.0);
        if let Some(c) = &mut self.distance_calls {
            c.fill(0);
        }
    }

    /// Bodies and mean diameter per species, and per pair of species its collisions and its
    /// part of Z (`three_nkt`: ∫ 3 N k_B T dt of the measured run, [`crate::run()`]'s
    /// `three_nkt_integral`).
    pub(crate) fn report(&self, three_nkt: f64) -> SpeciesReport {
        let mut count = vec![0usize; self.kinds];
        let mut sum = vec![0.0; self.kinds];
        for (&k, d) in self.species.iter().zip(&self.diameter) {
            count[k as usize] += 1;
            sum[k as usize] += d;
        }
        let total: u64 = self.collisions.iter().sum();
        let mut pairs = Vec::new();
        for a in 0..self.kinds as u16 {
            for b in a..self.kinds as u16 {
                let k = self.pair_index(a, b);
                pairs.push(PairReport {
                    species: [a as usize + 1, b as usize + 1],
                    collisions: self.collisions[k],
                    collision_fraction: self.collisions[k] as f64 / total.max(1) as f64,
                    pressure_z_part: self.virial[k] / three_nkt,
                    distance_calls: self.distance_calls.as_ref().map(|c| c[k]),
                });
            }
        }
        SpeciesReport {
            mean_diameter: sum
                .iter()
                .zip(&count)
                .map(|(d, &c)| d / c.max(1) as f64)
                .collect(),
            count,
            pairs,
        }
    }
}

/// Hard spheres of several sizes: a binary (or any) mixture, or size-polydisperse spheres. Each
/// body has its own radius and mass (m ∝ σ³); contact at (σ_i + σ_j)/2, the collision rule of
/// Eq. (41) with m_i ≠ m_j. A model of its own, so that [`SphereModel`], one σ for every pair, is
/// compiled without any per-body size: the engine is monomorphised on the model, and the sphere
/// path asks [`MIXED`](crate::engine::Spheres::MIXED), a constant, whether to read sizes at all.
/// A scene with one species of one size runs [`SphereModel`] and never looks a species up.
/// Per-pair costs: one radius read per candidate (with lists, from the spare word of the gathered
/// [`Trajectory`]), masses in the collision; lists are built of [`SizedBall`]s, so that a small
/// sphere's list holds only the spheres it can meet before a rebuild, while the cells of the
/// list grid and of linked cells are sized for the largest pair.
pub(crate) struct MixedSphereModel {
    /// Per body, in the engine's order.
    pub(crate) radius: Vec<f64>,
    mass: Vec<f64>,
    /// The largest radius: cells are sized for the largest pair.
    r_max: f64,
    pub(crate) sums: SpeciesSums,
    /// As in [`SphereModel`], with each neighbour's radius in [`Trajectory::radius`].
    pub(crate) gathered: Vec<Trajectory>,
}

impl MixedSphereModel {
    /// Bodies of the given diameters (masses σ³, the first species' diameter 1 being the unit),
    /// of the species in `sums`.
    pub(crate) fn new(diameter: &[f64], sums: SpeciesSums) -> Self {
        let radius: Vec<f64> = diameter.iter().map(|d| 0.5 * d).collect();
        let r_max = radius.iter().fold(0.0, |m: f64, &r| m.max(r));
        MixedSphereModel {
            mass: diameter.iter().map(|d| d * d * d).collect(),
            radius,
            r_max,
            sums,
            gathered: Vec::new(),
        }
    }
}

impl Model for MixedSphereModel {
    type Extra = ();
    type Body = SphereBody;
    type Region = SizedBall;
    type Shape = Ellipsoid;
    fn bounding_radius(&self) -> f64 {
        self.r_max
    }
    fn surface_of(&self, i: usize) -> Ellipsoid {
        let r = self.radius[i];
        Ellipsoid::new(r, r, r)
    }
    fn collide(
        &mut self,
        [i, j]: [usize; 2],
        a: &mut SphereBody,
        b: &mut SphereBody,
        offset: &V3,
        _: &(),
    ) -> Option<V3> {
        let r = (b.r + offset) - a.r;
        let n = r.normalize();
        let un = (a.v - b.v).dot(&n);
        if un <= 0.0 {
            return None;
        }
        // Eq. (41) without rotation: Δp = 2 μ u_n n, μ = m_i m_j / (m_i + m_j), given to j and
        // taken from i; each velocity changes by Δp over its own mass.
        let (ma, mb) = (self.mass[i], self.mass[j]);
        let dp = n * (2.0 * ma * mb / (ma + mb) * un);
        a.v -= dp / ma;
        b.v += dp / mb;
        self.sums.record([i, j], &r, &dp);
        Some(dp)
    }
    #[inline(always)]
    fn pair_kinetic(&self, [i, j]: [usize; 2], a: &SphereBody, b: &SphereBody) -> f64 {
        0.5 * (self.mass[i] * a.v.norm_squared() + self.mass[j] * b.v.norm_squared())
    }
    #[inline(always)]
    fn kinetic(&self, i: usize, b: &SphereBody) -> f64 {
        0.5 * self.mass[i] * b.v.norm_squared()
    }
    #[inline(always)]
    fn momentum(&self, i: usize, b: &SphereBody) -> V3 {
        b.v * self.mass[i]
    }
    fn reset_sums(&mut self) {
        self.sums.reset();
    }
    fn stats(&self) -> SolverStats {
        SolverStats::default()
    }
    fn set_stats(&mut self, _: SolverStats) {}
}

/// What the engine's search for a rigid body's first collision asks of a rigid model, for a
/// pair of bodies by index: one shape for every body ([`RigidModel`]) or one per body
/// ([`MixedRigidModel`]).
pub(crate) trait Rigid: Model<Extra = (V3, V3), Region = Obp, Body = Body> {
    /// The radius of body `i`'s bounding sphere.
    fn bounding_radius_of(&self, i: usize) -> f64;
    /// The first contact of bodies `pair` = [i, j] (`a`, `b`, at the present time) before
    /// `horizon`, from what the caller knows of them as they are now.
    fn predict(
        &mut self,
        pair: [usize; 2],
        a: &Body,
        b: &Body,
        horizon: f64,
        known: Option<Known>,
    ) -> Option<(f64, (V3, V3))>;
    /// Without any solver, a lower bound on the contact time of two bodies whose bounding spheres
    /// overlap, and an estimate of it to order the searches by; a bound at or beyond `horizon`
    /// (a time after the present) need not be tight. `first`: the bound of the ascent's first
    /// step, where the caller has it ([`crate::contact::quick_bound`]).
    fn quick_bound(
        &self,
        pair: [usize; 2],
        a: &Body,
        b: &Body,
        horizon: f64,
        start: Option<&V3>,
        first: Option<f64>,
    ) -> QuickBound;
    /// [`crate::contact::enclosing_bound`] of bodies `pair` = [i, j] (`a`, `b`, at the present
    /// time) along the unit axis `n` from A to B.
    fn enclosing_bound(&self, pair: [usize; 2], a: &Body, b: &Body, n: &V3) -> f64;
    fn solver_stats(&self) -> &SolverStats;
    /// The shape of every body where [`crate::first_step::first_steps`] bounds four candidates at
    /// once (one ellipsoid shape, not elongated); `None` otherwise.
    fn lanes(&self) -> Option<EllipsoidLanes> {
        None
    }
}

/// The rotational kinetic energy ½ I w² of a body of the given inertia.
fn spin_energy(inertia: &Inertia, b: &Body) -> f64 {
    if inertia.inv_i > 0.0 {
        0.5 * b.w.norm_squared() / inertia.inv_i
    } else {
        0.0
    }
}

/// [`collide`] of `a` with the image of `b` displaced by `offset`, at the contact point and
/// normal `x`; `b`'s velocities change as its image's do.
fn collide_with_image(
    a: &mut Body,
    b: &mut Body,
    offset: &V3,
    x: &(V3, V3),
    ia: Inertia,
    ib: Inertia,
) -> Option<V3> {
    let mut image = *b;
    image.r += offset;
    let impulse = collide(a, &mut image, &x.0, &x.1, ia, ib);
    b.v = image.v;
    b.w = image.w;
    impulse
}

/// The first contact of `a` (shape `sa`) and `b` (`sb`) before `horizon`.
#[allow(clippy::too_many_arguments)]
fn predict_pair<S: Surface>(
    sa: &S,
    a: &Body,
    sb: &S,
    b: &Body,
    horizon: f64,
    known: Option<Known>,
    params: &ContactParams,
    stats: &mut SolverStats,
) -> Option<(f64, (V3, V3))> {
    predict_from(sa, a, sb, b, horizon, known, params, stats).map(|h| (h.t, (h.xc, h.n)))
}

/// Hard rigid bodies of any [`Surface`] through the general algorithm of Sec. 2: ellipsoids (any
/// X0, including 1) and superquadrics, each monomorphised on its own shape.
pub(crate) struct RigidModel<S> {
    e: S,
    lanes: Option<EllipsoidLanes>,
    params: ContactParams,
    inertia: Inertia,
    pub(crate) stats: SolverStats,
}

impl<S: Surface + Copy> Model for RigidModel<S> {
    type Extra = (V3, V3);
    type Body = Body;
    type Region = Obp;
    type Shape = S;
    const READS_EVENT_TIMES: bool = true;
    fn bounding_radius(&self) -> f64 {
        self.e.bounding_radius()
    }
    #[inline(always)]
    fn surface_of(&self, _: usize) -> S {
        self.e
    }
    fn collide(
        &mut self,
        _: [usize; 2],
        a: &mut Body,
        b: &mut Body,
        offset: &V3,
        x: &(V3, V3),
    ) -> Option<V3> {
        collide_with_image(a, b, offset, x, self.inertia, self.inertia)
    }
    fn spin_kinetic(&self, _: usize, b: &Body) -> f64 {
        spin_energy(&self.inertia, b)
    }
    fn stats(&self) -> SolverStats {
        self.stats
    }
    fn set_stats(&mut self, stats: SolverStats) {
        self.stats = stats;
    }
}

impl<S: Surface + Copy> RigidModel<S> {
    pub(crate) fn new(e: S, params: ContactParams, inertia: Inertia) -> Self {
        let lanes = e
            .ellipsoid_semi_axes()
            .filter(|_| !elongated(&e))
            .and_then(EllipsoidLanes::of);
        RigidModel {
            e,
            lanes,
            params,
            inertia,
            stats: SolverStats::default(),
        }
    }
}

impl<S: Surface + Copy> Rigid for RigidModel<S> {
    #[inline(always)]
    fn bounding_radius_of(&self, _: usize) -> f64 {
        self.e.bounding_radius()
    }
    fn predict(
        &mut self,
        _: [usize; 2],
        a: &Body,
        b: &Body,
        horizon: f64,
        known: Option<Known>,
    ) -> Option<(f64, (V3, V3))> {
        predict_pair(
            &self.e,
            a,
            &self.e,
            b,
            horizon,
            known,
            &self.params,
            &mut self.stats,
        )
    }
    fn quick_bound(
        &self,
        _: [usize; 2],
        a: &Body,
        b: &Body,
        horizon: f64,
        start: Option<&V3>,
        first: Option<f64>,
    ) -> QuickBound {
        quick_bound(&self.e, a, &self.e, b, horizon, start, first)
    }
    fn enclosing_bound(&self, _: [usize; 2], a: &Body, b: &Body, n: &V3) -> f64 {
        enclosing_bound(&self.e, a, &self.e, b, n)
    }
    fn solver_stats(&self) -> &SolverStats {
        &self.stats
    }
    fn lanes(&self) -> Option<EllipsoidLanes> {
        self.lanes
    }
}

/// Rigid bodies of several shapes and sizes: mixtures of ellipsoids (spheres among them as
/// ellipsoids of X0 = 1) or of superquadrics, and size-polydisperse ones. Each body has its own
/// shape, mass (∝ volume) and moment of inertia; contact searches take the pair's two shapes
/// (Sec. 2 never assumes them equal), the collision rule of Eq. (41) the pair's two inertias;
/// two spheres meet at the root of the sphere path's quadratic, without a solver.
/// A model of its own, as [`MixedSphereModel`] is, so that [`RigidModel`], one shape for every
/// pair, never looks a body's shape up. Cells (and the list grid) are sized for the largest
/// bounding sphere; each body's parallelepiped is built around its own shape, and the bounding
/// spheres that order the candidates are the pair's own.
pub(crate) struct MixedRigidModel<S> {
    /// Per body, in the engine's order.
    shapes: Vec<S>,
    /// Per body: whether it is a sphere. Two spheres meet at the root of a quadratic, as on the
    /// sphere path: a sphere among rigid bodies pays the general search only against them.
    round: Vec<bool>,
    inertia: Vec<Inertia>,
    r_max: f64,
    params: ContactParams,
    pub(crate) sums: SpeciesSums,
    pub(crate) stats: SolverStats,
}

impl<S: Surface + Copy> MixedRigidModel<S> {
    /// Bodies of the given shapes (`round`: which are spheres) and inertias, of the given
    /// species.
    pub(crate) fn new(
        shapes: Vec<S>,
        round: Vec<bool>,
        inertia: Vec<Inertia>,
        sums: SpeciesSums,
        params: ContactParams,
    ) -> Self {
        let r_max = shapes
            .iter()
            .fold(0.0, |m: f64, s| m.max(s.bounding_radius()));
        MixedRigidModel {
            shapes,
            round,
            inertia,
            r_max,
            params,
            sums,
            stats: SolverStats::default(),
        }
    }

    /// Body `i`'s shape.
    pub(crate) fn shape(&self, i: usize) -> &S {
        &self.shapes[i]
    }

    /// When spheres `i` (`a`) and `j` (`b`) meet, after the bodies' time; +∞ if never.
    fn sphere_contact(&self, [i, j]: [usize; 2], a: &Body, b: &Body) -> f64 {
        let sigma = self.shapes[i].bounding_radius() + self.shapes[j].bounding_radius();
        sphere::contact_time_or_inf(&(b.r - a.r), &(b.v - a.v), sigma * sigma)
    }
}

impl<S: Surface + Copy> Model for MixedRigidModel<S> {
    type Extra = (V3, V3);
    type Body = Body;
    type Region = Obp;
    type Shape = S;
    const READS_EVENT_TIMES: bool = true;
    fn bounding_radius(&self) -> f64 {
        self.r_max
    }
    #[inline(always)]
    fn surface_of(&self, i: usize) -> S {
        self.shapes[i]
    }
    fn collide(
        &mut self,
        [i, j]: [usize; 2],
        a: &mut Body,
        b: &mut Body,
        offset: &V3,
        x: &(V3, V3),
    ) -> Option<V3> {
        let impulse = collide_with_image(a, b, offset, x, self.inertia[i], self.inertia[j]);
        if let Some(dp) = &impulse {
            self.sums.record([i, j], &(b.r + offset - a.r), dp);
        }
        impulse
    }
    #[inline(always)]
    fn pair_kinetic(&self, [i, j]: [usize; 2], a: &Body, b: &Body) -> f64 {
        self.kinetic(i, a) + self.kinetic(j, b)
    }
    #[inline(always)]
    fn kinetic(&self, i: usize, b: &Body) -> f64 {
        0.5 * b.v.norm_squared() / self.inertia[i].inv_m
    }
    #[inline(always)]
    fn momentum(&self, i: usize, b: &Body) -> V3 {
        b.v / self.inertia[i].inv_m
    }
    fn spin_kinetic(&self, i: usize, b: &Body) -> f64 {
        spin_energy(&self.inertia[i], b)
    }
    fn reset_sums(&mut self) {
        self.sums.reset();
    }
    fn stats(&self) -> SolverStats {
        self.stats
    }
    fn set_stats(&mut self, stats: SolverStats) {
        self.stats = stats;
    }
}

impl<S: Surface + Copy> Rigid for MixedRigidModel<S> {
    #[inline(always)]
    fn bounding_radius_of(&self, i: usize) -> f64 {
        self.shapes[i].bounding_radius()
    }
    fn predict(
        &mut self,
        [i, j]: [usize; 2],
        a: &Body,
        b: &Body,
        horizon: f64,
        known: Option<Known>,
    ) -> Option<(f64, (V3, V3))> {
        if self.round[i] && self.round[j] {
            self.stats.searches += 1;
            let tau = self.sphere_contact([i, j], a, b);
            let ra = self.shapes[i].bounding_radius();
            let n = ((b.r + b.v * tau) - (a.r + a.v * tau)).normalize();
            return (tau < horizon).then(|| (tau, (a.r + a.v * tau + n * ra, n)));
        }
        let (sa, sb) = (&self.shapes[i], &self.shapes[j]);
        let calls = self.stats.distance_calls;
        let hit = predict_pair(sa, a, sb, b, horizon, known, &self.params, &mut self.stats);
        self.sums
            .searched([i, j], self.stats.distance_calls - calls);
        hit
    }
    fn quick_bound(
        &self,
        [i, j]: [usize; 2],
        a: &Body,
        b: &Body,
        horizon: f64,
        start: Option<&V3>,
        first: Option<f64>,
    ) -> QuickBound {
        if self.round[i] && self.round[j] {
            let tau = self.sphere_contact([i, j], a, b);
            return QuickBound {
                lower: tau,
                estimate: tau,
                now: None,
                axis: None,
            };
        }
        quick_bound(
            &self.shapes[i],
            a,
            &self.shapes[j],
            b,
            horizon,
            start,
            first,
        )
    }
    fn enclosing_bound(&self, [i, j]: [usize; 2], a: &Body, b: &Body, n: &V3) -> f64 {
        enclosing_bound(&self.shapes[i], a, &self.shapes[j], b, n)
    }
    fn solver_stats(&self) -> &SolverStats {
        &self.stats
    }
}
