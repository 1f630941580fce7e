//! Event calendar (Sec. 2.7): one event per particle, in a 4-ary min-heap on time that knows
//! where each particle's entry is. A particle's new event replaces its old one in place (O(log N)
//! sift from where it sits), so the calendar never holds stale events: with one heap entry per
//! particle there are fewer entries and no stale pops, and re-scheduling the particle whose event
//! was just taken is a single sift down from the root.
//!
//! Four children per node, all in one cache line: a sift visits half the levels of a binary heap,
//! one line each. Spheres at N = 16384, φ = 0.45 (cachegrind, per collision): the calendar's
//! misses in a 32 KiB D1 fall from 43 to 21 and in a 512 KiB last level from 14.1 to 9.2.

use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Kind {
    /// Collision of `a` with `b`; `shift` is the periodic image of b, in box lengths.
    Collision { shift: [i32; 3] },
    /// Particle `a` leaves its cell through the face `dim`, upwards if `up`.
    CellCross { dim: u8, up: bool },
    /// Particle `a` may touch the face of its bounding parallelepiped: its box and list are rebuilt.
    BoxEscape,
}

/// An event of particle `a`; `cb` is the collision counter of `b` when it was predicted (`a` is
/// predicted anew whenever its counter changes, which replaces the event).
#[derive(Clone, Copy, Debug)]
pub struct Event<X> {
    pub t: f64,
    pub a: u32,
    pub b: u32,
    pub cb: u32,
    pub kind: Kind,
    /// Model-specific payload (the contact point and normal of a rigid-body collision).
    pub extra: X,
}

/// A heap entry: the time of a particle's event, and the particle.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
struct Entry {
    t: f64,
    a: u32,
}

const NONE: u32 = u32::MAX;

/// Where the heap has no entry: later than any event, so that a sift compares all four children
/// of a node without checking which exist.
const VACANT: Entry = Entry {
    t: f64::INFINITY,
    a: NONE,
};

/// The four children of one node, in one cache line.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[repr(C, align(64))]
struct Siblings([Entry; 4]);

#[derive(Clone, Serialize, Deserialize)]
pub struct Calendar<X> {
    /// Min-heap on `t`: node k has children 4k + 1 … 4k + 4, which are `groups[k + 1]`; the root
    /// is the last lane of `groups[0]`. Lanes past `len` are [`VACANT`].
    groups: Vec<Siblings>,
    len: usize,
    /// `entry(pos[a]).a == a` for every particle with an event, `NONE` for the others.
    pos: Vec<u32>,
    /// Each particle's event (meaningful where `pos` is not `NONE`).
    events: Vec<Stored<X>>,
    /// Each particle's event time, +∞ where it has none, where [`Calendar::keep_times`] asked
    /// for them (empty otherwise): what [`Calendar::time_of`] reads, 8 bytes a particle where a
    /// rigid body's event takes 96. A rigid prediction asks it of every candidate, and
    /// candidates are numbered near their body (along a Z curve), so their times share lines:
    /// ellipsoids X0 = 2, φ 0.5, N 16,384 missed the second-level cache on 33 of these reads a
    /// collision through `pos` and `events` (MEASUREMENTS.md). Not saved: the events give them.
    #[serde(skip)]
    times: Vec<f64>,
}

/// An event as the calendar keeps it: without its particle, which is its index. A sphere's is 32
/// bytes, aligned to 32 so that none straddles two cache lines (40 bytes, unaligned, made half of
/// them do).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[repr(C, align(32))]
struct Stored<X> {
    t: f64,
    b: u32,
    cb: u32,
    kind: Kind,
    extra: X,
}

impl<X: Copy> Stored<X> {
    fn of(e: &Event<X>) -> Self {
        Stored {
            t: e.t,
            b: e.b,
            cb: e.cb,
            kind: e.kind,
            extra: e.extra,
        }
    }

    fn event(&self, a: u32) -> Event<X> {
        Event {
            t: self.t,
            a,
            b: self.b,
            cb: self.cb,
            kind: self.kind,
            extra: self.extra,
        }
    }
}

impl<X: Copy + Default> Calendar<X> {
    /// An empty calendar for particles 0..n.
    pub fn new(n: usize) -> Self {
        Calendar {
            groups: vec![Siblings([VACANT; 4]); n / 4 + 2],
            len: 0,
            pos: vec![NONE; n],
            events: vec![
                Stored {
                    t: f64::INFINITY,
                    b: 0,
                    cb: 0,
                    kind: Kind::BoxEscape,
                    extra: X::default(),
                };
                n
            ],
            times: Vec::new(),
        }
    }
}

impl<X: Copy> Calendar<X> {
    /// Makes `e` the event of particle `e.a`, replacing the one it had. Times must not be NaN.
    #[inline]
    pub fn schedule(&mut self, e: Event<X>) {
        let a = e.a as usize;
        self.events[a] = Stored::of(&e);
        if let Some(t) = self.times.get_mut(a) {
            *t = e.t;
        }
        let item = Entry { t: e.t, a: e.a };
        match self.pos[a] {
            NONE => {
                self.len += 1;
                self.sift_up(self.len - 1, item);
            }
            i => self.sift(i as usize, item),
        }
    }

    /// Asks for what scheduling an event of particle `a` will read, ahead of its use.
    #[inline]
    pub fn prefetch(&self, a: usize) {
        crate::prefetch(&self.pos[a]);
        crate::prefetch(&self.events[a]);
    }

    /// Asks for the events that may come after the earliest one: those of the root's children,
    /// one of which is the earliest once the root's particle has been scheduled anew.
    #[inline]
    pub fn prefetch_next(&self) {
        if let Some(children) = self.groups.get(1) {
            for c in &children.0 {
                if let Some(e) = self.events.get(c.a as usize) {
                    crate::prefetch(e);
                }
            }
        }
    }

    /// Particle `a` has no event any more.
    pub fn cancel(&mut self, a: usize) {
        let i = self.pos[a];
        if i == NONE {
            return;
        }
        self.pos[a] = NONE;
        if let Some(t) = self.times.get_mut(a) {
            *t = f64::INFINITY;
        }
        self.len -= 1;
        let last = std::mem::replace(self.entry_mut(self.len), VACANT);
        if (i as usize) < self.len {
            self.sift(i as usize, last);
        }
    }

    /// The time of particle `a`'s event, +∞ where it has none.
    #[inline]
    pub fn time_of(&self, a: usize) -> f64 {
        match self.times.get(a) {
            Some(&t) => t,
            None => self.event_time(a),
        }
    }

    /// Particle `a`'s event time as its event holds it, +∞ where it has none.
    fn event_time(&self, a: usize) -> f64 {
        if self.pos[a] == NONE {
            f64::INFINITY
        } else {
            self.events[a].t
        }
    }

    /// Keeps every particle's event time in an array of its own from now on, for
    /// [`Calendar::time_of`] to read.
    pub fn keep_times(&mut self) {
        self.times = (0..self.pos.len()).map(|a| self.event_time(a)).collect();
    }

    /// The earliest event.
    pub fn first(&self) -> Option<Event<X>> {
        (self.len > 0).then(|| {
            let a = self.entry(0).a;
            self.events[a as usize].event(a)
        })
    }

    fn entry(&self, k: usize) -> &Entry {
        &self.groups[k.div_ceil(4)].0[(k + 3) % 4]
    }

    fn entry_mut(&mut self, k: usize) -> &mut Entry {
        &mut self.groups[k.div_ceil(4)].0[(k + 3) % 4]
    }

    /// Puts `item` at the hole `i`, or above or below it where the heap order wants it.
    fn sift(&mut self, i: usize, item: Entry) {
        if i > 0 && item.t < self.entry((i - 1) / 4).t {
            self.sift_up(i, item);
        } else {
            self.sift_down(i, item);
        }
    }

    /// Stores `item` at `i`.
    fn put(&mut self, i: usize, item: Entry) {
        *self.entry_mut(i) = item;
        self.pos[item.a as usize] = i as u32;
    }

    /// Puts `item` at the hole `i` or above it.
    fn sift_up(&mut self, mut i: usize, item: Entry) {
        while i > 0 {
            let p = (i - 1) / 4;
            let parent = *self.entry(p);
            if item.t >= parent.t {
                break;
            }
            self.put(i, parent);
            i = p;
        }
        self.put(i, item);
    }

    /// Puts `item` at the hole `i` or below it.
    fn sift_down(&mut self, mut i: usize, item: Entry) {
        while 4 * i + 1 < self.len {
            // The next level's four groups are adjacent: asked for while this level is decided,
            // so that the walk down does not wait on memory at every level.
            for next in self.groups.iter().skip(4 * i + 2).take(4) {
                crate::prefetch(next);
            }
            let c = &self.groups[i + 1].0;
            // The earliest child (the first among equal times) by arithmetic rather than
            // selects, which LLVM would make branches: which child it is is a coin flip.
            let l = usize::from(c[1].t < c[0].t);
            let r = 2 + usize::from(c[3].t < c[2].t);
            let k = if c[r].t < c[l].t { r } else { l };
            let child = c[k];
            if child.t >= item.t {
                break;
            }
            let at = 4 * i + 1 + k;
            self.put(i, child);
            i = at;
        }
        self.put(i, item);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_sphere_event_fills_half_a_cache_line() {
        assert_eq!(std::mem::size_of::<Stored<()>>(), 32);
        assert_eq!(std::mem::align_of::<Stored<()>>(), 32);
    }

    fn event(a: usize, t: f64) -> Event<()> {
        Event {
            t,
            a: a as u32,
            b: 0,
            cb: 0,
            kind: Kind::BoxEscape,
            extra: (),
        }
    }

    proptest! {
        /// Against a plain table of each particle's latest event: after any sequence of schedules
        /// and cancellations, the first event is the earliest one and the heap and positions agree.
        /// 70 particles fill four levels of the heap. The times are asked for from their own
        /// array after `keep_from` operations (taken from the events then), before from the
        /// events.
        #[test]
        fn first_is_the_earliest_latest_event(
            ops in prop::collection::vec((0usize..70, prop::option::weighted(0.85, 0.0f64..10.0)), 1..600),
            keep_from in 0usize..700,
        ) {
            let mut cal = Calendar::new(70);
            let mut table: Vec<Option<f64>> = vec![None; 70];
            for (step, (a, t)) in ops.into_iter().enumerate() {
                if step == keep_from {
                    cal.keep_times();
                }
                match t {
                    Some(t) => cal.schedule(event(a, t)),
                    None => cal.cancel(a),
                }
                table[a] = t;
                let want = table.iter().flatten().fold(f64::INFINITY, |m, &t| m.min(t));
                prop_assert_eq!(cal.len, table.iter().flatten().count());
                for (b, t) in table.iter().enumerate() {
                    prop_assert_eq!(cal.time_of(b), t.unwrap_or(f64::INFINITY));
                }
                prop_assert_eq!(cal.first().map_or(f64::INFINITY, |e| e.t), want);
                if let Some(e) = cal.first() {
                    prop_assert_eq!(table[e.a as usize], Some(want));
                }
                for i in 0..cal.len {
                    let e = cal.entry(i);
                    prop_assert_eq!(cal.pos[e.a as usize] as usize, i);
                    prop_assert!(i == 0 || cal.entry((i - 1) / 4).t <= e.t);
                }
                // Every lane past the last entry is vacant, so sifts may compare whole groups.
                for i in cal.len..4 * cal.groups.len() - 3 {
                    prop_assert_eq!(cal.entry(i).a, NONE);
                }
            }
        }
    }

    #[test]
    fn drains_in_time_order() {
        let mut c = Calendar::new(4);
        for (a, t) in [3.0, 1.0, 2.0, 0.5].into_iter().enumerate() {
            c.schedule(event(a, t));
        }
        c.schedule(event(3, 2.5));
        c.cancel(2);
        let mut ts = Vec::new();
        while let Some(e) = c.first() {
            ts.push(e.t);
            c.cancel(e.a as usize);
        }
        assert_eq!(ts, vec![1.0, 2.5, 3.0]);
    }
}
