//! The exact oracle the kernels' tests share: Eq. 2 in big rationals on the very values given.
#![allow(dead_code)] // each test binary uses a different subset

use num_rational::BigRational;
use num_traits::{Signed, Zero};
use overlap::{Configuration, Cuboid, Real};

pub fn exact(x: impl Real) -> BigRational {
    BigRational::from_float(x.to_f64()).expect("finite input")
}

/// d_min² − R², exactly.
pub fn exact_margin<T: Real>(cfg: &Configuration<T>, cuboid: &Cuboid<T>, radius: T) -> BigRational {
    let mut d2 = BigRational::zero();
    for i in 0..3 {
        let a: BigRational = (0..3)
            .map(|j| exact(cfg.r_sc[j]) * exact(cfg.axes[i][j]))
            .sum();
        let l = a.abs() - exact(cuboid.half[i]);
        if l.is_positive() {
            d2 += &l * &l;
        }
    }
    let r = exact(radius);
    d2 - &r * &r
}
