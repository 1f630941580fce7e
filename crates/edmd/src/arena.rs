//! Many short rows in one allocation: the members of each linked cell ([`crate::cells::Cells`])
//! and each body's neighbour list ([`crate::lists::Lists`]).
//!
//! Every row has the same room, so a row is found by its index alone, without a header (a
//! vector's, at an address of its own) loaded first, and rows of neighbouring indices lie side by
//! side. The room is sized for nearly every row, not the longest: a row that outgrows it moves
//! whole to a vector of its own in `spill`, and back once it fits again. Entries keep the order a
//! vector's `push` and `swap_remove` give them, so which rows spill never changes what a loop over
//! a row sees.

/// See the module's documentation. The fields are the crate's for the state files' forms.
#[derive(Clone, Debug)]
pub(crate) struct Arena<T> {
    /// Slots per row.
    pub(crate) room: usize,
    /// Each row's length, or [`SPILLED`] and the index of its vector in `spill`.
    pub(crate) count: Vec<u32>,
    pub(crate) slots: Vec<T>,
    pub(crate) spill: Vec<Vec<T>>,
    /// Vectors of `spill` no row holds.
    pub(crate) free: Vec<u32>,
}

/// The mark of a row whose entries are in `spill`.
pub(crate) const SPILLED: u32 = 1 << 31;

impl<T: Copy> Arena<T> {
    /// `rows` empty rows of `room` slots each, filled with `vacant`.
    pub(crate) fn new(rows: usize, room: usize, vacant: T) -> Self {
        Arena {
            room,
            count: vec![0; rows],
            slots: vec![vacant; rows * room],
            spill: Vec::new(),
            free: Vec::new(),
        }
    }

    /// The index in `spill` of row `i`'s vector, if it spilled.
    #[inline(always)]
    pub(crate) fn spilled(&self, i: usize) -> Option<usize> {
        let count = self.count[i];
        (count & SPILLED != 0).then_some((count & !SPILLED) as usize)
    }

    #[inline]
    pub(crate) fn row(&self, i: usize) -> &[T] {
        match self.spilled(i) {
            None => {
                let start = i * self.room;
                &self.slots[start..start + self.count[i] as usize]
            }
            Some(k) => &self.spill[k],
        }
    }

    #[inline]
    pub(crate) fn len(&self, i: usize) -> usize {
        match self.spilled(i) {
            None => self.count[i] as usize,
            Some(k) => self.spill[k].len(),
        }
    }

    #[inline]
    pub(crate) fn get_mut(&mut self, i: usize, p: usize) -> &mut T {
        debug_assert!(p < self.len(i));
        match self.spilled(i) {
            None => &mut self.slots[i * self.room + p],
            Some(k) => &mut self.spill[k][p],
        }
    }

    /// Asks for entry `p` of row `i` ahead of its use.
    #[inline]
    pub(crate) fn prefetch(&self, i: usize, p: usize) {
        match self.spilled(i) {
            None => crate::prefetch(&self.slots[i * self.room + p]),
            Some(k) => crate::prefetch(&self.spill[k][p]),
        }
    }

    /// Asks for row `i`'s count and the slots `ahead` (counted from its first) that exist.
    #[inline]
    pub(crate) fn prefetch_slots(&self, i: usize, ahead: &[usize]) {
        crate::prefetch(&self.count[i]);
        for &p in ahead {
            if let Some(x) = self.slots.get(i * self.room + p) {
                crate::prefetch(x);
            }
        }
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, i: usize, entry: T) {
        self.push_with(i, || entry);
    }

    /// [`Arena::push`] of the entry `make` builds: built in its slot, field by field. An entry
    /// built first and then moved was stored a field at a time and loaded whole straight after,
    /// which waits for the stores to reach the cache (nearly all the time of a list's links,
    /// `perf`, ellipsoids X0 = 2, φ = 0.5, N = 256).
    #[inline(always)]
    pub(crate) fn push_with(&mut self, i: usize, make: impl FnOnce() -> T) {
        let (len, start) = (self.count[i] as usize, i * self.room);
        if len < self.room {
            self.slots[start + len] = make();
            self.count[i] += 1;
        } else {
            self.push_beyond_room(i, make());
        }
    }

    /// [`Arena::push`] to a row that is spilled, or full (which moves it to a vector of `spill`).
    #[cold]
    #[inline(never)]
    fn push_beyond_room(&mut self, i: usize, entry: T) {
        if let Some(k) = self.spilled(i) {
            self.spill[k].push(entry);
            return;
        }
        let (len, start) = (self.count[i] as usize, i * self.room);
        let k = self.free.pop().unwrap_or_else(|| {
            self.spill.push(Vec::new());
            (self.spill.len() - 1) as u32
        });
        let moved = &mut self.spill[k as usize];
        moved.clear();
        moved.extend_from_slice(&self.slots[start..start + len]);
        moved.push(entry);
        self.count[i] = SPILLED | k;
    }

    /// Removes entry `p` of row `i`, its last entry taking its place: that entry, if one moved.
    /// Inlined, for the reason [`Arena::push_with`] is.
    #[inline(always)]
    pub(crate) fn swap_remove(&mut self, i: usize, p: usize) -> Option<T> {
        let start = i * self.room;
        let Some(k) = self.spilled(i) else {
            let last = self.count[i] as usize - 1;
            self.count[i] -= 1;
            self.slots.swap(start + p, start + last);
            return (p != last).then(|| self.slots[start + p]);
        };
        let row = &mut self.spill[k];
        row.swap_remove(p);
        let moved = (p < row.len()).then(|| row[p]);
        if row.len() <= self.room {
            // It fits again: back to the arena, in the same order.
            self.slots[start..start + row.len()].copy_from_slice(row);
            self.count[i] = row.len() as u32;
            row.clear();
            self.free.push(k as u32);
        }
        moved
    }

    pub(crate) fn clear(&mut self, i: usize) {
        if let Some(k) = self.spilled(i) {
            self.spill[k].clear();
            self.free.push(k as u32);
        }
        self.count[i] = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows against a vector per row (the oracle) under random pushes, swap-removes, writes and
    /// clears that take rows across their room both ways: the same entries in the same order,
    /// the same entry moved by each removal, and a spilled row exactly where it outgrew its room.
    #[test]
    fn rows_hold_what_vectors_would_in_the_same_order() {
        let mut rng = crate::rng::Rng::new(17);
        let (n, room) = (6, 3);
        let mut rows = Arena::new(n, room, (u32::MAX, 0u16));
        let mut oracle: Vec<Vec<(u32, u16)>> = vec![Vec::new(); n];
        for step in 0..20_000u32 {
            let i = (rng.next_u64() % n as u64) as usize;
            let len = oracle[i].len();
            match rng.next_u64() % 7 {
                0..=3 if len < 8 => {
                    let entry = (step, (step % 100) as u16);
                    rows.push(i, entry);
                    oracle[i].push(entry);
                }
                6 => {
                    rows.clear(i);
                    oracle[i].clear();
                }
                _ if len > 0 => {
                    let p = (rng.next_u64() % len as u64) as usize;
                    let moved = rows.swap_remove(i, p);
                    oracle[i].swap_remove(p);
                    assert_eq!(moved, oracle[i].get(p).copied());
                }
                _ => {}
            }
            if step % 3 == 0 && !oracle[i].is_empty() {
                let p = (rng.next_u64() % oracle[i].len() as u64) as usize;
                rows.get_mut(i, p).1 = p as u16;
                oracle[i][p].1 = p as u16;
            }
            for (k, row) in oracle.iter().enumerate() {
                assert_eq!(rows.row(k), &row[..], "row {k} at step {step}");
                assert_eq!(rows.len(k), row.len());
                assert_eq!(rows.spilled(k).is_some(), row.len() > room, "row {k}");
            }
            let spilled = (0..n).filter(|&k| rows.spilled(k).is_some()).count();
            assert_eq!(rows.free.len() + spilled, rows.spill.len());
        }
        assert!(rows.spill.len() >= 2, "rows never spilled");
    }
}
