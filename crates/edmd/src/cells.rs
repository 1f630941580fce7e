//! Linked cells in a periodic cubic box (Sec. 2.6). With at least 3 cells per side the 27 cells
//! around a particle are distinct, so each neighbouring cell fixes one periodic image.

use crate::arena::Arena;
use crate::geometry::{V3, floor_i32, min_image};

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

/// Each cell's members in a row of an `Arena` (`arena.rs`): the cells around a particle are read
/// without a header loaded first, and cells side by side along x lie side by side in memory.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(
    try_from = "SavedCells<T>",
    into = "SavedCells<T>",
    bound = "T: Member + Default + serde::Serialize + serde::de::DeserializeOwned"
)]
pub struct Cells<T: Member + Default = u32> {
    /// Cells per side.
    pub m: usize,
    pub side: f64,
    members: Arena<T>,
}

/// [`Cells`] as state files hold them: each cell's members in a vector.
#[derive(serde::Serialize, serde::Deserialize)]
struct SavedCells<T> {
    m: usize,
    side: f64,
    members: Vec<Vec<T>>,
}

impl<T: Member + Default> TryFrom<SavedCells<T>> for Cells<T> {
    type Error = String;

    fn try_from(saved: SavedCells<T>) -> Result<Self, String> {
        let cells = saved.m.checked_pow(3);
        if cells != Some(saved.members.len()) {
            return Err(format!(
                "{} cells saved for {} a side",
                saved.members.len(),
                saved.m
            ));
        }
        let members: usize = saved.members.iter().map(Vec::len).sum();
        let mut cells = Cells::sized(saved.m, saved.side, members);
        for (c, of_cell) in saved.members.iter().enumerate() {
            for &member in of_cell {
                cells.insert(c, member);
            }
        }
        Ok(cells)
    }
}

impl<T: Member + Default> From<Cells<T>> for SavedCells<T> {
    fn from(cells: Cells<T>) -> Self {
        SavedCells {
            m: cells.m,
            side: cells.side,
            members: (0..cells.m.pow(3))
                .map(|c| cells.members(c).to_vec())
                .collect(),
        }
    }
}

/// A neighbouring cell and the image shift (in box lengths) of the particles in it.
#[derive(Clone, Copy, Debug)]
pub struct Neighbour {
    pub cell: usize,
    pub shift: [i8; 3],
}

impl<T: Member + Default> Cells<T> {
    /// Cells of side ≥ `min_side` in a box of side `l`, for `members` members in all; `None` if
    /// fewer than 3 fit per side.
    pub fn new(l: f64, min_side: f64, members: usize) -> Option<Self> {
        let m = (l / min_side).floor();
        // Also rejects NaN.
        if m.is_nan() || m < 3.0 {
            return None;
        }
        let m = m as usize;
        Some(Cells::sized(m, l / m as f64, members))
    }

    /// `m` cells a side of side `side`, with room for `members` spread evenly: the mean count
    /// and its Poisson deviation, so that few cells spill.
    fn sized(m: usize, side: f64, members: usize) -> Self {
        let mean = members as f64 / (m * m * m) as f64;
        let room = ((mean + mean.sqrt()).ceil() as usize).max(2);
        Cells {
            m,
            side,
            members: Arena::new(m * m * m, room, T::default()),
        }
    }

    pub fn coords_of(&self, r: &V3) -> [usize; 3] {
        let c = |x: f64| (floor_i32(x / self.side) as isize).rem_euclid(self.m as isize) as usize;
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
        self.members.push(cell, member);
    }

    /// Removes particle `i` from `cell`.
    pub fn remove(&mut self, cell: usize, i: u32) {
        if let Some(p) = self.members(cell).iter().position(|m| m.particle() == i) {
            self.members.swap_remove(cell, p);
        }
    }

    pub fn members(&self, cell: usize) -> &[T] {
        self.members.row(cell)
    }

    /// Asks for the cell's count and its first members ahead of [`Cells::members`].
    #[inline]
    pub fn prefetch(&self, cell: usize) {
        self.members.prefetch_slots(cell, &[0]);
    }

    /// The cell at offset `d` (each component in −1..=1) from `c`, with the image shift.
    pub fn neighbour(&self, c: [usize; 3], d: [i32; 3]) -> Neighbour {
        let m = self.m as i32;
        let mut out = [0usize; 3];
        let mut shift = [0i8; 3];
        // Without a division: x is one cell at most outside 0..m.
        for k in 0..3 {
            let x = c[k] as i32 + d[k];
            let wrapped = if x < 0 {
                shift[k] = -1;
                x + m
            } else if x >= m {
                shift[k] = 1;
                x - m
            } else {
                x
            };
            out[k] = wrapped as usize;
        }
        Neighbour {
            cell: self.index(out),
            shift,
        }
    }

    /// All 27 cells around cell `idx` (including it), x fastest. Computed, not tabulated: a table
    /// costs 432 bytes per cell, about 500 bytes per particle in the sphere path's cells.
    pub fn around(&self, idx: usize) -> [Neighbour; 27] {
        let c = self.coords(idx);
        // Per axis, the three coordinates (below, at, above) with their shifts; then products.
        let axis = |k: usize| {
            let below = if c[k] == 0 {
                (self.m - 1, -1)
            } else {
                (c[k] - 1, 0)
            };
            let above = if c[k] + 1 == self.m {
                (0, 1)
            } else {
                (c[k] + 1, 0)
            };
            [below, (c[k], 0), above]
        };
        let (x, y, z) = (axis(0), axis(1), axis(2));
        std::array::from_fn(|k| {
            let (cx, sx) = x[k % 3];
            let (cy, sy) = y[(k / 3) % 3];
            let (cz, sz) = z[k / 9];
            Neighbour {
                cell: cx + self.m * (cy + self.m * cz),
                shift: [sx, sy, sz],
            }
        })
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

/// Points binned for proximity queries: every point within `reach` (nearest image) of a position
/// is among the members of the 27 cells around it, so a query costs O(1) instead of O(N). A box
/// with fewer than 3 cells of side `reach` a side is not binned: every point is a candidate.
/// Used where the set of points changes slowly (Monte Carlo, audits), not in the event loop.
///
/// The cells are intrusive doubly linked lists over the points: a query reads the heads of 27
/// cells and then only the points themselves, and a move is O(1). Points lie in the box,
/// [0, `l`] a side, and each is binned into the cell whose span holds it (the box's far face in
/// the last cell), so a neighbouring cell's image shift makes a candidate's separation one
/// addition: the nearest image for every point within `reach`, an image at least as far for the
/// others. The Monte Carlo's queries look at about a hundred candidates each, of which a sixth
/// are within reach: a nearest image rounded per candidate cost more than the rest of the scan.
pub struct Near {
    /// Cells per side; 0 when the box is not binned.
    m: usize,
    side: f64,
    l: f64,
    head: Vec<u32>,
    next: Vec<u32>,
    prev: Vec<u32>,
    cell_of: Vec<u32>,
}

const NONE: u32 = u32::MAX;

impl Near {
    /// `points` (each in [0, `l`] a side) in a periodic box of side `l`.
    pub fn new(points: &[V3], l: f64, reach: f64) -> Self {
        let n = points.len();
        let m = (l / reach).floor();
        // Also rejects NaN.
        let m = if m >= 3.0 { m as usize } else { 0 };
        let mut near = Near {
            m,
            side: if m > 0 { l / m as f64 } else { l },
            l,
            head: vec![NONE; m * m * m],
            next: vec![NONE; if m > 0 { n } else { 0 }],
            prev: vec![NONE; if m > 0 { n } else { 0 }],
            cell_of: vec![0; if m > 0 { n } else { 0 }],
        };
        if m > 0 {
            for (i, p) in points.iter().enumerate() {
                let c = near.cell(p);
                near.link(i, c);
            }
        }
        near
    }

    /// The cell coordinates of `p`, which must lie in the box: a point outside it would be binned
    /// where its neighbours' separations are not its own.
    #[inline(always)]
    fn coords(&self, p: &V3) -> [usize; 3] {
        assert!(
            p.iter().all(|&x| (0.0..=self.l).contains(&x)),
            "a point outside the box [0, {}]: {p:?}",
            self.l
        );
        p.map(|x| (floor_i32(x / self.side) as usize).min(self.m - 1))
            .into()
    }

    fn cell(&self, p: &V3) -> u32 {
        let [x, y, z] = self.coords(p);
        (x + self.m * (y + self.m * z)) as u32
    }

    fn link(&mut self, i: usize, c: u32) {
        let h = self.head[c as usize];
        self.next[i] = h;
        self.prev[i] = NONE;
        if h != NONE {
            self.prev[h as usize] = i as u32;
        }
        self.head[c as usize] = i as u32;
        self.cell_of[i] = c;
    }

    fn unlink(&mut self, i: usize) {
        let (p, q) = (self.prev[i], self.next[i]);
        if p == NONE {
            self.head[self.cell_of[i] as usize] = q;
        } else {
            self.next[p as usize] = q;
        }
        if q != NONE {
            self.prev[q as usize] = p;
        }
    }

    /// Whether `f(j, r)` holds for every candidate `j` near `p` (itself included, if a point is
    /// there), `r` the separation of `j` from `p` (the nearest image where `j` is within reach);
    /// stops at the first that fails. `points` are the points as last given to [`Near::new`] and
    /// [`Near::moved`]. Inlined, so that `f` is inlined into the scan.
    #[inline(always)]
    pub fn around(&self, points: &[V3], p: &V3, mut f: impl FnMut(usize, V3) -> bool) -> bool {
        if self.m == 0 {
            return points
                .iter()
                .enumerate()
                .all(|(j, q)| f(j, min_image(q - p, self.l)));
        }
        let (m, l) = (self.m, self.l);
        let c = self.coords(p);
        // Per axis, the three cells (below, at, above) with what turns a member's position there
        // into its separation from `p`: the image shift less `p`.
        let axis = |k: usize| {
            let below = if c[k] == 0 {
                (m - 1, -l)
            } else {
                (c[k] - 1, 0.0)
            };
            let above = if c[k] + 1 == m {
                (0, l)
            } else {
                (c[k] + 1, 0.0)
            };
            [below, (c[k], 0.0), above].map(|(c, shift)| (c, shift - p[k]))
        };
        let xs = axis(0);
        for (z, dz) in axis(2) {
            for (y, dy) in axis(1) {
                let row = m * (y + m * z);
                for (x, dx) in xs {
                    let base = V3::new(dx, dy, dz);
                    let mut j = self.head[row + x];
                    while j != NONE {
                        if !f(j as usize, points[j as usize] + base) {
                            return false;
                        }
                        j = self.next[j as usize];
                    }
                }
            }
        }
        true
    }

    /// `f(i, j, r)` once for every pair of points in the same or adjacent cells (every pair
    /// where the box is not binned), `r` the separation of `j` from `i` as [`Near::around`] of `i`
    /// gives it, to the bit: half the candidates of a scan around every point. Each pair of cells
    /// is visited from one side, the 13 neighbours ahead of a cell (z, then y, then x) and the
    /// cell itself, which is one pair per offset in a box of 3 cells a side or more.
    pub fn pairs(&self, points: &[V3], mut f: impl FnMut(usize, usize, V3)) {
        if self.m == 0 {
            for (i, p) in points.iter().enumerate() {
                for (j, q) in points.iter().enumerate().skip(i + 1) {
                    f(i, j, min_image(q - p, self.l));
                }
            }
            return;
        }
        let (m, l) = (self.m, self.l);
        let ahead: Vec<[i32; 3]> = (0..27)
            .map(|k| [k % 3 - 1, k / 3 % 3 - 1, k / 9 - 1])
            .filter(|d| (d[2], d[1], d[0]) > (0, 0, 0))
            .collect();
        let step = |c: usize, d: i32| {
            let x = c as i32 + d;
            if x < 0 {
                ((x + m as i32) as usize, -l)
            } else if x >= m as i32 {
                ((x - m as i32) as usize, l)
            } else {
                (x as usize, 0.0)
            }
        };
        let mut cells = Vec::with_capacity(ahead.len());
        for c in 0..m * m * m {
            if self.head[c] == NONE {
                continue;
            }
            let [cx, cy, cz] = [c % m, c / m % m, c / (m * m)];
            cells.clear();
            cells.extend(ahead.iter().map(|d| {
                let ((x, sx), (y, sy), (z, sz)) = (step(cx, d[0]), step(cy, d[1]), step(cz, d[2]));
                (x + m * (y + m * z), V3::new(sx, sy, sz))
            }));
            let mut i = self.head[c];
            while i != NONE {
                let p = &points[i as usize];
                let mut j = self.next[i as usize];
                let own = V3::zeros() - p;
                while j != NONE {
                    f(i as usize, j as usize, points[j as usize] + own);
                    j = self.next[j as usize];
                }
                for &(cell, shift) in &cells {
                    let base = shift - p;
                    let mut j = self.head[cell];
                    while j != NONE {
                        f(i as usize, j as usize, points[j as usize] + base);
                        j = self.next[j as usize];
                    }
                }
                i = self.next[i as usize];
            }
        }
    }

    /// Point `i` is now at `p` (in the box).
    pub fn moved(&mut self, i: usize, p: &V3) {
        if self.m > 0 {
            let c = self.cell(p);
            if c != self.cell_of[i] {
                self.unlink(i);
                self.link(i, c);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::wrap;

    #[test]
    fn neighbours_wrap_with_shift() {
        let c = Cells::<u32>::new(6.0, 2.0, 0).unwrap();
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
        assert!(Cells::<u32>::new(5.9, 2.0, 0).is_none());
    }

    /// `around` lists, x fastest, the cell and shift `neighbour` gives for each of the 27 offsets,
    /// for every cell of boxes with 3, 4 and 7 cells a side (edges and corners included).
    #[test]
    fn around_is_neighbour_at_every_offset() {
        for m in [3, 4, 7] {
            let c = Cells::<u32>::new(m as f64, 1.0, 0).unwrap();
            assert_eq!(c.m, m);
            for idx in 0..m * m * m {
                let around = c.around(idx);
                for (k, got) in around.iter().enumerate() {
                    let k = k as i32;
                    let want = c.neighbour(c.coords(idx), [k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1]);
                    assert_eq!(
                        (got.cell, got.shift),
                        (want.cell, want.shift),
                        "cell {idx}, offset {k}"
                    );
                }
            }
        }
    }

    /// `pairs` calls each pair of points once, with the separation `around` of its first point
    /// gives, to the bit, and leaves out no pair `around` finds: in boxes of 3, 4 and 10 cells a
    /// side and without cells, with points on cell and box faces.
    #[test]
    fn pairs_are_each_pair_around_finds_once() {
        let mut rng = crate::rng::Rng::new(8);
        for (n, l, reach) in [
            (400, 10.0, 1.0),
            (60, 3.3, 1.1),
            (90, 4.0, 1.0),
            (30, 2.5, 1.0),
        ] {
            let mut pts: Vec<V3> = (0..n)
                .map(|_| V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * l)
                .collect();
            pts[0] = V3::new(0.0, l, 1.0);
            pts[1] = V3::new(1.0, 0.0, l / 2.0);
            let near = Near::new(&pts, l, reach);
            let mut seen = std::collections::HashMap::new();
            near.pairs(&pts, |i, j, r| {
                assert_ne!(i, j);
                let key = (i.min(j), i.max(j));
                assert!(seen.insert(key, (i, r)).is_none(), "{key:?} twice");
            });
            let mut found = 0;
            for (i, p) in pts.iter().enumerate() {
                near.around(&pts, p, |j, r| {
                    if j != i {
                        found += 1;
                        let (first, got) = seen[&(i.min(j), i.max(j))];
                        if first == i {
                            assert_eq!(got.map(f64::to_bits), r.map(f64::to_bits));
                        }
                    }
                    true
                });
            }
            assert_eq!(found, 2 * seen.len(), "n {n}, l {l}");
        }
    }

    /// Every pair closer than `reach` is found by a query at its nearest image, before and after
    /// moves, in boxes with and without cells; points on cell and box faces included (one on
    /// the box's far faces, binned into the first cells).
    #[test]
    fn near_finds_every_close_pair() {
        let mut rng = crate::rng::Rng::new(5);
        for (n, l) in [(400, 10.0), (30, 2.5)] {
            let reach = 1.0;
            let mut pts: Vec<V3> = (0..n)
                .map(|_| V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * l)
                .collect();
            pts[0] = V3::new(0.0, l / 3.0, 1.0);
            pts[1] = V3::new(l.next_down(), l / 3.0, 1.0);
            pts[2] = V3::new(l, l / 3.0 + 0.5, l);
            let mut near = Near::new(&pts, l, reach);
            for round in 0..3 {
                for i in 0..n {
                    let mut seen = vec![None; n];
                    near.around(&pts, &pts[i], |j, r| {
                        assert!(seen[j].replace(r).is_none(), "{j} listed twice");
                        true
                    });
                    for j in 0..n {
                        let nearest = min_image(pts[j] - pts[i], l);
                        let d = nearest.norm();
                        match seen[j] {
                            Some(r) if d < reach => assert!(
                                (r - nearest).norm() < 1e-12 * l,
                                "round {round}: {i}-{j} at {r}, nearest {nearest}"
                            ),
                            Some(r) => assert!(r.norm() >= d - 1e-12 * l, "{r} {nearest}"),
                            None => assert!(d >= reach, "round {round}: {i}-{j} at {d} missed"),
                        }
                    }
                }
                for i in (round..n).step_by(3) {
                    pts[i] = (pts[i] + V3::new(rng.uniform(), rng.uniform(), -rng.uniform()))
                        .map(|x| wrap(x, l));
                    near.moved(i, &pts[i]);
                }
            }
            assert_eq!(near.m > 0, l == 10.0);
        }
    }

    proptest::proptest! {
        /// Inserts and removals in 27 cells with room for two members each (sized for 27 members
        /// spread over them), four of which take twelve particles, against a vector per cell:
        /// every cell holds the same members in the same order after every operation, in its
        /// room exactly where they fit there, and the saved form is the vectors', which reads
        /// back to the same cells (and is refused with a cell missing).
        #[test]
        fn cells_hold_what_vectors_would_in_the_same_order(
            ops in proptest::collection::vec((0usize..4, 0u32..12, proptest::bool::ANY), 1..300),
        ) {
            let mut cells = Cells::<u32>::new(3.0, 1.0, 27).expect("3 cells a side");
            proptest::prop_assert_eq!(cells.members.room, 2);
            let mut model: Vec<Vec<u32>> = vec![Vec::new(); 27];
            for (cell, particle, add) in ops {
                // A particle is in one cell at most: it is inserted where it is absent, and
                // removed (or looked for in vain) where it is present.
                let at = model.iter().position(|m| m.contains(&particle));
                if add && at.is_none() {
                    cells.insert(cell, particle);
                    model[cell].push(particle);
                } else {
                    let cell = at.unwrap_or(cell);
                    cells.remove(cell, particle);
                    if let Some(p) = model[cell].iter().position(|&j| j == particle) {
                        model[cell].swap_remove(p);
                    }
                }
                for (c, members) in model.iter().enumerate() {
                    proptest::prop_assert_eq!(cells.members(c), &members[..], "cell {}", c);
                    let spilled = cells.members.spilled(c).is_some();
                    proptest::prop_assert_eq!(spilled, members.len() > cells.members.room, "cell {}", c);
                }
            }
            let saved = serde_json::to_value(&cells).expect("saved");
            proptest::prop_assert_eq!(&saved["members"], &serde_json::json!(model));
            let mut short = saved.clone();
            short["members"].as_array_mut().expect("cells").pop();
            proptest::prop_assert!(serde_json::from_value::<Cells<u32>>(short).is_err());
            let back: Cells<u32> = serde_json::from_value(saved).expect("read back");
            for (c, members) in model.iter().enumerate() {
                proptest::prop_assert_eq!(back.members(c), &members[..]);
            }
        }
    }
}
