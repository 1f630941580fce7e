//! Arvo's test (Algorithm 1) for a randomly oriented cuboid: the sphere centre is first moved
//! into the cuboid frame (r_S,i = r_SC · ê_i, the cuboid centred at the origin, so
//! B_i = [−c_i, c_i]), then the axis-aligned test runs unchanged.

use crate::config::{ConfigurationView, Cuboid};
use crate::real::Real;

/// Algorithm 1 after the change of frame. Eq. 5 with the case analysis that follows it.
#[inline]
pub fn arvo<T: Real>(cfg: &impl ConfigurationView<T>, cuboid: &Cuboid<T>, radius: T) -> bool {
    let r_s = [cfg.projection(0), cfg.projection(1), cfg.projection(2)];
    let mut d = T::ZERO;
    // The loop over the axes i of Algorithm 1, as the paper writes it: a timed kernel keeps the
    // papers' form.
    #[allow(clippy::needless_range_loop)]
    for i in 0..3 {
        let (inf, sup) = (-cuboid.half[i], cuboid.half[i]);
        if r_s[i] < inf {
            let s = inf - r_s[i];
            d = d + s * s;
        } else if r_s[i] > sup {
            let s = r_s[i] - sup;
            d = d + s * s;
        }
    }
    d <= radius * radius
}
