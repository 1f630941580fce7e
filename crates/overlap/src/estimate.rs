//! Estimates of a run time from many short timed blocks, their 95 % confidence intervals, and
//! the rule that decides when a point has been measured precisely enough.
//!
//! **Two questions, two statistics** ([`Statistic`]). A block's time is the kernel's cost plus
//! whatever the machine added: an interrupt, a time slice given to another process, a busy
//! sibling thread, a neighbour on the memory bus, a slow phase of a shared VM. Nothing makes a
//! block *faster* than the kernel's cost: noise is additive and positive.
//! - *What does a configuration set cost on average on this machine?* The papers' Tables 1–2
//!   answer it with the mean time per configuration set, and so do ours by default
//!   ([`Statistic::FOR_TABLES`] = [`Statistic::Mean`]: the mean of the blocks, which is the
//!   whole passes' time over their configurations up to the shorter last block of a pass). On a
//!   quiet machine it is what the papers' protocol reports; on a shared one it includes what
//!   the machine's other work costs the kernel.
//! - *How does the kernel's own cost change across the (L*, W*) plane?* Figures 2–3 compare
//!   points measured minutes apart, so an estimate must ignore the machine: by default
//!   ([`Statistic::FOR_SURFACES`] = [`Statistic::P5`]) the **5th percentile of every block of
//!   every set** ([`QUANTILE`]), the time of the fastest twentieth of the blocks. It ignores any
//!   noise that leaves at least a twentieth of the blocks untouched: its breakdown point is 95 %
//!   for positive noise, where a median's is 50 % (a CPU hog sharing the cores slows most
//!   blocks, by an amount that changes from run to run: on the stored blocks of three hog
//!   experiments, two runs each of an 8 × 8 grid, QRF surfaces agreed to ρ 0.84–0.93 and a
//!   median difference of 1.5–2.6 % by the 5th percentile, ρ 0.60–0.69 and 3.7–6.2 % by the
//!   median, ρ 0.48–0.64 and 4.0–6.2 % by the mean). On a quiet machine it sits below the
//!   mean by the noise's spread (on two runs of the quick plan: 9–15 % for Arvo, QRI and QRF,
//!   11–24 % for OCSI and SSE, 28–32 % for `ocsi_batch`), which would change the ratios between
//!   algorithms that Tables 1–2 report: that is why the tables do not use it.
//! - [`Statistic::Median`] is in between: robust to occasional noise, 3–7 % below the mean on
//!   a quiet machine, not robust to a hog.
//!
//! **The interval** is a delete-a-group jackknife over [`JACKKNIFE_GROUPS`] groups of the
//! blocks taken in the order they were measured: whole sets, consecutive ones together, when a
//! point has at least that many sets; otherwise consecutive runs of its blocks. Student's t with
//! groups − 1 degrees of freedom. Why groups and not single sets: a slow phase of the machine
//! that spans a few consecutive sets is one event, not several independent ones, and the
//! delete-one jackknife is unreliable for a quantile. In the tests' simulation (20 sets whose
//! speed drifts by 1 %, phases of about three sets) the delete-one-set intervals covered the
//! truth in 70–75 % of points, these in 85–92 %; with independent sets 86–95 % and 93–95 %.
//! For a quantile the interval is also at least the distribution-free one from order
//! statistics (exact binomial ranks) over every block, which matters when the groups happen to
//! agree.
//!
//! What no interval of one measurement can see: a state of the machine that lasts longer than
//! the whole point, or a whole run. On this project's 2-core VM two runs of the same point agree
//! within their intervals far less often than 95 %: under a CPU hog (5th percentile, three
//! experiments) at 55–75 % of the QRI/QRF points and 48–61 % of the OCSI/SSE ones; on the quiet
//! machine (mean, quick plan) at about half, because whole runs there drift by 1–14 % from one
//! run to the next (`scripts/surface_agreement.py`, `scripts/quiet-table1.sh`). OCSI and SSE
//! under the hog switch between two speeds 1.65× apart for seconds at a time, and a point that
//! never saw the fast one cannot know it. An honest interval for "what another run would give"
//! needs that run: measuring a point again later, not more blocks now. That is what a plan's
//! `visits` does, and [`pool_visits`] combines the visits with a between-visit term (measured,
//! `scripts/visits-experiment.sh`, 6 × 6 grid under the hog, three experiments of two runs: by
//! the 5th percentile the OCSI/SSE intervals of two runs agreed at 28–50 % of the points with
//! one visit and at 92–100 % with three; QRI/QRF at 94–100 % either way). Visits spread over one
//! campaign still cannot see a state that lasts the whole campaign.
//!
//! Everything here is a pure function of numbers, tested on synthetic timings.

/// Which statistic of a point's blocks is its estimate (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Statistic {
    /// The mean of the blocks: the papers' mean time per configuration set.
    Mean,
    /// The median of the blocks.
    Median,
    /// The 5th percentile ([`QUANTILE`]) of the blocks: the kernel's cost without the noise.
    P5,
}

impl Statistic {
    /// Tables 1–2: the central value the papers' protocol reports.
    pub const FOR_TABLES: Statistic = Statistic::Mean;
    /// Figures 2–3 and the stopping rule of the protocol: the noise-robust low quantile.
    pub const FOR_SURFACES: Statistic = Statistic::P5;
    pub const ALL: [Statistic; 3] = [Statistic::Mean, Statistic::Median, Statistic::P5];

    /// The name reports print and `--statistic` takes.
    pub fn name(self) -> &'static str {
        match self {
            Statistic::Mean => "mean",
            Statistic::Median => "median",
            Statistic::P5 => "p5",
        }
    }

    /// The quantile it is, if it is one.
    fn quantile(self) -> Option<f64> {
        match self {
            Statistic::Mean => None,
            Statistic::Median => Some(0.5),
            Statistic::P5 => Some(QUANTILE),
        }
    }
}

impl std::fmt::Display for Statistic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Statistic {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Statistic::ALL
            .into_iter()
            .find(|statistic| statistic.name() == s)
            .ok_or_else(|| format!("unknown statistic `{s}` (expected mean, median or p5)"))
    }
}

/// Groups of the delete-a-group jackknife (see the module documentation): five leave 80 % of
/// a point's blocks in each estimate and give Student's t 4 degrees of freedom. Fewer groups
/// absorb longer phases of the machine but widen the interval by t; with phases of about five
/// sets (20 sets) five groups still cover 70–77 % (tests/estimate.rs).
pub const JACKKNIFE_GROUPS: usize = 5;

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

/// The 97.5 % quantile of Student's t with `df` degrees of freedom (`df` ≥ 1): the exact
/// quantiles rounded to 3 decimals up to 30, then a Cornish–Fisher expansion (within 9e-5 of
/// the exact quantile). Not a distribution crate's inverse CDF: exact quantiles (up to 2e-4
/// away) would move every report's intervals in their 4th digit, and the one checked
/// (statrs 0.19) loses its accuracy past df ≈ 10⁶ and does not return past 2·10⁷.
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

/// The estimate of one algorithm at one point from its blocks, grouped by set (repeat) in the
/// order they were measured: the [`QUANTILE`] of every block ([`Statistic::FOR_SURFACES`], the
/// protocol's own), with the interval described in the module documentation. `None` when there
/// is no sample at all.
pub fn estimate(blocks_by_repeat: &[Vec<f64>]) -> Option<Estimate> {
    estimate_with(Statistic::FOR_SURFACES, blocks_by_repeat)
}

/// [`estimate`] by any [`Statistic`].
pub fn estimate_with(statistic: Statistic, blocks_by_repeat: &[Vec<f64>]) -> Option<Estimate> {
    match statistic.quantile() {
        Some(q) => estimate_quantile(blocks_by_repeat, q),
        None => estimate_by(blocks_by_repeat, mean_of, |_| None),
    }
}

/// [`estimate`] for any quantile `q` (0 < q < 1).
pub fn estimate_quantile(blocks_by_repeat: &[Vec<f64>], q: f64) -> Option<Estimate> {
    estimate_by(
        blocks_by_repeat,
        |blocks| quantile_of_sorted(&sorted(blocks), q),
        |pooled| Some(order_interval(pooled, q)),
    )
}

fn mean_of(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// The estimate by `statistic` over every block, its interval the jackknife's widened to
/// `floor_interval` (if any) of the pooled blocks.
fn estimate_by(
    blocks_by_repeat: &[Vec<f64>],
    statistic: impl Fn(&[f64]) -> f64,
    floor_interval: impl Fn(&[f64]) -> Option<(f64, f64)>,
) -> Option<Estimate> {
    let sets: Vec<&[f64]> = blocks_by_repeat
        .iter()
        .filter(|b| !b.is_empty())
        .map(Vec::as_slice)
        .collect();
    let pooled: Vec<f64> = sets.concat();
    if pooled.is_empty() {
        return None;
    }
    let value = statistic(&pooled);
    let (mut lo, mut hi) = floor_interval(&pooled).unwrap_or((value, value));
    if let Some(half) = jackknife_half_width(&contiguous_groups(&sets), &statistic) {
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

/// The distribution-free 95 % interval of the `q` quantile of `samples` (treated as independent
/// draws of one distribution) from order statistics: [x_(lo), x_(hi)] by the ranks of
/// `quantile_ranks`; a side whose rank does not exist gets the extreme sample. Empty `samples`
/// give NaN.
pub fn order_interval(samples: &[f64], q: f64) -> (f64, f64) {
    let sorted = sorted(samples);
    let n = sorted.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let (lo, hi) = quantile_ranks(n, q);
    (
        sorted[lo.map_or(0, |k| k - 1)],
        sorted[hi.map_or(n - 1, |k| k - 1)],
    )
}

/// The blocks in [`JACKKNIFE_GROUPS`] groups of consecutive measurements (fewer when there are
/// fewer blocks): whole sets when there are at least that many, split as evenly as their
/// count allows; otherwise the blocks of all sets, in order, cut into runs of equal length.
fn contiguous_groups(sets: &[&[f64]]) -> Vec<Vec<f64>> {
    let cut = |len: usize, groups: usize| -> Vec<std::ops::Range<usize>> {
        (0..groups)
            .map(|g| g * len / groups..(g + 1) * len / groups)
            .collect()
    };
    if sets.len() >= JACKKNIFE_GROUPS {
        cut(sets.len(), JACKKNIFE_GROUPS)
            .into_iter()
            .map(|range| sets[range].concat())
            .collect()
    } else {
        let blocks = sets.concat();
        cut(blocks.len(), JACKKNIFE_GROUPS.min(blocks.len()))
            .into_iter()
            .map(|range| blocks[range].to_vec())
            .collect()
    }
}

/// Half the 95 % interval of `statistic` over every group by the delete-a-group jackknife:
/// how much the estimate depends on which stretch of the measurement is left out. `None`
/// below 2 groups. O(groups × blocks log blocks) for a quantile.
fn jackknife_half_width(groups: &[Vec<f64>], statistic: impl Fn(&[f64]) -> f64) -> Option<f64> {
    let g = groups.len();
    if g < 2 {
        return None;
    }
    let leave_one_out: Vec<f64> = (0..g)
        .map(|left_out| {
            let rest: Vec<f64> = groups
                .iter()
                .enumerate()
                .filter(|&(i, _)| i != left_out)
                .flat_map(|(_, group)| group.iter().copied())
                .collect();
            statistic(&rest)
        })
        .collect();
    let mean = mean_of(&leave_one_out);
    let spread = leave_one_out
        .iter()
        .map(|t| (t - mean).powi(2))
        .sum::<f64>();
    let standard_error = ((g - 1) as f64 / g as f64 * spread).sqrt();
    Some(student_t975(g - 1) * standard_error)
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

/// One point measured in several visits spread over a campaign (the plan key `visits`), each
/// visit's [`Estimate`] made from its own blocks: the point's estimate and interval, with a
/// **between-visit term**.
///
/// The estimate is the mean of the visits' estimates (each the chosen statistic of that visit's
/// blocks): a visit is one draw of the machine's state, and for the 5th percentile a quantile of
/// the pooled blocks would be set by the fastest visit alone. The 95 % interval is the larger
/// of two half-widths around it:
/// - between visits: Student's t with visits − 1 degrees of freedom on the visits' estimates,
///   t · s / √visits. Their spread holds both each visit's own error and whatever the machine
///   did between visits (a slow phase longer than a visit, a run-level drift), which no single
///   visit's interval can see;
/// - within visits: √(Σ hᵥ²) / visits from each visit's own half-width hᵥ, the interval the mean
///   would have if the machine never changed. It keeps the interval honest when a few visits
///   happen to agree by chance (with 2–3 visits the sample spread is often far below its
///   expectation).
///
/// Not their sum: the between-visit spread already contains the within-visit error. One visit
/// is returned unchanged (today's interval); `None` for none. A visit without an interval (NaN
/// bounds) adds nothing to the within-visit term.
pub fn pool_visits(visits: &[Estimate]) -> Option<Estimate> {
    match visits {
        [] => None,
        [one] => Some(*one),
        _ => {
            let n = visits.len();
            let values: Vec<f64> = visits.iter().map(|e| e.value).collect();
            let (mean, sd) = mean_and_sd(&values);
            let between = student_t975(n - 1) * sd / (n as f64).sqrt();
            let within = visits
                .iter()
                .map(|e| (e.hi - e.lo) / 2.0)
                .filter(|h| h.is_finite())
                .map(|h| h * h)
                .sum::<f64>()
                .sqrt()
                / n as f64;
            let half = between.max(within);
            Some(Estimate {
                value: mean,
                lo: mean - half,
                hi: mean + half,
                samples: visits.iter().map(|e| e.samples).sum(),
                repeats: visits.iter().map(|e| e.repeats).sum(),
            })
        }
    }
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
