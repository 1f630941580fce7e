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
    let b = r.dot(v);
    if b >= 0.0 {
        return None;
    }
    let c = r.norm_squared() - sigma * sigma;
    if c <= 0.0 {
        return Some(0.0);
    }
    let vv = v.norm_squared();
    let disc = b * b - vv * c;
    if disc < 0.0 {
        return None;
    }
    // c / (−b + √disc) is the small root without cancellation.
    Some(c / (-b + disc.sqrt()))
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
