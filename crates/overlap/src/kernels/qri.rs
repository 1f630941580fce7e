//! Quick Rejection Intertwined (Algorithm 2, Larsson et al.): the rejection test of Eq. 6 sits
//! inside the distance loop, so a far sphere leaves after the first axis it is far along.

use crate::config::{ConfigurationView, Cuboid};
use crate::real::Real;

/// Algorithm 2.
#[inline]
pub fn qri<T: Real>(cfg: &impl ConfigurationView<T>, cuboid: &Cuboid<T>, radius: T) -> bool {
    let mut d = T::ZERO;
    for i in 0..3 {
        let a = cfg.projection(i);
        let below = a + cuboid.half[i];
        if below < T::ZERO {
            if below < -radius {
                return false;
            }
            d = d + below * below;
        } else {
            let above = a - cuboid.half[i];
            if above > T::ZERO {
                if above > radius {
                    return false;
                }
                d = d + above * above;
            }
        }
    }
    d <= radius * radius
}
