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

/// The partners of one row, in one cache line: a lookup compares all of them at once and reads
/// the one axis it finds. Partners and axes side by side took four lines a lookup, scanned one
/// slot after another.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct Partners([u32; SLOTS]);

/// The axes of all pairs, [`SLOTS`] per body, allocated when the first is kept (never, for
/// spheres). Saved as [`Saved`], the form it had when partners and axes were kept together.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Saved", into = "Saved")]
pub(crate) struct PairAxes {
    partners: Vec<Partners>,
    /// Each slot's direction, in single precision: a start needs no more.
    axes: Vec<[f32; 3]>,
    /// The slot of each row to fill next when its pair is not kept yet.
    next: Vec<u8>,
}

/// The slot of a row that held a pair when [`PairAxes::get`] looked, or none.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SlotOf(u8);

impl SlotOf {
    const NONE: SlotOf = SlotOf(u8::MAX);
}

/// A kept axis as state files hold it: the partner and the direction.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
struct Slot(u32, [f32; 3]);

/// [`PairAxes`] as state files hold it.
#[derive(Serialize, Deserialize)]
struct Saved {
    slots: Vec<Slot>,
    next: Vec<u8>,
}

impl TryFrom<Saved> for PairAxes {
    type Error = String;

    fn try_from(saved: Saved) -> Result<Self, String> {
        if saved.slots.len() != saved.next.len() * SLOTS {
            return Err(format!(
                "{} axes kept for {} rows of {SLOTS}",
                saved.slots.len(),
                saved.next.len()
            ));
        }
        let partners = saved
            .slots
            .chunks(SLOTS)
            .map(|row| Partners(std::array::from_fn(|k| row[k].0)))
            .collect();
        Ok(PairAxes {
            partners,
            axes: saved.slots.iter().map(|s| s.1).collect(),
            next: saved.next,
        })
    }
}

impl From<PairAxes> for Saved {
    fn from(axes: PairAxes) -> Self {
        let partners = axes.partners.iter().flat_map(|row| row.0);
        Saved {
            slots: partners.zip(axes.axes).map(|(j, n)| Slot(j, n)).collect(),
            next: axes.next,
        }
    }
}

impl PairAxes {
    pub(crate) fn is_empty(&self) -> bool {
        self.partners.is_empty()
    }

    /// The axis last kept for the pair, oriented from `i` towards `j`, as kept: of about unit
    /// length, in single precision (a gap along it would be scaled by its length). Callers
    /// normalise it; the lanes of [`crate::first_step`] four at a time. With it, where the pair
    /// is kept, for [`PairAxes::put_at`]: a prediction reads a close candidate's axis, then keeps
    /// the pair's next one there without searching the row again.
    #[inline]
    pub(crate) fn get(&self, i: usize, j: usize) -> (Option<V3>, SlotOf) {
        let (row, partner, sign) = Self::key(i, j);
        let Some(k) = self.partners.get(row).and_then(|p| p.slot_of(partner)) else {
            return (None, SlotOf::NONE);
        };
        let [x, y, z] = self.axes[row * SLOTS + k];
        let n = V3::new(f64::from(x), f64::from(y), f64::from(z)) * sign;
        (Some(n), SlotOf(k as u8))
    }

    /// Asks for the row that holds the pair ahead of [`PairAxes::get`]: at N = 10⁵ its partners'
    /// line and its axes' three are seldom in cache.
    #[inline]
    pub(crate) fn prefetch(&self, i: usize, j: usize) {
        let row = Self::key(i, j).0;
        if let Some(partners) = self.partners.get(row) {
            crate::prefetch(partners);
        }
        // Every fifth axis, 60 bytes apart: one in each line the row's 192 bytes touch.
        for k in (row * SLOTS..(row + 1) * SLOTS).step_by(5) {
            if let Some(axis) = self.axes.get(k) {
                crate::prefetch(axis);
            }
        }
    }

    /// Keeps `n`, oriented from `i` towards `j`, for the pair; `bodies` sizes the rows.
    // Inlined, `n` comes in registers. Called, it was stored a component at a time and loaded
    // two at a time straight after, which waits for both stores to reach the cache (half of this
    // function's time, `perf`, X0 = 2, φ = 0.5, N = 256).
    #[inline(always)]
    pub(crate) fn put(&mut self, bodies: usize, i: usize, j: usize, n: &V3) {
        if self.partners.is_empty() {
            self.allocate(bodies);
        }
        let (row, partner, sign) = Self::key(i, j);
        let n = n * sign;
        let k = match self.partners[row].slot_of(partner) {
            Some(k) => k,
            None => {
                let next = &mut self.next[row];
                let k = usize::from(*next);
                *next = ((k + 1) % SLOTS) as u8;
                self.partners[row].0[k] = partner;
                k
            }
        };
        self.axes[row * SLOTS + k] = [n.x as f32, n.y as f32, n.z as f32];
    }

    /// [`PairAxes::put`] where [`PairAxes::get`] found the pair's slot: kept there if the
    /// pair still holds it (another pair may have taken it since, in its row's turn).
    #[inline(always)]
    pub(crate) fn put_at(&mut self, slot: SlotOf, bodies: usize, i: usize, j: usize, n: &V3) {
        let (row, partner, sign) = Self::key(i, j);
        let k = usize::from(slot.0);
        match self.partners.get(row) {
            Some(p) if k < SLOTS && p.0[k] == partner => {
                let n = n * sign;
                self.axes[row * SLOTS + k] = [n.x as f32, n.y as f32, n.z as f32];
            }
            _ => self.put(bodies, i, j, n),
        }
    }

    /// Rows for `bodies` bodies, all slots empty: at the first axis kept (never, for spheres).
    #[cold]
    fn allocate(&mut self, bodies: usize) {
        self.partners = vec![Partners([EMPTY; SLOTS]); bodies];
        self.axes = vec![[0.0; 3]; bodies * SLOTS];
        self.next = vec![0; bodies];
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

impl Partners {
    /// The slot that holds `partner` (a row holds each partner once at most): the sixteen
    /// compared at once, four to a vector register (SSE2, which every x86-64 has).
    #[inline]
    fn slot_of(&self, partner: u32) -> Option<usize> {
        let hits = self.hits(partner);
        (hits != 0).then(|| hits.trailing_zeros() as usize)
    }

    /// A bit per slot that holds `partner`.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn hits(&self, partner: u32) -> u32 {
        use std::arch::x86_64::*;
        let mut hits = 0;
        // SAFETY: SSE2 is part of every x86-64 (the intrinsics need no feature detection), and
        // each load reads the four u32 of one chunk (unaligned loads).
        unsafe {
            let key = _mm_set1_epi32(partner as i32);
            for (k, four) in self.0.chunks_exact(4).enumerate() {
                let v = _mm_loadu_si128(four.as_ptr().cast());
                let eq = _mm_castsi128_ps(_mm_cmpeq_epi32(v, key));
                hits |= (_mm_movemask_ps(eq) as u32) << (4 * k);
            }
        }
        hits
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn hits(&self, partner: u32) -> u32 {
        (self.0.iter().enumerate()).fold(0, |m, (k, &p)| m | (u32::from(p == partner) << k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An axis comes back oriented from whichever body asks, in single precision, and a row
    /// forgets its oldest pair once more partners than it has slots are kept.
    #[test]
    fn axes_come_back_oriented_and_rows_forget_the_oldest() {
        let mut axes = PairAxes::default();
        assert_eq!(axes.get(0, 1).0, None);
        let n = V3::new(0.6, -0.8, 0.0);
        axes.put(40, 3, 7, &n);
        let as_kept = V3::new(f64::from(0.6f32), f64::from(-0.8f32), 0.0);
        assert_eq!(axes.get(3, 7).0, Some(as_kept));
        assert_eq!(axes.get(7, 3).0, Some(-as_kept));
        axes.put(40, 7, 3, &V3::x());
        assert!((axes.get(3, 7).0.expect("kept") + V3::x()).norm() < 1e-15);
        for j in 8..8 + SLOTS {
            axes.put(40, 3, j, &V3::z());
        }
        assert_eq!(
            axes.get(3, 7).0,
            None,
            "the oldest pair of row 3 is forgotten"
        );
        assert!(axes.get(8, 3).0.is_some() && axes.get(3, 8 + SLOTS - 1).0.is_some());
        assert_eq!(axes.get(2, 7).0, None);
    }

    /// An axis kept at the slot where it was read goes to its pair: there, while the pair holds
    /// the slot; elsewhere in the row, without touching the pair that took it, once the row's
    /// turn has given it away.
    #[test]
    fn an_axis_kept_where_it_was_read_goes_to_its_own_pair() {
        let mut axes = PairAxes::default();
        assert_eq!(axes.get(3, 7), (None, SlotOf::NONE));
        axes.put_at(SlotOf::NONE, 40, 7, 3, &V3::x());
        let (kept, slot) = axes.get(3, 7);
        assert_eq!(kept, Some(-V3::x()));
        axes.put_at(slot, 40, 3, 7, &V3::y());
        assert_eq!(axes.get(3, 7), (Some(V3::y()), slot), "kept in its slot");
        for j in 8..8 + SLOTS {
            axes.put(40, 3, j, &V3::z());
        }
        assert_eq!(axes.get(3, 7).0, None, "its slot was given away");
        axes.put_at(slot, 40, 3, 7, &V3::x());
        assert_eq!(axes.get(3, 7).0, Some(V3::x()));
        let others = (8..8 + SLOTS).filter(|&j| axes.get(3, j).0 == Some(V3::z()));
        assert_eq!(
            others.count(),
            SLOTS - 1,
            "only the oldest other pair gave way"
        );
    }

    /// State files keep the form axes were saved in before partners had a line of their own:
    /// one written in that form reads back to the same axes, and is written back the same; one
    /// whose rows and slots disagree is refused.
    #[test]
    fn axes_are_saved_in_the_form_state_files_hold() {
        let mut slots = vec![Slot(EMPTY, [0.0; 3]); 2 * SLOTS];
        slots[5] = Slot(1, [0.0, 0.6, -0.8]);
        let old = serde_json::json!({ "slots": slots, "next": [6, 0] });
        let axes: PairAxes = serde_json::from_value(old.clone()).expect("old form");
        let n = axes.get(1, 0).0.expect("kept");
        assert!((n - V3::new(0.0, -0.6, 0.8)).norm() < 1e-7);
        assert_eq!(axes.get(1, 2).0, None, "row 1 keeps nothing");
        assert_eq!(serde_json::to_value(&axes).expect("saved"), old);
        let mut moved = axes.clone();
        moved.put(2, 1, 0, &V3::x());
        moved.put(2, 1, 2, &V3::y());
        let back: PairAxes =
            serde_json::from_value(serde_json::to_value(&moved).expect("saved")).expect("read");
        let short = serde_json::json!({ "slots": slots, "next": [6, 0, 0] });
        assert!(
            serde_json::from_value::<PairAxes>(short).is_err(),
            "a row without slots"
        );
        assert_eq!(back, moved);
        assert_eq!(back.next, vec![6, 1], "row 1's next slot is saved");
        assert!((back.get(0, 1).0.expect("kept") + V3::x()).norm() < 1e-15);
    }
}
