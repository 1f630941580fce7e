//! The event loop (Secs. 2.7 and 3.5): collisions, cell crossings, neighbour-list rebuilds,
//! lazy free flight, and the sums the measurements are made of (Eq. 69, collision virial).

use std::time::Instant;

use crate::axes::{PairAxes, SlotOf};
use crate::body::{Moving, SphereBody};
use crate::calendar::{Calendar, Event, Kind};
use crate::cells::Cells;
use crate::contact::{Known, QuickBound, bounding_sphere_window};
use crate::first_step::{Lane, first_steps};
use crate::geometry::{V3, image_offset};
use crate::lists::{Lists, Region};
use crate::model::{MixedSphereModel, Model, Rigid, SphereModel};
use crate::rigid::Body;
use crate::scene::{Neighbours, Scene};
use crate::sequence::Fingerprint;
use crate::sphere::{self, Probe, Trajectory};
use crate::{EdmdError, prefetch};

// One per engine: the size of its variants costs nothing, a box would cost an indirection.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub(crate) enum Neighbourhood<R: Region> {
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

pub(crate) struct Engine<M: Model> {
    pub(crate) m: M,
    pub(crate) l: f64,
    pub(crate) bodies: Vec<M::Body>,
    count: Vec<u32>,
    cal: Calendar<M::Extra>,
    pub(crate) t: f64,
    nb: Neighbourhood<M::Region>,
    scratch: Vec<(u32, [i32; 3])>,
    /// Candidate partners of a rigid prediction, in the order of their searches.
    order: Vec<Order>,
    /// Rigid candidates whose bounding spheres overlap now: the partner at the present, and what
    /// is known of the pair already (the quick bound's separating-axis gap, or the contact just
    /// resolved).
    near: Vec<(Body, Option<Known>)>,
    /// Rigid candidates whose bounding spheres overlap now, before their quick bounds.
    close: Vec<Close>,
    /// Close candidates whose first ascent step fell short of the horizon: the rest of their
    /// quick bound waits for their turn in `order`.
    deferred: Vec<Deferred>,
    /// While the two bodies of a collision are predicted anew: the pair, where they touched
    /// (`Extra`, the image offset of the second), so that each one's search for the other starts
    /// from that contact.
    met: Option<(u32, u32, M::Extra, V3)>,
    /// Each rigid pair's last separating axis, where its next quick bound starts.
    axes: PairAxes,
    pub(crate) acc: Accounting,
    /// The first error of the event loop (a contact search no solver could resolve, a list beyond
    /// its limits); the loop stops on it.
    failure: Option<EdmdError>,
    /// The pair and time of the last predicted collision the bodies turned out to leave: the
    /// same one again means the search predicts it for ever (see [`Engine::collision`]).
    last_parting: Option<(u32, u32, f64)>,
    /// The collision sequence so far, carried from one engine of a run to the next.
    pub(crate) sequence: Fingerprint,
    /// The collisions since the engine's first start, for the mean free time that bounds how far
    /// an escape time looks ahead ([`Engine::escape_horizon`]).
    pace: Pace,
}

/// How many mean free times ahead a box's escape time is looked for. Each step of a turning
/// body's escape costs a pose and a support point per face axis, and at high density most are
/// wasted: the body collides first. Instructions a collision against looking to the escape
/// (callgrind, X0 = 2, N 256): φ 0.5 −3.0 % at Δ_NNL 0.085 (1 and 2 mean free times: −3.1 and
/// −2.5 %), −5.0 % at 0.15; φ 0.3 −1.7 %; φ 0.1 +0.2 %, where escapes come within the horizon.
const ESCAPE_LOOKAHEAD: f64 = 1.5;

/// Collisions counted from `since` (the engine's first start, carried by its state).
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub(crate) struct Pace {
    since: f64,
    collisions: u64,
}

impl Pace {
    fn starting_at(since: f64) -> Self {
        Pace {
            since,
            collisions: 0,
        }
    }

    /// The mean free time of `n` bodies at time `t`, N (t − since) / 2C, once they have met one
    /// other each on average: before, it is too rough to use.
    fn mean_free_time(&self, t: f64, n: usize) -> Option<f64> {
        let n = n as u64;
        (2 * self.collisions >= n)
            .then(|| (t - self.since) * n as f64 / (2 * self.collisions) as f64)
    }
}

/// What [`Engine::snapshot`] saves; its layout is part of the state file (see [`crate::state`]).
/// Bodies are saved whole whatever the model stores ([`Moving::to_body`]): a sphere's state file
/// is the same as before spheres were stored compactly.
#[derive(serde::Serialize, serde::Deserialize)]
pub(crate) struct EngineState<X, R: Region> {
    pub(crate) bodies: Vec<Body>,
    pub(crate) count: Vec<u32>,
    pub(crate) cal: Calendar<X>,
    pub(crate) t: f64,
    pub(crate) nb: Neighbourhood<R>,
    pub(crate) acc: Accounting,
    pub(crate) sequence: Fingerprint,
    pub(crate) stats: crate::distance::SolverStats,
    /// Rigid bodies' kept separating axes (version 3); a sphere's state has none, and a file
    /// without them continues with none kept.
    #[serde(default, skip_serializing_if = "PairAxes::is_empty")]
    pub(crate) axes: PairAxes,
    /// The collisions that size an escape time's horizon (version 4); a file without them
    /// counts afresh from its clock.
    #[serde(default)]
    pub(crate) pace: Option<Pace>,
}

impl<X, R: Region> EngineState<X, R> {
    /// The neighbour method the saved engine uses.
    pub(crate) fn neighbours(&self) -> Neighbours {
        match self.nb {
            Neighbourhood::Ll { .. } => Neighbours::Ll,
            Neighbourhood::Nnl { .. } => Neighbours::Nnl,
        }
    }
}

/// The counts and sums the measurements are made of, kept as events happen.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub(crate) struct Accounting {
    pub(crate) collisions: u64,
    pub(crate) virial: f64,
    pub(crate) ke_trans: f64,
    pub(crate) ke_int: f64,
    pub(crate) t_last: f64,
    pub(crate) separating: u64,
    pub(crate) crossings: u64,
    pub(crate) rebuilds: u64,
    /// Wall time spent rebuilding boxes and lists (Eq. 73's list updates), in seconds.
    pub(crate) rebuild_s: f64,
}

impl<M: FirstCollision> Engine<M> {
    pub(crate) fn new(
        m: M,
        l: f64,
        bodies: Vec<M::Body>,
        scene: &Scene,
        t: f64,
    ) -> Result<Self, EdmdError> {
        let n = bodies.len();
        let lb = m.bounding_radius();
        let nb = match scene.neighbours {
            Neighbours::Ll => {
                let cells = Cells::new(l, 2.0 * lb, n).ok_or(EdmdError::BoxTooSmall {
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
                // Each body's region around its own shape (the same for all but mixtures).
                let lists = Lists::<M::Region>::build_each(
                    |i| m.surface_of(i),
                    &bodies,
                    l,
                    scene.delta_nnl,
                )?;
                let escape_at = bodies
                    .iter()
                    .enumerate()
                    .map(|(i, b)| {
                        lists.region(i).escape_time(
                            &m.surface_of(i),
                            b,
                            scene.eps_nnl,
                            f64::INFINITY,
                        )
                    })
                    .collect();
                Neighbourhood::Nnl {
                    lists,
                    escape_at,
                    eps: scene.eps_nnl,
                }
            }
        };
        let ke_trans = bodies
            .iter()
            .enumerate()
            .map(|(i, b)| m.kinetic(i, b))
            .sum();
        let mut cal = Calendar::new(n);
        if M::READS_EVENT_TIMES {
            cal.keep_times();
        }
        let mut e = Engine {
            m,
            l,
            bodies,
            count: vec![0; n],
            cal,
            t,
            nb,
            scratch: Vec::new(),
            order: Vec::new(),
            near: Vec::new(),
            close: Vec::new(),
            deferred: Vec::new(),
            met: None,
            axes: PairAxes::default(),
            acc: Accounting {
                ke_trans,
                ..Default::default()
            },
            failure: None,
            last_parting: None,
            sequence: Fingerprint::default(),
            pace: Pace::starting_at(t),
        };
        if let Neighbourhood::Ll { cells, cell_of, .. } = &mut e.nb {
            for (i, b) in e.bodies.iter().enumerate() {
                let c = cells.index(cells.coords_of(&b.r()));
                cell_of[i] = c;
                cells.insert(c, i as u32);
            }
        }
        for i in 0..n {
            e.predict_for(i);
        }
        Ok(e)
    }

    /// Everything the engine's future depends on, for a restart that continues bit for bit: the
    /// bodies as they are (each at its own time, not advanced), the calendar in its heap order (its
    /// ties resolve by position), the collision counters, the neighbour lists or cells with their
    /// build state, the sums and the solver counters. Scratch buffers are left out.
    pub(crate) fn snapshot(&self) -> EngineState<M::Extra, M::Region> {
        EngineState {
            bodies: self.bodies.iter().map(Moving::to_body).collect(),
            count: self.count.clone(),
            cal: self.cal.clone(),
            t: self.t,
            nb: self.nb.clone(),
            acc: self.acc,
            sequence: self.sequence.clone(),
            stats: self.m.stats(),
            axes: self.axes.clone(),
            pace: Some(self.pace),
        }
    }

    /// The engine of a [`snapshot`](Self::snapshot), with the model `m` of the same scene.
    pub(crate) fn restore(mut m: M, l: f64, s: EngineState<M::Extra, M::Region>) -> Self {
        m.set_stats(s.stats);
        let mut cal = s.cal;
        if M::READS_EVENT_TIMES {
            cal.keep_times();
        }
        Engine {
            m,
            l,
            bodies: s.bodies.iter().map(M::Body::from_body).collect(),
            count: s.count,
            cal,
            t: s.t,
            nb: s.nb,
            scratch: Vec::new(),
            order: Vec::new(),
            near: Vec::new(),
            close: Vec::new(),
            deferred: Vec::new(),
            met: None,
            axes: s.axes,
            acc: s.acc,
            failure: None,
            last_parting: None,
            sequence: s.sequence,
            pace: s.pace.unwrap_or(Pace::starting_at(s.t)),
        }
    }

    /// The model and the bodies; the rest (lists, calendar, cells) is freed.
    pub(crate) fn into_parts(self) -> (M, Vec<M::Body>) {
        (self.m, self.bodies)
    }

    /// Stops the event loop after the present event with `e` (an observer's failure).
    pub(crate) fn fail(&mut self, e: EdmdError) {
        self.failure.get_or_insert(e);
    }

    /// The failure recorded outside the event loop, if any.
    pub(crate) fn take_failure(&mut self) -> Option<EdmdError> {
        self.failure.take()
    }

    /// Schedules the earliest event of `i`: its cell crossing or box escape, or its first collision,
    /// whichever comes first (one event per particle). The crossing time (LL) or the box escape
    /// (NNL) is the horizon of every contact search.
    fn predict_for(&mut self, i: usize) {
        self.advance_body(i);
        let (r, v) = (self.bodies[i].r(), self.bodies[i].v());
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
        let Neighbourhood::Nnl { lists, .. } = &mut self.nb else {
            return;
        };
        // Rebuilds are rare (µs each): two clock reads time them for Eq. 73's split.
        let started = Instant::now();
        if let Err(e) = lists.rebuild(&self.m.surface_of(i), i, &self.bodies[i]) {
            self.failure.get_or_insert(e.into());
        }
        self.update_escape(i);
        self.acc.rebuild_s += started.elapsed().as_secs_f64();
        self.acc.rebuilds += 1;
        self.predict_for(i);
    }

    /// How far a box's escape time is looked for: [`ESCAPE_LOOKAHEAD`] mean free times. A body
    /// seldom flies longer without a collision, which computes its escape anew; one that does
    /// rebuilds its box early (the time found by then is a lower bound).
    fn escape_horizon(&self) -> f64 {
        self.pace
            .mean_free_time(self.t, self.bodies.len())
            .map_or(f64::INFINITY, |free| ESCAPE_LOOKAHEAD * free)
    }

    /// The escape time of `i` from its box, for its present trajectory: after a collision (Sec.
    /// 3.5, 5c) or in a new box.
    fn update_escape(&mut self, i: usize) {
        let surf = self.m.surface_of(i);
        let horizon = self.escape_horizon();
        if let Neighbourhood::Nnl {
            lists,
            escape_at,
            eps,
        } = &mut self.nb
        {
            escape_at[i] = self.t
                + lists
                    .region(i)
                    .escape_time(&surf, &self.bodies[i], *eps, horizon);
        }
    }

    /// Processes events until `n` more collisions have happened; `on_collision` sees each one.
    pub(crate) fn advance(
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
        let ke_before = self.m.pair_kinetic([a, b], ba, bb);
        let imp = self.m.collide([a, b], ba, bb, &offset, &ev.extra);
        let ke_after = self.m.pair_kinetic([a, b], ba, bb);
        let separation = (bb.r() + offset) - ba.r();
        self.count[a] = self.count[a].wrapping_add(1);
        self.count[b] = self.count[b].wrapping_add(1);
        let happened = if let Some(j) = imp {
            self.acc.ke_int += self.acc.ke_trans * (self.t - self.acc.t_last);
            self.acc.t_last = self.t;
            self.acc.ke_trans += ke_after - ke_before;
            self.acc.virial += separation.dot(&j);
            self.acc.collisions += 1;
            self.pace.collisions += 1;
            self.sequence.record(ev.a, ev.b);
            true
        } else {
            self.acc.separating += 1;
            // Nothing changed but the counters: predicted anew, the same pair would meet at the
            // same time again, for ever. A contact search that does so cannot resolve the pair.
            let pair = (ev.a.min(ev.b), ev.a.max(ev.b), self.t);
            if self.last_parting == Some(pair) && self.failure.is_none() {
                let arr = |v: V3| [v.x, v.y, v.z];
                self.failure = Some(EdmdError::Unresolved(Box::new(crate::UnresolvedContact {
                    quantity: "contact time (a contact of parting bodies predicted again)",
                    a,
                    b,
                    t: self.t,
                    ra: arr(ba.r()),
                    rb: arr(bb.r() + offset),
                    va: arr(ba.v()),
                    vb: arr(bb.v()),
                })));
            }
            self.last_parting = Some(pair);
            false
        };
        self.update_escape(a);
        self.update_escape(b);
        if let Neighbourhood::Nnl { lists, .. } = &self.nb {
            for n in lists.of(a).iter().chain(lists.of(b)) {
                prefetch(&self.bodies[n.j as usize]);
            }
        }
        self.met = happened.then_some((ev.a, ev.b, ev.extra, offset));
        self.predict_for(a);
        self.predict_for(b);
        self.met = None;
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

    /// Body `i` at the present time (a sphere's position alone).
    #[inline]
    fn advance_body(&mut self, i: usize) {
        let t = self.t;
        self.bodies[i].advance_to(t);
    }

    pub(crate) fn sync_all(&mut self) {
        let t = self.t;
        for b in self.bodies.iter_mut() {
            b.advance_to(t);
        }
    }

    pub(crate) fn energy(&self) -> f64 {
        self.bodies
            .iter()
            .enumerate()
            .map(|(i, b)| self.m.kinetic(i, b) + self.m.spin_kinetic(i, b))
            .sum()
    }

    pub(crate) fn momentum(&self) -> V3 {
        self.bodies
            .iter()
            .enumerate()
            .fold(V3::zeros(), |p, (i, b)| p + self.m.momentum(i, b))
    }
}

/// A body model's search for the first collision of a body among its neighbours: the sphere
/// path's batched hot loop, or the rigid bodies' search in the order of lower bounds.
pub(crate) trait FirstCollision: Model {
    /// The earliest collision of body `i` (advanced to the engine's present time) if it comes
    /// before `own`, the body's own event; otherwise `own`.
    fn first_collision(
        e: &mut Engine<Self>,
        i: usize,
        own: Event<Self::Extra>,
    ) -> Event<Self::Extra>
    where
        Self: Sized;
}

impl FirstCollision for SphereModel {
    #[inline]
    fn first_collision(e: &mut Engine<Self>, i: usize, own: Event<()>) -> Event<()> {
        e.first_sphere_collision(i, own)
    }
}

impl FirstCollision for MixedSphereModel {
    #[inline]
    fn first_collision(e: &mut Engine<Self>, i: usize, own: Event<()>) -> Event<()> {
        e.first_sphere_collision(i, own)
    }
}

/// The sphere models, of one size or several. The sphere path is compiled once for each:
/// [`MIXED`](Self::MIXED) is a constant, so that spheres of one size compute one σ² per prediction
/// and never read a size, while a mixture reads each partner's radius (a second array beside the
/// bodies with cells; the spare word of each gathered [`Trajectory`] with lists).
pub(crate) trait Spheres:
    Model<Extra = (), Shape = crate::ellipsoid::Ellipsoid, Body = SphereBody>
{
    const MIXED: bool;
    /// The radius of body `i` (read only where [`MIXED`](Self::MIXED)).
    fn radius(&self, i: usize) -> f64;
    /// Every body's radius (empty for one size), and the scratch of gathered trajectories.
    fn gather_parts(&mut self) -> (&[f64], &mut Vec<Trajectory>);
}

impl Spheres for SphereModel {
    const MIXED: bool = false;
    #[inline(always)]
    fn radius(&self, _: usize) -> f64 {
        0.5
    }
    #[inline(always)]
    fn gather_parts(&mut self) -> (&[f64], &mut Vec<Trajectory>) {
        (&[], &mut self.gathered)
    }
}

impl Spheres for MixedSphereModel {
    const MIXED: bool = true;
    #[inline(always)]
    fn radius(&self, i: usize) -> f64 {
        self.radius[i]
    }
    #[inline(always)]
    fn gather_parts(&mut self) -> (&[f64], &mut Vec<Trajectory>) {
        (&self.radius, &mut self.gathered)
    }
}

impl<M: Rigid> FirstCollision for M {
    fn first_collision(e: &mut Engine<Self>, i: usize, own: Event<(V3, V3)>) -> Event<(V3, V3)> {
        let a = e.bodies[i];
        e.first_rigid_collision(i, &a, own)
    }
}

impl<M: Spheres> Engine<M> {
    /// The hot loop of the sphere path. With lists, [`sphere::first_contact`] over the
    /// neighbours' trajectories, gathered with their images, four at a time. With cells, partners
    /// are extrapolated to now without being stored, and the contact time of every candidate is
    /// computed without data-dependent branches (i itself gives +∞); which candidate is the
    /// earliest so far is a select, not a branch: it is unpredictable, and mispredictions would
    /// serialise the square roots and divisions.
    ///
    /// In a mixture each pair's contact distance is the sum of the radii; spheres of one size
    /// compile these branches away.
    fn first_sphere_collision(&mut self, i: usize, own: Event<()>) -> Event<()> {
        let a = &self.bodies[i];
        let sigma2 = (2.0 * self.m.bounding_radius()).powi(2);
        let ri = if M::MIXED { self.m.radius(i) } else { 0.0 };
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
                        let sigma2 = if M::MIXED {
                            let s = ri + self.m.radius(j as usize);
                            s * s
                        } else {
                            sigma2
                        };
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
                    radius: ri,
                };
                let bodies = &self.bodies;
                let (radius, gathered) = self.m.gather_parts();
                gathered.clear();
                gathered.extend(lists.of(i).iter().map(|n| {
                    let mut t = Trajectory::of(&bodies[n.j as usize], &n.offset(self.l));
                    if M::MIXED {
                        t.radius = radius[n.j as usize];
                    }
                    t
                }));
                let found = if M::MIXED {
                    sphere::first_contact_mixed(gathered, &probe, horizon)
                } else {
                    sphere::first_contact(gathered, &probe, horizon)
                };
                found.map(|(p, tau)| {
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

impl<M: Rigid> Engine<M> {
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
        let lb = self.m.bounding_radius_of(i);
        let mut order = std::mem::take(&mut self.order);
        order.clear();
        let mut near = std::mem::take(&mut self.near);
        near.clear();
        let mut close = std::mem::take(&mut self.close);
        close.clear();
        let mut deferred = std::mem::take(&mut self.deferred);
        deferred.clear();
        let lanes = self.m.lanes();
        let prefetching = self.bodies.len() >= PREFETCH_FROM;
        // The partner of the collision just resolved, if this body is of it, and whether this
        // body is the event's first: asked of every close candidate, the pair's two indices were
        // compared for each, in branches that flipped from one body's prediction to the other's.
        let met_partner = self.met.and_then(|(p, q, ..)| match i {
            _ if p as usize == i => Some((q as usize, true)),
            _ if q as usize == i => Some((p as usize, false)),
            _ => None,
        });
        for (k, &(j, shift)) in cand.iter().enumerate() {
            // The bodies, events and kept axes of candidates a few ahead are seldom in cache at
            // large N.
            if prefetching && let Some(&(ahead, _)) = cand.get(k + PREFETCH_AHEAD) {
                self.bodies[ahead as usize].prefetch();
                self.cal.prefetch(ahead as usize);
                self.axes.prefetch(i, ahead as usize);
            }
            let ju = j as usize;
            if ju == i {
                continue;
            }
            // Where the bounding spheres are concerned, positions suffice; a body is rotated to
            // the present only when its orientation matters.
            let bj = &self.bodies[ju];
            let r = bj.r + bj.v * (self.t - bj.t) + image_offset(shift, self.l);
            let reach = lb + self.m.bounding_radius_of(ju);
            // A contact after the partner's own next event is the partner's to find: every
            // event predicts its body anew against all it may meet (a box escape against every
            // box its new one meets, Sec. 3.3), and a collision of the partner's with a third
            // changes its path. Whichever of the two is predicted last before their contact
            // sees the other's next event after it, so the contact is found then.
            let until = best.t.min(self.cal.time_of(ju));
            if until <= self.t {
                continue;
            }
            if let Some((t1, _)) = bounding_sphere_window(&(r - a.r), &(bj.v - a.v), reach)
                && self.t + t1 < until
            {
                if t1 == 0.0 {
                    // Bounding spheres already overlap: a separating axis bounds the contact time.
                    if let Some((partner, first)) = met_partner
                        && partner == ju
                        && let Some((b, contact)) = self.contact_with(first, ju, a, shift)
                    {
                        if first {
                            // The pair has just collided, and the partner is predicted next: its
                            // search of the pair reaches this body's new event (`until`), which
                            // covers what this one would (the rule above). Searched by both,
                            // it took 2.4 % more instructions a collision (X0 = 2, φ 0.5, N 256).
                            continue;
                        }
                        // The pair parts: rarely the first to meet again, it is searched last,
                        // with the shortest horizon.
                        order.push((
                            f64::INFINITY,
                            0.0,
                            until,
                            j,
                            shift,
                            Source::Near(near.len()),
                        ));
                        near.push((b, Some(contact)));
                        continue;
                    }
                    let (kept, slot) = self.axes.get(i, ju);
                    close.push((j, shift, until, kept, slot));
                } else {
                    order.push((t1, t1, until, j, shift, Source::Far));
                }
            }
        }
        // Most close candidates are ruled out by the first step of their ascent: four at a time
        // where the model can (a last group of fewer padded with its first). The others take
        // the rest of the ascent when their turn comes, if the best event found by then leaves
        // them any time (`order`'s loop); else the whole bound at once.
        match &lanes {
            Some(shape) => {
                for group in close.chunks(4) {
                    let lane = |k: usize| {
                        let (j, shift, _, start, _) = group[if k < group.len() { k } else { 0 }];
                        Lane {
                            body: &self.bodies[j as usize],
                            offset: image_offset(shift, self.l),
                            start,
                        }
                    };
                    let steps =
                        first_steps(shape, a, self.t, &[lane(0), lane(1), lane(2), lane(3)]);
                    for (k, &(j, shift, until, start, slot)) in group.iter().enumerate() {
                        let step = steps.lane(k);
                        if step.lower >= until - self.t {
                            // No contact before the horizon: nothing to search.
                            self.axes.put_at(
                                slot,
                                self.bodies.len(),
                                i,
                                j as usize,
                                &step.next_axis,
                            );
                        } else {
                            // Ordered by the first step's bound: the rest of the ascent, whose
                            // estimate ordered them before, is then taken by those whose turn
                            // comes before the best event found (X0 = 2, φ 0.5, N 256: 2.6 %
                            // fewer instructions a collision at Δ_NNL 0.085, 4.2 % at 0.15, for
                            // 0.7 % more searches).
                            let source = Source::Deferred(deferred.len());
                            order.push((step.lower, step.lower, until, j, shift, source));
                            deferred.push(Deferred {
                                start: start.map(|n| n.normalize()),
                                next_axis: step.next_axis,
                                slot,
                            });
                        }
                    }
                }
            }
            None => {
                for &(j, shift, until, start, slot) in &close {
                    let start = start.map(|n| n.normalize());
                    let b = self.candidate_now(j, shift);
                    // The bodies that hold the pair, along its kept axis or else the line of
                    // centres: most candidates end here (39 % at p = 10), before the ascent
                    // solves their support points.
                    let n = start.unwrap_or_else(|| (b.r - a.r).normalize());
                    if self.m.enclosing_bound([i, j as usize], a, &b, &n) >= until - self.t {
                        continue;
                    }
                    let c = (j, shift, until, start, slot);
                    self.bound_close(i, a, b, c, &mut order, &mut near);
                }
            }
        }
        order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        // Likely first partners first, so that the horizon shrinks early; the bound decides skipping.
        for &(_, lower, until, j, shift, source) in &order {
            let until = until.min(best.t);
            let ju = j as usize;
            if self.t + lower >= until {
                if let Source::Deferred(d) = source {
                    let Deferred {
                        next_axis, slot, ..
                    } = deferred[d];
                    self.axes.put_at(slot, self.bodies.len(), i, ju, &next_axis);
                }
                continue;
            }
            let (b, now) = match source {
                Source::Far => (self.candidate_now(j, shift), None),
                Source::Near(k) => {
                    let (b, now) = &mut near[k];
                    (*b, now.take())
                }
                Source::Deferred(d) => {
                    let Deferred { start, slot, .. } = deferred[d];
                    let b = self.candidate_now(j, shift);
                    let q = self.quick_bound_kept(i, a, &b, (j, slot), until, start, Some(lower));
                    if self.t + q.lower >= until {
                        continue;
                    }
                    (b, q.now.map(|(gap, safe)| Known::Gap(gap, safe)))
                }
            };
            let failures = self.m.solver_stats().failures;
            let hit = self.m.predict([i, ju], a, &b, until - self.t, now);
            let stats = self.m.solver_stats();
            if stats.failures > failures && self.failure.is_none() {
                let arr = |v: V3| [v.x, v.y, v.z];
                self.failure = Some(EdmdError::Unresolved(Box::new(crate::UnresolvedContact {
                    quantity: stats.failed.unwrap_or("contact time"),
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
        self.near = near;
        self.order = order;
        self.scratch = cand;
        self.close = close;
        self.deferred = deferred;
        best
    }

    /// Body `j` at the present, at its image `shift`.
    #[inline]
    fn candidate_now(&self, j: u32, shift: [i32; 3]) -> Body {
        let mut b = self.bodies[j as usize].at(self.t);
        b.r += image_offset(shift, self.l);
        b
    }

    /// The quick bound of close candidate `c` (index, image shift, time it must meet before, kept
    /// axis) of body `i` (`a`), `b` the candidate at the present, entered in `order` and `near`:
    /// the shapes without lanes. Apart from the loop that calls it, which the lanes' models
    /// (ellipsoids) compile too and never take: inlined there, it cost them 1–1.6 % more
    /// instructions a collision.
    #[inline(never)]
    fn bound_close(
        &mut self,
        i: usize,
        a: &Body,
        b: Body,
        (j, shift, until, start, slot): Close,
        order: &mut Vec<Order>,
        near: &mut Vec<(Body, Option<Known>)>,
    ) {
        let q = self.quick_bound_kept(i, a, &b, (j, slot), until, start, None);
        order.push((
            q.estimate,
            q.lower,
            until,
            j,
            shift,
            Source::Near(near.len()),
        ));
        near.push((b, q.now.map(|(gap, safe)| Known::Gap(gap, safe))));
    }

    /// [`Rigid::quick_bound`] of body `i` (`a`) and candidate `j` (`b`, at the present) before
    /// time `until`, its ascent started at the pair's kept axis `start`, read from `slot`. The
    /// axis the ascent would try next is kept for the pair, whatever the bound rules. Inlined:
    /// called apart, it cost 0.3 % more instructions a collision (X0 = 2, φ 0.5, N 256).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn quick_bound_kept(
        &mut self,
        i: usize,
        a: &Body,
        b: &Body,
        (j, slot): (u32, SlotOf),
        until: f64,
        start: Option<V3>,
        first: Option<f64>,
    ) -> QuickBound {
        let ju = j as usize;
        let q = self
            .m
            .quick_bound([i, ju], a, b, until - self.t, start.as_ref(), first);
        if let Some(n) = &q.axis {
            self.axes.put_at(slot, self.bodies.len(), i, ju, n);
        }
        q
    }

    /// Body `j`'s candidate image (image shift `shift`) at the present and where it touches `a`,
    /// `j` being `a`'s partner in the collision just resolved and `a` that event's first body
    /// where `first`; `None` where the image is another than the one that collided.
    fn contact_with(
        &self,
        first: bool,
        j: usize,
        a: &Body,
        shift: [i32; 3],
    ) -> Option<(Body, Known)> {
        let (p, q, (xc, _), offset) = self.met?;
        let (p, q) = (p as usize, q as usize);
        let b = self.candidate_now(j as u32, shift);
        // The contact point as the event's first body saw it, its partner's image `offset` away.
        let (off_p, off_q) = (xc - self.bodies[p].r, xc - (self.bodies[q].r + offset));
        let seen = self.bodies[q].r + offset - self.bodies[p].r;
        let (offset_a, offset_b, seen) = if first {
            (off_p, off_q, seen)
        } else {
            (off_q, off_p, -seen)
        };
        // Another image of the partner (any other is a box length away) did not collide.
        ((b.r - a.r - seen).norm_squared() < 0.25 * self.l * self.l)
            .then_some((b, Known::Contact { offset_a, offset_b }))
    }
}

/// How many candidates ahead of the one looked at [`Engine::first_rigid_collision`] asks for.
const PREFETCH_AHEAD: usize = 4;

/// Bodies from which [`Engine::first_rigid_collision`] asks for candidates ahead. Below, a body,
/// its event and its row of axes (about 500 B) all stay in a core's L2 cache (0.5 MB), and the
/// requests were 40 of the 175 instructions spent on each candidate (X0 = 2, N = 256).
const PREFETCH_FROM: usize = 1024;

/// A candidate of a rigid prediction in the order of its search: (estimate, lower bound, time it
/// must meet before, index, image shift, where the rest is kept).
type Order = (f64, f64, f64, u32, [i32; 3], Source);

/// Where [`Order`] keeps what else is known of a candidate.
#[derive(Clone, Copy, Debug)]
enum Source {
    /// Its bounding spheres do not overlap yet: nothing more.
    Far,
    /// Its index in `near`: the candidate at the present, and what is known of the pair.
    Near(usize),
    /// Its index in `deferred`.
    Deferred(usize),
}

/// A close candidate whose quick bound waits for its turn ([`Engine::first_rigid_collision`]).
#[derive(Clone, Copy, Debug)]
struct Deferred {
    /// The pair's kept axis, where the ascent started. The bound of its first step, which the
    /// lanes took, is the candidate's lower bound in `order`.
    start: Option<V3>,
    /// The axis the ascent would try next, kept for the pair if the rest is not taken.
    next_axis: V3,
    /// Where the pair's axis was kept.
    slot: SlotOf,
}

/// A candidate of a rigid prediction whose bounding spheres overlap, before its quick bound:
/// (index, image shift, time it must meet before, the pair's kept axis and where it is kept).
/// In `close`, the axis is as kept ([`PairAxes::get`]): the lanes normalise four at once, and
/// the others normalise it when they use it.
type Close = (u32, [i32; 3], f64, Option<V3>, SlotOf);

/// Image shift of j as seen from i with unwrapped positions: the cell shift plus the image counters.
fn ll_shift(cell: [i8; 3], img_i: [i32; 3], img_j: [i32; 3]) -> [i32; 3] {
    [0, 1, 2].map(|k| cell[k] as i32 + img_i[k] - img_j[k])
}
