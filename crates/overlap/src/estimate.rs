//! Robust estimates of a run time from many short timed blocks, their 95 % confidence
//! intervals, and the rule that decides when a point has been measured precisely enough.
//!
//! **Assumption: noise is additive and positive.** A block's time is the kernel's cost plus
//! whatever the machine added: an interrupt, a time slice given to another process, a busy
//! sibling thread, a neighbour on the memory bus, a slow phase of a shared VM. Nothing makes a
//! block *faster* than the kernel's cost. (Measured on this project's 2-core VM: timing the same
//! configurations three times over, the spread between rounds is as large as the spread between
//! blocks, 2–8 % — block times are machine noise, not a mix of cheap and dear configurations.)
//!
//! So an algorithm's estimate at a point is a **low quantile, the 5th percentile
//! ([`QUANTILE`]), of every block of every set**: the time of the fastest twentieth of the
//! blocks. It ignores any noise that leaves at least a twentieth of the blocks untouched,
//! whichever sets they are in: its breakdown point is 95 % for positive noise, where a
//! median's is 50 % (a
//! CPU hog sharing the cores slows most blocks, and by an amount that changes from run to run,
//! which is what made medians of hog runs disagree). The price: on a noisy machine, even a
//! "quiet" one, the estimate sits below a median of the same blocks by the noise's spread — it
//! estimates the kernel's cost, not the cost plus the machine's average disturbance. Reports
//! re-estimate from the stored blocks, so results measured with the earlier statistic (the
//! median of set medians) get this one too.
//!
//! The interval has two parts, and the wider bound of each side is kept:
//! - *within*: the distribution-free interval of the quantile from order statistics (exact
//!   binomial ranks) over every block, which treats the blocks as exchangeable;
//! - *between*: the delete-one-set jackknife of the estimate (Student's t with sets − 1 degrees
//!   of freedom), from 2 sets on. It catches what the first cannot: a slow phase that lasts a
//!   whole set, or a set whose configurations are cheaper. A slow set holds few of the fastest
//!   blocks, so leaving it out barely moves the estimate: it widens the interval little, and a
//!   point with `ci_target` converges by adding sets.
//!
//! Neither part sees a slow phase longer than the whole point: two runs of the same point can
//! differ by more than their intervals say (see the README's hog experiment). Where sets
//! differ *symmetrically* by more than the block jitter (not what this project's machines
//! show: the configuration mix moves a set by about 0.1 %), the jackknife of a quantile over
//! a few sets covers less than 95 % (measured in the tests).
//!
//! Why the 5th percentile: on the stored blocks of four hog experiments (two runs each, 8 × 8
//! grid), it gave the two runs' QRF surfaces ρ 0.78–0.95 and a median difference of 1.5–2.6 %;
//! the 10th 0.69–0.93 and 1.9–3.0 %, the 20th 0.61–0.87 and 2.3–4.3 %, the median of set
//! medians 0.47–0.78 and 3.6–6.8 %. Lower still gains little and needs more blocks for an
//! interval.
//!
//! Everything here is a pure function of numbers, tested on synthetic timings.

/// The quantile of the blocks that is a point's estimate (see the module documentation).
pub const QUANTILE: f64 = 0.05;

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

/// The `q` quantile (0 ≤ q ≤ 1) of `samples`, linearly interpolated between order statistics;
/// NaN if empty.
pub fn quantile(samples: &[f64], q: f64) -> f64 {
    quantile_of_sorted(&sorted(samples), q)
}

fn quantile_of_sorted(sorted: &[f64], q: f64) -> f64 {
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

/// The 1-based ranks (lo, hi) such that [x_(lo), x_(hi)] of `n` samples covers the `q`
/// quantile of the population with probability ≥ 95 % for any continuous distribution, each
/// side missing with at most 2.5 %: lo is the largest k with P(B ≤ k − 1) ≤ 2.5 %, hi the
/// smallest k with P(B ≥ k) ≤ 2.5 %, B ~ Binomial(n, q). `None` on a side where even the
/// extreme sample does not reach 95 % (few samples, or a quantile near that end).
fn quantile_ranks(n: usize, q: f64) -> (Option<usize>, Option<usize>) {
    let tail = (1.0 - CONFIDENCE) / 2.0;
    // P(B = i) in log space: q^n underflows for large n.
    let (ln_q, ln_1q) = (q.ln(), (-q).ln_1p());
    let mut ln_choose = 0.0f64;
    let mut cdf = Vec::with_capacity(n + 1);
    let mut sum = 0.0f64;
    for i in 0..=n {
        sum += (ln_choose + i as f64 * ln_q + (n - i) as f64 * ln_1q).exp();
        cdf.push(sum);
        if i < n {
            ln_choose += ((n - i) as f64 / (i + 1) as f64).ln();
        }
    }
    // P(B ≤ k − 1) = cdf[k − 1] grows with k: the last k that stays within the tail.
    let lo = (1..=n).take_while(|&k| cdf[k - 1] <= tail).last();
    // P(B ≥ k) = 1 − cdf[k − 1] falls with k: the first k within the tail.
    let hi = (1..=n).find(|&k| 1.0 - cdf[k - 1] <= tail);
    (lo, hi)
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
/// [`QUANTILE`] of every block, with the interval described in the module documentation.
/// `None` when there is no sample at all.
pub fn estimate(blocks_by_repeat: &[Vec<f64>]) -> Option<Estimate> {
    estimate_quantile(blocks_by_repeat, QUANTILE)
}

/// [`estimate`] for any quantile `q` (0 < q < 1).
pub fn estimate_quantile(blocks_by_repeat: &[Vec<f64>], q: f64) -> Option<Estimate> {
    let sets: Vec<&Vec<f64>> = blocks_by_repeat.iter().filter(|b| !b.is_empty()).collect();
    let pooled = sorted(
        &sets
            .iter()
            .flat_map(|b| b.iter().copied())
            .collect::<Vec<f64>>(),
    );
    if pooled.is_empty() {
        return None;
    }
    let value = quantile_of_sorted(&pooled, q);
    let (mut lo, mut hi) = order_interval(&pooled, q);
    if let Some(half) = jackknife_half_width(&sets, &pooled, q) {
        lo = lo.min(value - half);
        hi = hi.max(value + half);
    }
    Some(Estimate {
        value,
        lo: lo.min(value),
        hi: hi.max(value),
        samples: pooled.len(),
        repeats: sets.len(),
    })
}

/// The distribution-free 95 % interval of the `q` quantile of `sorted` samples; a side whose
/// rank does not exist gets the extreme sample.
fn order_interval(sorted: &[f64], q: f64) -> (f64, f64) {
    let n = sorted.len();
    let (lo, hi) = quantile_ranks(n, q);
    (
        sorted[lo.map_or(0, |k| k - 1)],
        sorted[hi.map_or(n - 1, |k| k - 1)],
    )
}

/// Half the 95 % interval of the `q` quantile of the pooled blocks by the delete-one-set
/// jackknife: how much the estimate depends on which sets were measured. `None` below 2 sets.
/// O(sets × blocks): each deletion removes one set's blocks from the sorted pool.
fn jackknife_half_width(sets: &[&Vec<f64>], pooled: &[f64], q: f64) -> Option<f64> {
    let k = sets.len();
    if k < 2 {
        return None;
    }
    let leave_one_out: Vec<f64> = sets
        .iter()
        .map(|set| {
            let mut removed = sorted(set).into_iter().peekable();
            let rest: Vec<f64> = pooled
                .iter()
                .copied()
                .filter(|&x| {
                    if removed.peek() == Some(&x) {
                        removed.next();
                        false
                    } else {
                        true
                    }
                })
                .collect();
            quantile_of_sorted(&rest, q)
        })
        .collect();
    let mean = leave_one_out.iter().sum::<f64>() / k as f64;
    let spread = leave_one_out
        .iter()
        .map(|t| (t - mean).powi(2))
        .sum::<f64>();
    let standard_error = ((k - 1) as f64 / k as f64 * spread).sqrt();
    Some(student_t975(k - 1) * standard_error)
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
