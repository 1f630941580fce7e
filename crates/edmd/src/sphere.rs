//! Hard spheres: the analytic path (no Newton–Raphson, no rotation).

use crate::geometry::V3;

/// Signed surface distance |r| − σ of two spheres whose centres are `r` apart.
pub fn distance(r: &V3, sigma: f64) -> f64 {
    r.norm() - sigma
}

/// Contact time of two spheres with relative position `r` = r_B − r_A and velocity `v` = v_B − v_A:
/// the smaller root of |r + v t| = σ. Returns 0 for overlapping spheres that still approach
/// (numerical overlap after a collision is thereby resolved, never amplified).
pub fn contact_time(r: &V3, v: &V3, sigma: f64) -> Option<f64> {
    let t = contact_time_or_inf(r, v, sigma * sigma);
    t.is_finite().then_some(t)
}

/// [`contact_time`] as +∞ for "never". Two coincident centres (a body against itself) give +∞.
pub fn contact_time_or_inf(r: &V3, v: &V3, sigma2: f64) -> f64 {
    contact_time_from(r.dot(v), r.norm_squared() - sigma2, v.norm_squared())
}

/// The contact time from b = r·v, c = |r|² − σ² and |v|², without data-dependent branches: whether
/// a pair approaches is a coin flip, and mispredictions would serialise the square roots and
/// divisions that the sphere path's hot loop otherwise overlaps (and vectorises) over a batch.
#[inline(always)]
pub fn contact_time_from(b: f64, c: f64, vv: f64) -> f64 {
    let disc = b * b - vv * c;
    // c / (−b + √disc) is the small root without cancellation; c ≤ 0 (overlap) gives ≤ 0, hence 0.
    let t = (c / (-b + disc.max(0.0).sqrt())).max(0.0);
    if b < 0.0 && disc >= 0.0 {
        t
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_on_and_miss() {
        let r = V3::new(3.0, 0.0, 0.0);
        let v = V3::new(-1.0, 0.0, 0.0);
        assert!((contact_time(&r, &v, 1.0).unwrap() - 2.0).abs() < 1e-15);
        assert_eq!(contact_time(&r, &(-v), 1.0), None);
        let r = V3::new(3.0, 1.000001, 0.0);
        assert_eq!(contact_time(&r, &v, 1.0), None);
        let r = V3::new(3.0, 0.999999, 0.0);
        let t = contact_time(&r, &v, 1.0).unwrap();
        assert!(distance(&(r + v * t), 1.0).abs() < 1e-12);
    }
}
