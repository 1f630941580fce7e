//! Nearest-neighbour lists kept per particle (Sec. 3.3, with the partial update of Donev et al.
//! \[26\] instead of the global rebuild of Sec. 3.5 step 4).
//!
//! Each body has its own [`Region`], built when it last escaped the previous one: the oriented
//! bounding parallelepiped of Sec. 3.3 for a rigid body, a ball for a sphere. Its list holds every
//! body whose region overlaps its own, with the periodic image of the overlap. Two bodies can touch
//! only where their regions overlap, so the list holds every possible partner until one of the two
//! escapes. The relation is symmetric, so a new region for one body touches only the lists of its
//! old and new neighbours: one escape costs one region and one prediction, not N of each.
//!
//! Positions are never wrapped (scheduled events keep their image shifts), so an image shift is
//! relative to the unwrapped positions and stays valid while both bodies keep moving.
//!
//! Lists hold indices, not copies of the neighbours: a collision then writes two bodies, not the
//! lists of all their neighbours. They live in one arena with the same room for every body, in
//! 12-byte entries ([`Link`]), found by index without a header to read first; a rebuild asks for
//! all the lines it will touch (mirrors, cell members) before it touches the first (what that
//! gained is in MEASUREMENTS.md).

use crate::arena::{Arena, SPILLED};
use crate::body::Moving;
use crate::cells::{Cells, Member};
use crate::geometry::{Surface, V3, floor_i32, image_offset, round_nearest};

/// A neighbour: its index and the image shift (in box lengths) that puts it next to the body.
pub type Neighbour = (u32, [i32; 3]);

/// An entry of a list: the neighbour, the image shift that puts it next to the body, and where
/// its mirror is in the neighbour's list (`lists[i][p] = (j, s, q)` ⇔ `lists[j][q] = (i, −s, p)`),
/// so that a rebuild drops a body from its old neighbours' lists without searching them.
///
/// 12 bytes, not the 20 of `u32` indices and `i32` shifts: the lists are most of the memory the
/// sphere path touches. Positions are unwrapped, so a shift grows with the boxes two bodies
/// have travelled apart; 32767 boxes is beyond any run (and refused with [`ListLimit`], not
/// wrapped), as is a list of more than 65535 entries.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Link {
    pub j: u32,
    back: u16,
    shift: [i16; 3],
}

impl Link {
    pub fn shift(&self) -> [i32; 3] {
        self.shift.map(i32::from)
    }

    /// The shift as a displacement in a box of side `l`: [`image_offset`] of [`Link::shift`].
    #[inline]
    pub fn offset(&self, l: f64) -> V3 {
        let [x, y, z] = self.shift.map(|k| f64::from(k) * l);
        V3::new(x, y, z)
    }
}

/// A list that the compact [`Link`] cannot hold: the run stops with it.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ListLimit {
    #[error(
        "bodies {i} and {j} are {shift:?} periodic boxes apart, beyond the ±32767 a neighbour list records (positions are kept unwrapped)"
    )]
    Shift { i: u32, j: u32, shift: [i32; 3] },
    #[error("body {i} has more than 65535 neighbours in its list; lower delta_nnl")]
    Length { i: u32 },
}

/// The region a body may not leave until its list is rebuilt, fixed when it is built.
pub trait Region: Copy {
    /// The bodies it is built around: a sphere's region reads its position and velocity alone.
    type Body: Moving;
    /// The region around `body` (at its present pose) with margin `delta` (Δ_NNL).
    fn around<S: Surface>(s: &S, body: &Self::Body, delta: f64) -> Self;
    /// The diameter of the sphere circumscribing a region: regions whose centres are farther
    /// apart cannot overlap.
    fn reach<S: Surface>(s: &S, delta: f64) -> f64;
    fn centre(&self) -> &V3;
    /// How the cells hold the centres for the gather of candidates within reach: exactly where
    /// the gather decides ([`Region::overlaps`] true), in single precision where the region
    /// decides and the gather only needs to keep every candidate.
    type Centre: Gathered;
    /// Whether `other`, with `shift` added to its centre, overlaps this region; only asked of
    /// regions whose centres are at most `reach` apart.
    fn overlaps(&self, other: &Self, shift: &V3, reach: f64) -> bool;
    /// Whether [`Lists`] should gather candidates four at a time for [`Region::overlaps4`].
    const IN_FOURS: bool = false;
    /// [`Region::overlaps`] of four regions at once, each with its shift.
    fn overlaps4(&self, others: [&Self; 4], shifts: &[V3; 4], reach: f64) -> [bool; 4] {
        [0, 1, 2, 3].map(|k| self.overlaps(others[k], &shifts[k], reach))
    }
    /// Time after `body.t` when the body may first touch the boundary of its region: exact or
    /// early, never late (ε_d^nnl of Eq. 61 where it has to be stepped to). A region that steps
    /// may stop at the first step past `horizon`.
    fn escape_time<S: Surface>(&self, s: &S, body: &Self::Body, eps_nnl: f64, horizon: f64) -> f64;
}

/// The lists whose lengths size the room of all ([`Lists::from_regions`]): every one up to this
/// many, every k-th beyond (between half this many and this many), whose 99.9th percentile is
/// within about one entry of all the lists' (lengths at φ = 0.45 are 11.3 ± 1.7).
const ROOM_SAMPLE: usize = 65_536;

#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct Lists<R: Region> {
    regions: Vec<R>,
    /// Every body's list, an [`Arena`] row each: the lists of neighbouring bodies lie side by
    /// side (bodies are numbered along a Z curve). The room is sized for nearly every list, not
    /// the longest ([`room_for`]): growing every list to the longest one's length took 27
    /// entries per body at N = 10⁶ where they hold 11 on average, a third of the run's memory,
    /// and doubled it for a moment at each growth. Saved as [`SavedRows`].
    #[serde(with = "saved_rows")]
    lists: Arena<Link>,
    /// Scratch for [`Lists::rebuild`].
    #[serde(skip)]
    found: Vec<Neighbour>,
    /// Scratch for [`Lists::find`] without cells: the bodies within reach.
    #[serde(skip)]
    within: Vec<u32>,
    /// The regions' centres for [`within_reach`]'s scan without cells, made at its first scan
    /// and kept with the regions after.
    #[serde(skip)]
    centres: Centres,
    delta: f64,
    l: f64,
    /// [`Region::reach`]: regions farther apart cannot overlap.
    reach: f64,
    /// Region centres binned in cells of side ≥ `reach`, when 3 fit per side; otherwise every
    /// body is tried.
    grid: Option<Grid<R::Centre>>,
    /// Whether the box exceeds twice `reach`, so that only the nearest image of a body can overlap.
    single_image: bool,
}

impl<R: Region> Lists<R> {
    /// Regions around every body with margin `delta` (Δ_NNL) and all lists, in a periodic box of
    /// side `l`.
    pub fn build<S: Surface>(
        s: &S,
        bodies: &[R::Body],
        l: f64,
        delta: f64,
    ) -> Result<Self, ListLimit> {
        let regions: Vec<R> = bodies.iter().map(|b| R::around(s, b, delta)).collect();
        Self::from_regions(regions, R::reach(s, delta), l, delta)
    }

    /// [`build`](Self::build) with a surface per body (bodies of several shapes or sizes): body
    /// `i`'s region is around `of(i)`, and the largest reach of any body's sets the reach.
    /// Rebuild each body with its own surface too.
    pub fn build_each<S: Surface>(
        of: impl Fn(usize) -> S,
        bodies: &[R::Body],
        l: f64,
        delta: f64,
    ) -> Result<Self, ListLimit> {
        let mut reach: f64 = 0.0;
        let regions: Vec<R> = bodies
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let s = of(i);
                reach = reach.max(R::reach(&s, delta));
                R::around(&s, b, delta)
            })
            .collect();
        Self::from_regions(regions, reach, l, delta)
    }

    fn from_regions(regions: Vec<R>, reach: f64, l: f64, delta: f64) -> Result<Self, ListLimit> {
        Self::from_regions_sized_by(regions, reach, l, delta, ROOM_SAMPLE)
    }

    /// [`from_regions`](Self::from_regions) with the room sized by about `sample` lists.
    fn from_regions_sized_by(
        regions: Vec<R>,
        reach: f64,
        l: f64,
        delta: f64,
        sample: usize,
    ) -> Result<Self, ListLimit> {
        let grid = Cells::new(l, reach, regions.len()).map(|cells| {
            let mut grid = Grid {
                cells,
                cell_of: vec![0; regions.len()],
                img: vec![[0; 3]; regions.len()],
                hits: Vec::new(),
            };
            for (i, r) in regions.iter().enumerate() {
                grid.place(i, r.centre(), l);
            }
            grid
        });
        let n = regions.len();
        let mut lists = Lists {
            lists: Arena::new(n, 0, VACANT),
            found: Vec::new(),
            within: Vec::new(),
            centres: Centres::default(),
            regions,
            delta,
            l,
            reach,
            grid,
            single_image: l > 2.0 * reach,
        };
        // The room is sized from the lengths of a sample of the lists, every `stride`-th, found
        // in full, rather than from all of them: a list outgrowing the room spills and loses
        // nothing, and each list holds what it would have held. All the pairs kept between a
        // count and the links took 270 MB at N = 10⁶, more than the lists; counting every list
        // first was a third of the lists' construction.
        let mut found = Vec::new();
        let stride = n.div_ceil(sample.max(1)).max(1);
        let lengths = (0..n)
            .step_by(stride)
            .map(|i| {
                found.clear();
                lists.find(i, |j| j != i, &mut found);
                found.len() as u32
            })
            .collect();
        lists.lists = Arena::new(n, room_for(lengths), VACANT);
        for i in 0..n {
            found.clear();
            lists.find(i, |j| j > i, &mut found);
            for &(j, s) in &found {
                lists.link(i, j as usize, s)?;
            }
        }
        Ok(lists)
    }

    /// Lists j in i's list with shift `s`, and i in j's with −s; nothing if either cannot be held.
    #[inline]
    fn link(&mut self, i: usize, j: usize, s: [i32; 3]) -> Result<(), ListLimit> {
        // ±32767, so that the mirror's −s fits too.
        if s.iter().any(|x| x.unsigned_abs() > i16::MAX as u32) {
            return Err(ListLimit::Shift {
                i: i as u32,
                j: j as u32,
                shift: s,
            });
        }
        let (p, q) = (self.room_at(i)?, self.room_at(j)?);
        self.lists.push_with(i, || Link {
            j: j as u32,
            back: q,
            shift: s.map(|x| x as i16),
        });
        self.lists.push_with(j, || Link {
            j: i as u32,
            back: p,
            shift: s.map(|x| -x as i16),
        });
        Ok(())
    }

    /// Where the next entry of list `i` goes, if a list can be that long.
    #[inline]
    fn room_at(&self, i: usize) -> Result<u16, ListLimit> {
        u16::try_from(self.lists.len(i))
            .ok()
            .filter(|&len| len < u16::MAX)
            .ok_or(ListLimit::Length { i: i as u32 })
    }

    /// Removes entry `q` of j's list, moving its last entry into the gap (and telling that entry's
    /// mirror where it went).
    fn unlink_entry(&mut self, j: usize, q: u16) {
        if let Some(moved) = self.lists.swap_remove(j, usize::from(q)) {
            self.lists
                .get_mut(moved.j as usize, usize::from(moved.back))
                .back = q;
        }
    }

    pub fn of(&self, i: usize) -> &[Link] {
        self.lists.row(i)
    }

    /// Asks for the first two cache lines of list `i` and for its region ahead of their use.
    #[inline]
    pub fn prefetch(&self, i: usize) {
        // Five 12-byte entries to a line.
        self.lists.prefetch_slots(i, &[0, 5]);
        crate::prefetch(&self.regions[i]);
    }

    pub fn region(&self, i: usize) -> &R {
        &self.regions[i]
    }

    /// A new region around body `i` (at the present time), and the lists updated to match.
    pub fn rebuild<S: Surface>(
        &mut self,
        s: &S,
        i: usize,
        body: &R::Body,
    ) -> Result<(), ListLimit> {
        // The mirrors and the last entries of their lists, which take their places, are in as
        // many lists as i has neighbours: asked for all at once, not one after the other.
        for n in self.lists.row(i) {
            let j = n.j as usize;
            self.lists.prefetch(j, usize::from(n.back));
            self.lists.prefetch(j, self.lists.len(j) - 1);
        }
        // Mirrors first: removing one may move another mirror of i (two images of i in one list),
        // which updates the `back` of i's entries as it goes.
        for p in 0..self.lists.row(i).len() {
            let Link { j, back, .. } = self.lists.row(i)[p];
            self.unlink_entry(j as usize, back);
        }
        self.lists.clear(i);
        // Rebuilds are frequent for spheres: no allocation in them.
        let mut found = std::mem::take(&mut self.found);
        found.clear();
        self.regions[i] = R::around(s, body, self.delta);
        if self.centres.len() == self.regions.len() {
            self.centres.set(i, self.regions[i].centre());
        }
        if let Some(grid) = &mut self.grid {
            grid.cells.remove(grid.cell_of[i] as usize, i as u32);
            grid.place(i, self.regions[i].centre(), self.l);
        }
        self.find(i, |j| j != i, &mut found);
        let linked = found
            .iter()
            .try_for_each(|&(j, shift)| self.link(i, j as usize, shift));
        self.found = found;
        linked
    }

    /// Appends to `found` the regions, among those of bodies `j` with `take(j)`, that overlap
    /// region `i`, with their images.
    fn find(&mut self, i: usize, take: impl Fn(usize) -> bool, found: &mut Vec<Neighbour>) {
        let a = &self.regions[i];
        let Some(grid) = &mut self.grid else {
            // Without cells, every body, at the image nearest to i and, when the box is small,
            // the images around that one. No division, and the image's integers only where in
            // reach: at N 256 this loop was a quarter of every rebuild's instructions.
            let (l, take) = (self.l, &take);
            let reach = Reach {
                centre: *a.centre(),
                l,
                inv_l: 1.0 / l,
                reach2: self.reach * self.reach,
            };
            let nearest = move |b: &R| reach.nearest(b.centre());
            let image = move |j: usize, b: &R, near: V3| {
                (reach.holds(b.centre(), &near) && take(j))
                    .then(|| (j as u32, [0, 1, 2].map(|k| near[k] as i32)))
            };
            if self.single_image {
                // The nearest image alone, without an iterator of offsets for each body: 2 % of
                // the instructions of an ellipsoid's collision at N 256 (X0 = 2, φ 0.5). The
                // bodies within reach are gathered first without a branch (about one in seven
                // is), four at a time, and only they are looked at further: tested as they came,
                // a fifth of a collision's branches were mispredicted here, and the rebuild took
                // 9 % of the time (`perf`); 6 % without the branch, 4.7 % four at a time.
                if self.centres.len() != self.regions.len() {
                    self.centres = Centres::of(&self.regions);
                }
                let mut within = std::mem::take(&mut self.within);
                within.resize(self.regions.len(), 0);
                let n = within_reach(&self.centres, &reach, &mut within);
                let candidates = within[..n]
                    .iter()
                    .map(|&j| (j as usize, &self.regions[j as usize]))
                    .filter_map(|(j, b)| image(j, b, nearest(b)));
                overlapping(a, &self.regions, candidates, l, self.reach, found);
                self.within = within;
                return;
            }
            let candidates = self.regions.iter().enumerate().flat_map(|(j, b)| {
                let near = nearest(b);
                ALL_27.iter().filter_map(move |off| {
                    image(
                        j,
                        b,
                        near + V3::new(off[0] as f64, off[1] as f64, off[2] as f64),
                    )
                })
            });
            overlapping(a, &self.regions, candidates, l, self.reach, found);
            return;
        };
        // With cells, each of the 27 around i fixes the image of its members: no rounding. The
        // members within reach are gathered first without a branch (about one in four is), and
        // only they are looked at further.
        let img_i = grid.img[i];
        // As `Grid::place` wrapped it, to the bit.
        let wrapped_i = a.centre() - image_offset(img_i, self.l);
        let around = grid.cells.around(grid.cell_of[i] as usize);
        // The 27 cells, asked for all at once.
        for nbc in &around {
            grid.cells.prefetch(nbc.cell);
        }
        let mut hits = std::mem::take(&mut grid.hits);
        let members: usize = around
            .iter()
            .map(|c| grid.cells.members(c.cell).len())
            .sum();
        if hits.len() < members {
            hits.resize(members, (0, 0));
        }
        let mut n = 0;
        for (k, nbc) in around.iter().enumerate() {
            let origin = image_offset(nbc.shift.map(i32::from), self.l) - wrapped_i;
            let near = R::Centre::near(&origin, self.reach, self.l);
            for m in grid.cells.members(nbc.cell) {
                hits[n] = (m.particle(), k as u8);
                n += usize::from(m.within(&near));
            }
        }
        // The regions within reach lie wherever their bodies are numbered: asked for all at once.
        for &(j, _) in &hits[..n] {
            crate::prefetch(&self.regions[j as usize]);
        }
        let candidates = hits[..n]
            .iter()
            .filter(|&&(j, _)| take(j as usize))
            .map(|&(j, k)| {
                let cell_shift = around[usize::from(k)].shift;
                let img_j = grid.img[j as usize];
                (
                    j,
                    [0, 1, 2].map(|c| i32::from(cell_shift[c]) + img_i[c] - img_j[c]),
                )
            });
        overlapping(a, &self.regions, candidates, self.l, self.reach, found);
        grid.hits = hits;
    }
}

/// Where [`within_reach`] looks: bodies whose centre's nearest image, in a box of side `l`
/// (`inv_l` = 1/`l`), lies within √`reach2` of `centre`.
#[derive(Clone, Copy)]
struct Reach {
    centre: V3,
    l: f64,
    inv_l: f64,
    reach2: f64,
}

impl Reach {
    /// The image of centre `c` nearest to `centre`, in box lengths.
    #[inline]
    fn nearest(&self, c: &V3) -> V3 {
        ((self.centre - c) * self.inv_l).map(round_nearest)
    }

    /// Whether centre `c`, at its image `near`, lies within reach.
    #[inline]
    fn holds(&self, c: &V3, near: &V3) -> bool {
        (c + near * self.l - self.centre).norm_squared() <= self.reach2
    }
}

/// Region centres a coordinate to a vector: [`within_reach`] loads four of each at once. Gathered
/// out of the regions (120 bytes each for boxes), its scan touched every line of them at every
/// rebuild: at X0 = 2, φ 0.5, N 256 a collision then missed the first-level cache 19 % more
/// often (callgrind's model) and took 0.7 % more instructions.
#[derive(Clone, Debug, Default)]
struct Centres([Vec<f64>; 3]);

impl Centres {
    fn of<R: Region>(regions: &[R]) -> Self {
        Centres([0, 1, 2].map(|k| regions.iter().map(|r| r.centre()[k]).collect()))
    }

    fn len(&self) -> usize {
        self.0[0].len()
    }

    fn set(&mut self, i: usize, c: &V3) {
        for k in 0..3 {
            self.0[k][i] = c[k];
        }
    }

    fn get(&self, j: usize) -> V3 {
        V3::new(self.0[0][j], self.0[1][j], self.0[2][j])
    }
}

/// Writes to the front of `within` the index of every centre within `reach`, in order, and
/// returns how many: each index is written and kept by the count alone, not by a branch. Four
/// at a time where the CPU has AVX2, to the bit what one at a time computes.
fn within_reach(centres: &Centres, reach: &Reach, within: &mut [u32]) -> usize {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        let done = unsafe { avx2::within_reach(centres, reach, within) };
        return within_reach_from(centres, reach, within, done);
    }
    within_reach_from(centres, reach, within, (0, 0))
}

/// [`within_reach`] one centre at a time, from centre `from` on, `n` indices written already.
fn within_reach_from(
    centres: &Centres,
    reach: &Reach,
    within: &mut [u32],
    (mut n, from): (usize, usize),
) -> usize {
    for j in from..centres.len() {
        let c = centres.get(j);
        within[n] = j as u32;
        n += usize::from(reach.holds(&c, &reach.nearest(&c)));
    }
    n
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{Centres, Reach};
    use crate::geometry::ROUND_MAGIC;
    use crate::lanes::{add, mul, splat, sub};

    /// The lane numbers of the set bits of each four-bit mask, packed to the front.
    const PACKED: [[u32; 4]; 16] = {
        let mut table = [[0; 4]; 16];
        let mut mask = 0;
        while mask < 16 {
            let mut n = 0;
            let mut lane = 0;
            while lane < 4 {
                if mask & (1 << lane) != 0 {
                    table[mask][n] = lane as u32;
                    n += 1;
                }
                lane += 1;
            }
            mask += 1;
        }
        table
    };

    /// [`super::within_reach`] of the centres in whole fours: (how many written, how many
    /// looked at). Each value as the scalar code computes it: the same operations in the same
    /// order, no fused multiply–add. The indices of a four within reach are written at once,
    /// packed by a table: four (whatever their count) land at the count so far, which never
    /// passes the four's own place.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn within_reach(
        centres: &Centres,
        reach: &Reach,
        within: &mut [u32],
    ) -> (usize, usize) {
        let c = [0, 1, 2].map(|k| splat(reach.centre[k]));
        let (magic, l, inv_l) = (splat(ROUND_MAGIC), splat(reach.l), splat(reach.inv_l));
        let reach2 = splat(reach.reach2);
        let [xs, ys, zs] = centres.0.each_ref().map(|c| c.chunks_exact(4));
        let mut n = 0;
        for (q, ((x, y), z)) in xs.zip(ys).zip(zs).enumerate() {
            // SAFETY: each of `x`, `y`, `z` holds four f64 (unaligned loads).
            let b = [x, y, z].map(|four| unsafe { _mm256_loadu_pd(four.as_ptr()) });
            let d = [0, 1, 2].map(|k| {
                let near = sub(add(mul(sub(c[k], b[k]), inv_l), magic), magic);
                sub(add(b[k], mul(near, l)), c[k])
            });
            let r2 = add(add(mul(d[0], d[0]), mul(d[1], d[1])), mul(d[2], d[2]));
            let hit = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(r2, reach2)) as usize;
            let to = &mut within[n..n + 4];
            let lanes = PACKED[hit].map(|lane| lane + 4 * q as u32);
            to.copy_from_slice(&lanes);
            n += hit.count_ones() as usize;
        }
        (n, centres.len() / 4 * 4)
    }
}

/// Appends to `found` the `candidates` (index, image shift) whose regions overlap `a`: four at
/// a time where the region tests them so ([`Region::IN_FOURS`]; a last group of fewer padded
/// with its first), else one at a time.
fn overlapping<R: Region>(
    a: &R,
    regions: &[R],
    candidates: impl Iterator<Item = Neighbour>,
    l: f64,
    reach: f64,
    found: &mut Vec<Neighbour>,
) {
    if !R::IN_FOURS {
        for (j, s) in candidates {
            if a.overlaps(&regions[j as usize], &image_offset(s, l), reach) {
                found.push((j, s));
            }
        }
        return;
    }
    let mut group = [(0u32, [0i32; 3]); 4];
    let mut len = 0;
    let test = |group: &[Neighbour; 4], len: usize, found: &mut Vec<Neighbour>| {
        let shifts = group.map(|(_, s)| image_offset(s, l));
        let hit = a.overlaps4(group.map(|(j, _)| &regions[j as usize]), &shifts, reach);
        found.extend((0..len).filter(|&k| hit[k]).map(|k| group[k]));
    };
    for c in candidates {
        group[len] = c;
        len += 1;
        if len == 4 {
            test(&group, 4, found);
            len = 0;
        }
    }
    if len > 0 {
        for k in len..4 {
            group[k] = group[0];
        }
        test(&group, len, found);
    }
}

const VACANT: Link = Link {
    j: u32::MAX,
    back: u16::MAX,
    shift: [0; 3],
};

/// The room for lists of the given lengths: the 99.9th percentile and two more, so that about one
/// list in a thousand spills (lengths are bounded by the density and vary little: 11.3 ± 1.7 for
/// spheres at φ = 0.45, Δ_NNL = 0.25).
fn room_for(mut lengths: Vec<u32>) -> usize {
    if lengths.is_empty() {
        return 1;
    }
    let k = (lengths.len() - 1) * 999 / 1000;
    let (_, &mut q, _) = lengths.select_nth_unstable(k);
    q as usize + 2
}

/// The lists as state files hold them, the form they had before they shared their arena with the
/// cells: each list's length, the arena's entries, and for a list longer than `room` its vector
/// in `spill`, named by the `j` of its first arena entry.
#[derive(serde::Serialize, serde::Deserialize)]
struct SavedRows {
    room: usize,
    len: Vec<u16>,
    items: Vec<Link>,
    /// Absent from state files written before lists spilled (none did).
    #[serde(default)]
    spill: Vec<Vec<Link>>,
    #[serde(default)]
    free: Vec<u32>,
}

mod saved_rows {
    use super::{Arena, Link, SPILLED, SavedRows};
    use serde::{Deserialize, Deserializer, Serialize, Serializer, de::Error};

    pub(super) fn serialize<S: Serializer>(rows: &Arena<Link>, to: S) -> Result<S::Ok, S::Error> {
        let mut items = rows.slots.clone();
        let mut len = Vec::with_capacity(rows.count.len());
        for i in 0..rows.count.len() {
            // Lists are refused past 65535 entries (`Lists::room_at`).
            len.push(rows.len(i) as u16);
            if let Some(k) = rows.spilled(i)
                && let Some(first) = items.get_mut(i * rows.room)
            {
                first.j = k as u32;
            }
        }
        SavedRows {
            room: rows.room,
            len,
            items,
            spill: rows.spill.clone(),
            free: rows.free.clone(),
        }
        .serialize(to)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(from: D) -> Result<Arena<Link>, D::Error> {
        let saved = SavedRows::deserialize(from)?;
        let (n, room) = (saved.len.len(), saved.room);
        if saved.items.len() != n * room {
            return Err(D::Error::custom(format!(
                "{} list entries saved for {n} lists of room {room}",
                saved.items.len()
            )));
        }
        let mut taken = vec![false; saved.spill.len()];
        for &k in &saved.free {
            match taken.get_mut(k as usize) {
                Some(t) if !*t => *t = true,
                _ => {
                    return Err(D::Error::custom(format!(
                        "free list vector {k} is past the {} saved or named twice",
                        saved.spill.len()
                    )));
                }
            }
        }
        let mut count = Vec::with_capacity(n);
        for (i, &len) in saved.len.iter().enumerate() {
            let len = usize::from(len);
            if len <= room {
                count.push(len as u32);
                continue;
            }
            // A room of 0 has no first entry to name a vector.
            let k = saved
                .items
                .get(i * room)
                .map_or(usize::MAX, |first| first.j as usize);
            match (taken.get_mut(k), saved.spill.get(k)) {
                (Some(t), Some(v)) if !*t && v.len() == len => *t = true,
                _ => {
                    return Err(D::Error::custom(format!(
                        "list {i} of {len} entries names vector {k}, which does not hold it"
                    )));
                }
            }
            count.push(SPILLED | k as u32);
        }
        Ok(Arena {
            room,
            count,
            slots: saved.items,
            spill: saved.spill,
            free: saved.free,
        })
    }
}

/// Region centres binned in cells. Each centre is kept wrapped into the box, in its cell and
/// beside it, together with the image it was wrapped from, so that the shift of a neighbouring
/// cell gives every candidate's image directly.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
#[serde(bound = "C: Gathered")]
struct Grid<C: Gathered> {
    cells: Cells<C>,
    cell_of: Vec<u32>,
    img: Vec<[i32; 3]>,
    /// Scratch for [`Lists::find`], as long as the most members 27 cells have held (it was N
    /// entries, 8 MB at N = 10⁶).
    hits: Vec<(u32, u8)>,
}

/// A region's centre as its cell holds it, wrapped into the box ([`Region::Centre`]).
pub trait Gathered:
    Member + Default + std::fmt::Debug + serde::Serialize + serde::de::DeserializeOwned
{
    /// What [`Gathered::within`] compares against: a cell's offset (its image less the body's
    /// wrapped centre) and the reach, in the centre's precision.
    type Near: Copy;
    fn new(particle: u32, wrapped: &V3) -> Self;
    fn near(offset: &V3, reach: f64, l: f64) -> Self::Near;
    /// Whether the centre, moved by the cell's offset, may be within reach: never false for a
    /// centre within it.
    fn within(&self, near: &Self::Near) -> bool;
}

/// A centre in double precision, within reach exactly where its distance is: what a ball's
/// gather decides by.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct ExactCentre {
    particle: u32,
    wrapped: V3,
}

impl Member for ExactCentre {
    fn particle(&self) -> u32 {
        self.particle
    }
}

impl Gathered for ExactCentre {
    type Near = (V3, f64);

    fn new(particle: u32, wrapped: &V3) -> Self {
        ExactCentre {
            particle,
            wrapped: *wrapped,
        }
    }

    #[inline]
    fn near(offset: &V3, reach: f64, _: f64) -> (V3, f64) {
        (*offset, reach * reach)
    }

    #[inline]
    fn within(&self, (offset, reach2): &(V3, f64)) -> bool {
        (self.wrapped + offset).norm_squared() <= *reach2
    }
}

/// A centre in single precision, for regions that decide themselves which candidates overlap
/// (boxes): a rebuild reads 27 cells of them, in 16 bytes a member instead of 32, so that read
/// touches half the lines (ellipsoids X0 = 2, φ 0.5, N 16,384: 11 % fewer first-level and 9 %
/// fewer second-level cache misses in all, MEASUREMENTS.md). Saved as an [`ExactCentre`].
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
#[serde(from = "ExactCentre", into = "ExactCentre")]
pub struct SingleCentre {
    wrapped: [f32; 3],
    particle: u32,
}

impl Member for SingleCentre {
    fn particle(&self) -> u32 {
        self.particle
    }
}

impl Gathered for SingleCentre {
    type Near = ([f32; 3], f32);

    fn new(particle: u32, wrapped: &V3) -> Self {
        SingleCentre {
            wrapped: [0, 1, 2].map(|k| wrapped[k] as f32),
            particle,
        }
    }

    /// The reach widened so that no centre within it is lost to rounding. A wrapped centre lies
    /// within [0, l] up to rounding, and an offset within 2l, so each rounding to single
    /// precision moves a component by at most 2⁻²⁴·3l, and the sum, the squares and the
    /// threshold's own rounding move the distance by under 10⁻⁶·l in all (the reach is below l):
    /// it is widened by 10⁻⁵·l, ten times that.
    #[inline]
    fn near(offset: &V3, reach: f64, l: f64) -> ([f32; 3], f32) {
        let widened = reach + 1e-5 * l;
        (
            [0, 1, 2].map(|k| offset[k] as f32),
            (widened * widened) as f32,
        )
    }

    #[inline]
    fn within(&self, (offset, reach2): &([f32; 3], f32)) -> bool {
        let d = [0, 1, 2].map(|k| self.wrapped[k] + offset[k]);
        d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= *reach2
    }
}

impl From<ExactCentre> for SingleCentre {
    fn from(exact: ExactCentre) -> Self {
        SingleCentre::new(exact.particle, &exact.wrapped)
    }
}

impl From<SingleCentre> for ExactCentre {
    fn from(single: SingleCentre) -> Self {
        ExactCentre {
            particle: single.particle,
            wrapped: V3::from(single.wrapped.map(f64::from)),
        }
    }
}

impl<C: Gathered> Grid<C> {
    /// Bins centre `c` of region `i` (not yet in any cell).
    fn place(&mut self, i: usize, c: &V3, l: f64) {
        let img = [0, 1, 2].map(|k| floor_i32(c[k] / l));
        let wrapped = c - image_offset(img, l);
        // Rounding may leave a wrapped coordinate a hair outside [0, l): it belongs to the edge
        // cell it touches, never to the opposite side of the box.
        let last = self.cells.m - 1;
        let coord = |x: f64| ((x / self.cells.side) as usize).min(last);
        let cell = self
            .cells
            .index([coord(wrapped.x), coord(wrapped.y), coord(wrapped.z)]);
        self.cells.insert(cell, C::new(i as u32, &wrapped));
        self.cell_of[i] = cell as u32;
        self.img[i] = img;
    }
}

const ALL_27: [[i32; 3]; 27] = {
    let mut all = [[0; 3]; 27];
    let mut k = 0;
    while k < 27 {
        all[k] = [
            (k % 3) as i32 - 1,
            ((k / 3) % 3) as i32 - 1,
            (k / 9) as i32 - 1,
        ];
        k += 1;
    }
    all
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ball::Ball;
    use crate::body::SphereBody;
    use crate::ellipsoid::Ellipsoid;
    use crate::geometry::M3;
    use crate::nnl::{Obp, overlap};
    use crate::rigid::{Body, rotate};

    /// Bodies as region `R` stores them.
    fn stored<R: Region>(b: &[Body]) -> Vec<R::Body> {
        b.iter().map(R::Body::from_body).collect()
    }

    fn bodies(n: usize, l: f64, seed: u64) -> Vec<Body> {
        let mut rng = crate::rng::Rng::new(seed);
        (0..n)
            .map(|_| Body {
                // Unwrapped positions up to two boxes away, as a long run leaves them.
                r: V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * (3.0 * l) - V3::repeat(l),
                v: V3::zeros(),
                rot: rotate(
                    &M3::identity(),
                    &V3::new(rng.uniform(), rng.uniform(), rng.uniform()),
                    3.0,
                ),
                w: V3::zeros(),
                t: 0.0,
            })
            .collect()
    }

    /// Every overlapping pair of regions, by brute force over all images, with `overlap` as the
    /// oracle.
    fn brute<R: Region>(
        l: &Lists<R>,
        overlap: impl Fn(&R, &R, &V3) -> bool,
    ) -> Vec<(usize, usize, [i32; 3])> {
        let mut all = Vec::new();
        let n = l.regions.len();
        for i in 0..n {
            for j in 0..n {
                if i == j {
                    continue;
                }
                let (a, b) = (&l.regions[i], &l.regions[j]);
                let nearest = ((a.centre() - b.centre()) / l.l).map(f64::round);
                for off in ALL_27 {
                    let s = [0, 1, 2].map(|k| nearest[k] as i32 + off[k]);
                    if overlap(a, b, &image_offset(s, l.l)) {
                        all.push((i, j, s));
                    }
                }
            }
        }
        all.sort();
        all
    }

    fn listed<R: Region>(l: &Lists<R>) -> Vec<(usize, usize, [i32; 3])> {
        let mut all: Vec<_> = (0..l.regions.len())
            .flat_map(|i| l.of(i).iter().map(move |n| (i, n.j as usize, n.shift())))
            .collect();
        all.sort();
        all
    }

    /// Builds lists for `b`, then moves and rebuilds 200 bodies, comparing with brute force each
    /// time: every pair for which `must` holds is listed, and only pairs for which `may` holds.
    fn check<R: Region>(
        s: &Ellipsoid,
        mut b: Vec<Body>,
        l: f64,
        delta: f64,
        must: impl Fn(&R, &R, &V3) -> bool,
        may: impl Fn(&R, &R, &V3) -> bool,
    ) -> Lists<R> {
        let n = b.len();
        let mut lists =
            Lists::<R>::build(s, &stored::<R>(&b), l, delta).expect("lists within limits");
        same(&lists, &must, &may, "after the build");
        let mut rng = crate::rng::Rng::new(11);
        for step in 0..200 {
            let i = step * 7 % n;
            b[i].r += V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 0.6;
            b[i].rot = rotate(&b[i].rot, &V3::new(1.0, rng.uniform(), 0.0), 0.3);
            lists
                .rebuild(s, i, &R::Body::from_body(&b[i]))
                .expect("lists within limits");
        }
        assert!(!listed(&lists).is_empty());
        same(&lists, &must, &may, "after the rebuilds");
        lists
    }

    fn same<R: Region>(
        lists: &Lists<R>,
        must: impl Fn(&R, &R, &V3) -> bool,
        may: impl Fn(&R, &R, &V3) -> bool,
        when: &str,
    ) {
        for i in 0..lists.regions.len() {
            for (p, n) in lists.of(i).iter().enumerate() {
                let mirror = lists.of(n.j as usize)[usize::from(n.back)];
                assert_eq!(
                    (mirror.j, mirror.back, mirror.shift),
                    (i as u32, p as u16, n.shift.map(|x| -x)),
                    "{when}: mirror of {i} → {}",
                    n.j
                );
            }
        }
        let got = listed(lists);
        let (required, allowed) = (brute(lists, must), brute(lists, may));
        let missing: Vec<_> = required.iter().filter(|p| !got.contains(p)).collect();
        let extra: Vec<_> = got.iter().filter(|p| !allowed.contains(p)).collect();
        assert!(
            missing.is_empty() && extra.is_empty(),
            "{when}: missing {missing:?}, extra {extra:?}"
        );
    }

    /// Bodies spread out, then 40 of them gathered in one spot, rebuilt one by one: their lists
    /// outgrow the room the build gave them and spill, and still match brute force with every
    /// mirror (and are saved and read back whole); spread out again, every list is back in the
    /// arena.
    #[test]
    fn lists_that_outgrow_their_room_keep_every_entry_and_mirror() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let l = 12.0;
        let mut b = bodies(200, l, 9);
        let mut lists =
            Lists::<Ball>::build(&e, &stored::<Ball>(&b), l, 0.2).expect("lists within limits");
        let room = lists.lists.room;
        let reach = 2.0 * (0.5 + 0.2);
        let within = |k: f64| move |a: &Ball, b: &Ball, shift: &V3| (b.c + shift - a.c).norm() <= k;
        let (must, may) = (within(reach * (1.0 - 1e-12)), within(reach * (1.0 + 1e-12)));
        let mut rng = crate::rng::Rng::new(4);
        let spread = b.clone();
        for (k, i) in (0..200).step_by(5).enumerate() {
            b[i].r = V3::new(6.0, 6.0, 6.0) + V3::new(rng.uniform(), rng.uniform(), 0.0) * 0.5;
            b[i].r.z += 0.01 * k as f64;
            lists
                .rebuild(&e, i, &SphereBody::from_body(&b[i]))
                .expect("lists within limits");
        }
        let spilled = (0..200).filter(|&i| lists.of(i).len() > room).count();
        assert!(spilled >= 30, "{spilled} lists outgrew the room {room}");
        assert_eq!(lists.lists.room, room);
        same(&lists, must, may, "after outgrowing");
        saved_and_read_back(&lists);
        for i in (0..200).step_by(5) {
            lists
                .rebuild(&e, i, &SphereBody::from_body(&spread[i]))
                .expect("lists within limits");
        }
        same(&lists, must, may, "spread out again");
        assert!((0..200).all(|i| lists.lists.spilled(i).is_none()));
        assert_eq!(lists.lists.free.len(), lists.lists.spill.len());
    }

    /// Lists with spilled ones, saved and read back, are the same lists; their saved form is the
    /// one state files held before the lists shared their arena (a spilled list's vector named by
    /// its first arena entry), and one whose list names the wrong vector is refused.
    fn saved_and_read_back(lists: &Lists<Ball>) {
        let spilled: Vec<usize> = (0..200)
            .filter(|&i| lists.lists.spilled(i).is_some())
            .collect();
        assert!(spilled.len() >= 2);
        fn bytes_of(value: &impl serde::Serialize) -> Vec<u8> {
            let mut raw = Vec::new();
            ciborium::into_writer(value, &mut raw).unwrap();
            raw
        }
        let back: Lists<Ball> = ciborium::from_reader(&bytes_of(lists)[..]).unwrap();
        for i in 0..200 {
            assert_eq!(back.of(i), lists.of(i), "list {i}");
        }
        // The lists' field alone, as the arena and as its saved form.
        #[derive(serde::Serialize, serde::Deserialize)]
        struct Field {
            #[serde(with = "saved_rows")]
            rows: Arena<Link>,
        }
        #[derive(serde::Serialize, serde::Deserialize)]
        struct Form {
            rows: SavedRows,
        }
        let field = Field {
            rows: lists.lists.clone(),
        };
        let Form { rows: mut form } = ciborium::from_reader(&bytes_of(&field)[..]).unwrap();
        let i = spilled[0];
        let k = lists.lists.spilled(i).unwrap();
        assert_eq!(usize::from(form.len[i]), lists.of(i).len());
        assert_eq!(form.items[i * form.room].j as usize, k);
        assert_eq!(form.spill[k], lists.of(i));
        form.items[i * form.room].j = lists.lists.spilled(spilled[1]).unwrap() as u32;
        let err = ciborium::from_reader::<Field, _>(&bytes_of(&Form { rows: form })[..])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("does not hold it"), "{err}");
        // A free vector named twice.
        let Form { rows: mut form } = ciborium::from_reader(&bytes_of(&field)[..]).unwrap();
        form.free = vec![0, 0];
        let err = ciborium::from_reader::<Field, _>(&bytes_of(&Form { rows: form })[..])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("named twice"), "{err}");
        // No room, so no first entry to name the vector: refused, not read out of bounds.
        let roomless = SavedRows {
            room: 0,
            len: vec![1],
            items: Vec::new(),
            spill: vec![lists.of(spilled[0])[..1].to_vec()],
            free: Vec::new(),
        };
        assert!(
            ciborium::from_reader::<Field, _>(&bytes_of(&Form { rows: roomless })[..]).is_err()
        );
    }

    /// Lists whose room was sized by 7 of 300 bodies, half of them gathered in a corner, hold
    /// what lists sized by all 300 hold, entry for entry and in the same order, though many spill.
    #[test]
    fn lists_sized_by_a_sample_hold_what_lists_sized_by_all_do() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let l = 12.0;
        let mut b = bodies(300, l, 5);
        for body in b.iter_mut().skip(150) {
            body.r = body.r.map(|x| x.rem_euclid(l) / 4.0);
        }
        let regions = || {
            stored::<Ball>(&b)
                .iter()
                .map(|s| Ball::around(&e, s, 0.2))
                .collect::<Vec<_>>()
        };
        let reach = Ball::reach(&e, 0.2);
        let all = Lists::from_regions_sized_by(regions(), reach, l, 0.2, 300)
            .expect("lists within limits");
        let sampled =
            Lists::from_regions_sized_by(regions(), reach, l, 0.2, 7).expect("lists within limits");
        assert!(sampled.lists.room < all.lists.room);
        assert!(!sampled.lists.spill.is_empty());
        for i in 0..300 {
            let row = |lists: &Lists<Ball>| {
                lists
                    .of(i)
                    .iter()
                    .map(|n| (n.j, n.back, n.shift))
                    .collect::<Vec<_>>()
            };
            assert_eq!(row(&sampled), row(&all), "list {i}");
        }
    }

    /// A shift beyond ±32767 boxes is refused, naming the bodies, not wrapped; one inside is kept.
    #[test]
    fn shifts_beyond_the_compact_range_are_refused() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let l = 7.0;
        for (boxes, fits) in [
            (32767.0, true),
            (-32767.0, true),
            (32768.0, false),
            (-32768.0, false),
        ] {
            let mut b = bodies(2, l, 1);
            b[0].r = V3::new(1.0, 1.0, 1.0);
            b[1].r = V3::new(1.5 + boxes * l, 1.0, 1.0);
            match Lists::<Ball>::build(&e, &stored::<Ball>(&b), l, 0.2) {
                Ok(lists) => {
                    assert!(fits, "{boxes} boxes apart were linked");
                    // The image of body 1 beside body 0 is `boxes` boxes back.
                    assert_eq!(lists.of(0)[0].shift(), [-(boxes as i32), 0, 0]);
                }
                Err(err) => {
                    assert!(!fits, "{boxes} boxes apart were refused: {err}");
                    let ListLimit::Shift { i, j, shift } = err else {
                        panic!("{err}")
                    };
                    assert_eq!((i, j, shift[0].abs()), (0, 1, boxes.abs() as i32));
                    assert!(err.to_string().contains("32767"));
                }
            }
        }
    }

    /// A list holds at most 65535 entries: the next one is refused and nothing is written.
    #[test]
    fn a_list_stops_at_65535_entries() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let b = bodies(2, 12.0, 3);
        let mut lists =
            Lists::<Ball>::build(&e, &stored::<Ball>(&b), 12.0, 0.2).expect("lists within limits");
        lists.lists.clear(0);
        for p in 0..u16::MAX {
            assert_eq!(lists.room_at(0), Ok(p));
            lists.lists.push(
                0,
                Link {
                    j: 1,
                    back: 0,
                    shift: [0; 3],
                },
            );
        }
        assert_eq!(lists.room_at(0), Err(ListLimit::Length { i: 0 }));
        assert_eq!(lists.link(0, 1, [0; 3]), Err(ListLimit::Length { i: 0 }));
        assert_eq!(lists.of(0).len(), usize::from(u16::MAX));
        assert_eq!(lists.room_at(1), Ok(lists.of(1).len() as u16));
    }

    #[test]
    fn box_lists_match_brute_force_after_builds_and_partial_rebuilds() {
        let e = Ellipsoid::new(0.8, 0.4, 0.4);
        // A box with a grid of centres (10 > 3 × reach), one without (5.5 > 2 × reach), and one
        // where a box may overlap two images of another (4 < 2 × reach).
        for (n, l) in [(300, 10.0), (60, 5.5), (40, 4.0)] {
            let lists = check::<Obp>(&e, bodies(n, l, 7), l, 0.15, overlap, overlap);
            assert_eq!(lists.grid.is_some(), l == 10.0);
            assert_eq!(lists.single_image, l > 5.0);
        }
    }

    /// Sized balls (a mixture of radii 0.5 and 1): built and rebuilt each around its own
    /// sphere, the lists hold exactly the pairs whose centres are within r_i + r_j + 2Δ, which
    /// for two small spheres is well inside the largest pair's reach.
    #[test]
    fn sized_ball_lists_match_brute_force_for_each_pair_of_sizes() {
        use crate::ball::SizedBall;
        let delta = 0.2;
        let radius = |i: usize| if i.is_multiple_of(2) { 0.5 } else { 1.0 };
        let sphere = |i: usize| Ellipsoid::new(radius(i), radius(i), radius(i));
        let within = |k: f64| {
            move |a: &SizedBall, b: &SizedBall, shift: &V3| {
                (b.c + shift - a.c).norm() <= k * (a.radius + b.radius + 2.0 * delta)
            }
        };
        for (n, l) in [(300, 9.0), (40, 4.0)] {
            let mut b = bodies(n, l, 5);
            let mut lists =
                Lists::<SizedBall>::build_each(sphere, &stored::<SizedBall>(&b), l, delta)
                    .expect("limits");
            let (must, may) = (within(1.0 - 1e-12), within(1.0 + 1e-12));
            same(&lists, must, may, "after the build");
            let mut rng = crate::rng::Rng::new(11);
            for step in 0..200 {
                let i = step * 7 % n;
                b[i].r += V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 0.6;
                lists
                    .rebuild(&sphere(i), i, &SphereBody::from_body(&b[i]))
                    .expect("limits");
            }
            same(&lists, must, may, "after the rebuilds");
            // Some small pairs are farther apart than their own reach but within the largest.
            let small_far = (0..n).step_by(2).any(|i| {
                (0..n).step_by(2).any(|j| {
                    let d = (b[j].r - b[i].r).map(|x| x - l * (x / l).round()).norm();
                    i != j && d > 1.0 + 2.0 * delta && d < 2.0 * (1.0 + delta)
                })
            });
            assert!(small_far);
        }
    }

    #[test]
    fn ball_lists_match_brute_force_including_centres_on_cell_and_box_faces() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let delta = 0.2;
        let reach = 2.0 * (0.5 + delta);
        // Centres exactly `reach` apart may go either way by rounding.
        let within = |k: f64| move |a: &Ball, b: &Ball, shift: &V3| (b.c + shift - a.c).norm() <= k;
        for (n, l) in [(300, 7.0), (60, 3.0)] {
            let mut b = bodies(n, l, 3);
            // Centres on box faces and cell faces, one rounding step inside or outside them,
            // and at a distance of exactly `reach` from another.
            let side = l / (l / reach).floor();
            let on = [0.0, -0.0, l, -l, 2.0 * l, side, 2.0 * side, l - side];
            for (k, x) in on.into_iter().enumerate() {
                b[3 * k].r = V3::new(x, 0.5, 0.5);
                b[3 * k + 1].r = V3::new(x.next_down(), x.next_up(), l * 0.5);
                b[3 * k + 2].r = b[3 * k].r + V3::new(0.0, reach, 0.0);
            }
            let lists = check::<Ball>(
                &e,
                b,
                l,
                delta,
                within(reach * (1.0 - 1e-12)),
                within(reach * (1.0 + 1e-12)),
            );
            assert_eq!(lists.grid.is_some(), l == 7.0);
        }
    }

    proptest::proptest! {
        /// The single-precision gather keeps every member within reach, at the reach itself and
        /// a rounding step inside it, in boxes from 1 to 4,000 wide, with both centres anywhere
        /// in the box (near its faces too) and every cell image. Mutated to widen the reach by
        /// nothing, it fails.
        #[test]
        fn single_precision_gather_keeps_every_member_within_reach(
            l in 1.0f64..4000.0,
            reach_part in 0.001f64..(1.0 / 3.0),
            at in proptest::array::uniform3(0.0f64..1.0),
            dir in proptest::array::uniform3(-1.0f64..1.0),
            inside in proptest::sample::select(vec![0.0, 1e-15, 1e-9]),
        ) {
            proptest::prop_assume!(V3::from(dir).norm() > 0.1);
            let reach = reach_part * l;
            let wrapped_i = V3::from(at) * l;
            let d = V3::from(dir).normalize() * reach * (1.0 - inside);
            // The cell image that holds the other centre wrapped into the box.
            let shift = [0, 1, 2].map(|k| floor_i32((wrapped_i[k] + d[k]) / l));
            let wrapped_j = wrapped_i + d - image_offset(shift, l);
            proptest::prop_assume!((0..3).all(|k| (0.0..l).contains(&wrapped_j[k])));
            let origin = image_offset(shift, l) - wrapped_i;
            proptest::prop_assume!((wrapped_j + origin).norm() <= reach);
            let centre = SingleCentre::new(7, &wrapped_j);
            proptest::prop_assert!(centre.within(&SingleCentre::near(&origin, reach, l)));
        }

        /// The scan of a box without cells keeps the same bodies, in the same order, four at a
        /// time as one at a time: centres up to two boxes away, some at the reach itself (its
        /// square rounded either way), ties of the nearest image half a box away, any count
        /// (the fours and the rest).
        #[test]
        fn the_scan_within_reach_keeps_what_one_at_a_time_keeps(
            l in 1.0f64..100.0,
            reach_part in 0.01f64..0.5,
            at in proptest::array::uniform3(-2.0f64..3.0),
            others in proptest::collection::vec(
                (proptest::array::uniform3(-2.0f64..3.0), 0u8..4, proptest::array::uniform3(-1.0f64..1.0)),
                0..23,
            ),
        ) {
            let reach = reach_part * l;
            let centre = V3::from(at) * l;
            let regions: Vec<Ball> = others
                .iter()
                .map(|&(x, kind, dir)| {
                    let dir = V3::from(dir).try_normalize(1e-3).unwrap_or(V3::x());
                    let c = match kind {
                        // At the reach, one box away.
                        0 => centre + dir * reach + V3::new(l, 0.0, 0.0),
                        // Half a box away along x: the nearest image is a tie.
                        1 => centre + V3::new(0.5 * l, 0.0, 0.0),
                        _ => V3::from(x) * l,
                    };
                    Ball { c, delta: 0.1 }
                })
                .collect();
            let reach = Reach { centre, l, inv_l: 1.0 / l, reach2: reach * reach };
            let (mut fours, mut ones) = (vec![0; regions.len()], vec![0; regions.len()]);
            let centres = Centres::of(&regions);
            let n = within_reach(&centres, &reach, &mut fours);
            let m = within_reach_from(&centres, &reach, &mut ones, (0, 0));
            proptest::prop_assert_eq!(&fours[..n], &ones[..m]);
        }
    }
}
