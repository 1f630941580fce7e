//! How far apart two mean results must be to say which is smaller: a relative spread of one run
//! pooled over every value run more than once (run times scale with the value they measure), or
//! a prior while no value has been repeated.

use overlap::estimate::student_t975;

/// The relative standard deviation of one run assumed while nothing has been repeated: τ_c of
/// one EDMD run varies by 1–3 % between seeds on a quiet machine (MEASUREMENTS.md), more on a
/// shared one.
pub const PRIOR_RELATIVE_SD: f64 = 0.03;

/// The runs at one value.
#[derive(Clone, Debug)]
pub struct Point {
    pub t: f64,
    pub x: f64,
    pub values: Vec<f64>,
}

impl Point {
    pub fn mean(&self) -> f64 {
        self.values.iter().sum::<f64>() / self.values.len() as f64
    }
}

/// The pooled relative spread: `(s, t)` where a mean of n runs at level m has the 95 %
/// half-width t · s · |m| / √n.
pub fn spread(points: &[Point]) -> (f64, f64) {
    let (mut sum, mut df) = (0.0, 0usize);
    for p in points.iter().filter(|p| p.values.len() > 1) {
        let m = p.mean();
        if m == 0.0 {
            continue;
        }
        sum += p.values.iter().map(|v| ((v - m) / m).powi(2)).sum::<f64>();
        df += p.values.len() - 1;
    }
    if df == 0 {
        (PRIOR_RELATIVE_SD, 1.959_963_984_540_054)
    } else {
        // Two runs that agree by chance must not make every difference look significant.
        (
            (sum / df as f64).sqrt().max(0.1 * PRIOR_RELATIVE_SD),
            student_t975(df),
        )
    }
}

pub fn half_width(point: &Point, (s, t): (f64, f64)) -> f64 {
    t * s * point.mean().abs() / (point.values.len() as f64).sqrt()
}
