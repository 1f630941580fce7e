//! Eq. 2 decided exactly: does the sphere overlap the cuboid, for the very values a kernel sees?
//!
//! Floats are dyadic rationals, so d_min² − R² = Σ_i max(|r_SC · ê_i| − c_i, 0)² − R² has an exact
//! value, and its sign is the exact verdict (touching counts as overlapping, as in the kernels).
//! [`margin_sign`] finds it in two steps:
//! - a filter: the margin evaluated in f64, whose error is bounded by [`rounding_band`]; outside
//!   the band its sign is certain, which settles all but the near-boundary configurations;
//! - exact arithmetic otherwise: floating-point expansions (Shewchuk's error-free sums and
//!   products), which represent every intermediate value exactly. That is exact as long as no
//!   partial product underflows or overflows, which inputs of magnitude 0 or within
//!   [2⁻¹⁰⁰, 2¹⁰⁰] guarantee (intermediate bits stay above 2⁻⁶⁰⁸); other inputs are refused
//!   with [`ExactError::OutOfRange`], never decided approximately.
//!
//! `crates/overlap/tests/oracle.rs` checks this against an independent oracle in big rationals.

use std::cmp::Ordering;

use crate::config::{Configuration, Cuboid};
use crate::real::Real;

#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ExactError {
    /// A value whose products could underflow or overflow the exact arithmetic.
    #[error(
        "{value:e} is outside the range the exact evaluation covers (0 or 2^-100 to 2^100 in magnitude, finite)"
    )]
    OutOfRange { value: f64 },
}

/// The exact verdict of Eq. 2: true when the sphere overlaps or touches the cuboid.
pub fn overlaps_exactly<T: Real>(
    cfg: &Configuration<T>,
    cuboid: &Cuboid<T>,
    radius: T,
) -> Result<bool, ExactError> {
    margin_sign(cfg, cuboid, radius).map(|sign| sign != Ordering::Greater)
}

/// The sign of d_min² − R², exactly.
pub fn margin_sign<T: Real>(
    cfg: &Configuration<T>,
    cuboid: &Cuboid<T>,
    radius: T,
) -> Result<Ordering, ExactError> {
    let wide = Configuration {
        r_sc: cfg.r_sc.map(T::to_f64),
        axes: cfg.axes.map(|e| e.map(T::to_f64)),
    };
    let half = cuboid.half.map(T::to_f64);
    let r = radius.to_f64();
    let margin = f64_margin(&wide, &half, r);
    if margin.abs() > rounding_band(&wide, &Cuboid { half }, r) {
        return Ok(margin.total_cmp(&0.0));
    }
    let inputs = wide.r_sc.iter().chain(wide.axes.iter().flatten());
    for &value in inputs.chain(&half).chain([&r]) {
        let magnitude = value.abs();
        if !(magnitude == 0.0 || (2f64.powi(-100)..=2f64.powi(100)).contains(&magnitude)) {
            return Err(ExactError::OutOfRange { value });
        }
    }
    Ok(expansion_margin(&wide, &half, r))
}

/// Whether `cfg` lies farther from the boundary than rounding can move it, so that a kernel
/// of precision `T` must give the exact verdict there (|d² − R²| beyond [`rounding_band`]): a
/// different verdict is a wrong algorithm, not a rounding.
pub fn beyond_rounding<T: Real>(cfg: &Configuration<T>, cuboid: &Cuboid<T>, radius: T) -> bool {
    let wide = Configuration {
        r_sc: cfg.r_sc.map(T::to_f64),
        axes: cfg.axes.map(|e| e.map(T::to_f64)),
    };
    let margin = f64_margin(&wide, &cuboid.half.map(T::to_f64), radius.to_f64());
    margin.abs() > rounding_band(cfg, cuboid, radius)
}

/// d² − R² in plain f64 arithmetic, in a fixed order.
fn f64_margin(cfg: &Configuration<f64>, half: &[f64; 3], r: f64) -> f64 {
    let d2: f64 = (0..3)
        .map(|i| {
            let a = cfg.r_sc[0] * cfg.axes[i][0]
                + cfg.r_sc[1] * cfg.axes[i][1]
                + cfg.r_sc[2] * cfg.axes[i][2];
            let l = (a.abs() - half[i]).max(0.0);
            l * l
        })
        .sum();
    d2 - r * r
}

/// γₙ = nu/(1 − nu) (Higham, Lemma 3.1): n roundings of unit roundoff u change a value by at
/// most γₙ relative to it. The γ₄ of [`rounding_band`], not the Γ function.
fn gamma_n(n: f64, u: f64) -> f64 {
    n * u / (1.0 - n * u)
}

/// A bound on |fl(d²) − d²| + |fl(R²) − R²| for d² − R² computed in `T` by any of the kernels
/// (plain or fused arithmetic, any summation order), or by [`margin_sign`]'s filter in f64.
///
/// Per axis, the projection a_i = Σ_j r_j e_ij carries at most γ₃·Σ_j|r_j e_ij|, and |a_i| − c_i
/// one more rounding: δ_i ≤ γ₄·(Σ_j|r_j e_ij| + c_i). Squaring l_i ± δ_i moves l_i² by at most
/// 2(l_i + δ_i)δ_i, the products and the three-term sum add γ₄·d², and R·R adds u·R². The
/// quick-rejection tests of QRI/QRF compare l_i with ±R, which can only flip when |l_i| is within
/// δ_i + u·R of R, a case the same terms cover. The factor 2 is slack for the second-order terms
/// dropped above.
pub fn rounding_band<T: Real>(cfg: &Configuration<T>, cuboid: &Cuboid<T>, radius: T) -> f64 {
    let u = T::UNIT_ROUNDOFF;
    let mut band = 0.0;
    let mut d2 = 0.0;
    for i in 0..3 {
        let terms = (0..3).map(|j| cfg.r_sc[j].to_f64() * cfg.axes[i][j].to_f64());
        let s: f64 = terms.clone().map(f64::abs).sum();
        let a: f64 = terms.sum();
        let c = cuboid.half[i].to_f64();
        let delta = gamma_n(4.0, u) * (s + c);
        let l = (a.abs() - c).max(0.0);
        band += 2.0 * (l + delta) * delta + delta * delta;
        d2 += l * l;
    }
    let r = radius.to_f64();
    2.0 * (band + gamma_n(4.0, u) * d2 + u * r * r)
}

/// a + b = s + e exactly (Knuth's two-sum).
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// a·b = p + e exactly when the product neither underflows nor overflows.
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// An exact sum of doubles: components nonoverlapping, in increasing magnitude, no zeros.
#[derive(Clone, Debug, Default)]
struct Expansion(Vec<f64>);

impl Expansion {
    /// Adds `b` exactly (Shewchuk's Grow-Expansion with zero elimination).
    fn add(&mut self, b: f64) {
        let mut q = b;
        let mut out = Vec::with_capacity(self.0.len() + 1);
        for &e in &self.0 {
            let (s, h) = two_sum(q, e);
            if h != 0.0 {
                out.push(h);
            }
            q = s;
        }
        if q != 0.0 {
            out.push(q);
        }
        self.0 = out;
    }

    fn add_product(&mut self, a: f64, b: f64) {
        let (p, e) = two_product(a, b);
        self.add(e);
        self.add(p);
    }

    /// The sign of the value: that of its largest component.
    fn sign(&self) -> Ordering {
        self.0.last().map_or(Ordering::Equal, |x| x.total_cmp(&0.0))
    }

    fn negate(&mut self) {
        for x in &mut self.0 {
            *x = -*x;
        }
    }
}

fn expansion_margin(cfg: &Configuration<f64>, half: &[f64; 3], r: f64) -> Ordering {
    let mut margin = Expansion::default();
    for (axis, &half) in cfg.axes.iter().zip(half) {
        let mut l = Expansion::default();
        for (&r, &e) in cfg.r_sc.iter().zip(axis) {
            l.add_product(r, e);
        }
        if l.sign() == Ordering::Less {
            l.negate();
        }
        l.add(-half);
        if l.sign() == Ordering::Greater {
            for &p in &l.0 {
                for &q in &l.0 {
                    margin.add_product(p, q);
                }
            }
        }
    }
    margin.add_product(-r, r);
    margin.sign()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn aligned(p: [f64; 3]) -> Configuration<f64> {
        Configuration {
            r_sc: p,
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }

    #[test]
    fn expansions_settle_what_f64_cannot() {
        // One ulp of 1.5 off, onto and inside the touching position off the face +T.
        let (half, r) = ([0.5, 1.0, 1.0], 1.0);
        let apart = aligned([1.5 + 2f64.powi(-52), 0.0, 0.0]);
        assert_eq!(
            expansion_margin(&apart, &half, r),
            Ordering::Greater,
            "one ulp apart"
        );
        assert_eq!(
            expansion_margin(&aligned([1.5, 0.0, 0.0]), &half, r),
            Ordering::Equal
        );
        assert_eq!(
            expansion_margin(&aligned([1.5 - 2f64.powi(-52), 0.0, 0.0]), &half, r),
            Ordering::Less
        );
        // A projection f64 rounds to 0 (1e17 + 3 is 1e17 there): exactly 3, so d = 2.5 > R.
        let cancelling = Configuration {
            r_sc: [1e17, 3.0, -1e17],
            axes: [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
        };
        assert!(f64_margin(&cancelling, &half, r) < 0.0, "f64 says overlap");
        assert_eq!(expansion_margin(&cancelling, &half, r), Ordering::Greater);
    }

    #[test]
    fn touching_overlaps_and_out_of_range_inputs_are_refused() {
        let cuboid = Cuboid {
            half: [0.5f32, 1.0, 1.0],
        };
        let touching = Configuration {
            r_sc: [1.5f32, 0.0, 0.0],
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        };
        assert_eq!(overlaps_exactly(&touching, &cuboid, 1.0), Ok(true));
        let tiny = Configuration {
            r_sc: [1.5f64, 1e-200, 0.0],
            ..aligned([0.0; 3])
        };
        let cuboid = Cuboid {
            half: [0.5, 1.0, 1.0],
        };
        assert!(matches!(
            overlaps_exactly(&tiny, &cuboid, 1.0),
            Err(ExactError::OutOfRange { .. })
        ));
        // Far from the boundary the filter decides, whatever the range.
        let far = Configuration {
            r_sc: [30.0, 1e-200, 0.0],
            ..aligned([0.0; 3])
        };
        assert_eq!(overlaps_exactly(&far, &cuboid, 1.0), Ok(false));
    }
}
