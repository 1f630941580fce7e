//! Event calendar (Sec. 2.7): one event per particle, in a binary min-heap on time that knows
//! where each particle's entry is. A particle's new event replaces its old one in place (O(log N)
//! sift from where it sits), so the calendar never holds stale events: with one heap entry per
//! particle there are fewer entries and no stale pops, and re-scheduling the particle whose event
//! was just taken is a single sift down from the root.

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
#[derive(Clone, Copy, Debug)]
struct Entry {
    t: f64,
    a: u32,
}

const NONE: u32 = u32::MAX;

pub struct Calendar<X> {
    /// Min-heap on `t`.
    heap: Vec<Entry>,
    /// `heap[pos[a]].a == a` for every particle with an event, `NONE` for the others.
    pos: Vec<u32>,
    /// Each particle's event (meaningful where `pos` is not `NONE`).
    events: Vec<Event<X>>,
}

impl<X: Copy + Default> Calendar<X> {
    /// An empty calendar for particles 0..n.
    pub fn new(n: usize) -> Self {
        Calendar {
            heap: Vec::with_capacity(n),
            pos: vec![NONE; n],
            events: vec![
                Event {
                    t: f64::INFINITY,
                    a: 0,
                    b: 0,
                    cb: 0,
                    kind: Kind::BoxEscape,
                    extra: X::default(),
                };
                n
            ],
        }
    }
}

impl<X: Copy> Calendar<X> {
    /// Makes `e` the event of particle `e.a`, replacing the one it had. Times must not be NaN.
    pub fn schedule(&mut self, e: Event<X>) {
        let a = e.a as usize;
        self.events[a] = e;
        let item = Entry { t: e.t, a: e.a };
        match self.pos[a] {
            NONE => {
                self.heap.push(item);
                self.sift_up(self.heap.len() - 1, item);
            }
            i => self.sift(i as usize, item),
        }
    }

    /// Particle `a` has no event any more.
    pub fn cancel(&mut self, a: usize) {
        let i = self.pos[a];
        if i == NONE {
            return;
        }
        self.pos[a] = NONE;
        let last = self
            .heap
            .pop()
            .expect("a scheduled particle is in the heap");
        if (i as usize) < self.heap.len() {
            self.sift(i as usize, last);
        }
    }

    /// The earliest event.
    pub fn first(&self) -> Option<&Event<X>> {
        self.heap.first().map(|e| &self.events[e.a as usize])
    }

    /// Puts `item` at the hole `i`, or above or below it where the heap order wants it.
    fn sift(&mut self, i: usize, item: Entry) {
        if i > 0 && item.t < self.heap[(i - 1) / 2].t {
            self.sift_up(i, item);
        } else {
            self.sift_down(i, item);
        }
    }

    /// Stores `item` at `i`.
    fn put(&mut self, i: usize, item: Entry) {
        self.heap[i] = item;
        self.pos[item.a as usize] = i as u32;
    }

    /// Puts `item` at the hole `i` or above it.
    fn sift_up(&mut self, mut i: usize, item: Entry) {
        while i > 0 {
            let p = (i - 1) / 2;
            let parent = self.heap[p];
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
        let n = self.heap.len();
        loop {
            let l = 2 * i + 1;
            if l >= n {
                break;
            }
            // The earlier child, by arithmetic rather than a select, which LLVM would make a
            // branch: which child it is is a coin flip. A lone child is compared with itself.
            let r = (l + 1).min(n - 1);
            let c = l + usize::from(self.heap[r].t < self.heap[l].t);
            let child = self.heap[c];
            if child.t >= item.t {
                break;
            }
            self.put(i, child);
            i = c;
        }
        self.put(i, item);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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
        #[test]
        fn first_is_the_earliest_latest_event(
            ops in prop::collection::vec((0usize..12, prop::option::weighted(0.8, 0.0f64..10.0)), 1..300)
        ) {
            let mut cal = Calendar::new(12);
            let mut table: Vec<Option<f64>> = vec![None; 12];
            for (a, t) in ops {
                match t {
                    Some(t) => cal.schedule(event(a, t)),
                    None => cal.cancel(a),
                }
                table[a] = t;
                let want = table.iter().flatten().fold(f64::INFINITY, |m, &t| m.min(t));
                prop_assert_eq!(cal.heap.len(), table.iter().flatten().count());
                prop_assert_eq!(cal.first().map_or(f64::INFINITY, |e| e.t), want);
                if let Some(e) = cal.first() {
                    prop_assert_eq!(table[e.a as usize], Some(want));
                }
                for (i, e) in cal.heap.iter().enumerate() {
                    prop_assert_eq!(cal.pos[e.a as usize] as usize, i);
                    prop_assert!(i == 0 || cal.heap[(i - 1) / 2].t <= e.t);
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
        while let Some(&e) = c.first() {
            ts.push(e.t);
            c.cancel(e.a as usize);
        }
        assert_eq!(ts, vec![1.0, 2.5, 3.0]);
    }
}
