//! Which runs a figure compares: the knobs a figure does not vary are held at the campaign's
//! baseline, so that (say) Figure 7 never averages the ε_d sweep of Figure 9 into its curves.

use std::cmp::Ordering;
use std::collections::BTreeMap;

use crate::EdmdRow;

/// Whether a smaller or a larger value of a knob is the more careful (slower) setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Tighter {
    Smaller,
    Larger,
}

/// The accuracy knobs of a scene, with the direction that makes each tighter.
pub(crate) const KNOBS: [(&str, Tighter); 8] = [
    ("eps_d", Tighter::Smaller),
    ("eps_nnl", Tighter::Smaller),
    ("nr_tol", Tighter::Smaller),
    ("nr_relax", Tighter::Smaller),
    ("brent_tol", Tighter::Smaller),
    ("sd_tol", Tighter::Smaller),
    ("nr_max_iter", Tighter::Larger),
    ("sd_max_iter", Tighter::Larger),
];
pub(crate) const EPS_D: usize = 0;

/// A row's knob values, in the order of [`KNOBS`].
pub(crate) fn knobs(r: &EdmdRow) -> [f64; 8] {
    [
        r.eps_d,
        r.eps_nnl,
        r.nr_tol,
        r.nr_relax,
        r.brent_tol,
        r.sd_tol,
        f64::from(r.nr_max_iter),
        f64::from(r.sd_max_iter),
    ]
}

/// A float usable as a map key (ordered by `total_cmp`; equal when bit-identical).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Key(pub f64);

impl PartialEq for Key {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Key {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// The most frequent value (the smallest of equally frequent ones).
fn mode(values: impl Iterator<Item = f64>) -> Option<f64> {
    let mut counts: BTreeMap<Key, usize> = BTreeMap::new();
    for v in values {
        *counts.entry(Key(v)).or_default() += 1;
    }
    counts
        .into_iter()
        .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
        .map(|(k, _)| k.0)
}

/// Per shape, the most frequent value of every knob and of Δ_NNL among NNL runs: the setting a
/// campaign's figures hold fixed while they vary something else.
pub(crate) struct Baseline {
    per_shape: BTreeMap<String, ShapeBaseline>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ShapeBaseline {
    pub knobs: [f64; 8],
    pub delta_nnl: Option<f64>,
}

impl Baseline {
    pub fn of(rows: &[EdmdRow]) -> Self {
        let mut by_shape: BTreeMap<&str, Vec<&EdmdRow>> = BTreeMap::new();
        for r in rows {
            by_shape.entry(&r.shape).or_default().push(r);
        }
        let per_shape = by_shape
            .into_iter()
            .map(|(shape, rows)| {
                let mut values = [0.0; 8];
                for (k, value) in values.iter_mut().enumerate() {
                    *value = mode(rows.iter().map(|r| knobs(r)[k])).unwrap_or(f64::NAN);
                }
                let delta_nnl = mode(
                    rows.iter()
                        .filter(|r| r.neighbours == "nnl")
                        .map(|r| r.delta_nnl),
                );
                (
                    shape.to_owned(),
                    ShapeBaseline {
                        knobs: values,
                        delta_nnl,
                    },
                )
            })
            .collect();
        Self { per_shape }
    }

    pub fn of_shape(&self, shape: &str) -> Option<ShapeBaseline> {
        self.per_shape.get(shape).copied()
    }

    /// Whether every knob of `r` but `free` (an index into [`KNOBS`]) is at its baseline.
    pub fn knobs_match(&self, r: &EdmdRow, free: Option<usize>) -> bool {
        let Some(base) = self.of_shape(&r.shape) else {
            return false;
        };
        knobs(r)
            .iter()
            .zip(&base.knobs)
            .enumerate()
            .all(|(k, (a, b))| Some(k) == free || Key(*a) == Key(*b))
    }

    /// Whether `r` is an LL run or an NNL run at the baseline Δ_NNL.
    pub fn delta_matches(&self, r: &EdmdRow) -> bool {
        r.neighbours != "nnl"
            || self
                .of_shape(&r.shape)
                .and_then(|b| b.delta_nnl)
                .is_some_and(|d| Key(d) == Key(r.delta_nnl))
    }

    /// Runs at the baseline in every respect.
    pub fn at_baseline(&self, r: &EdmdRow) -> bool {
        self.knobs_match(r, None) && self.delta_matches(r)
    }
}

/// Points grouped by x and averaged in y (repeated runs, other seeds), sorted by x, each with
/// the number of runs behind it.
pub(crate) fn mean_by_x(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64, u32)> {
    let mut sums: BTreeMap<Key, (f64, u32)> = BTreeMap::new();
    for (x, y) in points {
        let entry = sums.entry(Key(x)).or_default();
        entry.0 += y;
        entry.1 += 1;
    }
    sums.into_iter()
        .map(|(x, (sum, n))| (x.0, sum / f64::from(n), n))
        .collect()
}

/// Usable τ_c: positive and finite.
pub(crate) fn timed(r: &EdmdRow) -> bool {
    r.tau_c_us > 0.0 && r.tau_c_us.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(eps_d: f64, delta_nnl: f64, neighbours: &str) -> EdmdRow {
        EdmdRow {
            shape: "ellipsoid".into(),
            neighbours: neighbours.into(),
            eps_d,
            delta_nnl,
            nr_tol: 1e-10,
            ..Default::default()
        }
    }

    #[test]
    fn the_baseline_is_the_most_frequent_setting() {
        let rows = vec![
            row(1e-5, 0.06, "nnl"),
            row(1e-5, 0.06, "nnl"),
            row(1e-5, 0.06, "ll"),
            row(1e-2, 0.06, "nnl"),
            row(1e-5, 0.2, "nnl"),
        ];
        let base = Baseline::of(&rows);
        let b = base.of_shape("ellipsoid").unwrap();
        assert_eq!(b.knobs[EPS_D], 1e-5);
        assert_eq!(b.delta_nnl, Some(0.06));
        assert!(base.at_baseline(&rows[0]) && base.at_baseline(&rows[2]));
        assert!(!base.at_baseline(&rows[3]) && base.knobs_match(&rows[3], Some(EPS_D)));
        assert!(!base.at_baseline(&rows[4]) && base.knobs_match(&rows[4], None));
        // LL ignores Δ_NNL.
        assert!(base.delta_matches(&row(1e-5, 0.9, "ll")));
        assert!(!base.at_baseline(&EdmdRow {
            shape: "sphere".into(),
            ..rows[0].clone()
        }));
    }

    #[test]
    fn repeats_are_averaged_per_x() {
        assert_eq!(
            mean_by_x([(0.3, 1.0), (0.4, 5.0), (0.3, 3.0)].into_iter()),
            vec![(0.3, 2.0, 2), (0.4, 5.0, 1)]
        );
    }
}
