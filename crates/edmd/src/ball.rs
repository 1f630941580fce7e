//! Bounding balls as neighbour-list regions (the "bounding neighbourhoods" of Donev et al. \[26\]):
//! the body's centre may wander `delta` from where its list was built, so the body stays inside
//! the ball of radius (bounding radius + `delta`) around that point, whatever it does in between.
//! Valid for any shape; for a sphere, which does not rotate, it is the tightest region there is,
//! and its escape time is exact.

use crate::body::SphereBody;
use crate::geometry::{Surface, V3};
use crate::lists::{ExactCentre, Region, SingleCentre};

#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ball {
    /// The body's centre when the list was built.
    pub c: V3,
    /// How far the centre may move from `c`.
    pub delta: f64,
}

impl Region for Ball {
    type Body = SphereBody;
    fn around<S: Surface>(_: &S, body: &SphereBody, delta: f64) -> Self {
        Ball { c: body.r, delta }
    }

    fn reach<S: Surface>(s: &S, delta: f64) -> f64 {
        2.0 * (s.bounding_radius() + delta)
    }

    fn centre(&self) -> &V3 {
        &self.c
    }

    type Centre = ExactCentre;

    fn overlaps(&self, _: &Self, _: &V3, _: f64) -> bool {
        // Equal balls overlap exactly when their centres are at most `reach` apart.
        true
    }

    fn escape_time<S: Surface>(&self, _: &S, body: &SphereBody, _: f64, _: f64) -> f64 {
        leaves_ball(&(body.r - self.c), &body.v, self.delta)
    }
}

/// A [`Ball`] that knows the size of its body, for bodies of several sizes (a sphere mixture):
/// two are neighbours only when their bodies can meet before either leaves its ball, i.e. when
/// their centres are at most r_i + r_j + 2Δ apart, rather than the 2 (r_max + Δ) of the largest
/// pair. A small sphere's list then holds the spheres within its own reach, not the reach of
/// the largest ones.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SizedBall {
    pub c: V3,
    pub delta: f64,
    /// The body's bounding radius.
    pub radius: f64,
}

impl Region for SizedBall {
    type Body = SphereBody;
    /// `s` is the body's own surface.
    fn around<S: Surface>(s: &S, body: &SphereBody, delta: f64) -> Self {
        SizedBall {
            c: body.r,
            delta,
            radius: s.bounding_radius(),
        }
    }

    /// `s` is the largest body's surface.
    fn reach<S: Surface>(s: &S, delta: f64) -> f64 {
        2.0 * (s.bounding_radius() + delta)
    }

    fn centre(&self) -> &V3 {
        &self.c
    }

    type Centre = SingleCentre;

    fn overlaps(&self, other: &Self, shift: &V3, _: f64) -> bool {
        let reach = self.radius + other.radius + self.delta + other.delta;
        (other.c + shift - self.c).norm_squared() <= reach * reach
    }

    fn escape_time<S: Surface>(&self, _: &S, body: &SphereBody, _: f64, _: f64) -> f64 {
        leaves_ball(&(body.r - self.c), &body.v, self.delta)
    }
}

/// When a point at `p` from the centre, moving at `v`, reaches distance `delta`: the positive root
/// of |p + v t|² = δ², without cancellation. A point already outside (by rounding) leaves now.
pub fn leaves_ball(p: &V3, v: &V3, delta: f64) -> f64 {
    let (b, vv, c) = (p.dot(v), v.norm_squared(), p.norm_squared() - delta * delta);
    if c >= 0.0 {
        return 0.0;
    }
    if vv == 0.0 {
        return f64::INFINITY;
    }
    let root = (b * b - vv * c).sqrt();
    // Both forms of the root, chosen without a branch: whether the point moves outwards is a
    // coin flip after every collision, and one division serves either.
    let outwards = b > 0.0;
    let num = if outwards { -c } else { root - b };
    let den = if outwards { b + root } else { vv };
    num / den
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn the_escape_point_is_on_the_sphere(
            p in prop::array::uniform3(-1.0f64..1.0),
            v in prop::array::uniform3(-5.0f64..5.0),
            delta in 1e-3f64..2.0,
        ) {
            let p = V3::from(p) * (0.999 * delta / 3f64.sqrt());
            let v = V3::from(v);
            prop_assume!(v.norm() > 1e-6);
            let t = leaves_ball(&p, &v, delta);
            prop_assert!(t > 0.0);
            let at = (p + v * t).norm();
            prop_assert!((at - delta).abs() <= 1e-12 * delta, "|p + vt| = {} for δ = {}", at, delta);
        }
    }

    #[test]
    fn at_rest_never_and_outside_now() {
        assert_eq!(
            leaves_ball(&V3::new(0.1, 0.0, 0.0), &V3::zeros(), 0.2),
            f64::INFINITY
        );
        assert_eq!(
            leaves_ball(&V3::new(0.3, 0.0, 0.0), &V3::new(-1.0, 0.0, 0.0), 0.2),
            0.0
        );
        // Heading back through the centre: out on the far side.
        let t = leaves_ball(&V3::new(0.1, 0.0, 0.0), &V3::new(-1.0, 0.0, 0.0), 0.2);
        assert!((t - 0.3).abs() < 1e-15);
    }
}
