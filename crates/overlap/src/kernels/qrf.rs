//! Quick Rejection First (Algorithm 3, Larsson et al.): all three rejection tests of Eq. 6
//! first, then the distance from the stored projections.

use crate::config::{ConfigurationView, Cuboid};
use crate::real::Real;

/// Algorithm 3.
#[inline]
pub fn qrf<T: Real>(cfg: &impl ConfigurationView<T>, cuboid: &Cuboid<T>, radius: T) -> bool {
    let mut a = [T::ZERO; 3];
    for (i, a_i) in a.iter_mut().enumerate() {
        *a_i = cfg.projection(i);
        let c = cuboid.half[i];
        if *a_i < -c - radius || *a_i > c + radius {
            return false;
        }
    }
    let mut d = T::ZERO;
    for (i, &a_i) in a.iter().enumerate() {
        let c = cuboid.half[i];
        if a_i < -c {
            let l = a_i + c;
            d = d + l * l;
        } else if a_i > c {
            let l = a_i - c;
            d = d + l * l;
        }
    }
    d <= radius * radius
}
