//! The searched values: positions `t` ∈ [0, 1] in log space between `lo` and `hi`, and the
//! canonical value a search proposes inside a gap.

use crate::TuneError;

/// Significant digits of a proposed value: what a plan would write, so that a value proposed
/// twice is the same job.
pub const SIGNIFICANT_DIGITS: usize = 4;

/// A range searched in log space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    lo: f64,
    hi: f64,
}

impl Range {
    pub fn new(lo: f64, hi: f64) -> Result<Self, TuneError> {
        if lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo {
            Ok(Range { lo, hi })
        } else {
            Err(TuneError::Range { lo, hi })
        }
    }

    pub fn lo(&self) -> f64 {
        self.lo
    }

    pub fn hi(&self) -> f64 {
        self.hi
    }

    /// The position of `x` (outside [0, 1] for a value outside the range).
    pub fn position(&self, x: f64) -> f64 {
        (x / self.lo).ln() / (self.hi / self.lo).ln()
    }

    pub fn contains(&self, x: f64) -> bool {
        (self.lo..=self.hi).contains(&x)
    }

    /// The value at position `t`, unrounded (what a search reports, not what it runs).
    pub fn exact(&self, t: f64) -> f64 {
        (self.lo * (self.hi / self.lo).powf(t)).clamp(self.lo, self.hi)
    }

    /// The value proposed at position `t`: the range's own ends at 0 and 1, else
    /// `lo · (hi/lo)^t` rounded to [`SIGNIFICANT_DIGITS`] (kept inside the range).
    pub fn value(&self, t: f64) -> f64 {
        if t <= 0.0 {
            return self.lo;
        }
        if t >= 1.0 {
            return self.hi;
        }
        let exact = self.lo * (self.hi / self.lo).powf(t);
        let rounded: f64 = format!("{:.*e}", SIGNIFICANT_DIGITS - 1, exact)
            .parse()
            .unwrap_or(exact);
        rounded.clamp(self.lo, self.hi)
    }
}

/// The dyadic position (k / 2^m, smallest m) in the middle third of the gap (a, b), a < b:
/// unique, so a gap is always split at the same place, and never near either end, so each
/// split shrinks the gap to at most two thirds.
pub fn split(a: f64, b: f64) -> f64 {
    let (from, to) = (a + (b - a) / 3.0, b - (b - a) / 3.0);
    let mut scale = 1.0_f64;
    // 2^m grows until a multiple of 2^-m falls in [from, to]: by m ≈ log2(3 / (b − a)).
    for _ in 0..1100 {
        let k = (from * scale).ceil();
        if k / scale <= to {
            return k / scale;
        }
        scale *= 2.0;
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_range_refuses_what_log_space_cannot_hold() {
        for (lo, hi) in [
            (0.0, 1.0),
            (-1.0, 1.0),
            (2.0, 1.0),
            (1.0, 1.0),
            (1.0, f64::INFINITY),
        ] {
            assert!(Range::new(lo, hi).is_err(), "{lo} {hi}");
        }
    }

    #[test]
    fn values_are_rounded_and_the_ends_exact() {
        let r = Range::new(0.02, 1.5).unwrap();
        assert_eq!(r.value(0.0), 0.02);
        assert_eq!(r.value(1.0), 1.5);
        let mid = r.value(0.5);
        assert_eq!(mid, 0.1732);
        assert!((r.position(mid) - 0.5).abs() < 1e-3);
    }

    #[test]
    fn a_gap_splits_at_its_simplest_dyadic_in_the_middle_third() {
        assert_eq!(split(0.0, 1.0), 0.5);
        assert_eq!(split(0.25, 0.5), 0.375);
        assert_eq!(split(0.49, 0.99), 0.75);
        assert_eq!(split(0.26, 0.3), 0.28125);
        for (a, b) in [(0.1, 0.1 + 1e-9), (0.7, 0.71), (0.0, 1e-6)] {
            let s = split(a, b);
            assert!(
                a + (b - a) / 3.0 <= s && s <= b - (b - a) / 3.0,
                "{a} {b} {s}"
            );
        }
    }
}
