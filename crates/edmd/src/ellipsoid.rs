//! Hard ellipsoid: f(x') = Σ x'_k²/s_k² − 1 (Eq. 42 with X = diag(s_k⁻²), Eqs. 43–44).

use crate::geometry::{LabEval, M3, Placed, Pose, SupportModulus, Surface, V3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipsoid {
    /// Semi-axes (a, b, c) along body axes 0, 1, 2.
    pub s: V3,
    inv2: V3,
    /// The largest semi-axis, asked of every candidate of a prediction.
    radius: f64,
    /// The largest radius of curvature, asked of every bound the contact search makes.
    rho_max: f64,
}

impl Ellipsoid {
    pub fn new(a: f64, b: f64, c: f64) -> Self {
        let s = V3::new(a, b, c);
        Ellipsoid {
            s,
            inv2: V3::new(1.0 / (a * a), 1.0 / (b * b), 1.0 / (c * c)),
            radius: s.max(),
            rho_max: s.max().powi(2) / s.min(),
        }
    }

    /// The shape matrix X(0) = diag(s⁻²) of Eq. (44).
    pub fn x_body(&self) -> M3 {
        M3::from_diagonal(&self.inv2)
    }

    /// Σ s_k² u_k u_kᵀ in the lab frame: the matrix A of the Perram–Wertheim function.
    pub fn a_lab(&self, rot: &M3) -> M3 {
        lab_matrix(&self.s, rot)
    }
}

/// [`Ellipsoid::a_lab`] of the ellipsoid of semi-axes `s` (a superquadric's inscribed one).
pub fn lab_matrix(s: &V3, rot: &M3) -> M3 {
    rot.transpose() * M3::from_diagonal(&s.component_mul(s)) * rot
}

/// An ellipsoid at a pose: f = ½ dᵀ H d − 1 with d = x − r and the constant lab Hessian H = 2 Rᵀ X(0) R.
#[derive(Clone, Copy, Debug)]
pub struct PlacedEllipsoid {
    r: V3,
    h: M3,
}

impl Placed for PlacedEllipsoid {
    fn eval(&self, x: &V3) -> LabEval {
        let d = x - self.r;
        let grad = self.h * d;
        LabEval {
            f: 0.5 * d.dot(&grad) - 1.0,
            grad,
            hess: self.h,
        }
    }
    fn f(&self, x: &V3) -> f64 {
        let d = x - self.r;
        0.5 * d.dot(&(self.h * d)) - 1.0
    }
    fn grad(&self, x: &V3) -> V3 {
        self.h * (x - self.r)
    }
}

impl Surface for Ellipsoid {
    type Placed = PlacedEllipsoid;
    fn place(&self, p: &Pose) -> PlacedEllipsoid {
        // Rᵀ diag(2 s⁻²) R, without the diagonal matrix's products by zero (a distance search
        // places both bodies at every iterate).
        let scaled_t = M3::from_fn(|i, k| p.rot[(k, i)] * (2.0 * self.inv2[k]));
        PlacedEllipsoid {
            r: p.r,
            h: scaled_t * p.rot,
        }
    }
    fn f(&self, x: &V3) -> f64 {
        x.component_mul(x).dot(&self.inv2) - 1.0
    }
    fn grad(&self, x: &V3) -> V3 {
        2.0 * x.component_mul(&self.inv2)
    }
    fn hessian(&self, _x: &V3) -> M3 {
        M3::from_diagonal(&(2.0 * self.inv2))
    }
    fn bounding_radius(&self) -> f64 {
        self.radius
    }
    fn ray_point(&self, dir: &V3) -> V3 {
        dir / dir.component_mul(dir).dot(&self.inv2).sqrt()
    }
    fn max_curvature_radius(&self) -> f64 {
        self.rho_max
    }
    fn min_support(&self) -> f64 {
        self.s.min()
    }
    fn support_modulus(&self, _v: &V3) -> SupportModulus {
        SupportModulus::quadratic(self.max_curvature_radius())
    }
    fn support(&self, n: &V3) -> f64 {
        let sn = self.s.component_mul(n);
        sn.norm()
    }
    fn enclosing_support(&self, n: &V3) -> f64 {
        self.support(n)
    }
    fn support_point(&self, n: &V3) -> V3 {
        let sn = self.s.component_mul(n);
        self.s.component_mul(&sn) / sn.norm()
    }
    /// s∘s∘n / |s∘n| is homogeneous of degree 0 in n.
    const SCALE_FREE_SUPPORT: bool = true;
    fn support_point_scaled(&self, m: &V3) -> (V3, f64) {
        let sm = self.s.component_mul(m);
        (self.s.component_mul(&sm), sm.norm())
    }
    fn semi_axes(&self) -> V3 {
        self.s
    }
    fn ellipsoid_semi_axes(&self) -> Option<V3> {
        Some(self.s)
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// `SCALE_FREE_SUPPORT`: along any positive multiple of a direction, the support point
        /// p/k of `support_point_scaled` is the one along the unit direction, to rounding: on
        /// the surface, its normal along the direction (semi-axes of aspect up to 100).
        #[test]
        fn the_support_point_does_not_depend_on_the_direction_s_length(
            s in prop::array::uniform3(0.05f64..5.0),
            d in prop::array::uniform3(-1.0f64..1.0),
            scale in 1e-3f64..1e3,
        ) {
            let d = V3::from(d);
            prop_assume!(d.norm() > 1e-3);
            let (e, n) = (Ellipsoid::new(s[0], s[1], s[2]), d.normalize());
            let (p, k) = e.support_point_scaled(&(n * scale));
            prop_assert!(k > 0.0);
            let (unit, scaled) = (e.support_point(&n), p / k);
            let size = V3::from(s).max();
            prop_assert!((scaled - unit).norm() <= 1e-14 * size, "{scaled} against {unit}");
            prop_assert!(e.f(&scaled).abs() <= 1e-12, "off the surface: {}", e.f(&scaled));
            prop_assert!((e.grad(&scaled).normalize() - n).norm() <= 1e-9);
        }
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let e = Ellipsoid::new(1.3, 0.4, 0.7);
        let x = V3::new(0.3, -0.2, 0.5);
        let h = 1e-6;
        let g = e.grad(&x);
        let hs = e.hessian(&x);
        for k in 0..3 {
            let mut dx = V3::zeros();
            dx[k] = h;
            let fd = (e.f(&(x + dx)) - e.f(&(x - dx))) / (2.0 * h);
            assert!((fd - g[k]).abs() < 1e-8);
            let gd = (e.grad(&(x + dx)) - e.grad(&(x - dx))) / (2.0 * h);
            assert!((gd - hs.column(k)).norm() < 1e-8);
        }
        let p = e.ray_point(&V3::new(1.0, 2.0, -1.0));
        assert!(e.f(&p).abs() < 1e-14);
        // The support along an axis is that semi-axis.
        assert!((e.support(&V3::new(0.0, 1.0, 0.0)) - 0.4).abs() < 1e-15);
    }
}
