//! The two ellipsoids that bracket a superquadric Σ |x_k/s_k|^(e_k) ≤ 1 of exponents e_k ≥ 2:
//! the inscribed one of the same semi-axes (|t|^e ≤ t² where |t| ≤ 1), and the circumscribed one
//! of semi-axes κ s_k, κ² = max Σ (x_k/s_k)² over the superquadric. Contact scales order as the
//! shapes nest (a smaller body must be scaled up more to touch): μ_outer ≤ μ_SQ ≤ μ_inner, so
//! the Perram–Wertheim function of either ellipsoid (≈ 1 µs) decides most pairs of the Monte
//! Carlo without the superquadric's distance (≈ 100 µs, [`crate::scale::contact_scale`]).

/// κ² = max Σ u_k^(p_k) over the simplex Σ u_k = 1, u_k ≥ 0 (u_k = |x_k/s_k|^(e_k),
/// p_k = 2/e_k ∈ (0, 1]), never below it. The sum is concave and separable, so the Lagrangian
/// dual D(λ) = λ + Σ_k max_{u ≥ 0} (u^(p_k) − λ u) bounds it from above at every admissible λ
/// (λ ≥ 1 where some p_k = 1, whose term is otherwise unbounded) and equals it at the optimal λ:
/// bisection finds that λ (where Σ_k u_k*(λ) = 1, u_k* = (p_k/λ)^(1/(1 − p_k)) the inner
/// maximiser), and D at whatever λ it stops is still an upper bound. 1 for an ellipsoid; 1.25
/// for exponents [2, 2, 4]; 3 in the limit of a box.
pub fn outer_factor_squared(e: [f64; 3]) -> f64 {
    let p = e.map(|e| 2.0 / e);
    let curved: Vec<f64> = p.iter().copied().filter(|&p| p < 1.0).collect();
    let lambda_min = if curved.len() < 3 { 1.0 } else { 0.0 };
    let u = |p: f64, lambda: f64| (p / lambda).powf(1.0 / (1.0 - p));
    let total = |lambda: f64| curved.iter().map(|&p| u(p, lambda)).sum::<f64>();
    let dual = |lambda: f64| {
        lambda
            + curved
                .iter()
                .map(|&p| {
                    let x = u(p, lambda);
                    x.powf(p) - lambda * x
                })
                .sum::<f64>()
    };
    // Σ u_k*(λ) decreases with λ; at λ = max_k p_k 3^(1 − p_k) every u_k* ≤ 1/3.
    let mut hi = curved
        .iter()
        .map(|&p| p * 3f64.powf(1.0 - p))
        .fold(lambda_min, f64::max);
    if total(lambda_min.max(f64::MIN_POSITIVE)) <= 1.0 {
        // The flat terms (p = 1) take the rest of the simplex at λ = 1, or every term is flat.
        return dual(lambda_min) * (1.0 + 4.0 * f64::EPSILON);
    }
    let mut lo = lambda_min;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if total(mid) > 1.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // D(λ) ≥ the maximum at any admissible λ (hi ≥ λ_min); the margin covers its rounding.
    dual(hi) * (1.0 + 16.0 * f64::EPSILON)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Σ (x_k/s_k)² at the point of the superquadric's surface in direction `d` (body frame),
    /// found by bisection on the radius: the oracle, independent of the dual.
    fn surface_square(e: [f64; 3], d: [f64; 3]) -> f64 {
        let f = |t: f64| (0..3).map(|k| (d[k] * t).abs().powf(e[k])).sum::<f64>();
        let (mut lo, mut hi) = (0.0, 1.0);
        while f(hi) < 1.0 {
            hi *= 2.0;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) < 1.0 { lo = mid } else { hi = mid }
        }
        (0..3).map(|k| (d[k] * lo).powi(2)).sum()
    }

    #[test]
    fn closed_cases() {
        assert!((outer_factor_squared([2.0; 3]) - 1.0).abs() < 1e-14);
        assert!((outer_factor_squared([2.0, 2.0, 4.0]) - 1.25).abs() < 1e-12);
        // Two exponents 4: u = ¼ each at λ = 1 leaves ½ to the flat axis, 2·½ + ½ = 1.5.
        assert!((outer_factor_squared([2.0, 4.0, 4.0]) - 1.5).abs() < 1e-12);
        // Every exponent 4: equal u = ⅓, 3·(⅓)^½ = √3.
        assert!((outer_factor_squared([4.0; 3]) - 3f64.sqrt()).abs() < 1e-12);
        assert!(outer_factor_squared([1e6; 3]) < 3.0 + 1e-9);
    }

    proptest! {
        /// No point of the surface lies outside the outer ellipsoid or inside the inner one,
        /// and the outer one touches it: the largest Σ (x_k/s_k)² over directions near the
        /// dual's maximiser is within 10⁻⁹ of κ² (u_k* gives that point: x_k = s_k u_k^(1/e_k)).
        #[test]
        fn the_ellipsoids_bracket_the_surface_and_the_outer_one_touches_it(
            e in prop::array::uniform3(2.0f64..12.0),
            flat in prop::array::uniform3(any::<bool>()),
            d in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let e = [0, 1, 2].map(|k| if flat[k] { 2.0 } else { e[k] });
            let k2 = outer_factor_squared(e);
            prop_assume!(d.iter().map(|x| x * x).sum::<f64>() > 1e-6);
            let at = surface_square(e, d);
            prop_assert!(at <= k2 * (1.0 + 1e-12), "{e:?} {d:?}: {at} > {k2}");
            prop_assert!(at >= 1.0 - 1e-12, "{e:?} {d:?}: {at} < 1");
            // The touching point: maximise over the simplex on a fine grid, then polish.
            let mut best = 0.0f64;
            let m = 400;
            for i in 0..=m {
                for j in 0..=(m - i) {
                    let u = [i as f64 / m as f64, j as f64 / m as f64, (m - i - j) as f64 / m as f64];
                    best = best.max((0..3).map(|k| u[k].powf(2.0 / e[k])).sum());
                }
            }
            prop_assert!(best <= k2 * (1.0 + 1e-12));
            prop_assert!(best >= k2 * (1.0 - 2e-2), "{e:?}: grid {best} vs {k2}");
        }
    }
}
