//! Linked cells in a periodic cubic box (Sec. 2.6). With at least 3 cells per side the 27 cells
//! around a particle are distinct, so each neighbouring cell fixes one periodic image.

use crate::geometry::V3;

/// What a cell holds: a particle index, possibly with data kept beside it for the loops over
/// neighbouring cells.
pub trait Member: Copy {
    fn particle(&self) -> u32;
}

impl Member for u32 {
    fn particle(&self) -> u32 {
        *self
    }
}

#[derive(Clone, Debug)]
pub struct Cells<T = u32> {
    /// Cells per side.
    pub m: usize,
    pub side: f64,
    members: Vec<Vec<T>>,
    /// The 27 neighbours of every cell, computed once (the hot loop of the sphere path reads them).
    table: Vec<[Neighbour; 27]>,
}

/// A neighbouring cell and the image shift (in box lengths) of the particles in it.
#[derive(Clone, Copy, Debug)]
pub struct Neighbour {
    pub cell: usize,
    pub shift: [i8; 3],
}

impl<T: Member> Cells<T> {
    /// Cells of side ≥ `min_side` in a box of side `l`; `None` if fewer than 3 fit per side.
    pub fn new(l: f64, min_side: f64) -> Option<Self> {
        let m = (l / min_side).floor();
        // Also rejects NaN.
        if m.is_nan() || m < 3.0 {
            return None;
        }
        let m = m as usize;
        let mut c = Cells {
            m,
            side: l / m as f64,
            members: vec![Vec::new(); m * m * m],
            table: Vec::new(),
        };
        c.table = (0..m * m * m)
            .map(|idx| {
                let cc = c.coords(idx);
                std::array::from_fn(|k| {
                    let k = k as i32;
                    c.neighbour(cc, [k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1])
                })
            })
            .collect();
        Some(c)
    }

    pub fn coords_of(&self, r: &V3) -> [usize; 3] {
        let c = |x: f64| ((x / self.side).floor() as isize).rem_euclid(self.m as isize) as usize;
        [c(r.x), c(r.y), c(r.z)]
    }

    pub fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.m * (c[1] + self.m * c[2])
    }

    pub fn coords(&self, idx: usize) -> [usize; 3] {
        [
            idx % self.m,
            (idx / self.m) % self.m,
            idx / (self.m * self.m),
        ]
    }

    pub fn insert(&mut self, cell: usize, member: T) {
        self.members[cell].push(member);
    }

    /// Removes particle `i` from `cell`.
    pub fn remove(&mut self, cell: usize, i: u32) {
        let v = &mut self.members[cell];
        if let Some(p) = v.iter().position(|m| m.particle() == i) {
            v.swap_remove(p);
        }
    }

    pub fn members(&self, cell: usize) -> &[T] {
        &self.members[cell]
    }

    /// The cell at offset `d` (each component in −1..=1) from `c`, with the image shift.
    pub fn neighbour(&self, c: [usize; 3], d: [i32; 3]) -> Neighbour {
        let m = self.m as i32;
        let mut out = [0usize; 3];
        let mut shift = [0i8; 3];
        for k in 0..3 {
            let x = c[k] as i32 + d[k];
            if x < 0 {
                shift[k] = -1;
            } else if x >= m {
                shift[k] = 1;
            }
            out[k] = x.rem_euclid(m) as usize;
        }
        Neighbour {
            cell: self.index(out),
            shift,
        }
    }

    /// All 27 cells around cell `idx` (including it).
    pub fn around(&self, idx: usize) -> &[Neighbour; 27] {
        &self.table[idx]
    }

    /// Time until a point at `r` with velocity `v` leaves cell `c`, and through which face.
    pub fn exit(&self, c: [usize; 3], r: &V3, v: &V3) -> Option<(f64, u8, bool)> {
        let mut best: Option<(f64, u8, bool)> = None;
        for k in 0..3 {
            let (t, up) = if v[k] > 0.0 {
                (((c[k] + 1) as f64 * self.side - r[k]) / v[k], true)
            } else if v[k] < 0.0 {
                ((c[k] as f64 * self.side - r[k]) / v[k], false)
            } else {
                continue;
            };
            let t = t.max(0.0);
            if best.is_none_or(|b| t < b.0) {
                best = Some((t, k as u8, up));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_wrap_with_shift() {
        let c = Cells::<u32>::new(6.0, 2.0).unwrap();
        assert_eq!(c.m, 3);
        let n = c.neighbour([0, 2, 1], [-1, 1, 0]);
        assert_eq!(c.coords(n.cell), [2, 0, 1]);
        assert_eq!(n.shift, [-1, 1, 0]);
        assert_eq!(
            c.around(c.index([1, 1, 1]))
                .iter()
                .filter(|n| n.shift == [0, 0, 0])
                .count(),
            27
        );
        assert!(Cells::<u32>::new(5.9, 2.0).is_none());
    }
}
