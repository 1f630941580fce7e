//! Separating axes kept from one prediction to the next, as starts for the next quick bound.
//!
//! Every direction gives a rigorous lower bound on the distance (the support gap of
//! [`crate::contact::separating_axis`]), so a kept axis can be stale without harm: it only
//! starts the ascent closer to the best one. Between two predictions that look at the same pair
//! the bodies have moved about a mean free path and turned little, so last time's best axis is
//! near this time's: measured at X0 = 2, φ = 0.5 (MEASUREMENTS.md, "Axes kept between
//! predictions"), the bounds get tighter and fewer contact searches run.
//!
//! Each pair is kept in the row of its lower index, oriented from it to the higher one, in a few
//! slots per body filled round-robin: a pair not looked at for a while is forgotten. What a
//! prediction finds depends on the axes, so they are part of the engine's saved state.

use serde::{Deserialize, Serialize};

use crate::geometry::V3;

/// Slots per body: a body's row holds the pairs with higher-indexed partners (about half of the
/// 10–20 candidates a prediction looks at closely, at φ = 0.5).
const SLOTS: usize = 16;
const EMPTY: u32 = u32::MAX;

/// A kept axis: the partner and the direction (single precision: a start needs no more).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Slot(u32, [f32; 3]);

/// The axes of all pairs, [`SLOTS`] per body, allocated when the first is kept (never, for
/// spheres).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct PairAxes {
    slots: Vec<Slot>,
    /// The slot of each row to fill next when its pair is not kept yet.
    next: Vec<u8>,
}

impl PairAxes {
    pub(crate) fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The unit axis last kept for the pair, oriented from `i` towards `j`.
    pub(crate) fn get(&self, i: usize, j: usize) -> Option<V3> {
        let (row, partner, sign) = Self::key(i, j);
        let slots = self.slots.get(row * SLOTS..(row + 1) * SLOTS)?;
        let Slot(_, [x, y, z]) = slots.iter().find(|s| s.0 == partner)?;
        let n = V3::new(f64::from(*x), f64::from(*y), f64::from(*z));
        // A single-precision unit vector is not one in double: its gap would be scaled by |n|.
        Some(n.normalize() * sign)
    }

    /// Asks for the row that holds the pair ahead of [`PairAxes::get`]: at N = 10⁵ its four
    /// cache lines are seldom in cache.
    #[inline]
    pub(crate) fn prefetch(&self, i: usize, j: usize) {
        let row = Self::key(i, j).0 * SLOTS;
        for k in (row..row + SLOTS).step_by(4) {
            if let Some(slot) = self.slots.get(k) {
                crate::prefetch(slot);
            }
        }
    }

    /// Keeps `n`, oriented from `i` towards `j`, for the pair; `bodies` sizes the rows.
    pub(crate) fn put(&mut self, bodies: usize, i: usize, j: usize, n: &V3) {
        if self.slots.is_empty() {
            self.slots = vec![Slot(EMPTY, [0.0; 3]); bodies * SLOTS];
            self.next = vec![0; bodies];
        }
        let (row, partner, sign) = Self::key(i, j);
        let n = n * sign;
        let slot = Slot(partner, [n.x as f32, n.y as f32, n.z as f32]);
        let slots = &mut self.slots[row * SLOTS..(row + 1) * SLOTS];
        if let Some(s) = slots.iter_mut().find(|s| s.0 == partner) {
            *s = slot;
        } else {
            let k = &mut self.next[row];
            slots[usize::from(*k)] = slot;
            *k = ((usize::from(*k) + 1) % SLOTS) as u8;
        }
    }

    /// The row, the partner within it and the sign that orients an axis from `i` to `j`.
    fn key(i: usize, j: usize) -> (usize, u32, f64) {
        if i < j {
            (i, j as u32, 1.0)
        } else {
            (j, i as u32, -1.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An axis comes back oriented from whichever body asks, as a unit vector, and a row forgets
    /// its oldest pair once more partners than it has slots are kept.
    #[test]
    fn axes_come_back_oriented_and_rows_forget_the_oldest() {
        let mut axes = PairAxes::default();
        assert_eq!(axes.get(0, 1), None);
        let n = V3::new(0.6, -0.8, 0.0);
        axes.put(40, 3, 7, &n);
        let from_3 = axes.get(3, 7).expect("kept");
        let from_7 = axes.get(7, 3).expect("kept");
        assert!((from_3 - n).norm() < 1e-7 && (from_7 + n).norm() < 1e-7);
        assert!((from_7.norm() - 1.0).abs() < 1e-15);
        axes.put(40, 7, 3, &V3::x());
        assert!((axes.get(3, 7).expect("kept") + V3::x()).norm() < 1e-15);
        for j in 8..8 + SLOTS {
            axes.put(40, 3, j, &V3::z());
        }
        assert_eq!(
            axes.get(3, 7),
            None,
            "the oldest pair of row 3 is forgotten"
        );
        assert!(axes.get(8, 3).is_some() && axes.get(3, 8 + SLOTS - 1).is_some());
        assert_eq!(axes.get(2, 7), None);
    }
}
