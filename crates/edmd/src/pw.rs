//! Perram–Wertheim contact function: the independent overlap oracle for ellipsoids.
//!
//! F(λ) = λ(1−λ) rᵀ[(1−λ)A + λB]⁻¹ r with A = Σ a_k² u_k u_kᵀ (J. Comput. Phys. 58, 409 (1985)).
//! max_λ F = μ², where μ is the factor by which both ellipsoids must be scaled about their centres
//! to touch: μ < 1 ⇔ overlap. F is concave in λ, so Newton on F′(λ) = 0 inside a bracket finds
//! the maximum.

use crate::ellipsoid::Ellipsoid;
use crate::geometry::{M3, V3};

/// Contact scale factor μ = √(max_λ F(λ)) for ellipsoids A, B with orientations `rot_*`
/// (rows = body axes) and centre separation `r` = r_B − r_A.
pub fn contact_scale(ea: &Ellipsoid, rot_a: &M3, eb: &Ellipsoid, rot_b: &M3, r: &V3) -> f64 {
    Pw::new(ea, rot_a, eb, rot_b, r).scale()
}

/// [`contact_scale`] of the ellipsoids of lab matrices `a` and `b` ([`Ellipsoid::a_lab`]).
pub fn contact_scale_lab(a: &M3, b: &M3, r: &V3) -> f64 {
    Pw::lab(a, b, r).scale()
}

/// [`contact_scale_lab`] with the unit normal n (from A towards B) that the ellipsoids, scaled by
/// μ, share where they touch: at the maximiser λ* the touching point of A is
/// r_A + (1 − λ*) A M⁻¹ r, where A's normal A⁻¹(x − r_A) is along M⁻¹ r, M = (1 − λ*)A + λ*B
/// (Perram–Wertheim), and B's is opposite.
pub fn contact_scale_and_normal_lab(a: &M3, b: &M3, r: &V3) -> (f64, V3) {
    let pw = Pw::lab(a, b, r);
    let (best, at, _) = pw.maximise(|_, _, _| None);
    (best.max(0.0).sqrt(), pw.normal_at(at))
}

/// The normal of [`contact_scale_and_normal_lab`] for an axis, whose gap is measured on the
/// bodies' own support points: the maximisation stops where |F′| ≤ 10⁻³ F, one or two Newton
/// iterations short of 10⁻⁹ in λ, and the unscaled bodies' gap along the axis falls short of the
/// one along the exact normal by a thousandth of it at most (4.7·10⁻⁴ over 2·10⁵ random pairs
/// of aspect ratios up to 10).
pub fn contact_normal_lab(a: &M3, b: &M3, r: &V3) -> V3 {
    let pw = Pw::lab(a, b, r);
    let (_, at, _) = pw.maximise(|_, f, f1| (f1.abs() <= 1e-3 * f).then_some(true));
    pw.normal_at(at)
}

/// The normal of [`contact_scale_and_normal_lab`] from the maximiser λ* a search returned
/// ([`contact_scale_unless_above_lab`]).
pub fn normal_at_lab(a: &M3, b: &M3, r: &V3, lambda: f64) -> V3 {
    Pw::lab(a, b, r).normal_at(lambda)
}

/// The contact scale, or `None` where it is proved above `k` without being computed: every F(λ)
/// is at most its maximum μ², so F(½) > k² decides most pairs, and any later iterate of the
/// maximisation above k² ends it. Monte Carlo only needs the scales of bodies in contact.
pub fn contact_scale_unless_above(
    ea: &Ellipsoid,
    rot_a: &M3,
    eb: &Ellipsoid,
    rot_b: &M3,
    r: &V3,
    k: f64,
) -> Option<f64> {
    contact_scale_unless_above_lab(&ea.a_lab(rot_a), &eb.a_lab(rot_b), r, k).map(|(mu, _)| mu)
}

/// [`contact_scale_unless_above`] of the ellipsoids of lab matrices `a` and `b`, with the
/// maximiser λ* of F, where their contact normal is ([`normal_at_lab`]).
pub fn contact_scale_unless_above_lab(a: &M3, b: &M3, r: &V3, k: f64) -> Option<(f64, f64)> {
    let k2 = k * k;
    if above_at_half(a, b, r, k2) {
        return None;
    }
    let pw = Pw::lab(a, b, r);
    match pw.maximise(|_, f, _| (f > k2).then_some(true)) {
        (_, _, Some(_)) => None,
        (best, at, None) => Some((best.max(0.0).sqrt(), at)),
    }
}

/// Whether μ ≤ `k` (the ellipsoids scaled by `k` touch or overlap), decided as soon as either
/// side is proved: every F(λ) > k² proves μ > k (F(λ) ≤ μ²), and F, concave, lies under each of
/// its tangents, so the lowest crossing of a tangent where F rises with one where it falls
/// bounds μ² from above: at or below k², μ ≤ k. The Newton iterates of `Pw::scale` supply both,
/// so most pairs of a dense packing are decided in one or two steps instead of converging to
/// 10⁻⁹ (the Monte Carlo's tests of a move ask this and no more).
pub fn within(ea: &Ellipsoid, rot_a: &M3, eb: &Ellipsoid, rot_b: &M3, r: &V3, k: f64) -> bool {
    within_lab(&ea.a_lab(rot_a), &eb.a_lab(rot_b), r, k)
}

/// [`within`] for the ellipsoids of lab matrices `a` and `b`.
pub fn within_lab(a: &M3, b: &M3, r: &V3, k: f64) -> bool {
    let k2 = k * k;
    !above_at_half(a, b, r, k2) && Pw::lab(a, b, r).within(k2)
}

/// Whether F(½) > `k2`, which proves μ² > `k2` (F(λ) ≤ μ² everywhere) and decides most pairs
/// of a dense packing whose bounding spheres meet. F(½) = ½ rᵀ(A + B)⁻¹r, compared without a
/// division through the adjugate of the symmetric S = A + B (det S > 0), before any `Pw` is
/// built: the Monte Carlo asks it of every pair whose bounding spheres meet (its pair tests at
/// X0 = 2, N 4096: 3.46 → 2.82 G instructions a start, against `Pw::f(0.5)`).
#[inline]
fn above_at_half(a: &M3, b: &M3, r: &V3, k2: f64) -> bool {
    let s = a + b;
    let (s00, s01, s02, s11, s12, s22) = (s.m11, s.m12, s.m13, s.m22, s.m23, s.m33);
    let c00 = s11 * s22 - s12 * s12;
    let c01 = s02 * s12 - s01 * s22;
    let c02 = s01 * s12 - s02 * s11;
    let c11 = s00 * s22 - s02 * s02;
    let c12 = s01 * s02 - s00 * s12;
    let c22 = s00 * s11 - s01 * s01;
    let det = s00 * c00 + s01 * c01 + s02 * c02;
    let (x, y, z) = (r.x, r.y, r.z);
    let q =
        c00 * x * x + c11 * y * y + c22 * z * z + 2.0 * (c01 * x * y + c02 * x * z + c12 * y * z);
    0.5 * q > k2 * det
}

/// F(λ) of A and B, with its derivatives.
struct Pw {
    a: M3,
    /// B − A = dM/dλ, M(λ) = (1 − λ)A + λB.
    d: M3,
    r: V3,
}

impl Pw {
    fn new(ea: &Ellipsoid, rot_a: &M3, eb: &Ellipsoid, rot_b: &M3, r: &V3) -> Self {
        Pw::lab(&ea.a_lab(rot_a), &eb.a_lab(rot_b), r)
    }

    fn lab(a: &M3, b: &M3, r: &V3) -> Self {
        Pw {
            a: *a,
            d: b - a,
            r: *r,
        }
    }

    fn m(&self, l: f64) -> M3 {
        self.a + self.d * l
    }

    /// The unit normal, from A towards B, at λ ([`contact_scale_and_normal_lab`]).
    fn normal_at(&self, l: f64) -> V3 {
        solve_spd(&self.m(l), &self.r).normalize()
    }

    fn f(&self, l: f64) -> f64 {
        l * (1.0 - l) * self.r.dot(&solve_spd(&self.m(l), &self.r))
    }

    /// F, F′, F″ at λ: with x = M⁻¹r and g = r·x, g′ = −xᵀDx and g″ = 2 (Dx)ᵀM⁻¹(Dx)
    /// (dM⁻¹/dλ = −M⁻¹DM⁻¹), and F = h g with h = λ(1 − λ).
    fn derivatives(&self, l: f64) -> (f64, f64, f64) {
        let m = self.m(l);
        let x = solve_spd(&m, &self.r);
        let dx = self.d * x;
        let (g, g1, g2) = (
            self.r.dot(&x),
            -x.dot(&dx),
            2.0 * dx.dot(&solve_spd(&m, &dx)),
        );
        let (h, h1) = (l * (1.0 - l), 1.0 - 2.0 * l);
        (h * g, h1 * g + h * g1, -2.0 * g + 2.0 * h1 * g1 + h * g2)
    }

    /// Whether max F ≤ `k2` ([`within`]), by the iterates of [`Pw::scale`].
    fn within(&self, k2: f64) -> bool {
        // The latest tangents (λ, F, F′) where F rises and where it falls.
        let (mut rising, mut falling): (Option<Tangent>, Option<Tangent>) = (None, None);
        let (best, _, verdict) = self.maximise(|l, f, f1| {
            if f > k2 {
                return Some(false);
            }
            if f1 > 0.0 {
                rising = Some((l, f, f1));
            } else {
                falling = Some((l, f, f1));
            }
            (upper_bound(rising, falling) <= k2).then_some(true)
        });
        verdict.unwrap_or(best <= k2)
    }

    /// μ = √(max_λ F(λ)) ([`Pw::maximise`]).
    fn scale(&self) -> f64 {
        self.maximise(|_, _, _| None).0.max(0.0).sqrt()
    }

    /// The maximum of F: Newton on F′ = 0 from λ = ½, kept inside the bracket where F′ changes
    /// sign (F′(0) = rᵀA⁻¹r > 0 > F′(1)), a bisection wherever a step leaves it. F is concave, so
    /// Newton converges quadratically, in 3–5 steps where Brent's search took a dozen and more
    /// evaluations to 10⁻¹⁰. The largest F seen is returned, with the λ it was seen at: every
    /// F(λ) is a lower bound of μ². `visit` sees every iterate (λ, F, F′) and may end the search
    /// with its verdict.
    fn maximise(
        &self,
        mut visit: impl FnMut(f64, f64, f64) -> Option<bool>,
    ) -> (f64, f64, Option<bool>) {
        let (mut lo, mut hi, mut l) = (0.0_f64, 1.0_f64, 0.5_f64);
        // The largest F so far, and where (a NaN is never the largest).
        let (mut best, mut at) = (0.0_f64, l);
        for _ in 0..100 {
            let (f, f1, f2) = self.derivatives(l);
            if f > best {
                (best, at) = (f, l);
            }
            if let Some(verdict) = visit(l, f, f1) {
                return (best, at, Some(verdict));
            }
            if f1 > 0.0 {
                lo = l;
            } else {
                hi = l;
            }
            let newton = l - f1 / f2;
            let next = if f2 < 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            // At the maximum F is flat: a step of 10⁻⁹ changes F by ~|F″|·10⁻¹⁸, below rounding.
            if (next - l).abs() <= 1e-9 * (1.0 + l) || hi - lo <= 1e-12 {
                let f = self.f(next);
                if f > best {
                    (best, at) = (f, next);
                }
                break;
            }
            l = next;
        }
        (best, at, None)
    }
}

/// A tangent of F: (λ, F(λ), F′(λ)).
type Tangent = (f64, f64, f64);

/// The largest value on [0, 1] of the lower envelope of the tangents (λ, F, F′) of a concave
/// function F, the latest where it rises and where it falls: it bounds F from above.
fn upper_bound(rising: Option<Tangent>, falling: Option<Tangent>) -> f64 {
    match (rising, falling) {
        // F′(a) > 0 ≥ F′(b), so a < b and the lines cross once, between them.
        (Some((a, fa, sa)), Some((b, fb, sb))) => {
            let x = (fb - fa + sa * a - sb * b) / (sa - sb);
            fa + sa * (x - a)
        }
        (Some((a, fa, sa)), None) => fa + sa * (1.0 - a),
        (None, Some((b, fb, sb))) => fb - sb * b,
        (None, None) => f64::INFINITY,
    }
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

    proptest::prop_compose! {
        /// Two ellipsoids of aspect ratios up to 10, oriented at random, from deep overlap to far
        /// apart: (A, its orientation, B, its orientation, B's centre from A's).
        fn pair()(
            s in proptest::array::uniform6(0.1f64..1.0),
            angles in proptest::array::uniform6(-3.2f64..3.2),
            r in proptest::array::uniform3(-3.0f64..3.0),
        ) -> (Ellipsoid, M3, Ellipsoid, M3, V3) {
            let rot = |a: &[f64]| crate::rigid::rotate(&M3::identity(), &V3::new(a[0], a[1], a[2]), 1.0);
            (
                Ellipsoid::new(s[0], s[1], s[2]),
                rot(&angles[..3]),
                Ellipsoid::new(s[3], s[4], s[5]),
                rot(&angles[3..]),
                V3::from(r),
            )
        }
    }

    proptest::proptest! {
        /// Newton's maximum of F is Brent's (`contact::brent_min`, an independent search, to
        /// 10⁻¹³ in λ) within 10⁻⁹ relative, and no F(λ) on a grid exceeds it: random
        /// ellipsoids of aspect ratios up to 10, orientations and separations from deep overlap
        /// to far apart.
        #[test]
        fn newton_finds_the_maximum_brent_finds((ea, ra, eb, rb, r) in pair()) {
            proptest::prop_assume!(r.norm() > 1e-3);
            let pw = Pw::new(&ea, &ra, &eb, &rb, &r);
            let mu = pw.scale();
            let (_, neg) = crate::contact::brent_min(0.0, 0.5, 1.0, 1e-13, |l| -pw.f(l));
            let oracle = (-neg).sqrt();
            proptest::prop_assert!((mu / oracle - 1.0).abs() < 1e-9, "{} vs {}", mu, oracle);
            for k in 1..200 {
                let l = k as f64 / 200.0;
                proptest::prop_assert!(pw.f(l) <= mu * mu * (1.0 + 1e-12), "F({}) above", l);
            }
        }
    }

    proptest::proptest! {
        /// `above_at_half` decides as F(½) > k² does with F from the general solve
        /// ([`Pw::f`]), wherever k² is more than 10⁻¹² from F(½): k² near it on both sides, and
        /// far.
        #[test]
        fn the_test_at_half_is_f_at_half(
            (ea, ra, eb, rb, r) in pair(),
            near in -1e-6f64..1e-6,
            far in 0.5f64..2.0,
        ) {
            let (a, b) = (ea.a_lab(&ra), eb.a_lab(&rb));
            let f = Pw::lab(&a, &b, &r).f(0.5);
            for k2 in [f * (1.0 + near), f * far] {
                if (f / k2 - 1.0).abs() > 1e-12 {
                    proptest::prop_assert_eq!(above_at_half(&a, &b, &r, k2), f > k2, "{} {}", f, k2);
                }
            }
        }
    }

    proptest::proptest! {
        /// `within` decides as the full maximisation does, μ ≤ k, away from the rounding of μ
        /// (|μ/k − 1| > 10⁻¹²): random ellipsoids of aspect ratios up to 10, orientations,
        /// separations from deep overlap to far apart, thresholds on both sides and near μ.
        #[test]
        fn within_decides_as_the_maximum_does(
            (ea, ra, eb, rb, r) in pair(),
            near in -1e-3f64..1e-3,
            far in 0.5f64..2.0,
        ) {
            proptest::prop_assume!(r.norm() > 1e-3);
            let mu = contact_scale(&ea, &ra, &eb, &rb, &r);
            for k in [mu * (1.0 + near), mu * far, 1.0] {
                if (mu / k - 1.0).abs() > 1e-12 {
                    proptest::prop_assert_eq!(within(&ea, &ra, &eb, &rb, &r, k), mu <= k, "{} {}", mu, k);
                }
            }
        }
    }

    proptest::proptest! {
        /// The normal is the touching ellipsoids' separating axis, checked on their support
        /// functions h(m) = √(mᵀAm), independent of F: scaled by μ, the bodies' support gap
        /// r·m − μ(h_A(m) + h_B(m)) is their distance along m at most, which is 0; it is 0 along n,
        /// and no direction (random ones, and n turned slightly) does better. The looser
        /// [`contact_normal_lab`] gives the unscaled bodies as large a gap.
        #[test]
        fn the_normal_is_where_the_scaled_ellipsoids_touch(
            (ea, ra, eb, rb, r) in pair(),
            turns in proptest::collection::vec(proptest::array::uniform3(-1.0f64..1.0), 16),
        ) {
            proptest::prop_assume!(r.norm() > 1e-2);
            let (a, b) = (ea.a_lab(&ra), eb.a_lab(&rb));
            let (mu, n) = contact_scale_and_normal_lab(&a, &b, &r);
            proptest::prop_assert!((mu / contact_scale_lab(&a, &b, &r) - 1.0).abs() < 1e-12);
            // The support gap along m of the bodies scaled by `scale`.
            let support_gap = |m: &V3, scale: f64| {
                let m = m.normalize();
                r.dot(&m) - scale * ((m.dot(&(a * m))).sqrt() + (m.dot(&(b * m))).sqrt())
            };
            let gap = |m: &V3| support_gap(m, mu);
            let size = ea.s.max() + eb.s.max();
            proptest::prop_assert!(gap(&n).abs() < 1e-7 * size, "gap along n {}", gap(&n));
            // The axis of `contact_normal_lab`: the unscaled bodies' gap along it is as large as
            // along n, to a thousandth of it (4.7·10⁻⁴ at worst over 2·10⁵ random pairs).
            let unscaled = |m: &V3| support_gap(m, 1.0);
            let loose = contact_normal_lab(&a, &b, &r);
            proptest::prop_assert!(
                unscaled(&loose) >= unscaled(&n) - 1e-3 * unscaled(&n).abs() - 1e-9 * size,
                "{} along the loose normal, {} along n", unscaled(&loose), unscaled(&n)
            );
            for t in &turns {
                let t = V3::from(*t);
                for m in [t, n + t * 1e-3] {
                    if m.norm() > 1e-6 {
                        proptest::prop_assert!(gap(&m) <= 1e-7 * size, "{} along {}", gap(&m), m);
                    }
                }
            }
        }
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
