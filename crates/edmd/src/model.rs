//! The body models the event loop is generic over: what one particle kind costs to simulate,
//! from its shape to its collision rule and the contact-time search of one pair.

use crate::ball::Ball;
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
    /// The region a body's neighbour list is built for.
    type Region: Region;
    /// The shape every body has.
    type Shape: Surface + Copy;
    /// Whether bodies rotate; a model whose bodies never do advances their positions alone and
    /// never reads their orientation in the event loop (the cache lines past position, velocity
    /// and time).
    const ROTATES: bool;
    fn surface(&self) -> Self::Shape;
    /// Applies the collision of `a` with the image of `b` displaced by `offset`; returns the
    /// impulse given to `b`, or `None` if the bodies separate.
    fn collide(&self, a: &mut Body, b: &mut Body, offset: &V3, x: &Self::Extra) -> Option<V3>;
    fn stats(&self) -> SolverStats;
    /// Puts back the counters of a restored run.
    fn set_stats(&mut self, stats: SolverStats);
}

/// Hard spheres: quadratic contact time, no rotation, normal along the line of centres.
pub(crate) struct SphereModel {
    sigma: f64,
    /// Scratch: a neighbour list's trajectories with their images applied, contiguous for
    /// [`sphere::first_contact`](crate::sphere::first_contact). A body's position, velocity and
    /// time are the first cache line of its [`Body`], the only one the sphere path reads.
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
    type Region = Ball;
    type Shape = Ellipsoid;
    const ROTATES: bool = false;
    fn surface(&self) -> Ellipsoid {
        let r = 0.5 * self.sigma;
        Ellipsoid::new(r, r, r)
    }
    fn collide(&self, a: &mut Body, b: &mut Body, offset: &V3, _: &()) -> Option<V3> {
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
    type Region = Obp;
    type Shape = S;
    const ROTATES: bool = true;
    fn surface(&self) -> S {
        self.e
    }
    fn collide(&self, a: &mut Body, b: &mut Body, offset: &V3, x: &(V3, V3)) -> Option<V3> {
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
