//! The body models the event loop is generic over: what one particle kind costs to simulate,
//! from its shape to its collision rule and the contact-time search of one pair.

use crate::ball::{Ball, SizedBall};
use crate::body::{Moving, SphereBody};
use crate::contact::{ContactParams, predict, separating_axis};
use crate::distance::SolverStats;
use crate::ellipsoid::Ellipsoid;
use crate::geometry::{Surface, V3};
use crate::lists::Region;
use crate::nnl::Obp;
use crate::rigid::{Body, Inertia, collide};
use crate::sphere::Trajectory;

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
    fn surface(&self) -> Self::Shape;
    /// Body `i`'s own shape, which its neighbour-list region is built around: [`surface`]
    /// (Self::surface) unless bodies differ in size.
    #[inline(always)]
    fn surface_of(&self, _i: usize) -> Self::Shape {
        self.surface()
    }
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
    /// [`sphere::first_contact`](crate::sphere::first_contact), each from one [`SphereBody`].
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
    fn surface(&self) -> Ellipsoid {
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
    pub(crate) species: Vec<u16>,
    species_count: usize,
    /// The largest radius: cells are sized for the largest pair.
    r_max: f64,
    /// Collisions and collision virial Σ r·Δp per unordered pair of species (index
    /// [`pair_index`](Self::pair_index)).
    pub(crate) pair_collisions: Vec<u64>,
    pub(crate) pair_virial: Vec<f64>,
    /// As in [`SphereModel`], with each neighbour's radius in [`Trajectory::radius`].
    pub(crate) gathered: Vec<Trajectory>,
}

impl MixedSphereModel {
    /// Bodies of the given diameters and species (masses σ³, the first species' diameter 1
    /// being the unit).
    pub(crate) fn new(diameter: &[f64], species: Vec<u16>, species_count: usize) -> Self {
        let radius: Vec<f64> = diameter.iter().map(|d| 0.5 * d).collect();
        let r_max = radius.iter().fold(0.0, |m: f64, &r| m.max(r));
        let pairs = species_count * (species_count + 1) / 2;
        MixedSphereModel {
            mass: diameter.iter().map(|d| d * d * d).collect(),
            radius,
            species,
            species_count,
            r_max,
            pair_collisions: vec![0; pairs],
            pair_virial: vec![0.0; pairs],
            gathered: Vec::new(),
        }
    }

    /// The index of the unordered pair of species (a, b) among the S(S+1)/2 pairs, row by row:
    /// (0,0), (0,1), …, (0,S−1), (1,1), …
    pub(crate) fn pair_index(&self, a: u16, b: u16) -> usize {
        let (a, b) = (a.min(b) as usize, a.max(b) as usize);
        a * self.species_count - a * a.saturating_sub(1) / 2 + (b - a)
    }

    pub(crate) fn species_count(&self) -> usize {
        self.species_count
    }
}

impl Model for MixedSphereModel {
    type Extra = ();
    type Body = SphereBody;
    type Region = SizedBall;
    type Shape = Ellipsoid;
    /// The largest sphere: what cells and the neighbour-list grid are sized for.
    fn surface(&self) -> Ellipsoid {
        Ellipsoid::new(self.r_max, self.r_max, self.r_max)
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
        let k = self.pair_index(self.species[i], self.species[j]);
        self.pair_collisions[k] += 1;
        self.pair_virial[k] += r.dot(&dp);
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
        self.pair_collisions.fill(0);
        self.pair_virial.fill(0.0);
    }
    fn stats(&self) -> SolverStats {
        SolverStats::default()
    }
    fn set_stats(&mut self, _: SolverStats) {}
}

/// Hard rigid bodies of any [`Surface`] through the general algorithm of Sec. 2: ellipsoids (any
/// X0, including 1) and superquadrics, each monomorphised on its own shape.
pub(crate) struct RigidModel<S> {
    e: S,
    params: ContactParams,
    inertia: Inertia,
    pub(crate) stats: SolverStats,
}

impl<S: Surface + Copy> Model for RigidModel<S> {
    type Extra = (V3, V3);
    type Body = Body;
    type Region = Obp;
    type Shape = S;
    fn surface(&self) -> S {
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
        let mut image = *b;
        image.r += offset;
        let impulse = collide(a, &mut image, &x.0, &x.1, self.inertia, self.inertia);
        b.v = image.v;
        b.w = image.w;
        impulse
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
        RigidModel {
            e,
            params,
            inertia,
            stats: SolverStats::default(),
        }
    }

    /// The first contact before `horizon`.
    pub(crate) fn predict(&mut self, a: &Body, b: &Body, horizon: f64) -> Option<(f64, (V3, V3))> {
        predict(
            &self.e,
            a,
            &self.e,
            b,
            horizon,
            &self.params,
            &mut self.stats,
        )
        .map(|h| (h.t, (h.xc, h.n)))
    }
    /// Without any solver, a lower bound on the contact time of two bodies whose bounding spheres
    /// overlap, and an estimate of it to order the searches by.
    pub(crate) fn quick_bound(&self, a: &Body, b: &Body) -> (f64, f64) {
        let gap = separating_axis(&self.e, &a.pose_after(0.0), &self.e, &b.pose_after(0.0));
        let lower = gap.safe_time(&self.e, a, &self.e, b);
        (lower, gap.closing_estimate(a, b).max(lower))
    }
}
