//! What the event loop reads of a body, whatever its model stores: the rigid [`Body`] with its
//! orientation and angular velocity, or the sphere's [`SphereBody`], one cache line.
//!
//! A sphere never rotates, so its orientation and angular velocity (two thirds of a [`Body`]'s
//! 192 bytes) are constants that need no storage: at N = 10⁶ the bodies alone took 192 MB of a
//! run's 931 (MEASUREMENTS.md, "A million spheres").

use crate::geometry::{M3, V3};
use crate::rigid::Body;

/// A body in free flight as the engine, the neighbour lists and the audit see it.
pub trait Moving: Copy {
    /// The position at the body's own time [`t`](Self::t) (unwrapped).
    fn r(&self) -> V3;
    fn v(&self) -> V3;
    /// The time the stored state is at (bodies are advanced lazily).
    fn t(&self) -> f64;
    /// The orientation: rows are the body axes (Eq. 1); the identity for a sphere.
    fn rot(&self) -> M3;
    /// The angular velocity (lab frame); zero for a sphere.
    fn w(&self) -> V3;
    /// Moves the stored state freely to time `t` (Eq. 6).
    fn advance_to(&mut self, t: f64);
    /// The full rigid-body state (what state files, frames and dumps hold).
    fn to_body(&self) -> Body;
    /// From a full rigid-body state; a sphere keeps its position, velocity and time alone.
    fn from_body(b: &Body) -> Self;
}

impl Moving for Body {
    #[inline(always)]
    fn r(&self) -> V3 {
        self.r
    }
    #[inline(always)]
    fn v(&self) -> V3 {
        self.v
    }
    #[inline(always)]
    fn t(&self) -> f64 {
        self.t
    }
    #[inline(always)]
    fn rot(&self) -> M3 {
        self.rot
    }
    #[inline(always)]
    fn w(&self) -> V3 {
        self.w
    }
    #[inline(always)]
    fn advance_to(&mut self, t: f64) {
        Body::advance_to(self, t)
    }
    fn to_body(&self) -> Body {
        *self
    }
    fn from_body(b: &Body) -> Self {
        *b
    }
}

/// A sphere's state: position, velocity and time, in one cache line (64 bytes with the padding
/// of its alignment, a third of a [`Body`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct SphereBody {
    pub r: V3,
    pub v: V3,
    pub t: f64,
}

impl Moving for SphereBody {
    #[inline(always)]
    fn r(&self) -> V3 {
        self.r
    }
    #[inline(always)]
    fn v(&self) -> V3 {
        self.v
    }
    #[inline(always)]
    fn t(&self) -> f64 {
        self.t
    }
    #[inline(always)]
    fn rot(&self) -> M3 {
        M3::identity()
    }
    #[inline(always)]
    fn w(&self) -> V3 {
        V3::zeros()
    }
    /// [`Body::advance_to`] without a rotation: the same arithmetic, so that a sphere's
    /// trajectory does not depend on which of the two stores it.
    #[inline(always)]
    fn advance_to(&mut self, t: f64) {
        let tau = t - self.t;
        if tau != 0.0 {
            self.r += self.v * tau;
            self.t = t;
        }
    }
    fn to_body(&self) -> Body {
        Body {
            r: self.r,
            v: self.v,
            t: self.t,
            rot: M3::identity(),
            w: V3::zeros(),
        }
    }
    fn from_body(b: &Body) -> Self {
        SphereBody {
            r: b.r,
            v: b.v,
            t: b.t,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere stored compactly moves exactly as the same sphere stored as a rigid body that
    /// does not rotate (the engine's trajectories do not depend on the store), and is a third
    /// of its size.
    #[test]
    fn a_compact_sphere_moves_bit_for_bit_as_a_non_rotating_body() {
        let mut rng = crate::rng::Rng::new(5);
        let mut full = Body {
            r: V3::new(rng.normal(), rng.normal(), rng.normal()) * 40.0,
            v: V3::new(rng.normal(), rng.normal(), rng.normal()),
            t: 0.25,
            rot: M3::identity(),
            w: V3::zeros(),
        };
        let mut compact = SphereBody::from_body(&full);
        for k in 0..1000 {
            let t = 0.25 + 1e-3 * k as f64 * rng.uniform();
            Moving::advance_to(&mut full, t);
            compact.advance_to(t);
            assert_eq!(compact.to_body(), full);
            full.v = V3::new(rng.normal(), rng.normal(), rng.normal());
            compact.v = full.v;
        }
        assert_eq!(std::mem::size_of::<SphereBody>(), 64);
        assert_eq!(std::mem::size_of::<Body>(), 192);
    }
}
