//! The event loop (Secs. 2.7 and 3.5): collisions, cell crossings, neighbour-list rebuilds,
//! lazy free flight, measurements (Eq. 69, collision virial) and the final overlap audit.

use std::time::Instant;

use serde::Serialize;

use crate::audit::audit;
use crate::ball::Ball;
use crate::calendar::{Calendar, Event, Kind};
use crate::cells::Cells;
use crate::contact::{ContactParams, bounding_sphere_window, predict, separating_axis};
use crate::distance::{SolverStats, Tolerances};
use crate::ellipsoid::Ellipsoid;
use crate::geometry::{Surface, V3, image_offset};
use crate::init::{Geom, initial_configuration, sort_along_z_curve};
use crate::lists::{Lists, Region};
use crate::nnl::Obp;
use crate::rigid::{Body, Inertia, collide};
use crate::rng::Rng;
use crate::scene::{Neighbours, Scene, ShapeKind};
use crate::sequence::Fingerprint;
use crate::sphere::{self, Probe, Trajectory};
use crate::{EdmdError, prefetch};

/// What one particle kind costs to simulate: the analytic sphere, or the general rigid body.
trait Model {
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
    /// The earliest collision of body `i` (advanced to the engine's present time) if it comes
    /// before `own`, the body's own event; otherwise `own`.
    fn first_collision(
        e: &mut Engine<Self>,
        i: usize,
        own: Event<Self::Extra>,
    ) -> Event<Self::Extra>
    where
        Self: Sized;
    /// Applies the collision of `a` with the image of `b` displaced by `offset`; returns the
    /// impulse given to `b`, or `None` if the bodies separate.
    fn collide(&self, a: &mut Body, b: &mut Body, offset: &V3, x: &Self::Extra) -> Option<V3>;
    fn stats(&self) -> SolverStats;
}

/// Hard spheres: quadratic contact time, no rotation, normal along the line of centres.
struct SphereModel {
    sigma: f64,
    /// Scratch: a neighbour list's trajectories with their images applied, contiguous for
    /// [`sphere::first_contact`]. A body's position, velocity and time are the first cache line
    /// of its [`Body`], the only one the sphere path reads.
    gathered: Vec<Trajectory>,
}

impl SphereModel {
    fn new(sigma: f64) -> Self {
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
    #[inline]
    fn first_collision(e: &mut Engine<Self>, i: usize, own: Event<()>) -> Event<()> {
        e.first_sphere_collision(i, own)
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
}

/// Hard rigid bodies of any [`Surface`] through the general algorithm of Sec. 2: ellipsoids (any
/// X0, including 1) and superquadrics, each monomorphised on its own shape.
struct RigidModel<S> {
    e: S,
    params: ContactParams,
    inertia: Inertia,
    stats: SolverStats,
}

impl<S: Surface + Copy> Model for RigidModel<S> {
    type Extra = (V3, V3);
    type Region = Obp;
    type Shape = S;
    const ROTATES: bool = true;
    fn surface(&self) -> S {
        self.e
    }
    fn first_collision(e: &mut Engine<Self>, i: usize, own: Event<(V3, V3)>) -> Event<(V3, V3)> {
        let a = e.bodies[i];
        e.first_rigid_collision(i, &a, own)
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
}

impl<S: Surface + Copy> RigidModel<S> {
    fn new(e: S, params: ContactParams, inertia: Inertia) -> Self {
        RigidModel {
            e,
            params,
            inertia,
            stats: SolverStats::default(),
        }
    }

    /// The first contact before `horizon`.
    fn predict(&mut self, a: &Body, b: &Body, horizon: f64) -> Option<(f64, (V3, V3))> {
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
    fn quick_bound(&self, a: &Body, b: &Body) -> (f64, f64) {
        let gap = separating_axis(&self.e, &a.pose_after(0.0), &self.e, &b.pose_after(0.0));
        let lower = gap.safe_time(&self.e, a, &self.e, b);
        (lower, gap.closing_estimate(a, b).max(lower))
    }
}

enum Neighbourhood<R: Region> {
    Ll {
        cells: Cells,
        cell_of: Vec<usize>,
        /// Periodic images crossed by each body since the start (its position is unwrapped).
        img: Vec<[i32; 3]>,
        /// `img` in lengths, for the sphere path's hot loop.
        img_offset: Vec<V3>,
    },
    Nnl {
        lists: Lists<R>,
        /// When each body may first touch its box (Eq. 61), for its present trajectory and box.
        escape_at: Vec<f64>,
        eps: f64,
    },
}

struct Engine<M: Model> {
    m: M,
    l: f64,
    bodies: Vec<Body>,
    count: Vec<u32>,
    cal: Calendar<M::Extra>,
    t: f64,
    inv_i: f64,
    nb: Neighbourhood<M::Region>,
    scratch: Vec<(u32, [i32; 3])>,
    /// Candidate partners: (estimate, lower bound, partner, image shift).
    order: Vec<(f64, f64, u32, [i32; 3])>,
    acc: Accounting,
    /// The first error of the event loop (a contact search no solver could resolve, a list beyond
    /// its limits); the loop stops on it.
    failure: Option<EdmdError>,
    /// The collision sequence so far, carried from one engine of a run to the next.
    sequence: Fingerprint,
}

#[derive(Clone, Copy, Debug, Default)]
struct Accounting {
    collisions: u64,
    virial: f64,
    ke_trans: f64,
    ke_int: f64,
    t_last: f64,
    separating: u64,
    crossings: u64,
    rebuilds: u64,
    /// Wall time spent rebuilding boxes and lists (Eq. 73's list updates), in seconds.
    rebuild_s: f64,
}

impl<M: Model> Engine<M> {
    fn new(m: M, l: f64, bodies: Vec<Body>, inv_i: f64, scene: &Scene) -> Result<Self, EdmdError> {
        let n = bodies.len();
        let lb = m.surface().bounding_radius();
        let nb = match scene.neighbours {
            Neighbours::Ll => {
                let cells = Cells::new(l, 2.0 * lb).ok_or(EdmdError::BoxTooSmall {
                    l,
                    needed: 6.0 * lb,
                    why: "linked cells need 3 cells of bounding-sphere size per side; use neighbours = \"nnl\" or more particles",
                })?;
                Neighbourhood::Ll {
                    cells,
                    cell_of: vec![0; n],
                    img: vec![[0; 3]; n],
                    img_offset: vec![V3::zeros(); n],
                }
            }
            Neighbours::Nnl => {
                let surf = m.surface();
                let lists = Lists::<M::Region>::build(&surf, &bodies, l, scene.delta_nnl)?;
                let escape_at = bodies
                    .iter()
                    .enumerate()
                    .map(|(i, b)| lists.region(i).escape_time(&surf, b, scene.eps_nnl))
                    .collect();
                Neighbourhood::Nnl {
                    lists,
                    escape_at,
                    eps: scene.eps_nnl,
                }
            }
        };
        let ke_trans = bodies.iter().map(|b| 0.5 * b.v.norm_squared()).sum();
        let mut e = Engine {
            m,
            l,
            bodies,
            count: vec![0; n],
            cal: Calendar::new(n),
            t: 0.0,
            inv_i,
            nb,
            scratch: Vec::new(),
            order: Vec::new(),
            acc: Accounting {
                ke_trans,
                ..Default::default()
            },
            failure: None,
            sequence: Fingerprint::default(),
        };
        if let Neighbourhood::Ll { cells, cell_of, .. } = &mut e.nb {
            for (i, b) in e.bodies.iter().enumerate() {
                let c = cells.index(cells.coords_of(&b.r));
                cell_of[i] = c;
                cells.insert(c, i as u32);
            }
        }
        for i in 0..n {
            e.predict_for(i);
        }
        Ok(e)
    }

    /// Schedules the earliest event of `i`: its cell crossing or box escape, or its first collision,
    /// whichever comes first (one event per particle). The crossing time (LL) or the box escape
    /// (NNL) is the horizon of every contact search.
    fn predict_for(&mut self, i: usize) {
        self.advance_body(i);
        let (r, v) = (self.bodies[i].r, self.bodies[i].v);
        let mut own = Event {
            t: f64::INFINITY,
            a: i as u32,
            b: u32::MAX,
            cb: 0,
            kind: Kind::BoxEscape,
            extra: M::Extra::default(),
        };
        match &self.nb {
            Neighbourhood::Ll {
                cells,
                cell_of,
                img,
                ..
            } => {
                let c = cells.coords(cell_of[i]);
                let r = r - image_offset(img[i], self.l);
                if let Some((tau, dim, up)) = cells.exit(c, &r, &v) {
                    own.t = self.t + tau;
                    own.kind = Kind::CellCross { dim, up };
                }
            }
            // Nothing needs scheduling past the escape, which predicts this body anew (Eq. 65).
            Neighbourhood::Nnl { escape_at, .. } => own.t = escape_at[i],
        }
        let best = M::first_collision(self, i, own);
        // An event at +∞ (nothing moves) is never scheduled.
        if best.t.is_finite() {
            self.cal.schedule(best);
        } else {
            self.cal.cancel(i);
        }
    }

    /// Body `i` reached the face of its box: a new box and list for it alone, then its events.
    fn rebuild_box(&mut self, i: usize) {
        self.advance_body(i);
        let surf = self.m.surface();
        let Neighbourhood::Nnl {
            lists,
            escape_at,
            eps,
        } = &mut self.nb
        else {
            return;
        };
        // Rebuilds are rare (µs each): two clock reads time them for Eq. 73's split.
        let started = Instant::now();
        if let Err(e) = lists.rebuild(&surf, i, &self.bodies[i]) {
            self.failure.get_or_insert(e.into());
        }
        escape_at[i] = self.t + lists.region(i).escape_time(&surf, &self.bodies[i], *eps);
        self.acc.rebuild_s += started.elapsed().as_secs_f64();
        self.acc.rebuilds += 1;
        self.predict_for(i);
    }

    /// After a collision: the escape time of `i` follows its new trajectory (Sec. 3.5, 5c).
    fn update_escape(&mut self, i: usize) {
        let surf = self.m.surface();
        if let Neighbourhood::Nnl {
            lists,
            escape_at,
            eps,
        } = &mut self.nb
        {
            escape_at[i] = self.t + lists.region(i).escape_time(&surf, &self.bodies[i], *eps);
        }
    }

    /// Processes events until `n` more collisions have happened; `on_collision` sees each one.
    fn advance(
        &mut self,
        n: u64,
        mut on_collision: impl FnMut(&mut Self),
    ) -> Result<(), EdmdError> {
        let target = self.acc.collisions + n;
        while self.acc.collisions < target {
            // Every branch schedules `ev.a` anew (or cancels it), which replaces this event.
            let ev = self.cal.first().ok_or(EdmdError::Stalled)?;
            self.cal.prefetch_next();
            self.t = ev.t.max(self.t);
            match ev.kind {
                Kind::BoxEscape => self.rebuild_box(ev.a as usize),
                Kind::Collision { .. } if ev.cb != self.count[ev.b as usize] => {
                    self.predict_for(ev.a as usize)
                }
                Kind::Collision { shift } => {
                    if self.collision(&ev, shift) {
                        on_collision(self);
                    }
                }
                Kind::CellCross { dim, up } => self.cross(ev.a as usize, dim as usize, up),
            }
            if let Some(e) = self.failure.take() {
                return Err(e);
            }
        }
        Ok(())
    }

    fn collision(&mut self, ev: &Event<M::Extra>, shift: [i32; 3]) -> bool {
        let (a, b) = (ev.a as usize, ev.b as usize);
        if let Neighbourhood::Nnl {
            lists, escape_at, ..
        } = &self.nb
        {
            lists.prefetch(a);
            lists.prefetch(b);
            prefetch(&escape_at[a]);
            prefetch(&escape_at[b]);
        }
        self.cal.prefetch(a);
        self.cal.prefetch(b);
        self.advance_body(a);
        self.advance_body(b);
        let offset = image_offset(shift, self.l);
        // A body never collides with its own image (the box exceeds twice the bounding diameter).
        let (ba, bb) = if a < b {
            let (low, high) = self.bodies.split_at_mut(b);
            (&mut low[a], &mut high[0])
        } else {
            let (low, high) = self.bodies.split_at_mut(a);
            (&mut high[0], &mut low[b])
        };
        let ke_before = 0.5 * (ba.v.norm_squared() + bb.v.norm_squared());
        let imp = self.m.collide(ba, bb, &offset, &ev.extra);
        let ke_after = 0.5 * (ba.v.norm_squared() + bb.v.norm_squared());
        let separation = (bb.r + offset) - ba.r;
        self.count[a] = self.count[a].wrapping_add(1);
        self.count[b] = self.count[b].wrapping_add(1);
        let happened = if let Some(j) = imp {
            self.acc.ke_int += self.acc.ke_trans * (self.t - self.acc.t_last);
            self.acc.t_last = self.t;
            self.acc.ke_trans += ke_after - ke_before;
            self.acc.virial += separation.dot(&j);
            self.acc.collisions += 1;
            self.sequence.record(ev.a, ev.b);
            true
        } else {
            self.acc.separating += 1;
            false
        };
        self.update_escape(a);
        self.update_escape(b);
        if let Neighbourhood::Nnl { lists, .. } = &self.nb {
            for n in lists.of(a).iter().chain(lists.of(b)) {
                prefetch(&self.bodies[n.j as usize]);
            }
        }
        self.predict_for(a);
        self.predict_for(b);
        happened
    }

    fn cross(&mut self, i: usize, dim: usize, up: bool) {
        self.acc.crossings += 1;
        self.advance_body(i);
        let Neighbourhood::Ll {
            cells,
            cell_of,
            img,
            img_offset,
        } = &mut self.nb
        else {
            return;
        };
        let mut d = [0i32; 3];
        d[dim] = if up { 1 } else { -1 };
        let to = cells.neighbour(cells.coords(cell_of[i]), d);
        // Positions stay unwrapped (scheduled events keep their meaning); the image counter
        // records that the body now lives in the neighbouring box.
        img[i][dim] += to.shift[dim] as i32;
        img_offset[i][dim] = img[i][dim] as f64 * self.l;
        cells.remove(cell_of[i], i as u32);
        cells.insert(to.cell, i as u32);
        cell_of[i] = to.cell;
        self.predict_for(i);
    }

    /// Body `i` at the present time; positions alone where bodies do not rotate.
    #[inline]
    fn advance_body(&mut self, i: usize) {
        let (t, b) = (self.t, &mut self.bodies[i]);
        if M::ROTATES {
            b.advance_to(t);
        } else {
            // Body::advance_to without reading the angular velocity, which lies in another line.
            let tau = t - b.t;
            if tau != 0.0 {
                b.r += b.v * tau;
                b.t = t;
            }
        }
    }

    fn sync_all(&mut self) {
        let t = self.t;
        for b in self.bodies.iter_mut() {
            b.advance_to(t);
        }
    }

    fn energy(&self) -> f64 {
        self.bodies
            .iter()
            .map(|b| {
                0.5 * b.v.norm_squared()
                    + if self.inv_i > 0.0 {
                        0.5 * b.w.norm_squared() / self.inv_i
                    } else {
                        0.0
                    }
            })
            .sum()
    }

    fn momentum(&self) -> V3 {
        self.bodies.iter().fold(V3::zeros(), |p, b| p + b.v)
    }
}

impl Engine<SphereModel> {
    /// The hot loop of the sphere path. With lists, [`sphere::first_contact`] over the
    /// neighbours' trajectories, gathered with their images, four at a time. With cells, partners
    /// are extrapolated to now without being stored, and the contact time of every candidate is
    /// computed without data-dependent branches (i itself gives +∞); which candidate is the
    /// earliest so far is a select, not a branch: it is unpredictable, and mispredictions would
    /// serialise the square roots and divisions.
    fn first_sphere_collision(&mut self, i: usize, own: Event<()>) -> Event<()> {
        let a = &self.bodies[i];
        let sigma2 = (2.0 * self.m.surface().s.x).powi(2);
        let mut horizon = own.t - self.t;
        let found = match &self.nb {
            Neighbourhood::Ll {
                cells,
                cell_of,
                img,
                img_offset,
            } => {
                let mut partner = None;
                let around = cells.around(cell_of[i]);
                for (k, nbc) in around.iter().enumerate() {
                    // Where i's image sits relative to the box j lives in, minus i itself.
                    let origin =
                        image_offset(nbc.shift.map(i32::from), self.l) + img_offset[i] - a.r;
                    for &j in cells.members(nbc.cell) {
                        let bj = &self.bodies[j as usize];
                        let dr = bj.r + bj.v * (self.t - bj.t) - img_offset[j as usize] + origin;
                        let v = bj.v;
                        let tau = sphere::contact_time_or_inf(&dr, &(v - a.v), sigma2);
                        partner = if tau < horizon { Some((k, j)) } else { partner };
                        horizon = horizon.min(tau);
                    }
                }
                partner.map(|(k, j)| {
                    let cell_shift = around[k].shift;
                    (j, ll_shift(cell_shift, img[i], img[j as usize]))
                })
            }
            Neighbourhood::Nnl { lists, .. } => {
                let probe = Probe {
                    r: a.r,
                    v: a.v,
                    now: self.t,
                    sigma2,
                };
                let (bodies, gathered) = (&self.bodies, &mut self.m.gathered);
                gathered.clear();
                gathered.extend(
                    lists
                        .of(i)
                        .iter()
                        .map(|n| Trajectory::of(&bodies[n.j as usize], &n.offset(self.l))),
                );
                sphere::first_contact(gathered, &probe, horizon).map(|(p, tau)| {
                    horizon = tau;
                    let n = lists.of(i)[p];
                    (n.j, n.shift())
                })
            }
        };
        match found {
            Some((j, shift)) => Event {
                t: self.t + horizon,
                a: i as u32,
                b: j,
                cb: self.count[j as usize],
                kind: Kind::Collision { shift },
                extra: (),
            },
            None => own,
        }
    }
}

impl<S: Surface + Copy> Engine<RigidModel<S>> {
    /// Rigid bodies: partners are searched in the order in which their bounding spheres meet (or,
    /// where they already overlap, of a separating-axis estimate), so that the search stops as
    /// soon as a lower bound cannot beat the best event so far.
    fn first_rigid_collision(
        &mut self,
        i: usize,
        a: &Body,
        mut best: Event<(V3, V3)>,
    ) -> Event<(V3, V3)> {
        let mut cand = std::mem::take(&mut self.scratch);
        cand.clear();
        match &self.nb {
            Neighbourhood::Ll {
                cells,
                cell_of,
                img,
                ..
            } => {
                for nbc in &cells.around(cell_of[i]) {
                    cand.extend(
                        cells
                            .members(nbc.cell)
                            .iter()
                            .map(|&j| (j, ll_shift(nbc.shift, img[i], img[j as usize]))),
                    );
                }
            }
            Neighbourhood::Nnl { lists, .. } => {
                cand.extend(lists.of(i).iter().map(|n| (n.j, n.shift())))
            }
        }
        let lb = self.m.surface().bounding_radius();
        let mut order = std::mem::take(&mut self.order);
        order.clear();
        for &(j, shift) in &cand {
            let ju = j as usize;
            if ju == i {
                continue;
            }
            // Where the bounding spheres are concerned, positions suffice; a body is rotated to
            // the present only when its orientation matters.
            let bj = &self.bodies[ju];
            let r = bj.r + bj.v * (self.t - bj.t) + image_offset(shift, self.l);
            if let Some((t1, _)) = bounding_sphere_window(&(r - a.r), &(bj.v - a.v), 2.0 * lb) {
                // Bounding spheres already overlap: a separating axis bounds the contact time.
                let (lower, estimate) = if t1 == 0.0 {
                    let mut b = self.bodies[ju].at(self.t);
                    b.r += image_offset(shift, self.l);
                    self.m.quick_bound(a, &b)
                } else {
                    (t1, t1)
                };
                order.push((estimate, lower, j, shift));
            }
        }
        order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        // Likely first partners first, so that the horizon shrinks early; the bound decides skipping.
        for &(_, lower, j, shift) in &order {
            if self.t + lower >= best.t {
                continue;
            }
            let ju = j as usize;
            let mut b = self.bodies[ju].at(self.t);
            b.r += image_offset(shift, self.l);
            let failures = self.m.stats.failures;
            let hit = self.m.predict(a, &b, best.t - self.t);
            if self.m.stats.failures > failures && self.failure.is_none() {
                let arr = |v: V3| [v.x, v.y, v.z];
                self.failure = Some(EdmdError::Unresolved(Box::new(crate::UnresolvedContact {
                    quantity: self.m.stats.failed.unwrap_or("contact time"),
                    a: i,
                    b: ju,
                    t: self.t,
                    ra: arr(a.r),
                    rb: arr(b.r),
                    va: arr(a.v),
                    vb: arr(b.v),
                })));
            }
            if let Some((tau, extra)) = hit
                && self.t + tau < best.t
            {
                best = Event {
                    t: self.t + tau,
                    a: i as u32,
                    b: j,
                    cb: self.count[ju],
                    kind: Kind::Collision { shift },
                    extra,
                };
            }
        }
        self.order = order;
        self.scratch = cand;
        best
    }
}

/// Image shift of j as seen from i with unwrapped positions: the cell shift plus the image counters.
fn ll_shift(cell: [i8; 3], img_i: [i32; 3], img_j: [i32; 3]) -> [i32; 3] {
    [0, 1, 2].map(|k| cell[k] as i32 + img_i[k] - img_j[k])
}

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
    /// Measured kT = (2/3)⟨translational kinetic energy⟩/N, time-averaged.
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
    /// Newton–Raphson iterations per distance evaluation in the measured run (0 on the sphere path).
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
    /// Wall time of the initial state (s): lattice, melting, compression, first lists and events,
    /// and the [`RELAX_COLLISIONS_PER_PARTICLE`] collisions per particle that relax it.
    pub init_s: f64,
    /// The collision sequence from the first collision of the run (relaxation included); kept
    /// out of the report's JSON (a job stores it as hex, `sweep edmd` does not print it).
    #[serde(skip)]
    pub sequence: Fingerprint,
}

/// The final configuration, in the `--dump` format of DESIGN.md.
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
fn simulate<M: Model>(
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

/// Collisions per particle run at the end of the initial state (see [`measure`]).
pub const RELAX_COLLISIONS_PER_PARTICLE: u64 = 10;

fn measure<M: Model>(
    mut eng: Engine<M>,
    scene: &Scene,
    geom: Geom,
    init: Instant,
    progress: &mut dyn FnMut(u64),
) -> Result<(RunReport, FinalState), EdmdError> {
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
    let init_s = init.elapsed().as_secs_f64();
    let total = scene.equilibrate + scene.collisions;
    let every = (total / 100).clamp(1, 10_000);
    let mut tick = |done: u64| {
        if done.is_multiple_of(every) {
            progress(done);
        }
    };
    eng.advance(scene.equilibrate, |e| tick(e.acc.collisions))?;

    eng.sync_all();
    let n = eng.bodies.len();
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
    let blocks = scene.collisions.min(10);
    let mut marks: Vec<(f64, f64)> = Vec::with_capacity(blocks as usize);
    let (wall, cpu) = (Instant::now(), crate::clock::thread_cpu_seconds());
    measured_collisions(&mut eng, scene.collisions, |e| {
        let k = e.acc.collisions - base_collisions;
        tick(e.acc.collisions);
        if (k * blocks).is_multiple_of(scene.collisions) {
            marks.push((e.acc.virial, e.acc.ke_int));
        }
    })?;
    let elapsed = wall.elapsed().as_secs_f64();
    let cpu_elapsed = crate::clock::thread_cpu_seconds() - cpu;
    eng.sync_all();
    progress(eng.acc.collisions);

    let stats = eng.m.stats();
    let sim_time = eng.t - t0;
    let z_of = |w: f64, k: f64| 1.0 + w / (2.0 * k);
    let z = z_of(eng.acc.virial, eng.acc.ke_int);
    let mut zb = Vec::with_capacity(marks.len());
    let mut prev = (0.0, 0.0);
    for &m in &marks {
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
    let calls = (stats.distance_calls - stats0.distance_calls) as f64;
    let per_collision_us = |s: f64| s * 1e6 / scene.collisions as f64;
    let nnl_rebuild_s = eng.acc.rebuild_s - rebuild_s0;
    let report = RunReport {
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
        overlaps: audit(&eng.bodies, eng.l, &geom, scene.audit_tol),
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
    };
    let state = final_state(&eng.bodies, eng.l, &geom);
    Ok((report, state))
}

/// The measured run's collisions, in a frame of their own so that a profiler can select them
/// alone (`valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*measured_collisions*'`).
#[inline(never)]
fn measured_collisions<M: Model>(
    eng: &mut Engine<M>,
    n: u64,
    on_collision: impl FnMut(&mut Engine<M>),
) -> Result<(), EdmdError> {
    eng.advance(n, on_collision)
}

fn final_state(bodies: &[Body], l: f64, geom: &Geom) -> FinalState {
    let (shape, semi, exponents) = match geom {
        Geom::Sphere { sigma } => ("sphere", [0.5 * sigma; 3], [2.0; 3]),
        Geom::Ellipsoid(e) => ("ellipsoid", [e.s.x, e.s.y, e.s.z], [2.0; 3]),
        Geom::Superquadric(q) => ("superquadric", q.s.into(), q.e.into()),
    };
    let arr = |v: V3| [v.x, v.y, v.z];
    FinalState {
        box_: [l; 3],
        particles: bodies
            .iter()
            .map(|b| ParticleDump {
                shape,
                semi_axes: semi,
                exponents,
                position: arr(b.r.map(|x| x.rem_euclid(l))),
                orientation: [0, 1, 2].map(|k| arr(b.rot.row(k).transpose())),
                velocity: arr(b.v),
                angular_velocity: arr(b.w),
            })
            .collect(),
    }
}
