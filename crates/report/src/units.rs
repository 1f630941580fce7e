//! Lengths on the EDMD figures' axes: the engine's unit or the paper's.

use serde::{Deserialize, Serialize};

/// The unit of the lengths a figure puts on an axis (Δ_NNL, ε_d).
///
/// The engine measures lengths in σ, the diameter of the sphere of equal volume (every body has
/// the volume π/6 whatever X0); De Michele measures them in the smallest semi-axis of the
/// ellipsoid (Sec. 4). The same Δ_NNL reads 2.5–3.2 times larger in the paper's unit at X0 = 2
/// or 0.5, so comparisons with the paper's numbers use [`LengthUnit::SemiAxis`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LengthUnit {
    /// The smallest semi-axis, as in the paper.
    #[default]
    SemiAxis,
    /// σ, the diameter of the sphere of equal volume, as in the engine and in plans.
    Sigma,
}

impl LengthUnit {
    /// `length` (in σ) for a body of aspect ratio `x0`, in this unit.
    pub fn convert(self, length: f64, x0: f64) -> f64 {
        match self {
            Self::Sigma => length,
            Self::SemiAxis => length / smallest_semi_axis(x0),
        }
    }

    /// How an axis names the unit.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::Sigma => "σ (equal-volume sphere diameter)",
            Self::SemiAxis => "smallest semi-axis (paper's unit)",
        }
    }

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "semi-axis" => Some(Self::SemiAxis),
            "sigma" => Some(Self::Sigma),
            _ => None,
        }
    }
}

/// The smallest semi-axis in σ of a uniaxial body of aspect ratio `x0` = a/b whose volume is the
/// unit-diameter sphere's: b = c = (1/2)·x0^(−1/3), a = x0·b (the engine's `Scene::semi_axes`).
fn smallest_semi_axis(x0: f64) -> f64 {
    let b = 0.5 / x0.cbrt();
    (x0 * b).min(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn semi_axes_keep_the_volume_and_convert_lengths() {
        // A sphere: the smallest semi-axis is σ/2.
        assert!((LengthUnit::SemiAxis.convert(0.15, 1.0) - 0.3).abs() < 1e-12);
        for x0 in [0.25, 0.5, 2.0, 4.0] {
            let b = 0.5 / f64::cbrt(x0);
            assert!(
                (x0 * b * b * b - 0.125).abs() < 1e-12,
                "volume at X0 = {x0}"
            );
        }
        // X0 = 2: b = 0.5/2^(1/3) = 0.3969 σ; X0 = 0.5: a = 0.5·0.5^(2/3) = 0.3150 σ.
        assert!((LengthUnit::SemiAxis.convert(0.3969, 2.0) - 1.0).abs() < 1e-3);
        assert!((LengthUnit::SemiAxis.convert(0.3150, 0.5) - 1.0).abs() < 1e-3);
        assert_eq!(LengthUnit::Sigma.convert(0.15, 2.0), 0.15);
    }
}
