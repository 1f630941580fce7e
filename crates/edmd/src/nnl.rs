//! Nearest-neighbour lists from oriented bounding parallelepipeds (Sec. 3.3): the box of Eq. (52),
//! the 15-axis separation test (Eqs. 62–64), and the escape time of a body from its box (Eqs. 59–61).

use crate::geometry::{M3, Surface, V3};
use crate::lists::Region;
use crate::rigid::{Body, Flight, positive_for, support_acceleration_bound};

/// Oriented bounding parallelepiped, immobile between two rebuilds.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Obp {
    pub c: V3,
    /// Rows = the body axes at build time.
    pub rot: M3,
    /// Half-extents s_k + Δ_NNL (Eq. 52).
    pub half: V3,
}

impl Obp {
    pub fn around<S: Surface>(s: &S, body: &Body, delta: f64) -> Self {
        Obp {
            c: body.r,
            rot: body.rot,
            half: s.semi_axes().add_scalar(delta),
        }
    }

    /// Radius of the sphere circumscribing the box.
    pub fn radius(&self) -> f64 {
        self.half.norm()
    }
}

impl Region for Obp {
    type Body = Body;
    fn around<S: Surface>(s: &S, body: &Body, delta: f64) -> Self {
        Obp::around(s, body, delta)
    }

    fn reach<S: Surface>(s: &S, delta: f64) -> f64 {
        2.0 * s.semi_axes().add_scalar(delta).norm()
    }

    fn centre(&self) -> &V3 {
        &self.c
    }

    fn overlaps(&self, other: &Self, shift: &V3, reach: f64) -> bool {
        // The other box inside its circumsphere against this box's three slabs: most candidates
        // end here, before the 15-axis test builds its rotation.
        let local = self.rot * (other.c + shift - self.c);
        let radius = 0.5 * reach;
        (0..3).all(|k| local[k].abs() <= self.half[k] + radius) && overlap(self, other, shift)
    }

    fn escape_time<S: Surface>(&self, s: &S, body: &Body, eps_nnl: f64) -> f64 {
        escape_time(s, body, self, eps_nnl)
    }
}

/// Whether two boxes overlap; `shift` is added to the centre of `b` (periodic image).
///
/// The projections of Eqs. (62)–(64) onto the 3 + 3 face normals and the 9 edge cross products,
/// written as the separating-axis test: the boxes are disjoint iff one of the 15 axes separates them.
pub fn overlap(a: &Obp, b: &Obp, shift: &V3) -> bool {
    // Parallel edges make a cross-product axis vanish; the epsilon keeps that test conservative.
    const EPS: f64 = 1e-12;
    let r = a.rot * b.rot.transpose(); // r[(i,j)] = u_i^A · u_j^B
    let ar = r.abs().add_scalar(EPS);
    let t = a.rot * (b.c + shift - a.c);
    let (ea, eb) = (a.half, b.half);
    for i in 0..3 {
        let rb = eb[0] * ar[(i, 0)] + eb[1] * ar[(i, 1)] + eb[2] * ar[(i, 2)];
        if t[i].abs() > ea[i] + rb {
            return false;
        }
    }
    for j in 0..3 {
        let ra = ea[0] * ar[(0, j)] + ea[1] * ar[(1, j)] + ea[2] * ar[(2, j)];
        let tj = t[0] * r[(0, j)] + t[1] * r[(1, j)] + t[2] * r[(2, j)];
        if tj.abs() > ra + eb[j] {
            return false;
        }
    }
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let ra = ea[i1] * ar[(i2, j)] + ea[i2] * ar[(i1, j)];
            let rb = eb[j1] * ar[(i, j2)] + eb[j2] * ar[(i, j1)];
            let tt = (t[i2] * r[(i1, j)] - t[i1] * r[(i2, j)]).abs();
            if tt > ra + rb {
                return false;
            }
        }
    }
    true
}

/// Time after `body.t` when the body may first touch its box.
///
/// The distance of the body from face ±k is d = e_k ∓ (r − c)·u_k − h_k, with h_k the body's support
/// along u_k (exact for an ellipsoid, so no Newton–Raphson is needed for the planes of Eq. 59).
/// A body that does not rotate moves linearly and its escape time is exact. A rotating body advances
/// by steps that no face gap can close within (a sharper bound than ḋ_k ≤ |v·u_k| + L‖w‖ of
/// Eq. 60, see below), and the escape time is taken as soon as a gap falls below ε_d^nnl (Eq. 61):
/// a lower bound, so a rebuild comes early, never late.
pub fn escape_time<S: Surface>(s: &S, body: &Body, obp: &Obp, eps_nnl: f64) -> f64 {
    let axes = [
        obp.rot.row(0).transpose(),
        obp.rot.row(1).transpose(),
        obp.rot.row(2).transpose(),
    ];
    if body.w == V3::zeros() {
        let mut best = f64::INFINITY;
        for (k, u) in axes.iter().enumerate() {
            let h = s.support(&(body.rot * u));
            let o = (body.r - obp.c).dot(u);
            let vu = body.v.dot(u);
            let gap = if vu > 0.0 {
                obp.half[k] - o - h
            } else {
                obp.half[k] + o - h
            };
            if vu != 0.0 {
                best = best.min(gap.max(0.0) / vu.abs());
            }
        }
        return best;
    }
    // Each face gap g = e_k ∓ o − h changes at the exact rate ġ = ∓v·u_k − ḣ (ḣ = u_k·(w × p), p
    // the support point) with |g̈| ≤ M from `support_acceleration_bound`: g stays positive for the
    // root of g + ġτ − ½Mτ² (the contact search's bound, applied to the six planes).
    let (l, rho_max, h_min) = (
        s.bounding_radius(),
        s.max_curvature_radius(),
        s.min_support(),
    );
    let accel = axes.map(|u| support_acceleration_bound(&body.w, &u, l, rho_max, h_min));
    let (mut tau, flight) = (0.0, Flight::of(body));
    for _ in 0..100_000 {
        let p = flight.pose_after(tau);
        let mut dt = f64::INFINITY;
        for (k, u) in axes.iter().enumerate() {
            let support = p.rot.transpose() * s.support_point(&(p.rot * u));
            let h = support.dot(u);
            let h_rate = u.dot(&body.w.cross(&support));
            let o = (p.r - obp.c).dot(u);
            let vu = body.v.dot(u);
            for (gap, rate) in [
                (obp.half[k] - o - h, -vu - h_rate),
                (obp.half[k] + o - h, vu - h_rate),
            ] {
                if gap < eps_nnl {
                    return tau;
                }
                dt = dt.min(if accel[k].is_infinite() {
                    // A flat face has no curvature bound (Surface::max_curvature_radius = +∞):
                    // the gap changes at most at |v·u| + L|w × u| (Eq. 60 along one axis).
                    gap / (vu.abs() + l * body.w.cross(u).norm())
                } else {
                    positive_for(gap, rate, accel[k])
                });
            }
        }
        tau += dt;
    }
    tau
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ellipsoid::Ellipsoid;
    use crate::rigid::rotate;

    fn obp(c: V3, rot: M3, half: V3) -> Obp {
        Obp { c, rot, half }
    }

    #[test]
    fn axis_aligned_boxes() {
        let id = M3::identity();
        let a = obp(V3::zeros(), id, V3::new(1.0, 0.5, 0.5));
        let b = obp(V3::new(2.1, 0.0, 0.0), id, V3::new(1.0, 0.5, 0.5));
        assert!(!overlap(&a, &b, &V3::zeros()));
        assert!(overlap(&a, &b, &V3::new(-0.2, 0.0, 0.0)));
    }

    #[test]
    fn edge_edge_separation_needs_cross_axes() {
        // Two long thin boxes, crossed at 90° and slightly apart along z: only a cross axis separates
        // them once they are rotated 45° about z; the face axes alone would report overlap.
        let ra = rotate(
            &M3::identity(),
            &V3::new(0.0, 0.0, 1.0),
            std::f64::consts::FRAC_PI_4,
        );
        let rb = rotate(
            &M3::identity(),
            &V3::new(0.0, 0.0, 1.0),
            -std::f64::consts::FRAC_PI_4,
        );
        let half = V3::new(2.0, 0.1, 0.1);
        let a = obp(V3::zeros(), ra, half);
        let b = obp(V3::new(0.0, 0.0, 0.21), rb, half);
        assert!(!overlap(&a, &b, &V3::zeros()));
        let b = obp(V3::new(0.0, 0.0, 0.19), rb, half);
        assert!(overlap(&a, &b, &V3::zeros()));
    }

    #[test]
    fn escape_time_is_exact_without_rotation_and_early_with_rotation() {
        let e = Ellipsoid::new(1.0, 0.5, 0.5);
        let mut body = Body {
            r: V3::zeros(),
            v: V3::new(0.5, 0.0, 0.0),
            rot: M3::identity(),
            w: V3::zeros(),
            t: 0.0,
        };
        let o = Obp::around(&e, &body, 0.2);
        assert!((escape_time(&e, &body, &o, 1e-3) - 0.4).abs() < 1e-14);
        body.w = V3::new(0.0, 0.0, 1.0);
        let te = escape_time(&e, &body, &o, 1e-3);
        // At the escape time every gap is still non-negative and the smallest is below ε_d^nnl.
        let p = body.pose_after(te);
        let mut min_gap = f64::INFINITY;
        for k in 0..3 {
            let u = o.rot.row(k).transpose();
            let h = e.support(&(p.rot * u));
            let off = (p.r - o.c).dot(&u).abs();
            min_gap = min_gap.min(o.half[k] - off - h);
        }
        assert!((0.0..1e-3).contains(&min_gap), "gap {min_gap} at {te}");
    }
}
