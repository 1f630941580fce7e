//! Nearest-neighbour lists kept per particle (Sec. 3.3 boxes, with the partial update of Donev et
//! al. [26] instead of the global rebuild of Sec. 3.5 step 4).
//!
//! Each body has its own oriented bounding parallelepiped, built when it last escaped the previous
//! one, and its list holds every body whose box overlaps its own, with the periodic image of the
//! overlap. The relation is symmetric, so a new box for one body touches only the lists of its old
//! and new neighbours: one escape costs one box and one prediction, not N of each.
//!
//! Positions are never wrapped (scheduled events keep their image shifts), so an image shift is
//! relative to the unwrapped positions and stays valid while both bodies keep moving.

use crate::cells::Cells;
use crate::geometry::{Surface, V3};
use crate::nnl::{Obp, overlap};
use crate::rigid::Body;

/// A neighbour: its index and the image shift (in box lengths) that puts it next to the body.
pub type Neighbour = (u32, [i32; 3]);

pub struct Lists {
    obps: Vec<Obp>,
    lists: Vec<Vec<Neighbour>>,
    delta: f64,
    l: f64,
    /// The diameter of a box's circumscribed sphere: boxes farther apart cannot overlap.
    reach: f64,
    /// Box centres binned in cells of side ≥ `reach`, when 3 fit per side; otherwise every body is
    /// tried.
    grid: Option<(Cells, Vec<usize>)>,
    /// Whether the box exceeds twice `reach`, so that only the nearest image of a body can overlap.
    single_image: bool,
}

impl Lists {
    /// Boxes around every body with margin `delta` (Δ_NNL) and all lists, in a periodic box of side `l`.
    pub fn build<S: Surface>(s: &S, bodies: &[Body], l: f64, delta: f64) -> Lists {
        let obps: Vec<Obp> = bodies.iter().map(|b| Obp::around(s, b, delta)).collect();
        let reach = 2.0 * s.semi_axes().add_scalar(delta).norm();
        let grid = Cells::new(l, reach).map(|mut cells| {
            let cell_of: Vec<usize> = obps
                .iter()
                .enumerate()
                .map(|(i, o)| {
                    let c = cells.index(cells.coords_of(&o.c));
                    cells.insert(c, i as u32);
                    c
                })
                .collect();
            (cells, cell_of)
        });
        let mut lists = Lists {
            lists: vec![Vec::new(); obps.len()],
            obps,
            delta,
            l,
            reach,
            grid,
            single_image: l > 2.0 * reach,
        };
        for i in 0..lists.obps.len() {
            let found = lists.find(i, |j| j > i);
            for &(j, s) in &found {
                lists.lists[j as usize].push((i as u32, s.map(|x| -x)));
            }
            lists.lists[i].extend(found);
        }
        lists
    }

    pub fn of(&self, i: usize) -> &[Neighbour] {
        &self.lists[i]
    }

    pub fn obp(&self, i: usize) -> &Obp {
        &self.obps[i]
    }

    /// A new box around `body` (particle `i`, at the present time), and the lists updated to match.
    pub fn rebuild<S: Surface>(&mut self, s: &S, i: usize, body: &Body) {
        for (j, shift) in std::mem::take(&mut self.lists[i]) {
            let theirs = &mut self.lists[j as usize];
            let back = shift.map(|x| -x);
            if let Some(p) = theirs
                .iter()
                .position(|&(k, s)| k as usize == i && s == back)
            {
                theirs.swap_remove(p);
            }
        }
        self.obps[i] = Obp::around(s, body, self.delta);
        if let Some((cells, cell_of)) = &mut self.grid {
            let c = cells.index(cells.coords_of(&self.obps[i].c));
            cells.remove(cell_of[i], i as u32);
            cells.insert(c, i as u32);
            cell_of[i] = c;
        }
        let found = self.find(i, |j| j != i);
        for &(j, shift) in &found {
            self.lists[j as usize].push((i as u32, shift.map(|x| -x)));
        }
        self.lists[i] = found;
    }

    /// The boxes, among those of bodies `j` with `take(j)`, that overlap box `i`, with their images.
    fn find(&self, i: usize, take: impl Fn(usize) -> bool) -> Vec<Neighbour> {
        let mut found = Vec::new();
        let a = &self.obps[i];
        let mut try_pair = |j: usize| {
            if !take(j) {
                return;
            }
            let b = &self.obps[j];
            // The image of j nearest to i first; beyond it only when the box is small.
            let nearest = ((a.c - b.c) / self.l).map(f64::round);
            let offsets: &[[i32; 3]] = if self.single_image {
                &[[0; 3]]
            } else {
                &ALL_27
            };
            for off in offsets {
                let s = [0, 1, 2].map(|k| nearest[k] as i32 + off[k]);
                let shift = V3::new(s[0] as f64, s[1] as f64, s[2] as f64) * self.l;
                let d = b.c + shift - a.c;
                if d.norm_squared() >= self.reach * self.reach {
                    continue;
                }
                // B inside its circumsphere against A's three slabs: most candidates end here,
                // before the 15-axis test builds its rotation.
                let local = a.rot * d;
                let radius = 0.5 * self.reach;
                if (0..3).any(|k| local[k].abs() > a.half[k] + radius) {
                    continue;
                }
                if overlap(a, b, &shift) {
                    found.push((j as u32, s));
                }
            }
        };
        match &self.grid {
            Some((cells, cell_of)) => {
                for nbc in cells.around(cell_of[i]) {
                    for &j in cells.members(nbc.cell) {
                        try_pair(j as usize);
                    }
                }
            }
            None => {
                for j in 0..self.obps.len() {
                    try_pair(j);
                }
            }
        }
        found
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
    use crate::ellipsoid::Ellipsoid;
    use crate::geometry::M3;
    use crate::rigid::rotate;

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

    /// Every overlapping pair of boxes, by brute force over all images.
    fn brute(l: &Lists) -> Vec<(usize, usize, [i32; 3])> {
        let mut all = Vec::new();
        let n = l.obps.len();
        for i in 0..n {
            for j in 0..n {
                if i == j {
                    continue;
                }
                let nearest = ((l.obps[i].c - l.obps[j].c) / l.l).map(f64::round);
                for off in ALL_27 {
                    let s = [0, 1, 2].map(|k| nearest[k] as i32 + off[k]);
                    let shift = V3::new(s[0] as f64, s[1] as f64, s[2] as f64) * l.l;
                    if overlap(&l.obps[i], &l.obps[j], &shift) {
                        all.push((i, j, s));
                    }
                }
            }
        }
        all.sort();
        all
    }

    fn listed(l: &Lists) -> Vec<(usize, usize, [i32; 3])> {
        let mut all: Vec<_> = (0..l.obps.len())
            .flat_map(|i| l.of(i).iter().map(move |&(j, s)| (i, j as usize, s)))
            .collect();
        all.sort();
        all
    }

    #[test]
    fn lists_match_brute_force_after_builds_and_partial_rebuilds() {
        let e = Ellipsoid::new(0.8, 0.4, 0.4);
        // A box with a grid of centres (10 > 3 × reach), one without (5.5 > 2 × reach), and one
        // where a box may overlap two images of another (4 < 2 × reach).
        for (n, l) in [(300, 10.0), (60, 5.5), (40, 4.0)] {
            let mut b = bodies(n, l, 7);
            let mut lists = Lists::build(&e, &b, l, 0.15);
            assert_eq!(lists.grid.is_some(), l == 10.0);
            assert_eq!(lists.single_image, l > 5.0);
            assert_eq!(listed(&lists), brute(&lists));
            let mut rng = crate::rng::Rng::new(11);
            for step in 0..200 {
                let i = step * 7 % n;
                b[i].r += V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 0.6;
                b[i].rot = rotate(&b[i].rot, &V3::new(1.0, rng.uniform(), 0.0), 0.3);
                lists.rebuild(&e, i, &b[i]);
            }
            assert!(!listed(&lists).is_empty());
            assert_eq!(listed(&lists), brute(&lists));
        }
    }
}
