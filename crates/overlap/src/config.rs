//! One cuboid–sphere configuration, in the papers' variables.

use crate::real::Real;

/// The cuboid C of Eq. 1 by its half extents (c_T, c_L, c_W).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cuboid<T> {
    pub half: [T; 3],
}

impl<T: Real> Cuboid<T> {
    /// The paper's reduced units: thickness T = 1, so L = L*, W = W* (Sec. 3).
    pub fn from_reduced(l_star: f64, w_star: f64) -> Self {
        Self {
            half: [
                T::from_f64(0.5),
                T::from_f64(l_star / 2.0),
                T::from_f64(w_star / 2.0),
            ],
        }
    }
}

/// A sphere centre relative to the cuboid centre, r_SC = r_S − r_C, and the cuboid axes
/// ê_T, ê_L, ê_W (`axes[0..3]`), all in the lab frame: exactly the arguments of Algorithms 2–5.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Configuration<T> {
    pub r_sc: [T; 3],
    pub axes: [[T; 3]; 3],
}

/// Read access to one configuration wherever it is stored. The kernels read through this so
/// that, in the timed loops, each value is loaded straight from the configuration arrays (as the
/// papers' harness passes pointers into its arrays) instead of being copied into a temporary
/// first: such a copy costs store-forwarding stalls that belong to no algorithm.
pub trait ConfigurationView<T: Real> {
    /// Component j of r_SC.
    fn r_sc(&self, j: usize) -> T;
    /// Component j of the cuboid axis ê_i (i = 0, 1, 2 for T, L, W).
    fn axis(&self, i: usize, j: usize) -> T;

    /// r_SC · ê_i, the projection on the cuboid axis i (line 4 of Algorithms 2–4).
    #[inline(always)]
    fn projection(&self, i: usize) -> T {
        self.r_sc(0) * self.axis(i, 0)
            + self.r_sc(1) * self.axis(i, 1)
            + self.r_sc(2) * self.axis(i, 2)
    }
}

impl<T: Real> ConfigurationView<T> for Configuration<T> {
    #[inline(always)]
    fn r_sc(&self, j: usize) -> T {
        self.r_sc[j]
    }
    #[inline(always)]
    fn axis(&self, i: usize, j: usize) -> T {
        self.axes[i][j]
    }
}

/// Builds the cuboid frame from a unit quaternion (w, x, y, z) that rotates the lab axes x̂, ŷ, ẑ
/// onto ê_T, ê_L, ê_W: the axes are the columns of its rotation matrix.
pub fn axes_from_quaternion(q: [f64; 4]) -> [[f64; 3]; 3] {
    let [w, x, y, z] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + w * z),
            2.0 * (x * z - w * y),
        ],
        [
            2.0 * (x * y - w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z + w * x),
        ],
        [
            2.0 * (x * z + w * y),
            2.0 * (y * z - w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}
