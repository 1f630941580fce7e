//! Event calendar: a binary heap (O(log N) insert and extract) whose stale entries are recognised
//! by per-particle event counters, so invalidating all events of a particle is O(1) (Sec. 2.7).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Collision of `a` with `b`; `shift` is the periodic image of b, in box lengths.
    Collision { shift: [i32; 3] },
    /// Particle `a` leaves its cell through the face `dim`, upwards if `up`.
    CellCross { dim: u8, up: bool },
    /// Particle `a` may touch the face of its bounding parallelepiped: its box and list are rebuilt.
    BoxEscape,
}

/// An event; `ca`/`cb` are the counters of `a`/`b` when it was predicted.
#[derive(Clone, Copy, Debug)]
pub struct Event<X> {
    pub t: f64,
    pub a: u32,
    pub b: u32,
    pub ca: u32,
    pub cb: u32,
    pub kind: Kind,
    /// Model-specific payload (the contact point and normal of a rigid-body collision).
    pub extra: X,
}

struct Entry<X>(Event<X>);

impl<X> PartialEq for Entry<X> {
    fn eq(&self, o: &Self) -> bool {
        self.0.t == o.0.t
    }
}
impl<X> Eq for Entry<X> {}
impl<X> PartialOrd for Entry<X> {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl<X> Ord for Entry<X> {
    // Reversed, so that the max-heap yields the earliest event.
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.t.total_cmp(&self.0.t)
    }
}

pub struct Calendar<X> {
    heap: BinaryHeap<Entry<X>>,
}

impl<X> Default for Calendar<X> {
    fn default() -> Self {
        Calendar {
            heap: BinaryHeap::new(),
        }
    }
}

impl<X> Calendar<X> {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn push(&mut self, e: Event<X>) {
        self.heap.push(Entry(e));
    }
    pub fn pop(&mut self) -> Option<Event<X>> {
        self.heap.pop().map(|e| e.0)
    }
    pub fn len(&self) -> usize {
        self.heap.len()
    }
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
    pub fn clear(&mut self) {
        self.heap.clear();
    }
    /// Drops every event for which `valid` is false (stale events pile up otherwise), O(len).
    pub fn retain(&mut self, mut valid: impl FnMut(&Event<X>) -> bool) {
        self.heap.retain(|e| valid(&e.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pops_in_time_order() {
        let mut c = Calendar::new();
        for (i, t) in [3.0, 1.0, 2.0, 0.5].into_iter().enumerate() {
            c.push(Event {
                t,
                a: i as u32,
                b: 0,
                ca: 0,
                cb: 0,
                kind: Kind::BoxEscape,
                extra: (),
            });
        }
        c.retain(|e| e.a != 2);
        let ts: Vec<f64> = std::iter::from_fn(|| c.pop().map(|e| e.t)).collect();
        assert_eq!(ts, vec![0.5, 1.0, 3.0]);
    }
}
