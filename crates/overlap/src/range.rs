//! Which configurations a precision can judge: values whose squares stay normal and finite,
//! and a sphere not within rounding of touching the cuboid. Outside that, the kernels answer
//! confidently and wrongly (beyond f32's range a coordinate becomes ∞, and ∞ − ∞ = NaN compares
//! false), so callers refuse such a configuration instead.

use crate::error::OverlapError;
use crate::real::Real;

/// Largest magnitude a coordinate, radius or half extent may have in precision `T`: its square,
/// summed three times with the others', stays finite with room to spare.
pub fn max_magnitude<T: Real>() -> f64 {
    T::MAX_F64.sqrt() / 16.0
}

/// Smallest radius or half extent in precision `T`: its square is a normal number, so squared
/// distances do not flush to zero or lose their precision in denormals.
pub fn min_length<T: Real>() -> f64 {
    16.0 * T::MIN_POSITIVE_F64.sqrt()
}

/// Checks one configuration (in f64, as read) for precision `T`. `columns` names the values in
/// the error: r_SC's three components, the radius, the three half extents. `distance` is the
/// configuration's minimum distance computed in f64 (Eq. 2); the verdict is decidable in `T` when
/// it differs from the radius by more than the rounding error of the kernels' arithmetic, taken
/// as 64 unit roundoffs of the configuration's scale (conversion, a dot product, a square root).
pub fn check_case<T: Real>(
    r_sc: &[f64; 3],
    radius: f64,
    half: &[f64; 3],
    distance: f64,
    columns: &[&'static str; 7],
) -> Result<(), OverlapError> {
    let values = [r_sc[0], r_sc[1], r_sc[2], radius, half[0], half[1], half[2]];
    for (k, (&v, &key)) in values.iter().zip(columns).enumerate() {
        if !v.is_finite() || v.abs() > max_magnitude::<T>() {
            return Err(OverlapError::Invalid {
                key,
                reason: format!(
                    "{v} is beyond what {} can square (|x| ≤ {:.3e})",
                    T::NAME,
                    max_magnitude::<T>()
                ),
            });
        }
        if k >= 3 && v < min_length::<T>() {
            return Err(OverlapError::Invalid {
                key,
                reason: format!(
                    "{v} is below what {} can square into a normal number (≥ {:.3e})",
                    T::NAME,
                    min_length::<T>()
                ),
            });
        }
    }
    let scale = r_sc.iter().map(|x| x.abs()).sum::<f64>() + radius + half.iter().sum::<f64>();
    let margin = 64.0 * T::UNIT_ROUNDOFF * scale;
    if (distance - radius).abs() <= margin {
        return Err(OverlapError::Invalid {
            key: columns[3],
            reason: format!(
                "the sphere is within rounding of touching the cuboid in {} (distance {distance:e}, radius {radius:e}, margin {margin:.3e}): no verdict can be trusted; use a wider precision",
                T::NAME
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const COLUMNS: [&str; 7] = ["rx", "ry", "rz", "radius", "half_t", "half_l", "half_w"];

    #[test]
    fn beyond_f32_names_the_column() {
        let e = check_case::<f32>(&[1e39, 0.0, 0.0], 1.0, &[0.5, 0.5, 0.5], 1e39, &COLUMNS)
            .unwrap_err();
        assert!(matches!(e, OverlapError::Invalid { key: "rx", .. }), "{e}");
        assert!(
            check_case::<f64>(&[1e39, 0.0, 0.0], 1.0, &[0.5, 0.5, 0.5], 1e39, &COLUMNS).is_ok()
        );
    }

    #[test]
    fn denormal_radius_is_refused() {
        let e = check_case::<f32>(&[3.0, 0.0, 0.0], 1e-40, &[0.5, 0.5, 0.5], 2.5, &COLUMNS)
            .unwrap_err();
        assert!(
            matches!(e, OverlapError::Invalid { key: "radius", .. }),
            "{e}"
        );
    }

    proptest! {
        /// Wherever the check passes, the kernels' verdict in f32 equals the exact one, over
        /// R* from 1e-6 to 1e6 and L* up to 1e4 (the sphere on an axis, where the distance is exact).
        #[test]
        fn accepted_cases_get_the_right_verdict(
            log_r in -6.0f64..6.0, log_l in 0.0f64..4.0, gap in -1.0f64..1.0, rel in -12.0f64..0.0,
        ) {
            let radius = 10f64.powf(log_r);
            let half = [0.5, 0.5 * 10f64.powf(log_l), 0.5];
            // Centre on the T axis, the surface gap `gap · 10^rel · radius` away from touching.
            let distance = radius * (1.0 + gap * 10f64.powf(rel));
            let r_sc = [half[0] + distance, 0.0, 0.0];
            let exact = distance < radius;
            let cfg = crate::Configuration { r_sc: r_sc.map(|x| x as f32), axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] };
            let cuboid = crate::Cuboid { half: half.map(|x| x as f32) };
            if check_case::<f32>(&r_sc, radius, &half, distance, &COLUMNS).is_ok() {
                for a in crate::Algorithm::ALL {
                    prop_assert_eq!(crate::overlaps(a, &cfg, &cuboid, radius as f32), exact, "{:?}", a);
                }
            }
        }
    }
}
