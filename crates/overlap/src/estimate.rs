//! Robust estimates of a run time from many short timed blocks, their 95 % confidence
//! intervals, and the rule that decides when a point has been measured precisely enough.
//!
//! A block's time is the kernel's true cost plus noise that only ever adds: an interrupt, a
//! time slice given to another process, a cold cache after it. So a set's estimate is the
//! **median** of its blocks' ns/check: a block slowed by a foreign process moves it by at most
//! one rank, where it moves a mean by its whole excess. Blocks are short (see
//! [`crate::protocol`]), so on a machine shared by time slicing most blocks run untouched and
//! the median is theirs. A machine also has slow *phases* that last a whole set (on a shared
//! VM, the memory system slows down for tenths of a second to seconds at a time), so a point's
//! estimate is the **median of its sets' medians**: one slow set of three does not move it.
//!
//! The interval has two parts, and the wider bound of each side is kept:
//! - *within*: the distribution-free interval of a median from order statistics (exact binomial
//!   ranks) over every block, which treats the blocks as exchangeable;
//! - *between*: over the sets' medians, the same order-statistic interval from 6 sets on, and
//!   Student's interval below (none for a single set). It catches what the first cannot: a slow
//!   phase that lasts a whole set, or a set whose configurations happen to be cheaper (every
//!   set is independent). With order statistics, a rare slow set widens it by one rank, not by
//!   its whole excess, so a point with `ci_target` converges by adding sets.
//!
//! Everything here is a pure function of numbers, tested on synthetic timings.

/// Confidence level of every interval of this module.
pub const CONFIDENCE: f64 = 0.95;

/// A point estimate with its 95 % confidence interval, all in the unit of the samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub value: f64,
    pub lo: f64,
    pub hi: f64,
    /// Samples (blocks) the estimate is over.
    pub samples: usize,
    /// Independent sets (repeats) they came from.
    pub repeats: usize,
}

impl Estimate {
    /// Half the interval's width relative to the estimate: the precision `ci_target` asks for.
    pub fn relative_half_width(&self) -> f64 {
        if self.value > 0.0 {
            (self.hi - self.lo) / 2.0 / self.value
        } else {
            f64::INFINITY
        }
    }
}

/// The median of `samples` (the mean of the two middle values for an even count); NaN if empty.
pub fn median(samples: &[f64]) -> f64 {
    let sorted = sorted(samples);
    median_of_sorted(&sorted)
}

fn sorted(samples: &[f64]) -> Vec<f64> {
    let mut sorted = samples.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted
}

fn median_of_sorted(sorted: &[f64]) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => sorted[n / 2],
        n => (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0,
    }
}

/// The `q` quantile (0 ≤ q ≤ 1) of `samples`, linearly interpolated between order statistics.
pub fn quantile(samples: &[f64], q: f64) -> f64 {
    let sorted = sorted(samples);
    if sorted.is_empty() {
        return f64::NAN;
    }
    let at = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (i, f) = (at.floor() as usize, at.fract());
    if i + 1 < sorted.len() {
        sorted[i] + f * (sorted[i + 1] - sorted[i])
    } else {
        sorted[i]
    }
}

/// The 1-based rank k such that [x_(k), x_(n+1−k)] covers the median of the population with
/// probability ≥ 95 % for any continuous distribution: the largest k with
/// P(Binomial(n, ½) ≤ k − 1) ≤ 2.5 %. `None` below 6 samples, where even [min, max] covers it
/// with less than 95 %.
fn median_rank(n: usize) -> Option<usize> {
    let tail = (1.0 - CONFIDENCE) / 2.0;
    // P(B = i) in log space: 2^-n underflows from n = 1075 on.
    let ln_half_n = -(n as f64) * std::f64::consts::LN_2;
    let (mut ln_choose, mut cdf) = (0.0f64, 0.0f64);
    for i in 0..=n / 2 {
        let next = cdf + (ln_choose + ln_half_n).exp();
        if next > tail {
            // P(B ≤ i) exceeds the tail: k − 1 = i − 1 is the last rank that does not.
            return (i >= 1).then_some(i);
        }
        cdf = next;
        ln_choose += ((n - i) as f64 / (i + 1) as f64).ln();
    }
    None
}

/// The 97.5 % quantile of Student's t with `df` degrees of freedom (`df` ≥ 1).
pub fn student_t975(df: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => TABLE[df - 1],
        _ => {
            // Cornish–Fisher expansion around the normal quantile: below 1e-4 off from df = 31.
            let z = 1.959_963_984_540_054_f64;
            let d = df as f64;
            z + (z.powi(3) + z) / (4.0 * d)
                + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * d * d)
        }
    }
}

fn mean_and_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, var.sqrt())
}

/// The estimate of one algorithm at one point from its blocks, grouped by set (repeat): the
/// median over the sets of each set's median block, with the interval described in the module
/// documentation. `None` when there is no sample at all.
pub fn estimate(blocks_by_repeat: &[Vec<f64>]) -> Option<Estimate> {
    let pooled = sorted(&blocks_by_repeat.concat());
    if pooled.is_empty() {
        return None;
    }
    let n = pooled.len();
    let medians = sorted(
        &blocks_by_repeat
            .iter()
            .filter(|b| !b.is_empty())
            .map(|b| median(b))
            .collect::<Vec<f64>>(),
    );
    let value = median_of_sorted(&medians);
    let (mut lo, mut hi) = order_interval(&pooled);
    let sets = medians.len();
    let (between_lo, between_hi) = if sets >= 6 {
        order_interval(&medians)
    } else if sets >= 2 {
        let (_, sd) = mean_and_sd(&medians);
        let half = student_t975(sets - 1) * sd / (sets as f64).sqrt();
        (value - half, value + half)
    } else {
        (value, value)
    };
    lo = lo.min(between_lo);
    hi = hi.max(between_hi);
    Some(Estimate {
        value,
        lo,
        hi,
        samples: n,
        repeats: sets,
    })
}

/// The distribution-free 95 % interval of the median of `sorted` samples ([min, max] below 6).
fn order_interval(sorted: &[f64]) -> (f64, f64) {
    let n = sorted.len();
    match median_rank(n) {
        Some(k) => (sorted[k - 1], sorted[n - k]),
        None => (sorted[0], sorted[n - 1]),
    }
}

/// The estimate from one value per set and no blocks (results of the protocol before blocks
/// were kept): their mean, as those results were always reported, with Student's interval.
pub fn mean_interval(per_repeat: &[f64]) -> Option<Estimate> {
    if per_repeat.is_empty() {
        return None;
    }
    let (mean, sd) = mean_and_sd(per_repeat);
    let half = if per_repeat.len() >= 2 {
        student_t975(per_repeat.len() - 1) * sd / (per_repeat.len() as f64).sqrt()
    } else {
        f64::NAN
    };
    let (lo, hi) = if half.is_finite() {
        (mean - half, mean + half)
    } else {
        (f64::NAN, f64::NAN)
    };
    Some(Estimate {
        value: mean,
        lo,
        hi,
        samples: per_repeat.len(),
        repeats: per_repeat.len(),
    })
}

/// How long to measure a point: at least `min_repeats` sets; then, if `ci_target` is given,
/// more sets until every algorithm's 95 % CI half-width is within `ci_target` of its estimate,
/// unless the next set would take the measurement past `time_cap_s` or `max_repeats` is reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Goal {
    pub min_repeats: u32,
    pub ci_target: Option<f64>,
    pub time_cap_s: f64,
    pub max_repeats: u32,
}

/// Why a point's measurement stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// No precision was asked for: the sets the plan asked for are measured.
    Repeats,
    /// Every algorithm reached the precision asked for.
    Precise,
    /// The time cap came first: the estimate is less precise than asked.
    TimeCap,
    /// The most sets a point may have came first.
    MaxRepeats,
}

impl Goal {
    /// After `repeats` sets, whose worst relative CI half-width is `worst_relative_half_width`,
    /// having spent `spent_s` and `last_repeat_s` on the last set: `None` to measure one more
    /// set, or why to stop. The time cap never cuts the sets the plan asked for.
    pub fn next(
        &self,
        repeats: u32,
        worst_relative_half_width: f64,
        spent_s: f64,
        last_repeat_s: f64,
    ) -> Option<Stop> {
        if repeats < self.min_repeats {
            return None;
        }
        let Some(target) = self.ci_target else {
            return Some(Stop::Repeats);
        };
        // A NaN width (no interval yet) is not precise.
        if worst_relative_half_width <= target {
            Some(Stop::Precise)
        } else if repeats >= self.max_repeats {
            Some(Stop::MaxRepeats)
        } else if spent_s + last_repeat_s > self.time_cap_s {
            Some(Stop::TimeCap)
        } else {
            None
        }
    }
}
