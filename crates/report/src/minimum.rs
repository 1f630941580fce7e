//! Where a measured curve τ_c(Δ) has its minimum: a parabola in log Δ through the smallest
//! measured value and its neighbours, not just the smallest grid value.

use serde::{Deserialize, Serialize};

/// How [`locate_minimum`] found the minimum.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MinimumMethod {
    /// Least-squares parabola through the smallest value and up to two neighbours on each side.
    Parabola5,
    /// The parabola through the smallest value and its two neighbours (the wider fit was not
    /// convex or put its vertex outside its points).
    Parabola3,
    /// The smallest value is at an end of the grid: the minimum is not bracketed, and `x` is
    /// only that end.
    GridEdge,
    /// Not fitted to a grid: the answer of a `[[tune]]` search (the vertex of its last parabola,
    /// or its best evaluated value).
    Search,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Minimum {
    /// Where the minimum lies (same unit as the input's x).
    pub x: f64,
    /// The fitted (or, at a grid edge, measured) value there.
    pub y: f64,
    pub method: MinimumMethod,
}

impl Minimum {
    /// Whether the grid brackets the minimum, so that `x` is a located minimum.
    pub fn bracketed(&self) -> bool {
        self.method != MinimumMethod::GridEdge
    }
}

/// The minimum of `points` (x > 0, sorted by x, distinct x), fitted in log x. `None` for fewer
/// than three points or a non-positive x.
pub fn locate_minimum(points: &[(f64, f64)]) -> Option<Minimum> {
    if points.len() < 3
        || points
            .iter()
            .any(|&(x, y)| x.is_nan() || x <= 0.0 || !y.is_finite())
    {
        return None;
    }
    let logs: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x.ln(), y)).collect();
    let k = (0..logs.len()).min_by(|&i, &j| logs[i].1.total_cmp(&logs[j].1))?;
    if k == 0 || k == logs.len() - 1 {
        return Some(Minimum {
            x: points[k].0,
            y: points[k].1,
            method: MinimumMethod::GridEdge,
        });
    }
    let wide = &logs[k.saturating_sub(2)..(k + 3).min(logs.len())];
    if wide.len() > 3
        && let Some((u, y)) = least_squares_vertex(wide)
    {
        return Some(Minimum {
            x: u.exp(),
            y,
            method: MinimumMethod::Parabola5,
        });
    }
    let (u, y) = least_squares_vertex(&logs[k - 1..=k + 1])?;
    Some(Minimum {
        x: u.exp(),
        y,
        method: MinimumMethod::Parabola3,
    })
}

/// Vertex of the least-squares parabola y = a u² + b u + c through `points` (exact through
/// three), if it opens upwards and its vertex lies within the points' u range.
fn least_squares_vertex(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    // Centre u for a well-conditioned 3×3 system.
    let mean = points.iter().map(|p| p.0).sum::<f64>() / points.len() as f64;
    let mut m = [[0.0f64; 4]; 3];
    for &(u, y) in points {
        let u = u - mean;
        let basis = [u * u, u, 1.0];
        for (row, &bi) in m.iter_mut().zip(&basis) {
            for (cell, &bj) in row.iter_mut().zip(&basis) {
                *cell += bi * bj;
            }
            row[3] += bi * y;
        }
    }
    let [a, b, c] = solve3(m)?;
    if a.is_nan() || a <= 0.0 {
        return None;
    }
    let vertex = -b / (2.0 * a);
    let (lo, hi) = (points[0].0 - mean, points[points.len() - 1].0 - mean);
    (lo..=hi)
        .contains(&vertex)
        .then_some((vertex + mean, a * vertex * vertex + b * vertex + c))
}

/// Gaussian elimination with partial pivoting of an augmented 3×3 system.
fn solve3(mut m: [[f64; 4]; 3]) -> Option<[f64; 3]> {
    for col in 0..3 {
        let pivot = (col..3).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        m.swap(col, pivot);
        if m[col][col].abs() < 1e-300 {
            return None;
        }
        let pivot_row = m[col];
        for row in m.iter_mut().skip(col + 1) {
            let f = row[col] / pivot_row[col];
            for (cell, p) in row.iter_mut().zip(pivot_row).skip(col) {
                *cell -= f * p;
            }
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let tail: f64 = (row + 1..3).map(|k| m[row][k] * x[k]).sum();
        x[row] = (m[row][3] - tail) / m[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(f: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
        [0.02, 0.04, 0.07, 0.1, 0.15, 0.25, 0.4, 0.6]
            .into_iter()
            .map(|x| (x, f(x)))
            .collect()
    }

    #[test]
    fn a_parabola_in_log_delta_is_found_between_grid_values() {
        let points = grid(|x| 30.0 + 4.0 * (x / 0.13_f64).ln().powi(2));
        let m = locate_minimum(&points).expect("a minimum");
        assert_eq!(m.method, MinimumMethod::Parabola5);
        assert!((m.x - 0.13).abs() < 1e-9, "{m:?}");
        assert!((m.y - 30.0).abs() < 1e-9, "{m:?}");
        // Not the smallest grid value (0.15).
        assert!(m.bracketed());
    }

    #[test]
    fn an_asymmetric_minimum_lies_between_the_neighbours() {
        // τ = Δu⁻¹-like at small Δ and linear at large Δ (Eqs. 74–75): the minimum is at
        // x = sqrt(0.01 / 1) = 0.1 exactly, and the fit must land within a grid step.
        let points = grid(|x| 0.01 / x + x);
        let m = locate_minimum(&points).expect("a minimum");
        assert!(m.x > 0.07 && m.x < 0.15, "{m:?}");
        assert!((m.x / 0.1).ln().abs() < 0.2, "{m:?}");
    }

    #[test]
    fn a_minimum_at_the_edge_is_not_bracketed() {
        let m = locate_minimum(&grid(|x| x)).expect("a minimum");
        assert_eq!(m.method, MinimumMethod::GridEdge);
        assert_eq!(m.x, 0.02);
        assert!(!m.bracketed());
        let m = locate_minimum(&grid(|x| -x)).expect("a minimum");
        assert_eq!((m.x, m.method), (0.6, MinimumMethod::GridEdge));
        assert_eq!(locate_minimum(&[(0.1, 1.0), (0.2, 0.5)]), None);
        assert_eq!(locate_minimum(&[(0.0, 1.0), (0.1, 0.5), (0.2, 1.0)]), None);
    }

    #[test]
    fn noise_on_the_wide_fit_falls_back_to_three_points() {
        // Smallest at 0.1; the outer neighbours make the five-point fit concave.
        let points = vec![(0.02, 1.0), (0.05, 9.0), (0.1, 5.0), (0.2, 9.5), (0.4, 1.2)];
        // 0.02 and 0.4 are smaller than 0.1: the minimum is the grid edge 0.02.
        assert_eq!(
            locate_minimum(&points).unwrap().method,
            MinimumMethod::GridEdge
        );
        let points = vec![
            (0.02, 20.0),
            (0.05, 9.0),
            (0.1, 5.0),
            (0.2, 9.5),
            (0.4, 6.0),
        ];
        let m = locate_minimum(&points).unwrap();
        assert!(m.bracketed() && m.x > 0.05 && m.x < 0.2, "{m:?}");
    }
}
