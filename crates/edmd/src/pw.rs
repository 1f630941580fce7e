//! Perram–Wertheim contact function: the independent overlap oracle for ellipsoids.
//!
//! F(λ) = λ(1−λ) rᵀ[(1−λ)A + λB]⁻¹ r with A = Σ a_k² u_k u_kᵀ (J. Comput. Phys. 58, 409 (1985)).
//! max_λ F = μ², where μ is the factor by which both ellipsoids must be scaled about their centres
//! to touch: μ < 1 ⇔ overlap. F is concave in λ, so a one-dimensional search finds the maximum.

use crate::contact::brent_min;
use crate::ellipsoid::Ellipsoid;
use crate::geometry::{M3, V3};

/// Contact scale factor μ = √(max_λ F(λ)) for ellipsoids A, B with orientations `rot_*`
/// (rows = body axes) and centre separation `r` = r_B − r_A.
pub fn contact_scale(ea: &Ellipsoid, rot_a: &M3, eb: &Ellipsoid, rot_b: &M3, r: &V3) -> f64 {
    scale_of(&contact_function(ea, rot_a, eb, rot_b, r))
}

/// The contact scale, or `None` where it is proved above `k` without being computed: F is
/// concave and its maximum is μ², so F(½) > k² suffices (and the maximisation starts at ½, so
/// `contact_scale` then exceeds k as well). Monte Carlo only needs the scales of bodies in contact.
pub fn contact_scale_unless_above(
    ea: &Ellipsoid,
    rot_a: &M3,
    eb: &Ellipsoid,
    rot_b: &M3,
    r: &V3,
    k: f64,
) -> Option<f64> {
    let f = contact_function(ea, rot_a, eb, rot_b, r);
    (f(0.5) <= k * k).then(|| scale_of(&f))
}

/// F(λ) of A and B.
fn contact_function(
    ea: &Ellipsoid,
    rot_a: &M3,
    eb: &Ellipsoid,
    rot_b: &M3,
    r: &V3,
) -> impl Fn(f64) -> f64 {
    let a = ea.a_lab(rot_a);
    let b = eb.a_lab(rot_b);
    let r = *r;
    move |l: f64| {
        let m = a * (1.0 - l) + b * l;
        l * (1.0 - l) * r.dot(&solve_spd(&m, &r))
    }
}

/// μ = √(max_λ F(λ)).
fn scale_of(f: &impl Fn(f64) -> f64) -> f64 {
    // Brent's parabolic steps converge in a dozen evaluations on this smooth concave function.
    let (_, neg_max) = brent_min(0.0, 0.5, 1.0, 1e-10, |l| -f(l));
    (-neg_max).max(0.0).sqrt()
}

/// m⁻¹ r for a symmetric positive definite 3×3 matrix, by the adjugate (Cramer's rule).
fn solve_spd(m: &M3, r: &V3) -> V3 {
    let c0 = m.column(1).cross(&m.column(2));
    let c1 = m.column(2).cross(&m.column(0));
    let c2 = m.column(0).cross(&m.column(1));
    let det = m.column(0).dot(&c0);
    V3::new(c0.dot(r), c1.dot(r), c2.dot(r)) / det
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spheres_scale_is_centre_distance_over_diameter() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let r = V3::new(0.3, 0.9, -0.2);
        let mu = contact_scale(&e, &M3::identity(), &e, &M3::identity(), &r);
        assert!((mu - r.norm()).abs() < 1e-12);
    }

    /// Either the very scale of the full maximisation, or one above the threshold.
    #[test]
    fn the_shortcut_leaves_out_only_scales_above_the_threshold() {
        let e = Ellipsoid::new(0.794, 0.397, 0.397);
        let mut rng = crate::rng::Rng::new(3);
        let mut u = || rng.uniform() - 0.5;
        let (mut above, mut below) = (0, 0);
        for _ in 0..2000 {
            let ra = crate::rigid::rotate(&M3::identity(), &V3::new(u(), u(), u()), 3.0);
            let rb = crate::rigid::rotate(&M3::identity(), &V3::new(u(), u(), u()), 3.0);
            let r = V3::new(u(), u(), u()) * 3.0;
            let k = 1.0 + 0.2 * u();
            let mu = contact_scale(&e, &ra, &e, &rb, &r);
            let exact = mu > k;
            match contact_scale_unless_above(&e, &ra, &e, &rb, &r, k) {
                Some(got) => assert_eq!(got, mu),
                None => assert!(exact, "{mu} not above {k}"),
            }
            if exact { above += 1 } else { below += 1 }
        }
        assert!(above > 100 && below > 100, "{above} above, {below} below");
    }

    #[test]
    fn parallel_ellipsoids_end_to_end_and_side_by_side() {
        let e = Ellipsoid::new(1.0, 0.25, 0.25);
        let id = M3::identity();
        // Tip to tip along the long axis: contact at separation 2a.
        assert!((contact_scale(&e, &id, &e, &id, &V3::new(2.0, 0.0, 0.0)) - 1.0).abs() < 1e-12);
        // Side by side: contact at 2b.
        assert!((contact_scale(&e, &id, &e, &id, &V3::new(0.0, 0.5, 0.0)) - 1.0).abs() < 1e-12);
    }
}
