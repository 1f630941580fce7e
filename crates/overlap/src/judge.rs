//! One configuration as a user gives it (in f64), judged by every kernel in one precision and by
//! Eq. 2 exactly: what `sweep overlap` prints for each row of a file.
//!
//! A precision cannot judge every configuration: values beyond what it can square, or a sphere
//! within rounding of touching the cuboid ([`crate::range::check_case`]). There the kernels
//! would answer confidently and possibly wrongly, so the case is **undecided** in that precision,
//! with the reason, and no kernel verdict is given; the exact verdict is given for every case
//! whose values the exact evaluation covers ([`crate::exact`]). Where the kernels do answer, they
//! agree with the exact verdict (`tests/judge.rs` checks it against the exact oracle).

use crate::algorithm::Algorithm;
use crate::config::{Configuration, Cuboid};
use crate::exact::{ExactError, overlaps_exactly};
use crate::kernels::Kernels;
use crate::kernels::ocsi::min_distance;
use crate::range::check_case;

/// A configuration: r_SC (sphere centre minus cuboid centre, lab frame), the radius, the half
/// extents along ê_T, ê_L, ê_W and those axes (unit rows, lab frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Case {
    pub r_sc: [f64; 3],
    pub radius: f64,
    pub half: [f64; 3],
    pub axes: [[f64; 3]; 3],
}

/// The names of a case's values in the errors of [`check_case`]: r_SC's components, the
/// radius, the half extents (the columns of `sweep overlap`'s input).
const VALUES: [&str; 7] = ["rx", "ry", "rz", "radius", "half_t", "half_l", "half_w"];

/// What every kernel in one precision, and Eq. 2 exactly, say of one case.
#[derive(Clone, Debug, PartialEq)]
pub struct Judgement {
    /// Every algorithm's verdict (true: overlap or touching), in [`Algorithm::ALL`]'s order; or
    /// why the precision cannot judge the case.
    pub kernels: Result<Vec<(Algorithm, bool)>, String>,
    /// Eq. 2 decided exactly for the case as given, or why it could not be.
    pub exact: Result<bool, ExactError>,
    /// The minimum distance of Eq. 2 between the sphere's centre and the cuboid, in f64.
    pub distance: f64,
}

/// Judges `case` in precision `T`.
pub fn judge<T: Kernels>(case: &Case) -> Judgement {
    let wide = Configuration {
        r_sc: case.r_sc,
        axes: case.axes,
    };
    let distance = min_distance(&wide, &Cuboid { half: case.half });
    let exact = overlaps_exactly(&wide, &Cuboid { half: case.half }, case.radius);
    let kernels = check_case::<T>(&case.r_sc, case.radius, &case.half, distance, &VALUES)
        .map(|()| {
            let cfg = Configuration {
                r_sc: case.r_sc.map(T::from_f64),
                axes: case.axes.map(|e| e.map(T::from_f64)),
            };
            let cuboid = Cuboid {
                half: case.half.map(T::from_f64),
            };
            let radius = T::from_f64(case.radius);
            Algorithm::ALL
                .into_iter()
                .map(|a| (a, crate::overlaps(a, &cfg, &cuboid, radius)))
                .collect()
        })
        .map_err(|e| e.to_string());
    Judgement {
        kernels,
        exact,
        distance,
    }
}
