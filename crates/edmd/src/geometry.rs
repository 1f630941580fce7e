//! Implicit surfaces f(x) = 0 (f < 0 inside) in the body frame, and their lab-frame view (Sec. 2.1).

use nalgebra::{Matrix3, Vector3};

pub type V3 = Vector3<f64>;
pub type M3 = Matrix3<f64>;

/// `x` rounded to the nearest integer, ties to even, for |x| < 2⁵¹: adding and subtracting
/// 1.5·2⁵² leaves no fraction bits. `f64::round` is a libm call on baseline x86-64 (no SSE4.1),
/// and nearest images are taken for every pair a push moves.
pub fn round_nearest(x: f64) -> f64 {
    (x + ROUND_MAGIC) - ROUND_MAGIC
}

/// 1.5·2⁵²: see [`round_nearest`].
pub(crate) const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

/// x^e without `powf` where e is a whole number up to 64 (by multiplications, within e ulp of
/// `powf` at a tenth of its cost) or ½: the Hölder powers are where a superquadric's time goes.
/// The exponents of an ellipsoid, 2, 1 and 0 (e, 1/(e − 1), e − 2, and the quadratic term of every
/// support modulus), come out exactly as `x * x`, `x` and 1: p = 2 must cost what an ellipsoid
/// does. (powf(0, 0) is 1 too.)
#[inline]
pub(crate) fn pow(x: f64, e: f64) -> f64 {
    if e == 2.0 {
        x * x
    } else if e == 1.0 {
        x
    } else if e == 0.0 {
        1.0
    } else if e == 0.5 {
        x.sqrt()
    } else if let whole = e as i32
        && f64::from(whole) == e
        && (3..=64).contains(&whole)
    {
        // The conversions, not `trunc`, which x86-64 without SSE4.1 calls out of line for.
        whole_power(x, whole as u32)
    } else {
        x.powf(e)
    }
}

/// x^n by repeated squaring, inline: the multiplications of `powi`, which a variable exponent
/// makes a call out of line (a twentieth of the instructions of superquadrics at p = 10), in
/// the same order, so to the bit the same.
#[inline]
pub(crate) fn whole_power(x: f64, n: u32) -> f64 {
    let (mut acc, mut base, mut n) = (1.0, x, n);
    loop {
        if n & 1 == 1 {
            acc *= base;
        }
        n >>= 1;
        if n == 0 {
            return acc;
        }
        base *= base;
    }
}

/// A number 0.9 % to 11 % above x^(1/m), for x ≥ 0 (+∞ for +∞), from the bits of
/// x: read as an integer, a positive double is, up to a constant, 2^52 times an estimate of its
/// base-2 logarithm that errs low by at most 0.0861 (the mantissa f in place of log₂(1 + f)).
/// That estimate divided by m, read back, is 2^(y) with y within [−0.0861/m, 0.0861] of the
/// root's logarithm; times 1.04 it is at least 1.04 · 2^(−0.0431) > 1.009 times the root for
/// m ≥ 2 and at most 1.04 · 2^0.0861 < 1.104 times it.
pub(crate) fn root_above(x: f64, m: u32) -> f64 {
    if m == 1 || x == 0.0 {
        return x;
    }
    if !(f64::MIN_POSITIVE..f64::INFINITY).contains(&x) {
        // Subnormal, infinite or NaN: where the bits' estimate does not hold.
        return x.powf(1.0 / f64::from(m));
    }
    const ONE: i64 = 0x3FF0_0000_0000_0000;
    let log2_scaled = (x.to_bits() as i64 - ONE) as f64;
    f64::from_bits((ONE + (log2_scaled / f64::from(m)) as i64) as u64) * 1.04
}

/// Minimum-image vector in a cubic box of side `l`.
pub fn min_image(d: V3, l: f64) -> V3 {
    let inv = 1.0 / l;
    d.map(|x| x - l * round_nearest(x * inv))
}

/// ⌊x⌋ for |x| < 2³¹, inline: without SSE4.1 in the target, `f64::floor` is a call into libm,
/// and every list rebuild and Monte Carlo move bins a point in a cell.
#[inline]
pub fn floor_i32(x: f64) -> i32 {
    debug_assert!(x.abs() < 2f64.powi(31));
    let t = x as i32;
    t - i32::from(x < f64::from(t))
}

/// `x.rem_euclid(l)` to the bit (`l` > 0), without its division where `x` lies within one box of
/// [0, l): `f64::rem_euclid` calls libm's `fmod`, 3 % of a start of 10⁵ spheres, where every
/// push and every box step wraps a position. In (−l, 0) `fmod` gives x and `rem_euclid` x + l;
/// in [l, 2l) x − l is exact (Sterbenz), as `fmod` is.
#[inline]
pub fn wrap(x: f64, l: f64) -> f64 {
    if (0.0..l).contains(&x) {
        x
    } else if x >= l && x < 2.0 * l {
        x - l
    } else if x < 0.0 && x > -l {
        x + l
    } else {
        x.rem_euclid(l)
    }
}

/// The displacement of the periodic image `s` (in box lengths) of a box of side `l`.
pub fn image_offset(s: [i32; 3], l: f64) -> V3 {
    V3::new(s[0] as f64, s[1] as f64, s[2] as f64) * l
}

/// A convex body given by an implicit function in its own frame, centred at its centre of mass.
pub trait Surface {
    type Placed: Placed;
    /// The surface at pose `p` (Eq. 43 for an ellipsoid: X = Rᵀ X(0) R).
    fn place(&self, p: &Pose) -> Self::Placed;
    /// f(x') with f < 0 inside, f = 0 on the surface (Eq. 7).
    fn f(&self, x: &V3) -> f64;
    /// ∂f/∂x' (a column vector).
    fn grad(&self, x: &V3) -> V3;
    /// ∂²f/∂x'².
    fn hessian(&self, x: &V3) -> M3;
    /// L of Eq. (33): the radius of the bounding sphere around the centre of mass.
    fn bounding_radius(&self) -> f64;
    /// The point of the surface on the ray from the centre along `dir` (any length > 0).
    fn ray_point(&self, dir: &V3) -> V3;
    /// Half-width of the body along the unit body-frame direction `n` (the support function).
    fn support(&self, n: &V3) -> f64;
    /// The point of the surface farthest along the unit body-frame direction `n` (body frame).
    fn support_point(&self, n: &V3) -> V3;
    /// At least [`Surface::support`] at the unit body-frame direction `n`, without a solve: the
    /// support of a simple body that holds this one (a box, a cylinder, or the body itself where
    /// its support has a closed form), for bounds that need only be rigorous.
    fn enclosing_support(&self, n: &V3) -> f64;
    /// [`Surface::support_point`], and what its solve leaves for
    /// [`Surface::support_modulus_kept`] at the same direction (NaN where the shape keeps
    /// nothing): a separating axis's ascent tries several directions and needs the modulus of its
    /// best only, without a second solve there.
    fn support_point_kept(&self, n: &V3) -> (V3, f64) {
        (self.support_point(n), f64::NAN)
    }
    /// Whether the support point along any positive multiple m of a unit direction is that of
    /// the direction, given as p/k by [`Surface::support_point_scaled`], so that a direction
    /// need not be normalised first. Such shapes keep nothing for the moduli.
    const SCALE_FREE_SUPPORT: bool = false;
    /// Where [`Surface::SCALE_FREE_SUPPORT`]: (p, k), k > 0, with p/k the support point along
    /// the body-frame direction `m` of any nonzero length, without its division.
    fn support_point_scaled(&self, m: &V3) -> (V3, f64) {
        (self.support_point(&m.normalize()), 1.0)
    }
    /// The largest principal radius of curvature of the surface, which bounds the Hessian of the
    /// support function: for an ellipsoid s_max²/s_min.
    fn max_curvature_radius(&self) -> f64;
    /// The least value of the support function over all directions: the half-width of the body
    /// across its thinnest direction (its smallest semi-axis for an ellipsoid).
    fn min_support(&self) -> f64;
    /// The bound on how far the support function rises above its tangent plane at the unit
    /// body-frame direction `v`.
    fn support_modulus(&self, v: &V3) -> SupportModulus;
    /// [`Surface::support_modulus`] at `v` from what [`Surface::support_point_kept`] left at the
    /// same direction (or NaN).
    fn support_modulus_kept(&self, v: &V3, _kept: f64) -> SupportModulus {
        self.support_modulus(v)
    }
    /// Semi-axes, for the guess of Sec. 3.2 (Eq. 51) and the bounding parallelepiped (Eq. 52).
    fn semi_axes(&self) -> V3;
    /// The semi-axes where the body is an ellipsoid (a superquadric of exponents 2 included),
    /// whose support point along u is s∘s∘u / |s∘u| ([`crate::first_step`] spells it out);
    /// `None` for other shapes.
    fn ellipsoid_semi_axes(&self) -> Option<V3> {
        None
    }
}

/// How far a body's support function h rises above its tangent plane at v, a bound that holds for
/// flat faces too: for the unit body-frame direction v it was given for and every u,
/// h(u) ≤ h(v) + x(v)·(u − v) + Σ c_i |u − v|^(q_i), with x(v) = ∇h(v) the support point.
///
/// An ellipsoid (or any body whose radii of curvature are at most ρ_max) has the single term
/// (ρ_max/2, 2). A superquadric with an exponent e > 2 has no curvature bound at the centre of
/// its flat face, but a term with the Hölder power q = e/(e − 1) < 2 instead
/// ([`crate::superquadric`] derives it). Terms with c = 0 are unused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SupportModulus {
    pub terms: [(f64, f64); 3],
    /// A whole M > 0 with every power q = m/M for a whole m (a flat face of whole exponent e
    /// has q = e/(e − 1): M = e − 1), so that the powers of τ the safe times of
    /// [`crate::rigid`] take are whole powers of τ^(1/M); 0 where there is none.
    pub denominator: u32,
}

/// The largest [`SupportModulus::denominator`]: p = 10 needs 9, [2, 4, 8] 21, the two in one
/// safe time 63.
pub(crate) const MOST_DENOMINATOR: u32 = 64;

/// The least common multiple of `a` and `b`, or 0 where it exceeds `most` (or either is 0).
pub(crate) fn lcm_at_most(a: u32, b: u32, most: u32) -> u32 {
    if a == 0 || b == 0 {
        return 0;
    }
    let (mut x, mut y) = (a, b);
    while y != 0 {
        (x, y) = (y, x % y);
    }
    let lcm = u64::from(a) / u64::from(x) * u64::from(b);
    if lcm <= u64::from(most) {
        lcm as u32
    } else {
        0
    }
}

impl SupportModulus {
    /// The modulus of a body whose radii of curvature are at most `rho_max`.
    pub fn quadratic(rho_max: f64) -> Self {
        SupportModulus {
            terms: [(0.5 * rho_max, 2.0), (0.0, 2.0), (0.0, 2.0)],
            denominator: 1,
        }
    }

    /// The largest radius of curvature, where the modulus is that of bounded curvature alone.
    pub fn curvature_radius(&self) -> Option<f64> {
        let [(c, q), rest @ ..] = self.terms;
        (q == 2.0 && rest.iter().all(|t| t.0 == 0.0)).then_some(2.0 * c)
    }
}

/// Position of the centre and orientation: `rot` has the body axes as rows (Eq. 1), x' = rot (x − r) (Eq. 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub r: V3,
    pub rot: M3,
}

impl Pose {
    pub fn to_body(&self, x: &V3) -> V3 {
        self.rot * (x - self.r)
    }
    pub fn to_lab(&self, xb: &V3) -> V3 {
        self.r + self.rot.transpose() * xb
    }
}

/// f, ∇f and the Hessian of a placed surface at a lab point.
#[derive(Clone, Copy, Debug)]
pub struct LabEval {
    pub f: f64,
    pub grad: V3,
    pub hess: M3,
}

/// A surface at a fixed pose, evaluated in the lab frame; built once per pose because the
/// Newton–Raphson iterations evaluate it many times at the same pose.
pub trait Placed {
    fn eval(&self, x: &V3) -> LabEval;
    fn f(&self, x: &V3) -> f64;
    fn grad(&self, x: &V3) -> V3;
}

#[cfg(test)]
mod tests {
    proptest::proptest! {
        /// [`pow`] is `powf` within e ulp for the whole exponents e it multiplies out (repeated
        /// squaring rounds at each product; x^26 was 5 ulp off), to the bit where it names the
        /// result (2, 1, 0, ½), and `powf` itself elsewhere: over magnitudes 10⁻⁹⁰ to 10⁹⁰.
        #[test]
        fn pow_is_powf_within_rounding(
            mantissa in 1.0f64..2.0,
            exponent in -300i32..300,
            e in proptest::prop_oneof![
                (0u32..=64).prop_map(f64::from),
                proptest::prelude::Just(0.5),
                0.0f64..12.0,
            ],
        ) {
            let x = mantissa * 2f64.powi(exponent);
            let (ours, libm) = (super::pow(x, e), x.powf(e));
            if [2.0, 1.0, 0.0].contains(&e) || e == 0.5 || e.fract() != 0.0 {
                proptest::prop_assert_eq!(ours, if e == 2.0 { x * x } else if e == 0.5 { x.sqrt() } else { libm });
            } else if libm.is_finite() && libm > f64::MIN_POSITIVE {
                proptest::prop_assert!((ours - libm).abs() <= e * f64::EPSILON * libm, "{x}^{e}: {ours} vs {libm}");
            }
        }

        /// [`whole_power`] multiplies as `powi` does, to the bit, over magnitudes 2^±300 and
        /// powers 0 to 64 (past the range of a double too).
        #[test]
        fn whole_power_is_powi_to_the_bit(
            mantissa in -2.0f64..2.0,
            exponent in -300i32..300,
            n in 0u32..=64,
        ) {
            let x = mantissa * 2f64.powi(exponent);
            let (ours, powi) = (super::whole_power(x, n), x.powi(n as i32));
            proptest::prop_assert!(ours.to_bits() == powi.to_bits(), "{x:e}^{n}: {ours:e} vs {powi:e}");
        }

        /// [`root_above`] is between 0.9 % and 11 % above x^(1/m), from the smallest normal
        /// double to the largest; x itself for m = 1, 0 for 0, `powf` where x is subnormal or
        /// infinite.
        #[test]
        fn root_above_is_just_above_the_root(
            mantissa in 1.0f64..2.0,
            exponent in -1022i32..1024,
            m in 1u32..=64,
            edge in 0..10usize,
        ) {
            let x = match edge {
                0 => 0.0,
                1 => f64::MIN_POSITIVE,
                2 => f64::MAX,
                3 => f64::INFINITY,
                4 => 1e-310,
                _ => mantissa * 2f64.powi(exponent),
            };
            let (ours, root) = (super::root_above(x, m), x.powf(1.0 / f64::from(m)));
            if m == 1 {
                proptest::prop_assert_eq!(ours, x);
            } else if x == 0.0 || !(f64::MIN_POSITIVE..f64::INFINITY).contains(&x) {
                proptest::prop_assert_eq!(ours, root);
            } else {
                proptest::prop_assert!(ours >= 1.009 * root && ours <= 1.104 * root, "{x:e}^(1/{m}): {ours:e} vs {root:e}");
            }
        }

        /// [`wrap`] is `rem_euclid` to the bit: within a box of [0, l) either way, at its ends
        /// (0, −0, ±l, 2l and their neighbouring floats), far outside, and for NaN.
        #[test]
        fn wrap_is_rem_euclid_to_the_bit(
            l in 1e-3f64..1e3,
            t in proptest::prop_oneof![-3.0f64..3.0, -1e6f64..1e6],
            edge in 0..12usize,
        ) {
            let x = match edge {
                0 => 0.0,
                1 => -0.0,
                2 => l,
                3 => -l,
                4 => 2.0 * l,
                5 => l.next_down(),
                6 => (-l).next_up(),
                7 => (2.0 * l).next_down(),
                8 => 0.0f64.next_down(),
                9 => f64::NAN,
                _ => t * l,
            };
            let (a, b) = (super::wrap(x, l), x.rem_euclid(l));
            proptest::prop_assert!(a.to_bits() == b.to_bits(), "{x:e} mod {l:e}: {a:e} vs {b:e}");
        }
    }

    use super::*;
    use proptest::prelude::*;

    #[test]
    fn floor_i32_is_floor() {
        let edges = [
            0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 3.0, -3.0, 1e9, -1e9, 2.5e-300, -2.5e-300,
        ];
        for x in edges
            .into_iter()
            .flat_map(|x: f64| [x, x.next_up(), x.next_down()])
        {
            assert_eq!(floor_i32(x), x.floor() as i32, "{x:e}");
        }
    }

    proptest! {
        #[test]
        fn round_nearest_is_round_away_from_ties(x in -1e12f64..1e12) {
            prop_assume!((x.fract().abs() - 0.5).abs() > 1e-9);
            prop_assert_eq!(round_nearest(x), x.round());
        }
    }

    #[test]
    fn round_nearest_at_ties_and_signs() {
        assert_eq!(round_nearest(0.5), 0.0);
        assert_eq!(round_nearest(1.5), 2.0);
        assert_eq!(round_nearest(-2.5), -2.0);
        assert_eq!(round_nearest(-0.49999999999999994), 0.0);
        assert_eq!(round_nearest(3.0), 3.0);
    }
}
