//! OCSI (Algorithm 5): Eq. 2 with the absolute value, no branch inside the loop, so the
//! compiler vectorises the three axes by itself (the papers' `omp simd`, here LLVM's SLP pass).

use crate::config::{ConfigurationView, Cuboid};
use crate::real::Real;

/// Algorithm 5.
#[inline]
pub fn ocsi<T: Real>(cfg: &impl ConfigurationView<T>, cuboid: &Cuboid<T>, radius: T) -> bool {
    let mut l = [T::ZERO; 3];
    for (i, l_i) in l.iter_mut().enumerate() {
        let s = (cfg.projection(i).abs() - cuboid.half[i]).positive_part();
        *l_i = s * s;
    }
    l[0] + l[1] + l[2] <= radius * radius
}

/// d_min of Eq. 2: the distance from the sphere centre to the cuboid (0 inside it).
pub fn min_distance<T: Real>(cfg: &impl ConfigurationView<T>, cuboid: &Cuboid<T>) -> T {
    let mut d2 = 0.0;
    for i in 0..3 {
        let s = (cfg.projection(i).abs() - cuboid.half[i])
            .positive_part()
            .to_f64();
        d2 += s * s;
    }
    T::from_f64(d2.sqrt())
}
